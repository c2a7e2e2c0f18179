//! The render loop: the film is cut into tiles that rayon renders in parallel; each pixel sample
//! draws its numbers from the sampler by (seed, pixel index, global sample index), so a render is
//! deterministic for a given seed whatever the thread count or tile order, and a render split into
//! film windows and sample ranges ([`RenderSlice`]) draws exactly the samples of the one-piece
//! render.

use crate::accel::ClosestHit;
use crate::cameras::{Camera, CameraSample, MAX_RAYS};
use crate::film::{Film, Filter, TileFilm};
use crate::integrator::wavefront::{CameraPath, PathSamplers, Wavefront};
use crate::integrator::{radiance, EnvStrategy, PathLoop, PathSettings, RayCount};
use crate::lights::Light;
use crate::ray::Ray;
use crate::sampler::{PcgSampler, Sampler, SamplerKind, SobolSampler};
use crate::scene::RenderScene;
use crate::shapes::SurfaceHit;
use glam::{Vec2, Vec3A};
use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};
use torrey_parser::PixelFilter;
use torrey_texture::{centre_weight, spp_scale, Image, RayCone};

#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub spp: u32,
    pub max_depth: i32,
    pub rr_depth: i32,
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
    /// the wavefront where an environment map lights the scene, or where its surface stage
    /// shades diffuse surfaces in SIMD lanes and every light's samples too): the same images,
    /// bit for bit.
    pub path_loop: PathLoop,
}

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
    let samples = slice.samples.clone();
    let mut film = Film::new(settings.filter, scene.sample_window(), slice.crop);
    let tiles = film.tiles(settings.tile_size);
    let total = tiles.len() as u64;
    let done = AtomicU64::new(0);
    let closest_rays = AtomicU64::new(0);
    let shadow_rays = AtomicU64::new(0);
    let first_tile_ns = AtomicU64::new(u64::MAX);
    let path = PathSettings {
        max_depth: settings.max_depth,
        rr_depth: settings.rr_depth,
        mipmapping: settings.mipmapping,
        // The footprint is the whole render's (its spp), whatever range this slice holds.
        footprint_scale: spp_scale(settings.spp),
        env_strategy: settings.env_strategy,
    };

    // `direct` with several samples per hit has no wavefront form: one path at a time.
    let wavefront = scene.direct_samples.is_none()
        && match settings.path_loop {
            PathLoop::Scalar => false,
            PathLoop::Wavefront => true,
            PathLoop::Auto => {
                scene.lights.iter().any(|l| matches!(l, Light::Env(_)))
                    || scene.lanes.wavefront_pays()
            }
        };

    let rendered: Vec<TileFilm> = tiles
        .par_iter()
        .map(|&(x0, y0, x1, y1)| {
            let mut tile = film.tile((x0, y0, x1, y1));
            let mut rays = RayCount::default();
            // One Sobol sampler per tile: its table of points is reused from pixel to pixel.
            let mut sobol = (settings.sampler == SamplerKind::Sobol)
                .then(|| SobolSampler::tabled(settings.seed, 0, samples.end));
            let mut pcg_wavefront = WavefrontBuffers::<PcgSampler>::default();
            let mut sobol_wavefront = WavefrontBuffers::<SobolSampler>::default();
            for y in y0..y1 {
                for x in x0..x1 {
                    let pixel_index = y as u64 * width as u64 + x as u64;
                    match settings.sampler {
                        SamplerKind::Independent if wavefront => render_pixel_wavefront(
                            scene,
                            (x, y),
                            settings,
                            samples.clone(),
                            path,
                            &mut PcgSampler::new(settings.seed, pixel_index),
                            true,
                            &mut rays,
                            &mut pcg_wavefront,
                            &mut tile,
                        ),
                        SamplerKind::Sobol if wavefront => {
                            let sampler = sobol.as_mut().expect("made for the Sobol sampler");
                            sampler.restart(settings.seed, pixel_index, samples.end);
                            render_pixel_wavefront(
                                scene,
                                (x, y),
                                settings,
                                samples.clone(),
                                path,
                                sampler,
                                false,
                                &mut rays,
                                &mut sobol_wavefront,
                                &mut tile,
                            )
                        }
                        SamplerKind::Independent => render_pixel(
                            scene,
                            (x, y),
                            settings,
                            samples.clone(),
                            path,
                            &mut PcgSampler::new(settings.seed, pixel_index),
                            &mut rays,
                            &mut tile,
                        ),
                        SamplerKind::Sobol => {
                            // Tables cover the samples up to the range's end (one past its last).
                            let sampler = sobol.as_mut().expect("made for the Sobol sampler");
                            sampler.restart(settings.seed, pixel_index, samples.end);
                            render_pixel(
                                scene,
                                (x, y),
                                settings,
                                samples.clone(),
                                path,
                                sampler,
                                &mut rays,
                                &mut tile,
                            )
                        }
                    }
                }
            }
            closest_rays.fetch_add(rays.closest, Ordering::Relaxed);
            shadow_rays.fetch_add(rays.shadow, Ordering::Relaxed);
            first_tile_ns.fetch_min(start.elapsed().as_nanos() as u64, Ordering::Relaxed);
            let d = done.fetch_add(1, Ordering::Relaxed) + 1;
            progress(d, total);
            tile
        })
        .collect();

    // In the order of `tiles`: a pixel's splats add up in the same order whatever the window.
    for tile in rendered {
        film.add_tile(tile);
    }
    let nonfinite = film.nonfinite();
    let pixels = film.finish();
    let (_, _, cw, ch) = slice.crop;
    let image = Image::new(cw, ch, pixels.iter().map(|p| p.mean.into()).collect());
    let variance = Image::new(cw, ch, pixels.iter().map(|p| p.variance.into()).collect());
    let counts = pixels.iter().map(|p| p.count).collect();
    let clamped_pixels = pixels.iter().filter(|p| p.clamped).count() as u64;
    let weights = pixels.iter().map(|p| p.weight).collect();
    let elapsed = start.elapsed();
    Ok(RenderOutput {
        image,
        variance,
        spp: samples.end - samples.start,
        counts,
        weights,
        nonfinite_samples: nonfinite,
        clamped_pixels,
        elapsed,
        rays: RayCount {
            closest: closest_rays.into_inner(),
            shadow: shadow_rays.into_inner(),
        },
        first_tile: Duration::from_nanos(first_tile_ns.into_inner()).min(elapsed),
    })
}

