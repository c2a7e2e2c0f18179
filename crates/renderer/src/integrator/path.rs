//! Mitsuba 3's `path` integrator: unidirectional path tracing with next-event estimation,
//! combined with BSDF sampling by multiple importance sampling (power heuristic). This file holds
//! its parameters and the scalar driver, which follows one path to its end before the next; the
//! step at a surface is [`PathState::scatter`], shared with the wavefront driver.

use super::direct;
use super::path_state::{BounceDraws, Guides, PathContext, PathState};
use super::{Integrator, PathSettings, RayCount};
use crate::sampler::Sampler;
use crate::scene::RenderScene;
use crate::shapes::SurfaceHit;
use glam::Vec3A;
use torrey_texture::RayCone;

/// Mitsuba's `path`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathIntegrator {
    /// Path segments: 1 = emitters seen directly, 2 = direct light, -1 = unbounded.
    pub max_depth: i32,
    /// Russian roulette starts at this depth.
    pub rr_depth: i32,
    /// Camera rays see no emitter.
    pub hide_emitters: bool,
}

/// Radiance arriving at the camera along the primary ray from `origin` along `dir`, with
/// `integrator`, and the path's guides for the denoiser (the path tracer's, when
/// `settings.guides`; `direct` takes none); `rays` counts the queries traced. `first_hit` is the primary ray's closest hit
/// (between the camera's clip planes), which the render loop traces (in a packet with the
/// pixel's other samples where it can).
#[allow(clippy::too_many_arguments)]
pub fn radiance(
    scene: &RenderScene,
    integrator: &Integrator,
    origin: Vec3A,
    dir: Vec3A,
    cone: RayCone,
    settings: PathSettings,
    sampler: &mut impl Sampler,
    rays: &mut RayCount,
    first_hit: Option<SurfaceHit>,
) -> (Vec3A, Guides) {
    match integrator {
        Integrator::Path(_) => {
            let path = trace_path(
                &PathContext::new(scene, settings),
                PathState::camera(origin, dir, cone),
                sampler,
                rays,
                first_hit,
            );
            (path.result, path.guides)
        }
        Integrator::Direct(d) => (
            direct::radiance(scene, d, dir, cone, settings, sampler, rays, first_hit),
            Guides::default(),
        ),
    }
}

/// The scalar driver: follows `path` to its end, bounce after bounce.
#[inline(always)]
fn trace_path(
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
    loop {
        let last_segment = path.last_segment(ctx);
        // This bounce's numbers and its light's draw, made before tracing: they do not depend on
        // the hit, so their chains of dependent operations overlap the traversal. The last
        // segment only looks for emission and draws none (nothing is drawn after it).
        let draws = if last_segment {
            BounceDraws::NONE
        } else {
            BounceDraws::new(ctx, std::array::from_fn(|_| sampler.next_2d()))
        };
        // A reference, to the camera ray's hit or this segment's: the camera ray's is not copied.
        let traced;
        let hit = if path.depth == 0 {
            rays.closest += 1;
            first_hit.as_ref()
        } else if last_segment && !scene.has_area_lights {
            // Without area lights a hit on the last segment adds nothing: only whether the ray
            // escapes to the lights at infinity matters, which an any-hit query answers sooner.
            rays.shadow += 1;
            let ray = path.ray;
            if !scene.visible(ray.origin, ray.dir, ray.tmax) {
                break;
            }
            None
        } else {
            rays.closest += 1;
            traced = scene.intersect(&path.ray);
            traced.as_ref()
        };
        let Some(hit) = hit else {
            path.escape(ctx);
            break;
        };
        let (shadow, continues) = path.scatter(ctx, hit, &draws);
        if let Some(s) = shadow {
            rays.shadow += 1;
            if scene.visible(s.origin, s.dir, s.tmax) {
                path.result += s.contribution;
            }
        }
        if !continues {
            break;
        }
    }
    path
}
