//! The wavefront pixel loop: a pixel's samples in batches, each batch's camera rays drawn and
//! traced, then its paths advanced a bounce at a time by [`Wavefront`].

use super::pixel::{clip_near, clipped_first_hit, in_packet, PixelCamera};
use super::{RenderSettings, MAX_PACKET};
use crate::accel::ClosestHit;
use crate::film::TileFilm;
use crate::integrator::aov::{AovWriter, CameraRay};
use crate::integrator::wavefront::{CameraPath, PathSamplers, Wavefront};
use crate::integrator::{PathSettings, RayCount};
use crate::ray::Ray;
use crate::sampler::Sampler;
use crate::scene::RenderScene;
use glam::{Vec2, Vec3A};
use std::ops::Range;

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
pub(super) fn render_pixel_wavefront<S: Sampler + Clone>(
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
    aov: Option<&AovWriter>,
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
                        lens: lenses[k],
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
                let (o, d, position, lens, inside) = camera_ray(lane_sampler, film);
                if inside {
                    cameras.push(CameraPath {
                        sample: s,
                        origin: o,
                        dir: d,
                        position,
                        cone,
                        lens,
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
        match aov.filter(|_| film.channels > 0) {
            None => film.add_samples(
                (x, y),
                cameras
                    .iter()
                    .map(|c| c.position)
                    .zip(radiance.iter().copied()),
            ),
            Some(aov) => {
                let mut extras = vec![0.0; film.channels];
                for ((c, &l), guides) in cameras.iter().zip(radiance.iter()).zip(loop_.guides()) {
                    let ray = CameraRay {
                        origin: c.origin,
                        dir: c.dir,
                        film: c.position,
                        lens: c.lens,
                    };
                    aov.sample(&ray, c.first_hit.as_ref(), l, guides, &mut extras);
                    film.add_sample_with((x, y), c.position, l, &extras);
                }
            }
        }
        start = end;
    }
}

/// One worker's wavefront loop and its batch buffers, reused from pixel to pixel.
pub(super) struct WavefrontBuffers<S> {
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
