//! Mitsuba 3's `volpath` and `volpathmis`: the path tracer with participating media, one loop
//! as Mitsuba keeps it. Its surface step is the path tracer's ([`PathState::scatter`] with the
//! volumetric rules of [`PathContext::volumetric`]); this file adds what happens between
//! surfaces and the shadow rays' transmittance.
//!
//! A path knows its medium ([`PathState::medium`]: the camera's, then whatever the shapes it
//! crosses hold on the side it enters). On each segment in a medium a free flight is drawn
//! ([`Medium::sample`]): a real scattering event (a bounce: next-event estimation with the phase
//! function, MIS against phase sampling, the phase function's sample continues the path), or
//! the segment's end, where the surface or the sky is met as in the path tracer.
//!
//! Shadow rays carry a transmittance, not a boolean: each medium they travel through attenuates
//! them (its transmittance estimate), and surfaces whose BSDF passes light straight through
//! (`null`, `thindielectric`, `mask`) weight them by that passage and carry them into the
//! medium beyond; any other surface blocks them (a `dielectric` boundary, as in Mitsuba).
//!
//! `volpath` and `volpathmis` differ in Mitsuba only in how they sample chromatic media; both
//! converge to the same image, and torrey renders both with one estimator (the spectral MIS of
//! [`super::super::media::Medium`]), whose noise is at most theirs. Runs in the scalar loop
//! only (the render loop does not batch it). Its random numbers: [`draws`].

mod draws;

use super::path_state::{BounceDraws, PathContext, PathState};
use super::shading::ShadingPoint;
use super::{EnvStrategy, RayCount};
use crate::lights::LightSample;
use crate::media::{Flight, Medium};
use crate::ray::{offset_origin, Ray};
use crate::sampler::Sampler;
use crate::sampling::power_heuristic;
use crate::shapes::SurfaceHit;
use draws::PathDraws;
use glam::{Vec2, Vec3A};
use torrey_texture::RayCone;

/// Mitsuba's `volpath` (`mis` false) and `volpathmis` (true).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolPathIntegrator {
    /// Path segments: 1 = emitters seen directly, 2 = direct light, -1 = unbounded. Scattering
    /// in a medium is a bounce; index-matched crossings are not.
    pub max_depth: i32,
    pub rr_depth: i32,
    pub hide_emitters: bool,
    pub mis: bool,
}

/// The scalar driver: follows `path` (a camera ray starting in the camera's medium) to its end
/// ([`PathState::radiance`] is its sample).
pub(super) fn trace_volpath(
    ctx: &PathContext,
    mut path: PathState,
    sampler: &mut impl Sampler,
    rays: &mut RayCount,
    first_hit: Option<SurfaceHit>,
) -> PathState {
    if ctx.settings.max_depth == 0 {
        return path;
    }
    let scene = ctx.scene;
    let draws = &mut PathDraws::new(sampler);
    path.medium = scene.media.camera;
    let mut first = Some(first_hit);
    loop {
        let bounce: [Vec2; 4] = std::array::from_fn(|_| draws.next_2d());
        let medium = path.medium.map(|m| &scene.media.list[m as usize]);
        // The free flight's first numbers. In a homogeneous medium the distance is drawn now and
        // the ray traced only that far.
        let u_flight = match medium {
            Some(_) => draws.next_2d(),
            None => Vec2::ZERO,
        };
        let drawn = medium.and_then(|m| m.draw_distance(path.throughput, u_flight));
        rays.closest += 1;
        let hit = match first.take() {
            Some(h) => h,
            None => scene.intersect(&Ray {
                tmax: drawn.unwrap_or(f32::INFINITY),
                ..path.ray
            }),
        };
        if let (Some(m), Some(medium)) = (path.medium, medium) {
            let tmax = hit.as_ref().map_or(f32::INFINITY, |h| h.t);
            let (o, d) = (path.ray.origin, path.ray.dir);
            let mut fixed = [u_flight.x, u_flight.y].into_iter();
            let u = &mut || fixed.next().unwrap_or_else(|| draws.stream_1d());
            match medium.sample(o, d, tmax, drawn, &mut path.throughput, u) {
                Flight::Scatter(t) => {
                    // A medium that samples no emitters draws no light sample (the numbers
                    // BounceDraws::new would take for the rest).
                    let bounce = match medium.sample_emitters {
                        true => BounceDraws::new(ctx, bounce),
                        false => BounceDraws::without_light(bounce),
                    };
                    if !scatter_in_medium(ctx, &mut path, medium, m, t, &bounce, draws, rays) {
                        break;
                    }
                    continue;
                }
                Flight::Pass if !(path.throughput.max_element() > 0.0) => break,
                Flight::Pass => {}
            }
        }
        let Some(hit) = hit else {
            path.escape(ctx);
            break;
        };
        let bounce = BounceDraws::new(ctx, bounce);
        let medium_in = path.medium;
        let (shadow, continues) = path.scatter(ctx, &hit, &bounce);
        if let Some(s) = shadow {
            let m = scene
                .media
                .after_crossing(medium_in, hit.shape, hit.ng, s.dir);
            let tr = transmittance(ctx, s.origin, s.dir, s.tmax, m, draws, rays);
            path.result += s.contribution * tr;
        }
        if !continues {
            break;
        }
    }
    path
}

