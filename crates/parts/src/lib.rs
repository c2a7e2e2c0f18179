//! Render parts: a render split into film windows (crops) and ranges of global sample indices
//! ([`torrey_renderer::RenderSlice`]) gives one [`Part`] per piece. A part carries its pixels'
//! mean and variance of the mean and a [`PartMeta`] that says which scene (path and content
//! hash), which settings and which slice it holds; it is stored as an EXR whose header carries
//! that metadata. [`merge`] puts parts back together: crops side by side, sample ranges by the
//! sample-count-weighted mean and the parallel variance formula, so that a render split in any
//! way and merged equals the one-piece render to float rounding.

mod denoise;
mod exr_io;
mod hash;
mod merge;
mod meta;
mod part;

pub use denoise::denoise_part;
pub use exr_io::{read_part, read_part_bytes, write_part, write_part_bytes};
pub use hash::scene_hash;
pub use merge::merge;
pub use meta::{settings_text, PartMeta};
pub use part::Part;
