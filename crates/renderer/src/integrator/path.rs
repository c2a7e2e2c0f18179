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
            let ctx = PathContext::new(scene, settings);
            let path = trace_path(
                &ctx,
                PathState::camera(origin, dir, cone),
                sampler,
                rays,
                first_hit,
            );
            (path.radiance(&ctx), path.guides)
        }
        Integrator::Direct(d) => (
            direct::radiance(scene, d, dir, cone, settings, sampler, rays, first_hit),
            Guides::default(),
        ),
        Integrator::VolPath(_) => {
            let ctx = PathContext::volumetric(scene, settings);
            let path = super::volpath::trace_volpath(
                &ctx,
                PathState::camera(origin, dir, cone),
                sampler,
                rays,
                first_hit,
            );
            (path.radiance(&ctx), path.guides)
        }
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

#[cfg(test)]
mod tests {
    /// Mitsuba's `valid_ray` (3.9.1, `llvm_ad_rgb`): a `null` emitter in front of the camera,
    /// seen against nothing, adds nothing; with a wall behind it, or a light at infinity in the
    /// scene, it adds its radiance; a path that ends on it (max depth 1) does not count, unless
    /// the scene has a light at infinity; a diffuse emitter always does. Each value is Mitsuba's
    /// for the same scene (the centre pixel). Both loops, both samplers.
    #[test]
    fn null_emitters_count_only_as_mitsubas_path_counts_them() {
        use crate::integrator::{Integrator, PathIntegrator, PathLoop};
        use crate::render::{render, RenderSettings};
        use crate::sampler::SamplerKind;
        use glam::Vec3;
        use torrey_parser::PixelFilter;
        let scene = |bsdf: &str, wall: f32, env: bool| {
            let env = if env {
                r#"<emitter type="constant"><rgb name="radiance" value="0.25"/></emitter>"#
            } else {
                ""
            };
            crate::scene::scene_from_xml(
                &format!(
                    r#"<scene version="3.0.0">
                    <sensor type="perspective"><float name="fov" value="40"/>
                        <transform name="to_world"><lookat origin="0,0,5" target="0,0,0" up="0,1,0"/></transform>
                        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
                            <rfilter type="box"/></film></sensor>
                    <shape type="rectangle"><bsdf type="{bsdf}"/>
                        <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
                    <shape type="rectangle"><bsdf type="diffuse"/>
                        <transform name="to_world"><scale value="{wall}"/><translate z="-1"/></transform></shape>
                    {env}
                </scene>"#
                ),
                8,
                8,
            )
        };
        // (bsdf, wall scale (0: none), constant background, max depth, Mitsuba's centre pixel)
        let cases = [
            ("null", 0.0, false, -1, 0.0),
            ("null", 10.0, false, -1, 1.0),
            ("null", 10.0, false, 2, 1.0),
            ("null", 10.0, false, 1, 0.0),
            ("null", 0.0, true, -1, 1.25),
            ("null", 0.0, true, 1, 1.0),
            ("diffuse", 0.0, false, -1, 1.0),
            ("diffuse", 0.0, false, 1, 1.0),
        ];
        for (bsdf, wall, env, max_depth, want) in cases {
            let scene = scene(bsdf, wall, env);
            for sampler in [SamplerKind::Sobol, SamplerKind::Independent] {
                for path_loop in [PathLoop::Scalar, PathLoop::Wavefront] {
                    let settings = RenderSettings {
                        spp: 4,
                        integrator: Integrator::Path(PathIntegrator {
                            max_depth,
                            rr_depth: 5,
                            hide_emitters: false,
                        }),
                        seed: 0,
                        filter: PixelFilter::Box,
                        tile_size: 8,
                        mipmapping: true,
                        env_strategy: Default::default(),
                        sampler,
                        packets: true,
                        path_loop,
                        channels: Default::default(),
                        noise_threshold: None,
                        time_limit: None,
                    };
                    let out = render(&scene, &settings, &|_, _| {});
                    let centre = out.image.pixels[4 * 8 + 4];
                    assert_eq!(
                        centre,
                        Vec3::splat(want),
                        "{bsdf} wall {wall} env {env} max depth {max_depth} {sampler:?} {path_loop:?}"
                    );
                }
            }
        }
    }
}
