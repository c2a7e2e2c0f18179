//! The render loop: the film is cut into tiles that rayon renders in parallel; each pixel sample
//! draws its numbers from the sampler by (seed, pixel index, global sample index), so a render is
//! deterministic for a given seed whatever the thread count or tile order, and a render split into
//! film windows and sample ranges ([`RenderSlice`]) draws exactly the samples of the one-piece
//! render.
//!
//! One file per part: the settings ([`settings`]), the passes of a render with a time limit or
//! adaptive sampling ([`passes`], [`adaptive`]), the scalar pixel loop ([`pixel`]), the
//! wavefront pixel loop ([`wavefront_pixel`]).

mod adaptive;
mod passes;
mod pixel;
mod settings;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_passes;
mod wavefront_pixel;

pub use adaptive::relative_error;
pub use passes::PassReport;
pub use settings::{Overrides, RenderSettings};

use crate::cameras::MAX_RAYS;
use crate::film::{Film, TileFilm};
use crate::integrator::aov::AovWriter;
use crate::integrator::{Integrator, PathLoop, PathSettings, RayCount};
use crate::lights::Light;
use crate::sampler::{PcgSampler, SamplerKind, SobolSampler};
use crate::scene::RenderScene;
use pixel::render_pixel;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};
use torrey_texture::{spp_scale, Image};
use wavefront_pixel::{render_pixel_wavefront, WavefrontBuffers};

pub struct RenderOutput {
    /// Per-pixel mean radiance.
    pub image: Image,
    /// Per-pixel variance of the mean (sample variance / spp): the noise level of `image`.
    pub variance: Image,
    pub spp: u32,
    /// Samples that counted in each pixel, row by row: those whose filter offset stayed inside
    /// the film (all `spp` of them with a box filter), or the splats of non-zero weight it got.
    pub counts: Vec<u32>,
    /// Each pixel's sum of sample weights: `counts` for importance-sampled filters, the sum of
    /// the splats' filter weights for splatted ones. Merging sample ranges weighs by it.
    pub weights: Vec<f32>,
    /// Samples whose value was NaN or infinite; they were dropped (counted as zero).
    pub nonfinite_samples: u64,
    /// Pixels whose mean or variance exceeded f32's range and was clamped to f32::MAX (the
    /// film sums in f64; `PixelValue::clamped`).
    pub clamped_pixels: u64,
    pub elapsed: Duration,
    /// Rays traced, closest-hit and shadow.
    pub rays: RayCount,
    /// From the start of rendering until the first tile was finished (its pixels final).
    pub first_tile: Duration,
    /// The names of the values each sample wrote besides the radiance (AOVs, guides:
    /// [`RenderSettings::channels`]), and each pixel's means of them, `channels.len()` per pixel
    /// row by row.
    pub channels: Vec<String>,
    pub extras: Vec<f32>,
    /// Passes rendered (one unless a time limit or adaptive sampling split the render).
    pub passes: u32,
}

/// The most camera rays a packet holds (the widest any layout traces; what
/// [`Camera::generate_packet`] takes).
const MAX_PACKET: usize = MAX_RAYS;

/// One piece of a render: a window of the film and a range of every pixel's samples. Pixel and
/// sample indices stay those of the whole film and of `0..spp`, so pieces rendered apart (other
/// processes, other machines) hold exactly the samples of the one-piece render and merge into it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RenderSlice {
    /// Film window `(x, y, width, height)` in pixels of the full film.
    pub crop: (u32, u32, u32, u32),
    /// Global sample indices to render in every pixel of the window (within `0..spp`).
    pub samples: Range<u32>,
}

impl RenderSlice {
    /// The whole film and all `spp` samples: the one-piece render.
    pub fn full(width: u32, height: u32, spp: u32) -> Self {
        Self {
            crop: (0, 0, width, height),
            samples: 0..spp.max(1),
        }
    }

    /// Checks the window against the film and the range against the render's `spp`.
    pub fn validate(&self, width: u32, height: u32, spp: u32) -> Result<(), String> {
        let (x, y, w, h) = self.crop;
        if w == 0 || h == 0 {
            return Err(format!("crop {x},{y},{w},{h} is empty"));
        }
        if x as u64 + w as u64 > width as u64 || y as u64 + h as u64 > height as u64 {
            return Err(format!(
                "crop {x},{y},{w},{h} reaches outside the {width}x{height} film"
            ));
        }
        let (first, end) = (self.samples.start, self.samples.end);
        if first >= end {
            return Err(format!("sample range {first}..{end} is empty"));
        }
        if end > spp.max(1) {
            return Err(format!(
                "sample range {first}..{end} reaches beyond the render's {spp} spp"
            ));
        }
        Ok(())
    }
}

