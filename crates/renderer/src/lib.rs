//! Geometry, BVH, camera, materials, path integrator and film.

pub mod bsdf;
pub mod sampling;
