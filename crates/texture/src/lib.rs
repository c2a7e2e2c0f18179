//! Image loading, sRGB decoding, box-filtered mip pyramids and anisotropic lookups driven by
//! ray cones.
//!
//! Everything is stored as linear RGB with Rec.709 primaries ([`Image`]); loaders convert on the
//! way in ([`load_image`]), writers convert on the way out ([`write_exr`], [`write_png_srgb`]).

#![warn(missing_docs)]

pub mod aniso;
pub mod bitmap;
pub mod color;
pub mod footprint;
pub mod image;
pub mod io;
pub mod mipmap;
mod packed;
pub mod raycone;

pub use aniso::{MAX_ANISOTROPY, MAX_PROBES};
pub use bitmap::BitmapTexture;
pub use color::{linear_to_srgb, srgb_to_linear, Chromaticities, WhiteAdaptation};
pub use footprint::{centre_weight, spp_scale, Footprint};
pub use image::{Codes8, Image};
pub use io::{
    image_pixel_limit, load_image, load_image_as_stored, set_image_pixel_limit, write_exr,
    write_png_srgb, LoadedImage, TextureError, DEFAULT_IMAGE_PIXEL_LIMIT,
};
pub use mipmap::{FilterType, MipMap, WrapMode};
pub use raycone::RayCone;
