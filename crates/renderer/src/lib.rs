//! Geometry, BVH, camera, materials, path integrator and film: everything between a parsed scene
//! description and a linear radiance image.

pub mod accel;
pub mod bsdf;
pub mod bvh;
#[cfg(target_arch = "x86_64")]
pub mod bvh8;
pub mod camera;
pub mod geometry;
pub mod integrator;
pub mod light;
pub mod render;
pub mod sampler;
pub mod sampling;
pub mod scene;
pub mod texture;
pub mod triangle4;

pub use accel::BvhWidth;
pub use integrator::EnvStrategy;
pub use render::{render, RenderOutput, RenderSettings};
pub use sampler::SamplerKind;
pub use scene::{BuildError, RenderScene};
