//! Image loading, sRGB decoding, box-filtered mip pyramids and ray-cone driven lookups.

pub mod image;

pub use image::Image;
