//! The scalar pixel loop: a pixel's camera rays (in packets where the camera and the BVH allow),
//! each path then followed to its end ([`crate::integrator::radiance`]); and the clipping of
//! camera rays to the camera's near and far planes, which the wavefront loop shares.

use super::{RenderSettings, MAX_PACKET};
use crate::accel::ClosestHit;
use crate::cameras::{Camera, CameraSample};
use crate::film::{Filter, TileFilm};
use crate::integrator::aov::{AovWriter, CameraRay};
use crate::integrator::{radiance, PathSettings, RayCount};
use crate::ray::Ray;
use crate::sampler::Sampler;
use crate::scene::RenderScene;
use crate::shapes::SurfaceHit;
use glam::{Vec2, Vec3A};
use std::ops::Range;
use torrey_texture::{centre_weight, RayCone};

/// Renders one pixel's samples `samples` (global indices) into the tile's film.
/// What every camera sample of one pixel shares: the camera, the pixel's ray cone and the film's
/// filter; [`PixelCamera::ray`] draws one sample's camera ray. Both render loops start from it.
pub(super) struct PixelCamera<'a> {
    pub(super) camera: &'a Camera,
    pub(super) pixel: (u32, u32),
    pub(super) filter: Filter,
    /// One sample's share of the pixel: 1/sqrt(spp) of its width, centred towards the pixel
    /// centre (the ray through the film's and the lens's centres).
    pub(super) cone: RayCone,
    /// The camera's sampler draws: the film position, then its lens (if it has one).
    pub(super) requests: u32,
}

impl<'a> PixelCamera<'a> {
    #[inline]
    pub(super) fn new(
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

    /// One sample's camera ray: origin, direction, film position, lens point and whether that
    /// position counts. Samples whose film position leaves the film do not count (see
    /// `TileFilm::film_position`) and are not traced.
    #[inline(always)]
    pub(super) fn ray<S: Sampler>(
        &self,
        sampler: &mut S,
        film: &TileFilm,
    ) -> (Vec3A, Vec3A, Vec2, Vec2, bool) {
        let (position, lens, inside) = self.draw(sampler, film);
        let (o, d) = self.camera.generate_ray(&CameraSample {
            film: position,
            lens,
        });
        (o, d, position, lens, inside)
    }

    /// One sample's camera draws: its film position, lens point (zero without a lens) and
    /// whether the position counts; [`PixelCamera::ray`] without the ray, for packets, whose
    /// rays [`Camera::generate_packet`] makes together once every lane has drawn.
    #[inline(always)]
    pub(super) fn draw<S: Sampler>(&self, sampler: &mut S, film: &TileFilm) -> (Vec2, Vec2, bool) {
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
pub(super) fn render_pixel<S: Sampler>(
    scene: &RenderScene,
    (x, y): (u32, u32),
    settings: &RenderSettings,
    samples: Range<u32>,
    path: PathSettings,
    sampler: &mut S,
    rays: &mut RayCount,
    film: &mut TileFilm,
    aov: Option<&AovWriter>,
) {
    let pixel = PixelCamera::new(scene, (x, y), settings, path, film);
    // A film without the channels (adaptive sampling's pilot) takes the radiance alone.
    let aov = aov.filter(|_| film.channels > 0);
    let mut extras = vec![0.0; aov.map_or(0, |_| film.channels)];
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
        let (o, d, first_hit, position, lens, inside) = if in_packet(s, lanes, &samples) {
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
                lenses[lane],
                insides[lane],
            )
        } else {
            sampler.start_sample(s);
            let (o, d, position, lens, inside) = camera_ray(sampler, film);
            (o, d, None, position, lens, inside)
        };
        if inside {
            let first_hit = clipped_first_hit(scene, o, d, first_hit);
            let (l, guides) = radiance(
                scene,
                &settings.integrator,
                o,
                d,
                cone,
                path,
                sampler,
                rays,
                first_hit,
            );
            match aov {
                None => film.add_sample((x, y), position, l),
                Some(aov) => {
                    let ray = CameraRay {
                        origin: o,
                        dir: d,
                        film: position,
                        lens,
                    };
                    aov.sample(&ray, first_hit.as_ref(), l, guides, &mut extras);
                    film.add_sample_with((x, y), position, l, &extras);
                }
            }
        }
    }
}

/// Whether global sample `s` lies in a packet group of `lanes` samples that is whole inside
/// `samples` (0 lanes: no packets).
#[inline]
pub(super) fn in_packet(s: u32, lanes: usize, samples: &Range<u32>) -> bool {
    let group = lanes as u32;
    group > 0 && {
        let group_start = s - s % group;
        group_start >= samples.start
            && group_start
                .checked_add(group)
                .is_some_and(|end| end <= samples.end)
    }
}

/// The camera ray's first hit between the camera's clip planes ([`crate::Camera::clip_range`]):
/// Mitsuba starts perspective and thin lens rays on the near plane and ends them on the far one.
/// `traced` is the closest hit from the ray's origin if it was traced already (in a packet): its
/// surface is set up only once it is known to lie between the planes; a hit nearer than the near
/// plane is traced again from there.
#[inline]
pub(super) fn clipped_first_hit(
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
pub(super) fn clip_near(
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
