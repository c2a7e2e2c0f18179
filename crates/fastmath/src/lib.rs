//! Branch-light f32 replacements for the libm functions on torrey's hot paths: the shading
//! (BSDFs, light and shape sampling) and the environment map.
//!
//! Every function states its maximum error and a unit test checks it over a dense sweep against
//! f64 (or against the C library's double-precision function where std has none). The
//! polynomials are minimax fits evaluated with plain multiply-adds (Estrin's scheme where the
//! latency matters), so nothing here needs FMA or calls into libm on the fast path: the
//! renderer's baseline x86-64 build gets the same code everywhere, and the functions inline into
//! loops over SIMD lanes.
//!
//! | function | error (max, tested) |
//! | --- | --- |
//! | [`exp`], [`exp2`], [`expm1`] | 2.5e-7 relative |
//! | [`ln`], [`log2`] | 1.2e-7 relative (absolute near 1; 2e-7 for log2) |
//! | [`powf`] | 3e-7 + 1.5e-7 |y log2 x| relative |
//! | [`erf`] | 1.6e-7 absolute, 2.5e-7 relative below 0.9 |
//! | [`erfinv`] | 5e-7 relative |
//! | [`atan2`] | 4e-7 rad |
//! | [`acos`] | 5e-7 rad |
//! | [`sin_cos_2pi`] | 1.2e-7 absolute |

mod erf;
mod explog;
mod trig;

pub use erf::{erf, erfinv};
pub use explog::{exp, exp2, expm1, ln, log2, powf};
pub use trig::{acos, atan2, atan2_inline, sin_cos_2pi, sin_cos_eighth, swap_if};
