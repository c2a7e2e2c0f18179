//! Integrators: from a camera ray to the radiance arriving along it. One file per integrator:
//! Mitsuba's `path` ([`path::radiance`]), run one path at a time or as a wavefront of paths
//! ([`wavefront::Wavefront`]), the same estimator; and Mitsuba's `direct` with several emitter or
//! BSDF samples per hit ([`direct::radiance`]; with one of each it is `path` at depth 2).

pub mod direct;
pub mod path;
pub mod wavefront;

pub use path::radiance;

/// How the render loop runs the path tracer: one path to its end after another (`Scalar`), or a
/// batch of paths (one pixel's samples) a bounce at a time (`Wavefront`). Both compute the same
/// estimator with the same sampler dimensions, so the images agree bit for bit; they differ in
/// speed (docs/performance.md). `Auto` takes the wavefront for scenes lit by an environment map
/// (its batched lookups: envmap_sky 14-22% faster) and for scenes whose surface stage runs in
/// SIMD lanes with every light (`wavefront::LaneTable::wavefront_pays`: cbox 7% faster,
/// textured_mesh 1-2%), and the scalar loop otherwise (the wavefront's bookkeeping costs more
/// than it gains where the scalar `shade` takes the paths).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PathLoop {
    #[default]
    Auto,
    Scalar,
    Wavefront,
}

#[derive(Clone, Copy, Debug)]
pub struct PathSettings {
    pub max_depth: i32,
    pub rr_depth: i32,
    /// Filter textures by the ray cone's footprint (mip-mapping). Off: finest level, bilinear,
    /// as Mitsuba does; used to measure what mip-mapping changes.
    pub mipmapping: bool,
    /// Scale of every ray-cone spread: `torrey_texture::spp_scale(spp)` = 1/sqrt(spp).
    pub footprint_scale: f32,
    /// How lights at infinity are sampled; the default is luminance importance sampling with MIS.
    pub env_strategy: EnvStrategy,
}

/// Strategies for lights at infinity, kept selectable so their noise can be compared (issue: env
/// sampling (a) uniform, (b) luminance-importance, (c) importance + MIS). (a) and (b) count the
/// environment only through light samples: BSDF-sampled rays that escape add nothing after the
/// first rough bounce, which keeps each estimator unbiased on its own.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum EnvStrategy {
    Uniform,
    Importance,
    #[default]
    ImportanceMis,
}

/// Rays traced, by query kind, for the rays-per-second report.
#[derive(Clone, Copy, Debug, Default)]
pub struct RayCount {
    /// Closest-hit queries (camera rays and path continuations).
    pub closest: u64,
    /// Any-hit queries: shadow rays, and last path segments in scenes without area lights.
    pub shadow: u64,
}