/// Renders one pixel's samples `samples` (global indices) into the tile's film.
/// What every camera sample of one pixel shares: the camera, the pixel's ray cone and the film's
/// filter; [`PixelCamera::ray`] draws one sample's camera ray. Both render loops start from it.
struct PixelCamera<'a> {
    camera: &'a Camera,
    pixel: (u32, u32),
    filter: Filter,
    /// One sample's share of the pixel: 1/sqrt(spp) of its width, centred towards the pixel
    /// centre (the ray through the film's and the lens's centres).
    cone: RayCone,
    /// The camera's sampler draws: the film position, then its lens (if it has one).
    requests: u32,
}

impl<'a> PixelCamera<'a> {
    #[inline]
    fn new(
        scene: &'a RenderScene,
        (x, y): (u32, u32),
        settings: &RenderSettings,
        path: PathSettings,
        film: &TileFilm,
    ) -> Self {
        let camera = scene.camera();
        let centre = camera
            .generate_ray(&CameraSample {
                film: Vec2::new(x as f32 + 0.5, y as f32 + 0.5),
                lens: Vec2::splat(0.5),
            })
            .1;
        let cone = RayCone::from_pixel(camera.pixel_spread() * path.footprint_scale)
            .toward_pixel_centre(centre.into(), centre_weight(settings.spp.max(1)));
        Self {
            camera,
            pixel: (x, y),
            filter: film.filter(),
            cone,
            requests: 1 + camera.lens_requests(),
        }
    }

    /// One sample's camera ray: origin, direction, film position and whether that position
    /// counts. Samples whose film position leaves the film do not count (see
    /// `TileFilm::film_position`) and are not traced.
    #[inline(always)]
    fn ray<S: Sampler>(&self, sampler: &mut S, film: &TileFilm) -> (Vec3A, Vec3A, Vec2, bool) {
        let (position, lens, inside) = self.draw(sampler, film);
        let (o, d) = self.camera.generate_ray(&CameraSample {
            film: position,
            lens,
        });
        (o, d, position, inside)
    }

    /// One sample's camera draws: its film position, lens point (zero without a lens) and
    /// whether the position counts; [`PixelCamera::ray`] without the ray, for packets, whose
    /// rays [`Camera::generate_packet`] makes together once every lane has drawn.
    #[inline(always)]
    fn draw<S: Sampler>(&self, sampler: &mut S, film: &TileFilm) -> (Vec2, Vec2, bool) {
        let offset = self.filter.offset(sampler.next_2d());
        let (position, inside) = film.film_position(self.pixel, offset);
        let lens = if self.camera.lens_requests() > 0 {
            sampler.next_2d()
        } else {
            Vec2::ZERO
        };
        (position, lens, inside)
    }
}

#[allow(clippy::too_many_arguments)]
#[inline]
fn render_pixel<S: Sampler>(
    scene: &RenderScene,
    (x, y): (u32, u32),
    settings: &RenderSettings,
    samples: Range<u32>,
    path: PathSettings,
    sampler: &mut S,
    rays: &mut RayCount,
    film: &mut TileFilm,
) {
    let pixel = PixelCamera::new(scene, (x, y), settings, path, film);
    let (camera, cone, camera_requests) = (pixel.camera, pixel.cone, pixel.requests);
    let camera_ray = |sampler: &mut S, film: &TileFilm| pixel.ray(sampler, film);
    // Camera rays go in packets, traced together, for every group of `lanes` global sample
    // indices (k lanes .. (k+1) lanes) that lies whole in the range: each packet's rays are drawn
    // first, then their paths are followed one by one from the hits. Samplers resume a sample's
    // numbers where its camera ray left them, so each sample is the same with or without
    // packets, and a range that cuts a group renders that group's samples one by one with the
    // same numbers. Packets need a layout that traces them and a camera whose rays share their
    // origin.
    let lanes = if settings.packets && camera.rays_share_origin() {
        scene.packet_width().min(MAX_PACKET)
    } else {
        0
    };
    let mut origin = Vec3A::ZERO;
    let mut dirs = [Vec3A::ZERO; MAX_PACKET];
    let mut positions = [Vec2::ZERO; MAX_PACKET];
    let mut lenses = [Vec2::ZERO; MAX_PACKET];
    let mut insides = [true; MAX_PACKET];
    let mut hits = [None; MAX_PACKET];
    let mut resume = [[0u64; 2]; MAX_PACKET];
    let mut packed = false;
    for s in samples.clone() {
        let (o, d, first_hit, position, inside) = if in_packet(s, lanes, &samples) {
            let lane = (s % lanes as u32) as usize;
            if lane == 0 {
                for k in 0..lanes {
                    sampler.start_sample(s + k as u32);
                    (positions[k], lenses[k], insides[k]) = pixel.draw(sampler, film);
                    resume[k] = sampler.checkpoint();
                }
                origin = camera.generate_packet(
                    &positions[..lanes],
                    &lenses[..lanes],
                    &mut dirs[..lanes],
                );
                packed = scene
                    .accel()
                    .intersect_packet(origin, &dirs[..lanes], &mut hits[..lanes]);
            }
            sampler.restore(resume[lane], s, camera_requests);
            (
                origin,
                dirs[lane],
                packed.then_some(hits[lane]),
                positions[lane],
                insides[lane],
            )
        } else {
            sampler.start_sample(s);
            let (o, d, position, inside) = camera_ray(sampler, film);
            (o, d, None, position, inside)
        };
        if inside {
            let first_hit = clipped_first_hit(scene, o, d, first_hit);
            let l = radiance(scene, o, d, cone, path, sampler, rays, first_hit);
            film.add_sample((x, y), position, l);
        }
    }
}

