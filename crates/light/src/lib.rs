//! Distribution1D/2D, alias tables, environment-map importance sampling, point and area light
//! sampling.
//!
//! Everything here is renderer-agnostic: the renderer owns the scene and its rays, this crate owns
//! the densities. Every sampler has a matching pdf so that multiple importance sampling can weigh
//! strategies consistently, and every routine works in f32 without allocating on the hot path.

#![deny(missing_docs)]

pub mod alias;
pub mod distribution;
pub mod envmap;
pub mod fastmath;
pub mod geometry;

pub use alias::AliasTable;
pub use distribution::{Distribution1D, Distribution2D};
pub use envmap::{luminance, EnvMap, EnvSample};
pub use geometry::{
    sample_sphere_solid_angle, sample_triangle_uniform, sphere_solid_angle_pdf, SphereSample,
};