/// Renders the scene. `progress(done, total)` is called after each tile from worker threads.
pub fn render(
    scene: &RenderScene,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> RenderOutput {
    let full = RenderSlice::full(
        scene.camera().width(),
        scene.camera().height(),
        settings.spp,
    );
    render_slice(scene, settings, &full, progress).expect("the full film is a valid slice")
}

/// Renders one [`RenderSlice`] of the scene: an image of the crop's size whose pixels average the
/// slice's samples (`RenderOutput::spp` is their count). Errors if the slice does not fit the film
/// or the render's `spp`.
pub fn render_slice(
    scene: &RenderScene,
    settings: &RenderSettings,
    slice: &RenderSlice,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<RenderOutput, String> {
    render_slice_reporting(scene, settings, slice, progress, &|_| {})
}

/// [`render_slice`], calling `report` after every pass of a render in passes (a time limit,
/// adaptive sampling; [`passes`]). `progress(done, total)` counts the tiles of the current pass.
pub fn render_slice_reporting(
    scene: &RenderScene,
    settings: &RenderSettings,
    slice: &RenderSlice,
    progress: &(dyn Fn(u64, u64) + Sync),
    report: &(dyn Fn(&PassReport) + Sync),
) -> Result<RenderOutput, String> {
    let start = Instant::now();
    let width = scene.camera().width();
    slice.validate(width, scene.camera().height(), settings.spp)?;
    let (cx, cy, cw, ch) = slice.crop;
    let (wx, wy, ww, wh) = scene.sample_window();
    if cx < wx || cy < wy || cx + cw > wx + ww || cy + ch > wy + wh {
        return Err(format!(
            "the window {cw}x{ch} at ({cx}, {cy}) is not inside the film's crop window {ww}x{wh} at ({wx}, {wy})"
        ));
    }
    let tracer = Tracer::new(scene, settings);
    let mut film = Film::new(settings.filter, scene.sample_window(), slice.crop)
        .with_channels(settings.channels.len());
    let rects = film.tiles(settings.tile_size);
    let mut tiles: Vec<TileFilm> = rects.iter().map(|&r| film.tile(r)).collect();
    let summary = passes::run(
        &tracer, &film, &rects, &mut tiles, slice, start, progress, report,
    )?;

    // In the order of `tiles`: a pixel's splats add up in the same order whatever the window.
    for tile in tiles {
        film.add_tile(tile);
    }
    let nonfinite = film.nonfinite();
    let (pixels, mut extras) = film.finish();
    let channels = settings.channels.names();
    if settings.channels.writes_inner_image() {
        // The wrapped integrator's image is the image (its running mean, not the channel sums).
        for (p, e) in pixels.iter().zip(extras.chunks_exact_mut(channels.len())) {
            e[..3].copy_from_slice(&p.mean.to_array());
        }
    }
    let image = Image::new(cw, ch, pixels.iter().map(|p| p.mean.into()).collect());
    let variance = Image::new(cw, ch, pixels.iter().map(|p| p.variance.into()).collect());
    let counts = pixels.iter().map(|p| p.count).collect();
    let clamped_pixels = pixels.iter().filter(|p| p.clamped).count() as u64;
    let weights = pixels.iter().map(|p| p.weight).collect();
    let elapsed = start.elapsed();
    Ok(RenderOutput {
        image,
        variance,
        spp: slice.samples.end - slice.samples.start,
        counts,
        weights,
        nonfinite_samples: nonfinite,
        clamped_pixels,
        elapsed,
        rays: RayCount {
            closest: tracer.closest_rays.into_inner(),
            shadow: tracer.shadow_rays.into_inner(),
        },
        first_tile: Duration::from_nanos(tracer.first_tile_ns.into_inner()).min(elapsed),
        channels,
        extras,
        passes: summary.passes,
    })
}

/// Which samples a pass renders in each pixel: the same range everywhere, or a range per pixel
/// of a window (empty ranges render nothing).
pub(crate) enum Ranges<'a> {
    All(Range<u32>),
    PerPixel {
        window: (u32, u32, u32, u32),
        ranges: &'a [Range<u32>],
    },
}

impl Ranges<'_> {
    #[inline]
    fn get(&self, x: u32, y: u32) -> Range<u32> {
        match self {
            Ranges::All(r) => r.clone(),
            Ranges::PerPixel { window, ranges } => {
                let (wx, wy, ww, _) = *window;
                ranges[(y - wy) as usize * ww as usize + (x - wx) as usize].clone()
            }
        }
    }
}

/// What every tile of every pass shares: the scene, the settings, the loops' settings, the
/// AOV writer and the counters.
pub(crate) struct Tracer<'a> {
    scene: &'a RenderScene,
    settings: &'a RenderSettings,
    path: PathSettings,
    wavefront: bool,
    aov: Option<AovWriter<'a>>,
    closest_rays: AtomicU64,
    shadow_rays: AtomicU64,
    first_tile_ns: AtomicU64,
}

