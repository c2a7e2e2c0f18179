//! The render settings and the one way to make them: [`RenderSettings::new`] from a parsed scene
//! and the caller's [`Overrides`] (the command line, Python and the fuzzer all go through it).

use crate::integrator::aov::SampleChannels;
use crate::integrator::{EnvStrategy, Integrator, PathLoop};
use crate::sampler::SamplerKind;
use std::time::Duration;
use torrey_parser::PixelFilter;

#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub spp: u32,
    /// The integrator and its parameters (the scene's, with `--max-depth` applied).
    pub integrator: Integrator,
    pub seed: u64,
    pub filter: PixelFilter,
    pub tile_size: u32,
    /// Ray-cone mip-mapping of textures and environment maps (on by default).
    pub mipmapping: bool,
    pub env_strategy: EnvStrategy,
    pub sampler: SamplerKind,
    /// Trace each pixel's camera rays in packets (on by default; used with eight-wide BVH nodes
    /// and cameras whose rays share an origin). Off, every ray is traced alone: the same hits,
    /// slower.
    pub packets: bool,
    /// Run the path tracer one path at a time or as a wavefront of a pixel's samples (`Auto`:
    /// the wavefront where an environment map lights the scene): the same images, bit for bit.
    pub path_loop: PathLoop,
    /// What each sample writes besides the radiance: the scene's AOVs (Mitsuba's `aov`
    /// integrator) and the denoiser's guides.
    pub channels: SampleChannels,
    /// Adaptive sampling: stop each pixel once its relative standard error is predicted under
    /// this (`spp` stays the cap; see `render/adaptive.rs`).
    pub noise_threshold: Option<f32>,
    /// Render in passes until this much time has gone, stopping at a pass boundary.
    pub time_limit: Option<Duration>,
}

/// What a caller changes of a scene's own render settings (the command line, Python, the
/// fuzzer); None keeps the scene's value or the default.
#[derive(Clone, Debug, Default)]
pub struct Overrides {
    pub spp: Option<u32>,
    /// The path tracer's `max_depth` (`direct` with several samples per hit has none).
    pub max_depth: Option<i32>,
    pub seed: Option<u64>,
    /// Default: Sobol.
    pub sampler: Option<SamplerKind>,
    /// Default: on.
    pub mipmapping: Option<bool>,
    /// Default: on.
    pub packets: Option<bool>,
    pub path_loop: Option<PathLoop>,
    /// Default: 16 pixels.
    pub tile_size: Option<u32>,
    /// Take the denoiser's albedo and normal guides. Default: off.
    pub guides: Option<bool>,
    pub noise_threshold: Option<f32>,
    pub time_limit: Option<Duration>,
}

impl RenderSettings {
    /// The settings of `scene`: its sampler's sample count and seed, its integrator and its
    /// film's filter, with `overrides` applied. The one place settings are made, so the same
    /// scene and overrides give the same pixels from every front end.
    pub fn new(scene: &torrey_parser::Scene, overrides: &Overrides) -> Self {
        let integrator = Integrator::from_desc(&scene.integrator);
        RenderSettings {
            spp: overrides.spp.unwrap_or(scene.sampler.sample_count).max(1),
            integrator: match overrides.max_depth {
                Some(depth) => integrator.with_max_depth(depth),
                None => integrator,
            },
            seed: overrides.seed.unwrap_or(scene.sampler.seed),
            filter: scene.film.filter,
            tile_size: overrides.tile_size.unwrap_or(16),
            env_strategy: EnvStrategy::default(),
            sampler: overrides.sampler.unwrap_or_default(),
            mipmapping: overrides.mipmapping.unwrap_or(true),
            packets: overrides.packets.unwrap_or(true),
            path_loop: overrides.path_loop.unwrap_or_default(),
            channels: SampleChannels {
                aovs: scene.integrator.aovs.clone(),
                guides: overrides.guides.unwrap_or(false),
            },
            noise_threshold: overrides.noise_threshold,
            time_limit: overrides.time_limit,
        }
    }
}