/// Whether global sample `s` lies in a packet group of `lanes` samples that is whole inside
/// `samples` (0 lanes: no packets).
#[inline]
fn in_packet(s: u32, lanes: usize, samples: &Range<u32>) -> bool {
    let group = lanes as u32;
    group > 0 && {
        let group_start = s - s % group;
        group_start >= samples.start
            && group_start
                .checked_add(group)
                .is_some_and(|end| end <= samples.end)
    }
}

/// Paths per wavefront batch: a block of the Sobol sampler's table (its columns stay valid while
/// the batch's paths resume one another), a multiple of every packet width.
const WAVEFRONT_BATCH: u32 = 64;

/// [`render_pixel`] with the path tracer run as a wavefront ([`Wavefront`]): the pixel's samples
/// go in batches of up to [`WAVEFRONT_BATCH`] (aligned to multiples of it), each batch's camera
/// rays drawn and traced (in packets where `render_pixel` uses them, then clipped), then its
/// paths advanced a bounce at a time. The samples' numbers, rays and radiance are those of
/// `render_pixel`, and they reach the film through [`TileFilm::add_sample`] in the same order, so
/// the results are bit-identical (splatted filters included). `per_path`: give each path its own
/// copy of `sampler` (independent streams) instead of resuming the shared one.
#[allow(clippy::too_many_arguments)]
fn render_pixel_wavefront<S: Sampler + Clone>(
    scene: &RenderScene,
    (x, y): (u32, u32),
    settings: &RenderSettings,
    samples: Range<u32>,
    path: PathSettings,
    sampler: &mut S,
    per_path: bool,
    rays: &mut RayCount,
    wavefront: &mut WavefrontBuffers<S>,
    film: &mut TileFilm,
) {
    let pixel = PixelCamera::new(scene, (x, y), settings, path, film);
    let (camera, cone, camera_requests) = (pixel.camera, pixel.cone, pixel.requests);
    let camera_ray = |sampler: &mut S, film: &TileFilm| pixel.ray(sampler, film);
    let lanes = if settings.packets && camera.rays_share_origin() {
        scene.packet_width().min(MAX_PACKET)
    } else {
        0
    };
    let WavefrontBuffers {
        loop_,
        cameras,
        samplers,
        radiance,
    } = wavefront;
    let mut dirs = [Vec3A::ZERO; MAX_PACKET];
    let mut positions = [Vec2::ZERO; MAX_PACKET];
    let mut lenses = [Vec2::ZERO; MAX_PACKET];
    let mut insides = [true; MAX_PACKET];
    let mut hits = [None; MAX_PACKET];
    let mut start = samples.start;
    while start < samples.end {
        let end = (start - start % WAVEFRONT_BATCH + WAVEFRONT_BATCH).min(samples.end);
        cameras.clear();
        samplers.clear();
        let mut s = start;
        while s < end {
            if in_packet(s, lanes, &samples) {
                // A whole packet group (groups never straddle batches: lanes divide the batch).
                for k in 0..lanes {
                    let index = s + k as u32;
                    let lane_sampler = if per_path {
                        let mut own = sampler.clone();
                        own.start_sample(index);
                        samplers.push(own);
                        samplers.last_mut().expect("just pushed")
                    } else {
                        sampler.start_sample(index);
                        &mut *sampler
                    };
                    (positions[k], lenses[k], insides[k]) = pixel.draw(lane_sampler, film);
                }
                let origin = camera.generate_packet(
                    &positions[..lanes],
                    &lenses[..lanes],
                    &mut dirs[..lanes],
                );
                let packed =
                    scene
                        .accel()
                        .intersect_packet(origin, &dirs[..lanes], &mut hits[..lanes]);
                // Samples outside the film are dropped (with their samplers, kept in step).
                let first = cameras.len();
                for k in 0..lanes {
                    if !insides[k] {
                        continue;
                    }
                    let traced = packed.then_some(hits[k]);
                    if per_path {
                        samplers.swap(cameras.len(), first + k);
                    }
                    cameras.push(CameraPath {
                        sample: s + k as u32,
                        origin,
                        dir: dirs[k],
                        position: positions[k],
                        cone,
                        first_hit: None,
                    });
                    set_first_hit(scene, traced, cameras.last_mut().expect("just pushed"));
                }
                if per_path {
                    samplers.truncate(cameras.len());
                }
                s += lanes as u32;
            } else {
                let lane_sampler = if per_path {
                    let mut own = sampler.clone();
                    own.start_sample(s);
                    samplers.push(own);
                    samplers.last_mut().expect("just pushed")
                } else {
                    sampler.start_sample(s);
                    &mut *sampler
                };
                let (o, d, position, inside) = camera_ray(lane_sampler, film);
                if inside {
                    cameras.push(CameraPath {
                        sample: s,
                        origin: o,
                        dir: d,
                        position,
                        cone,
                        first_hit: clipped_first_hit(scene, o, d, None),
                    });
                } else if per_path {
                    samplers.pop();
                }
                s += 1;
            }
        }
        let samplers = if per_path {
            PathSamplers::PerPath(&mut samplers[..])
        } else {
            PathSamplers::Shared(&mut *sampler)
        };
        loop_.radiance(
            scene,
            cameras,
            camera_requests,
            path,
            samplers,
            rays,
            radiance,
        );
        film.add_samples(
            (x, y),
            cameras
                .iter()
                .map(|c| c.position)
                .zip(radiance.iter().copied()),
        );
        start = end;
    }
}