impl<'a> Tracer<'a> {
    fn new(scene: &'a RenderScene, settings: &'a RenderSettings) -> Self {
        let integrator = settings.integrator;
        let path = PathSettings {
            max_depth: u32::try_from(integrator.max_depth()).unwrap_or(u32::MAX),
            rr_depth: integrator.rr_depth(),
            hide_emitters: integrator.hide_emitters(),
            mipmapping: settings.mipmapping,
            // The footprint is the whole render's (its spp), whatever range this slice holds.
            footprint_scale: spp_scale(settings.spp),
            env_strategy: settings.env_strategy,
            guides: settings.channels.guides,
        };
        // `direct` with several samples per hit has no wavefront form: one path at a time.
        let wavefront = matches!(integrator, Integrator::Path(_))
            && match settings.path_loop {
                PathLoop::Scalar => false,
                PathLoop::Wavefront => true,
                PathLoop::Auto => scene.lights.iter().any(|l| matches!(l, Light::Env(_))),
            };
        let aov = (!settings.channels.is_empty()).then(|| {
            AovWriter::new(
                scene,
                &settings.channels,
                settings.spp,
                integrator.hide_emitters(),
                matches!(integrator, Integrator::Direct(_)),
            )
        });
        Self {
            scene,
            settings,
            path,
            wavefront,
            aov,
            closest_rays: AtomicU64::new(0),
            shadow_rays: AtomicU64::new(0),
            first_tile_ns: AtomicU64::new(u64::MAX),
        }
    }

    /// Renders `ranges` of every pixel of `rects` into the matching `tiles`, in parallel;
    /// `progress(done, total)` after each tile.
    fn pass(
        &self,
        rects: &[(u32, u32, u32, u32)],
        tiles: &mut [TileFilm],
        ranges: &Ranges,
        start: Instant,
        progress: &(dyn Fn(u64, u64) + Sync),
    ) {
        let total = rects.len() as u64;
        let done = AtomicU64::new(0);
        rects
            .par_iter()
            .zip(tiles.par_iter_mut())
            .for_each(|(&rect, tile)| {
                self.tile(rect, tile, ranges);
                self.first_tile_ns
                    .fetch_min(start.elapsed().as_nanos() as u64, Ordering::Relaxed);
                progress(done.fetch_add(1, Ordering::Relaxed) + 1, total);
            });
    }

    /// Renders the pixels of one tile.
    fn tile(&self, (x0, y0, x1, y1): (u32, u32, u32, u32), tile: &mut TileFilm, ranges: &Ranges) {
        let (scene, settings, path) = (self.scene, self.settings, self.path);
        let width = scene.camera().width();
        let mut end = 0;
        for y in y0..y1 {
            for x in x0..x1 {
                end = end.max(ranges.get(x, y).end);
            }
        }
        if end == 0 {
            return;
        }
        let mut rays = RayCount::default();
        let aov = self.aov.as_ref();
        // One Sobol sampler per tile: its table of points is reused from pixel to pixel.
        let mut sobol = (settings.sampler == SamplerKind::Sobol)
            .then(|| SobolSampler::tabled(settings.seed, 0, end));
        let mut pcg_wavefront = WavefrontBuffers::<PcgSampler>::default();
        let mut sobol_wavefront = WavefrontBuffers::<SobolSampler>::default();
        for y in y0..y1 {
            for x in x0..x1 {
                let samples = ranges.get(x, y);
                if samples.is_empty() {
                    continue;
                }
                let pixel_index = y as u64 * width as u64 + x as u64;
                match settings.sampler {
                    SamplerKind::Independent if self.wavefront => render_pixel_wavefront(
                        scene,
                        (x, y),
                        settings,
                        samples,
                        path,
                        &mut PcgSampler::new(settings.seed, pixel_index),
                        true,
                        &mut rays,
                        &mut pcg_wavefront,
                        tile,
                        aov,
                    ),
                    SamplerKind::Sobol if self.wavefront => {
                        let sampler = sobol.as_mut().expect("made for the Sobol sampler");
                        sampler.restart(settings.seed, pixel_index, samples.end);
                        render_pixel_wavefront(
                            scene,
                            (x, y),
                            settings,
                            samples,
                            path,
                            sampler,
                            false,
                            &mut rays,
                            &mut sobol_wavefront,
                            tile,
                            aov,
                        )
                    }
                    SamplerKind::Independent => render_pixel(
                        scene,
                        (x, y),
                        settings,
                        samples,
                        path,
                        &mut PcgSampler::new(settings.seed, pixel_index),
                        &mut rays,
                        tile,
                        aov,
                    ),
                    SamplerKind::Sobol => {
                        // Tables cover the samples up to the range's end (one past its last).
                        let sampler = sobol.as_mut().expect("made for the Sobol sampler");
                        sampler.restart(settings.seed, pixel_index, samples.end);
                        render_pixel(
                            scene,
                            (x, y),
                            settings,
                            samples,
                            path,
                            sampler,
                            &mut rays,
                            tile,
                            aov,
                        )
                    }
                }
            }
        }
        self.closest_rays.fetch_add(rays.closest, Ordering::Relaxed);
        self.shadow_rays.fetch_add(rays.shadow, Ordering::Relaxed);
    }
}