/// A real scattering event at distance `t` along the path's ray in `medium` (index `m`):
/// next-event estimation through the media, then the phase function's sample. Returns whether
/// the path goes on.
#[allow(clippy::too_many_arguments)]
fn scatter_in_medium(
    ctx: &PathContext,
    path: &mut PathState,
    medium: &Medium,
    m: u32,
    t: f32,
    draws: &BounceDraws,
    numbers: &mut PathDraws<impl Sampler>,
    rays: &mut RayCount,
) -> bool {
    let scene = ctx.scene;
    path.depth += 1;
    if path.depth >= ctx.settings.max_depth {
        return false;
    }
    let d_in = path.ray.dir;
    let p = path.ray.origin + d_in * t;
    let light = match medium.sample_emitters {
        true => draws.light_at(scene, p, Vec3A::ZERO),
        false => None,
    };
    if let Some((index, select_pdf, draw)) = light {
        let light = &scene.lights[index];
        let uniform_env = ctx.settings.env_strategy == EnvStrategy::Uniform;
        if let Some(ls) = light.connect(draw, p, uniform_env, &scene.textures) {
            let f = medium.phase.eval(d_in, ls.wi);
            if f > 0.0 && ls.pdf > 0.0 {
                let light_pdf = ls.pdf * select_pdf;
                let w = if ls.is_delta || (light.is_infinite() && !ctx.infinite_mis()) {
                    1.0
                } else {
                    power_heuristic(light_pdf, f)
                };
                let (dir, tmax) = towards(&ls);
                let tr = transmittance(ctx, p, dir, tmax, Some(m), numbers, rays);
                path.result += path.throughput * tr * ls.radiance * (f * w / light_pdf);
            }
        }
    }
    let (wi, pdf) = medium.phase.sample(d_in, draws.u_dir, draws.u_lobe);
    if !(pdf > 0.0) {
        return false;
    }
    // Without emitter sampling, emitters this sample finds count in full (Mitsuba's
    // `specular_chain` for such media).
    path.scattered_in_medium(ctx, t, p, wi, pdf, !medium.sample_emitters);
    path.roulette(ctx, draws.u_rr)
}

/// The direction and length of a shadow ray from a point in a medium to light sample `ls`.
fn towards(ls: &LightSample) -> (Vec3A, f32) {
    if !ls.dist.is_finite() {
        return (ls.wi, f32::INFINITY);
    }
    (ls.wi, ls.dist * (1.0 - 2e-4))
}

/// The transmittance from `o` along `dir` up to `tmax`, starting in `medium`: media attenuate,
/// index-matched surfaces weight and carry it on, other surfaces block it.
fn transmittance(
    ctx: &PathContext,
    mut o: Vec3A,
    dir: Vec3A,
    tmax: f32,
    mut medium: Option<u32>,
    numbers: &mut PathDraws<impl Sampler>,
    rays: &mut RayCount,
) -> Vec3A {
    let scene = ctx.scene;
    rays.shadow += 1;
    if medium.is_none() && !scene.media.passable {
        return if scene.visible(o, dir, tmax) {
            Vec3A::ONE
        } else {
            Vec3A::ZERO
        };
    }
    let mut tr = Vec3A::ONE;
    let mut remaining = tmax;
    // Enough for any scene: a stack of index-matched surfaces deeper than this is treated as
    // opaque.
    for _ in 0..256 {
        let hit = scene.intersect(&Ray {
            origin: o,
            dir,
            tmax: remaining,
        });
        if let Some(m) = medium {
            let seg = hit.as_ref().map_or(remaining, |h| h.t);
            let medium = &scene.media.list[m as usize];
            tr *= medium.transmittance(o, dir, seg, &mut || numbers.stream_1d());
            if !(tr.max_element() > 0.0) {
                return Vec3A::ZERO;
            }
        }
        let Some(h) = hit else {
            return tr;
        };
        let shape = &scene.shapes[h.shape as usize];
        if !scene.materials[shape.material as usize].bsdf.may_pass() {
            return Vec3A::ZERO;
        }
        let at = scene.attribute_point(&h);
        let cone = RayCone::from_pixel(0.0);
        let sp = ShadingPoint::new(scene, &h, dir, &cone, false, at.as_ref());
        tr *= sp.bsdf.null_transmission(sp.wo);
        if !(tr.max_element() > 0.0) {
            return Vec3A::ZERO;
        }
        medium = scene.media.after_crossing(medium, h.shape, h.ng, dir);
        let next = offset_origin(h.p, h.ng, dir);
        remaining -= (next - o).dot(dir);
        o = next;
        if !(remaining > 0.0) {
            return tr;
        }
        rays.shadow += 1;
    }
    Vec3A::ZERO
}
