//! Kernels for x86-64 instruction-set extensions beyond the baseline (SSE2), one module per
//! level. Each is compiled always and selected at run time ([`super::Simd::detect`]); its
//! functions carry `#[target_feature]` and are only called after the CPU was checked.

pub(crate) mod avx2;
pub(crate) mod avx512;
pub(crate) mod shadow_packet;