/// One worker's wavefront loop and its batch buffers, reused from pixel to pixel.
struct WavefrontBuffers<S> {
    loop_: Wavefront,
    cameras: Vec<CameraPath>,
    samplers: Vec<S>,
    radiance: Vec<Vec3A>,
}

impl<S> Default for WavefrontBuffers<S> {
    fn default() -> Self {
        Self {
            loop_: Wavefront::default(),
            cameras: Vec::new(),
            samplers: Vec::new(),
            radiance: Vec::new(),
        }
    }
}

/// Sets the camera path's first hit to [`clipped_first_hit`] of its ray, a hit between the
/// clip planes set up in place ([`RenderScene::surface_into_some`]): built in a temporary and
/// copied into the batch, its fields were read back right after the set-up stored them, in
/// pieces the CPU cannot forward from the stores (a stall per camera ray).
#[inline]
fn set_first_hit(scene: &RenderScene, traced: Option<Option<ClosestHit>>, path: &mut CameraPath) {
    let (origin, dir) = (path.origin, path.dir);
    let (near, far) = scene.camera().clip_range(dir);
    // `clipped_first_hit`'s cases.
    match traced {
        Some(Some(h)) if h.t < near => path.first_hit = clip_near(scene, origin, dir, near, far),
        Some(Some(h)) if h.t > far => path.first_hit = None,
        Some(Some(h)) => {
            let ray = Ray {
                origin,
                dir,
                tmax: f32::INFINITY,
            };
            scene.surface_into_some(&ray, &h, &mut path.first_hit);
        }
        _ => path.first_hit = clipped_first_hit(scene, origin, dir, traced),
    }
}

/// The camera ray's first hit between the camera's clip planes ([`crate::Camera::clip_range`]):
/// Mitsuba starts perspective and thin lens rays on the near plane and ends them on the far one.
/// `traced` is the closest hit from the ray's origin if it was traced already (in a packet): its
/// surface is set up only once it is known to lie between the planes; a hit nearer than the near
/// plane is traced again from there.
#[inline]
fn clipped_first_hit(
    scene: &RenderScene,
    origin: Vec3A,
    dir: Vec3A,
    traced: Option<Option<ClosestHit>>,
) -> Option<SurfaceHit> {
    let (near, far) = scene.camera().clip_range(dir);
    let Some(traced) = traced else {
        let hit = scene.intersect(&Ray {
            origin,
            dir,
            tmax: far,
        });
        return match hit {
            Some(h) if h.t < near => clip_near(scene, origin, dir, near, far),
            Some(h) if h.t > far => None,
            hit => hit,
        };
    };
    match traced {
        Some(h) if h.t < near => clip_near(scene, origin, dir, near, far),
        Some(h) if h.t > far => None,
        Some(h) => {
            let ray = Ray {
                origin,
                dir,
                tmax: f32::INFINITY,
            };
            Some(scene.surface(&ray, &h))
        }
        None => None,
    }
}

