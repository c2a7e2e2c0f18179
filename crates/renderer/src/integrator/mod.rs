//! Integrators: from a camera ray to the radiance arriving along it.
//!
//! [`Integrator`] is the scene's integrator with its parameters: Mitsuba's `path`
//! ([`PathIntegrator`]) and `direct` with several samples per hit ([`DirectIntegrator`]; with one
//! of each it is `path` at depth 2, the same estimator).
//!
//! The path tracer's step at a surface (emission with MIS, the shading point, next-event
//! estimation, the BSDF sample that continues the path, Russian roulette) is written once, on a
//! [`path_state::PathState`] ([`path_state::PathState::scatter`]); three drivers advance that state:
//! the scalar loop ([`path::radiance`]), one path to its end after another, and the wavefront
//! ([`wavefront::Wavefront`]), a batch of paths a bounce at a time with each stage's rays and
//! lookups done together (both give the same image, bit for bit), and the volumetric path
//! tracer ([`volpath`], Mitsuba's `volpath`/`volpathmis`), which adds free flights through
//! participating media between surfaces and transmittance on its shadow rays. The shading point
//! ([`shading::ShadingPoint`]: footprint, frame, BSDF at a hit) and the light connection are
//! shared with `direct` too.

// Comparisons are written `!(x > 0.0)` on purpose: they also reject NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod aov;
mod direct;
mod path;
mod path_state;
mod shading;
mod volpath;
#[cfg(test)]
mod volpath_tests;
pub mod wavefront;

pub use direct::DirectIntegrator;
pub use path::{radiance, PathIntegrator};
pub use volpath::VolPathIntegrator;

use torrey_parser as desc;

/// The integrator of a render, with its parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Integrator {
    Path(PathIntegrator),
    Direct(DirectIntegrator),
    /// Mitsuba's `volpath` and `volpathmis`: the path tracer with participating media.
    VolPath(VolPathIntegrator),
}

impl Integrator {
    /// The parsed integrator. `direct` with one emitter and one BSDF sample is the path tracer at
    /// depth 2 (the same estimator), which also runs as a wavefront.
    pub fn from_desc(d: &desc::Integrator) -> Self {
        match d.kind {
            desc::IntegratorKind::Path(p) => Integrator::Path(PathIntegrator {
                max_depth: p.max_depth,
                rr_depth: p.rr_depth,
                hide_emitters: p.hide_emitters,
            }),
            desc::IntegratorKind::Direct(p) if (p.emitter_samples, p.bsdf_samples) == (1, 1) => {
                Integrator::Path(PathIntegrator {
                    max_depth: 2,
                    rr_depth: d.rr_depth(),
                    hide_emitters: p.hide_emitters,
                })
            }
            desc::IntegratorKind::Direct(p) => Integrator::Direct(DirectIntegrator {
                emitter_samples: p.emitter_samples,
                bsdf_samples: p.bsdf_samples,
                hide_emitters: p.hide_emitters,
            }),
            desc::IntegratorKind::VolPath { params: p, mis } => {
                Integrator::VolPath(VolPathIntegrator {
                    max_depth: p.max_depth,
                    rr_depth: p.rr_depth,
                    hide_emitters: p.hide_emitters,
                    mis,
                })
            }
        }
    }

    /// The integrator with the path tracer's `max_depth` replaced (`--max-depth`); `direct` with
    /// several samples per hit follows one bounce whatever the depth.
    pub fn with_max_depth(self, max_depth: i32) -> Self {
        match self {
            Integrator::Path(p) => Integrator::Path(PathIntegrator { max_depth, ..p }),
            Integrator::VolPath(p) => Integrator::VolPath(VolPathIntegrator { max_depth, ..p }),
            direct => direct,
        }
    }

    /// Path segments followed (Mitsuba's `max_depth`; -1 unbounded).
    pub fn max_depth(&self) -> i32 {
        match self {
            Integrator::Path(p) => p.max_depth,
            Integrator::VolPath(p) => p.max_depth,
            Integrator::Direct(_) => 2,
        }
    }

    /// Where Russian roulette starts.
    pub fn rr_depth(&self) -> i32 {
        match self {
            Integrator::Path(p) => p.rr_depth,
            Integrator::VolPath(p) => p.rr_depth,
            Integrator::Direct(_) => 5,
        }
    }

    /// Camera rays see no emitter.
    pub fn hide_emitters(&self) -> bool {
        match self {
            Integrator::Path(p) => p.hide_emitters,
            Integrator::VolPath(p) => p.hide_emitters,
            Integrator::Direct(d) => d.hide_emitters,
        }
    }
}

/// How the render loop runs the path tracer: one path to its end after another (`Scalar`), or a
/// batch of paths (one pixel's samples) a bounce at a time (`Wavefront`). Both compute the same
/// estimator with the same sampler dimensions, so the images agree bit for bit; they differ in
/// speed (docs/performance.md). `Auto` takes the wavefront for scenes lit by an environment map
/// (its batched lookups) and the scalar loop otherwise.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PathLoop {
    #[default]
    Auto,
    Scalar,
    Wavefront,
}

/// What the path loops read besides the scene: the integrator's parameters and the render's.
#[derive(Clone, Copy, Debug)]
pub struct PathSettings {
    /// Path segments to follow (-1, unbounded, is `u32::MAX`).
    pub max_depth: u32,
    pub rr_depth: i32,
    /// Camera rays see no emitter (Mitsuba's `hide_emitters`): neither emitting shapes nor the
    /// lights at infinity; emitters seen after a bounce, even a mirror's, and the light they cast
    /// stay.
    pub hide_emitters: bool,
    /// Filter textures by the ray cone's footprint (mip-mapping). Off: finest level, bilinear,
    /// as Mitsuba does; used to measure what mip-mapping changes.
    pub mipmapping: bool,
    /// Scale of every ray-cone spread: `torrey_texture::spp_scale(spp)` = 1/sqrt(spp).
    pub footprint_scale: f32,
    /// How lights at infinity are sampled; the default is luminance importance sampling with MIS.
    pub env_strategy: EnvStrategy,
    /// Take the denoiser's guides along each path ([`path_state::Guides`]).
    pub guides: bool,
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
