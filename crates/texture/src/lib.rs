//! Image loading, sRGB decoding, box-filtered mip pyramids and ray-cone driven lookups.