/// The camera ray's closest hit traced again from the near plane.
#[cold]
fn clip_near(
    scene: &RenderScene,
    origin: Vec3A,
    dir: Vec3A,
    near: f32,
    far: f32,
) -> Option<SurfaceHit> {
    scene.intersect(&Ray {
        origin: origin + dir * near,
        dir,
        tmax: far - near,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cameras::{Camera, ThinLensCamera};
    use std::path::Path;

    /// A small scene with meshes, a sphere and an area light (24x20).
    fn packet_scene() -> RenderScene {
        let xml = r#"<scene version="0.6.0">
            <integrator type="path"><integer name="maxDepth" value="5"/></integrator>
            <sensor type="perspective">
                <float name="fov" value="50"/>
                <transform name="toWorld"><lookAt origin="0, 1, 4" target="0, 0.6, 0" up="0, 1, 0"/></transform>
                <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="20"/></film>
            </sensor>
            <shape type="rectangle">
                <transform name="toWorld"><scale value="3"/><rotate x="1" angle="-90"/></transform>
            </shape>
            <shape type="sphere"><point name="center" x="0.4" y="0.5" z="0"/><float name="radius" value="0.5"/>
                <bsdf type="plastic"/></shape>
            <shape type="obj"><string name="filename" value="meshes/torus.obj"/>
                <transform name="toWorld"><scale value="0.5"/><translate x="-0.7" y="0.4"/></transform></shape>
            <shape type="rectangle">
                <transform name="toWorld"><rotate x="1" angle="90"/><translate y="2.5"/></transform>
                <emitter type="area"><rgb name="radiance" value="4, 4, 4"/></emitter>
            </shape>
        </scene>"#;
        crate::scene::scene_from_xml(xml, 24, 20)
    }

    fn settings(spp: u32, sampler: SamplerKind, packets: bool) -> RenderSettings {
        RenderSettings {
            spp,
            max_depth: 5,
            rr_depth: 5,
            seed: 3,
            filter: PixelFilter::Box,
            tile_size: 8,
            mipmapping: true,
            env_strategy: EnvStrategy::default(),
            sampler,
            packets,
            path_loop: PathLoop::Scalar,
        }
    }

    fn assert_bits_eq(a: &Image, b: &Image, what: &str) {
        assert_eq!((a.width, a.height), (b.width, b.height), "{what}");
        for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
            assert_eq!(
                p.to_array().map(f32::to_bits),
                q.to_array().map(f32::to_bits),
                "{what}: pixel {i}"
            );
        }
    }

    /// Camera rays traced in packets give the image traced ray by ray, bit for bit, with both
    /// samplers (each resumes a sample's numbers where its camera ray left them): meshes, a
    /// sphere, an area light; 12 spp, so a whole packet and four single samples per pixel.
    #[test]
    fn packets_render_the_image_of_single_rays() {
        let scene = packet_scene();
        for sampler in [SamplerKind::Sobol, SamplerKind::Independent] {
            let packed = render(&scene, &settings(12, sampler, true), &|_, _| {});
            let single = render(&scene, &settings(12, sampler, false), &|_, _| {});
            assert!(packed.image.pixels.iter().any(|p| p.max_element() > 0.0));
            assert_eq!(packed.rays.closest, single.rays.closest);
            assert_bits_eq(&packed.image, &single.image, &format!("{sampler:?}"));
            assert_bits_eq(&packed.variance, &single.variance, &format!("{sampler:?}"));
        }
    }

    /// Slices hold the samples of the one-piece render: crop windows give its pixels bit for
    /// bit; sample ranges that cut packet groups (0..5, 5..13, 13..20 of 20 spp) give, merged
    /// by count-weighted mean and the parallel variance formula, its mean and variance to float
    /// rounding; a range rendered with and without packets is bit-identical. Both samplers.
    #[test]
    fn slices_hold_the_samples_of_the_one_piece_render() {
        let scene = packet_scene();
        // A gaussian filter's offsets can leave the film at its border: those samples do not
        // count, so border pixels hold fewer, and the merge weighs each pixel by its count.
        // Lanczos splats across pixels with signed weights: the merge weighs by weight sums.
        for (sampler, filter) in [
            (SamplerKind::Sobol, PixelFilter::Box),
            (SamplerKind::Independent, PixelFilter::Box),
            (SamplerKind::Sobol, PixelFilter::Gaussian { stddev: 0.5 }),
            (SamplerKind::Independent, PixelFilter::Lanczos { lobes: 3 }),
        ] {
            let set = RenderSettings {
                filter,
                ..settings(20, sampler, true)
            };
            let splats = matches!(filter, PixelFilter::Lanczos { .. });
            let full = render(&scene, &set, &|_, _| {});
            if filter != PixelFilter::Box {
                assert!(
                    full.counts.iter().any(|&n| n != 20),
                    "some samples leave the film, or splat into neighbours"
                );
            }
            // Crops: a window's pixels are the full render's pixels.
            let crop = RenderSlice {
                crop: (5, 3, 11, 9),
                samples: 0..20,
            };
            let part = render_slice(&scene, &set, &crop, &|_, _| {}).unwrap();
            let window = |img: &Image| {
                Image::new(
                    11,
                    9,
                    (3..12)
                        .flat_map(|y| (5..16).map(move |x| (x, y)))
                        .map(|(x, y)| img.get(x, y))
                        .collect(),
                )
            };
            assert_bits_eq(
                &part.image,
                &window(&full.image),
                &format!("{sampler:?} crop"),
            );
            assert_bits_eq(
                &part.variance,
                &window(&full.variance),
                &format!("{sampler:?} crop variance"),
            );
            // Sample ranges.
            let parts: Vec<RenderOutput> = [0..5, 5..13, 13..20]
                .into_iter()
                .map(|samples| {
                    let slice = RenderSlice {
                        crop: (0, 0, 24, 20),
                        samples,
                    };
                    render_slice(&scene, &set, &slice, &|_, _| {}).unwrap()
                })
                .collect();
            let mut worst = 0.0f64;
            let (mut merged_var, mut one_var) = (0.0f64, 0.0f64);
            for i in 0..full.image.pixels.len() {
                let rel = |merged: f64, one: f32| {
                    let one = one as f64;
                    (merged - one).abs() / merged.abs().max(one.abs()).max(1e-30)
                };
                if splats {
                    // By weight sums; the variance of the merged mean.
                    let w: f64 = parts.iter().map(|p| p.weights[i] as f64).sum();
                    for c in 0..3 {
                        let s: f64 = parts
                            .iter()
                            .map(|p| p.weights[i] as f64 * p.image.pixels[i][c] as f64)
                            .sum();
                        let v: f64 = parts
                            .iter()
                            .map(|p| (p.weights[i] as f64).powi(2) * p.variance.pixels[i][c] as f64)
                            .sum();
                        // Means: relative to the pixel's scale (signed weights can cancel).
                        let scale = full.image.pixels[i].abs().max_element().max(1e-3) as f64;
                        worst = worst.max((s / w - full.image.pixels[i][c] as f64).abs() / scale);
                        merged_var += v / (w * w);
                        one_var += full.variance.pixels[i][c] as f64;
                    }
                    continue;
                }
                let (mut n, mut mean, mut m2) = (0.0f64, [0.0f64; 3], [0.0f64; 3]);
                for p in &parts {
                    let nb = p.counts[i] as f64;
                    if nb == 0.0 {
                        continue;
                    }
                    let (mb, vb) = (p.image.pixels[i], p.variance.pixels[i]);
                    for c in 0..3 {
                        let m2b = vb[c] as f64 * nb * (nb - 1.0);
                        let delta = mb[c] as f64 - mean[c];
                        let total = n + nb;
                        mean[c] += delta * nb / total;
                        m2[c] += m2b + delta * delta * n * nb / total;
                    }
                    n += nb;
                }
                for c in 0..3 {
                    let var = m2[c] / (n * (n - 1.0));
                    worst = worst.max(rel(mean[c], full.image.pixels[i][c]));
                    worst = worst.max(rel(var, full.variance.pixels[i][c]));
                }
            }
            assert!(
                worst < 1e-5,
                "{sampler:?} {filter:?}: merged ranges differ by {worst:e}"
            );
            // Splatted: the merged variance estimates the same variance from other sums: over the
            // image, they agree to 10%.
            if splats {
                let ratio = merged_var / one_var;
                assert!(
                    (0.9..1.1).contains(&ratio),
                    "{filter:?}: variance ratio {ratio}"
                );
            }
            // A range that cuts groups renders the same with and without packets.
            let slice = RenderSlice {
                crop: (0, 0, 24, 20),
                samples: 3..19,
            };
            let packed = render_slice(&scene, &set, &slice, &|_, _| {}).unwrap();
            let unpacked = RenderSettings {
                packets: false,
                ..set.clone()
            };
            let single = render_slice(&scene, &unpacked, &slice, &|_, _| {}).unwrap();
            assert_bits_eq(&packed.image, &single.image, &format!("{sampler:?} 3..19"));
        }
    }

    /// The wavefront loop renders the scalar loop's image bit for bit (the same numbers, rays,
    /// MIS weights and Russian roulette, summed in the same order): both samplers, with packets
    /// and without, a gaussian filter whose offsets leave the film at the border, splatted
    /// filters (lanczos, mitchell) whose samples reach neighbouring pixels, a crop and a sample
    /// range that cuts packet groups and crosses a batch boundary (60..70 of 70 spp), and a film
    /// with a crop window (its bounds: samples leaving it do not count); meshes, a sphere and an
    /// area light here, an environment map with a sun, a mirror and a microfacet sphere in
    /// `envmap_sky.xml`.
    #[test]
    fn wavefront_renders_the_image_of_the_scalar_loop() {
        let sky = {
            let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/envmap_sky.xml");
            let desc = torrey_parser::load_scene(&path, &[]).unwrap();
            RenderScene::build(&desc, 24, 20).unwrap()
        };
        let windowed = {
            let mut scene = packet_scene();
            scene.sample_window = (4, 3, 14, 12);
            scene
        };
        let window = Some(RenderSlice {
            crop: (4, 3, 14, 12),
            samples: 0..12,
        });
        for (name, scene) in [
            ("packets", packet_scene()),
            ("envmap_sky", sky),
            ("film crop window", windowed),
        ] {
            let cases: Vec<(SamplerKind, PixelFilter, bool, u32, Option<RenderSlice>)> =
                if name == "film crop window" {
                    vec![
                        (
                            SamplerKind::Sobol,
                            PixelFilter::Box,
                            true,
                            12,
                            window.clone(),
                        ),
                        (
                            SamplerKind::Independent,
                            PixelFilter::Gaussian { stddev: 0.5 },
                            true,
                            12,
                            window.clone(),
                        ),
                        (
                            SamplerKind::Sobol,
                            PixelFilter::Lanczos { lobes: 3 },
                            true,
                            12,
                            window.clone(),
                        ),
                        (
                            SamplerKind::Independent,
                            PixelFilter::Lanczos { lobes: 3 },
                            false,
                            12,
                            Some(RenderSlice {
                                crop: (6, 5, 7, 6),
                                samples: 3..12,
                            }),
                        ),
                    ]
                } else {
                    vec![
                        (SamplerKind::Sobol, PixelFilter::Box, true, 12, None),
                        (SamplerKind::Independent, PixelFilter::Box, true, 12, None),
                        (SamplerKind::Sobol, PixelFilter::Box, false, 12, None),
                        (
                            SamplerKind::Independent,
                            PixelFilter::Gaussian { stddev: 0.5 },
                            true,
                            9,
                            None,
                        ),
                        (
                            SamplerKind::Sobol,
                            PixelFilter::Lanczos { lobes: 3 },
                            true,
                            12,
                            None,
                        ),
                        (
                            SamplerKind::Independent,
                            PixelFilter::Mitchell {
                                b: 1.0 / 3.0,
                                c: 1.0 / 3.0,
                            },
                            false,
                            70,
                            Some(RenderSlice {
                                crop: (2, 4, 10, 8),
                                samples: 60..70,
                            }),
                        ),
                        (SamplerKind::Sobol, PixelFilter::Box, true, 12, None),
                        (SamplerKind::Independent, PixelFilter::Box, true, 12, None),
                        (SamplerKind::Sobol, PixelFilter::Box, false, 12, None),
                        (
                            SamplerKind::Independent,
                            PixelFilter::Gaussian { stddev: 0.5 },
                            true,
                            9,
                            None,
                        ),
                        (
                            SamplerKind::Sobol,
                            PixelFilter::Gaussian { stddev: 0.5 },
                            true,
                            70,
                            Some(RenderSlice {
                                crop: (3, 2, 9, 7),
                                samples: 60..70,
                            }),
                        ),
                        (
                            SamplerKind::Independent,
                            PixelFilter::Box,
                            true,
                            70,
                            Some(RenderSlice {
                                crop: (17, 9, 6, 5),
                                samples: 5..67,
                            }),
                        ),
                    ]
                };
            for (sampler, filter, packets, spp, slice) in cases {
                let scalar = RenderSettings {
                    filter,
                    ..settings(spp, sampler, packets)
                };
                let wave = RenderSettings {
                    path_loop: PathLoop::Wavefront,
                    ..scalar.clone()
                };
                let slice = slice.unwrap_or(RenderSlice::full(24, 20, spp));
                let a = render_slice(&scene, &scalar, &slice, &|_, _| {}).unwrap();
                let b = render_slice(&scene, &wave, &slice, &|_, _| {}).unwrap();
                let what = format!("{name} {sampler:?} {filter:?} packets {packets} {slice:?}");
                assert!(
                    a.image.pixels.iter().any(|p| p.max_element() > 0.0),
                    "{what}"
                );
                assert_eq!(a.rays.closest, b.rays.closest, "{what}");
                assert_eq!(a.rays.shadow, b.rays.shadow, "{what}");
                assert_eq!(a.counts, b.counts, "{what}");
                assert_eq!(
                    a.weights.iter().map(|w| w.to_bits()).collect::<Vec<_>>(),
                    b.weights.iter().map(|w| w.to_bits()).collect::<Vec<_>>(),
                    "{what}"
                );
                assert_eq!(a.nonfinite_samples, b.nonfinite_samples, "{what}");
                assert_bits_eq(&a.image, &b.image, &what);
                assert_bits_eq(&a.variance, &b.variance, &what);
            }
        }
    }

    /// The wavefront loop renders the scalar loop's image bit for bit on the verdict scenes of
    /// the features the path loop touches: a sphere lamp (shadow rays aimed at the sampled
    /// point), textured area emitters (radiance and pdf at the hit's uv), instances (two-level
    /// BVH, no packets), bump and normal maps (the perturbation), clip planes and a principal
    /// point, a film crop window, a splatted filter, a projector, a thin lens, disks and cylinders,
    /// mesh attributes as textures. Each scene at its
    /// own film size and filter, 3 spp, both samplers.
    #[test]
    fn wavefront_renders_the_scalar_image_of_the_feature_scenes() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/scenes");
        for name in [
            "mitsuba/area_reflective.xml",
            "mitsuba/area_textured.xml",
            "mitsuba/instances_two_level.xml",
            "mitsuba/principal_point_clip.xml",
            "mitsuba/crop_window.xml",
            "mitsuba/filter_lanczos.xml",
            "mitsuba/projector.xml",
            "mitsuba/thinlens.xml",
            "mitsuba/disk_cylinder.xml",
            "mitsuba/mesh_attribute.xml",
            "mitsuba_bsdfs/bumpmap_env.xml",
            "mitsuba_bsdfs/normalmap_twosided_env.xml",
            "mitsuba_bsdfs/principled_area.xml",
        ] {
            let desc = torrey_parser::load_scene(&root.join(name), &[]).unwrap();
            let scene = RenderScene::build(&desc, desc.film.width, desc.film.height).unwrap();
            let slice = RenderSlice {
                crop: desc
                    .film
                    .crop
                    .map_or((0, 0, desc.film.width, desc.film.height), |c| c.rect()),
                samples: 0..3,
            };
            for sampler in [SamplerKind::Sobol, SamplerKind::Independent] {
                let scalar = RenderSettings {
                    filter: desc.film.filter,
                    max_depth: desc.integrator.max_depth,
                    rr_depth: desc.integrator.rr_depth,
                    ..settings(3, sampler, true)
                };
                let wave = RenderSettings {
                    path_loop: PathLoop::Wavefront,
                    ..scalar.clone()
                };
                let a = render_slice(&scene, &scalar, &slice, &|_, _| {}).unwrap();
                let b = render_slice(&scene, &wave, &slice, &|_, _| {}).unwrap();
                let what = format!("{name} {sampler:?}");
                assert!(
                    a.image.pixels.iter().any(|p| p.max_element() > 0.0),
                    "{what}"
                );
                assert_eq!(a.rays.closest, b.rays.closest, "{what}");
                assert_eq!(a.rays.shadow, b.rays.shadow, "{what}");
                assert_eq!(a.counts, b.counts, "{what}");
                assert_bits_eq(&a.image, &b.image, &what);
                assert_bits_eq(&a.variance, &b.variance, &what);
            }
        }
    }

    #[test]
    fn bad_slices_are_refused() {
        let scene = packet_scene();
        let set = settings(8, SamplerKind::Sobol, true);
        for (crop, samples, message) in [
            ((20, 0, 5, 4), 0..8, "outside the 24x20 film"),
            ((0, 0, 0, 4), 0..8, "is empty"),
            ((0, 0, 4, 4), 4..4, "sample range 4..4 is empty"),
            ((0, 0, 4, 4), 0..9, "beyond the render's 8 spp"),
        ] {
            let slice = RenderSlice { crop, samples };
            let err = render_slice(&scene, &set, &slice, &|_, _| {})
                .err()
                .expect("refused");
            assert!(err.contains(message), "{err}");
        }
    }

    /// A sampler that records, for every draw, the sample it belongs to and its dimension (the
    /// count of draws since the sample started or resumed), and returns fixed numbers.
    struct DimensionRecorder {
        sample: u32,
        dimension: u32,
        draws: Vec<(u32, u32)>,
    }

    impl Sampler for DimensionRecorder {
        fn start_sample(&mut self, index: u32) {
            self.sample = index;
            self.dimension = 0;
        }
        fn resume_sample(&mut self, index: u32, requests: u32) {
            self.sample = index;
            self.dimension = requests;
        }
        fn next_1d(&mut self) -> f32 {
            self.draws.push((self.sample, self.dimension));
            self.dimension += 1;
            0.37
        }
        fn next_2d(&mut self) -> Vec2 {
            Vec2::new(self.next_1d(), 0.61)
        }
    }

    /// Each sample's draws are its dimensions 0, 1, 2, ... in order, none skipped or repeated,
    /// whether its camera ray was drawn in a packet first or not, for a camera that takes one
    /// 2D draw (pinhole) and one that takes two (thin lens: film, then lens). With the thin lens
    /// of zero aperture (rays share the origin, so packets stay on) the path must resume at
    /// dimension 2, not 1.
    #[test]
    fn cameras_keep_sampler_dimensions_aligned() {
        let mut scene = packet_scene();
        let pinhole = match scene.camera() {
            Camera::Perspective(c) => c.clone(),
            _ => unreachable!(),
        };
        for (camera, lens_draws) in [
            (Camera::Perspective(pinhole.clone()), 0),
            (
                Camera::ThinLens(ThinLensCamera::new(pinhole.clone(), 0.0, 3.0)),
                1,
            ),
            (
                Camera::ThinLens(ThinLensCamera::new(pinhole.clone(), 0.05, 3.0)),
                1,
            ),
        ] {
            assert_eq!(camera.lens_requests(), lens_draws);
            scene.camera = camera;
            for packets in [true, false] {
                let mut recorder = DimensionRecorder {
                    sample: 0,
                    dimension: 0,
                    draws: Vec::new(),
                };
                let path = PathSettings {
                    max_depth: 5,
                    rr_depth: 5,
                    mipmapping: true,
                    footprint_scale: spp_scale(12),
                    env_strategy: EnvStrategy::default(),
                };
                let mut rays = RayCount::default();
                let set = settings(12, SamplerKind::Sobol, packets);
                let film = Film::new(set.filter, (0, 0, 24, 20), (12, 10, 1, 1));
                render_pixel(
                    &scene,
                    (12, 10),
                    &set,
                    0..12,
                    path,
                    &mut recorder,
                    &mut rays,
                    &mut film.tile((12, 10, 13, 11)),
                );
                let mut next = vec![0u32; 12];
                for &(sample, dimension) in &recorder.draws {
                    assert_eq!(
                        dimension, next[sample as usize],
                        "sample {sample} (packets {packets}, lens draws {lens_draws})"
                    );
                    next[sample as usize] += 1;
                }
                // Film (and lens) draws, then at least one bounce's four.
                assert!(next.iter().all(|&n| n >= 1 + lens_draws + 4), "{next:?}");
            }
        }
    }

    /// A camera whose rays do not share an origin (a thin lens with an aperture) is not traced
    /// in packets: asked for packets, the render is the single-ray render, bit for bit.
    #[test]
    fn cameras_without_a_shared_origin_disable_packets() {
        let mut scene = packet_scene();
        let pinhole = match scene.camera() {
            Camera::Perspective(c) => c.clone(),
            _ => unreachable!(),
        };
        scene.camera = Camera::ThinLens(ThinLensCamera::new(pinhole, 0.1, 3.5));
        assert!(!scene.camera().rays_share_origin());
        for sampler in [SamplerKind::Sobol, SamplerKind::Independent] {
            let packed = render(&scene, &settings(12, sampler, true), &|_, _| {});
            let single = render(&scene, &settings(12, sampler, false), &|_, _| {});
            assert!(packed.image.pixels.iter().any(|p| p.max_element() > 0.0));
            assert_eq!(packed.rays.closest, single.rays.closest);
            assert_bits_eq(&packed.image, &single.image, &format!("{sampler:?}"));
        }
    }
}
