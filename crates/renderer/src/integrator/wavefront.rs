//! The path tracer of [`super::path`] run as a wavefront: a batch of paths advances one bounce
//! at a time through stages (the bounce's sampler draws for every live path, their closest hits,
//! escaped rays' environment lookups, surface shading with the BSDF and light samples, the
//! shadow rays, then compaction of the paths still alive), instead of following one path to its
//! end before starting the next.
//!
//! The estimator is the scalar loop's, operation for operation: the same sampler dimensions per
//! bounce (four requests, drawn whatever the branches), the same MIS weights and Russian roulette
//! rule, and each path's radiance summed in the same order. With the same sampler state the two
//! loops give bit-identical radiance per sample (tests in `render.rs`).
//!
//! Three parts run in SIMD lanes (16 with AVX-512, 8 with AVX2): escaped rays' environment
//! lookups, the surfaced paths' environment-map light samples (`draw_env_lights`), and the
//! surface stage of `diffuse` surfaces (constant or textured) lit by area lights, point lights, a
//! constant background or an environment map's batched samples, and of torrey `mirror` surfaces
//! (`lanes`, admitted by the scene's `LaneTable`). Every other surface goes through the scalar
//! `shade`, one path at a time; there the batch buys independent work between dependent chains
//! (one path's traversal overlaps the next path's set-up).

mod lane_kernel;
mod lane_table;
mod lanes;

pub(crate) use lane_table::LaneTable;

use super::path::shadow_ray;
use super::{EnvStrategy, PathSettings, RayCount};
use crate::accel::Simd;
use crate::lights::{Light, LightDraw};
use crate::ray::{offset_origin, Ray};
use crate::sampler::Sampler;
use crate::sampling::power_heuristic;
use crate::scene::RenderScene;
use crate::shapes::SurfaceHit;
use crate::textures::TextureQuery;
use glam::{Vec2, Vec3, Vec3A};
use std::sync::OnceLock;
use torrey_light::{BatchSimd, EnvSample};
use torrey_texture::{Footprint, RayCone};

/// A camera ray that starts a path of the batch.
#[derive(Clone, Copy, Debug)]
pub struct CameraPath {
    /// The sample's global index (for a sampler shared by the batch's paths).
    pub sample: u32,
    pub origin: Vec3A,
    pub dir: Vec3A,
    /// The sample's film position, inside the film (for the film; the loop does not read it).
    pub position: Vec2,
    pub cone: RayCone,
    /// The camera ray's closest hit between the camera's clip planes (traced by the caller, as
    /// the scalar loop's camera rays are).
    pub first_hit: Option<SurfaceHit>,
}

/// Where the batch's paths draw their numbers.
pub enum PathSamplers<'a, S: Sampler> {
    /// One sampler for all paths; each draw resumes the path's sample at its dimension
    /// (low-discrepancy samplers, whose resume is a table lookup).
    Shared(&'a mut S),
    /// One sampler per path, already positioned after the camera's draws (independent streams,
    /// whose resume would replay the stream).
    PerPath(&'a mut [S]),
}

/// One path's state between stages.
#[derive(Clone, Copy)]
struct PathState {
    sample: u32,
    /// Sampler requests drawn so far by this sample.
    requests: u32,
    ray: Ray,
    cone: RayCone,
    throughput: Vec3A,
    result: Vec3A,
    prev_bsdf_pdf: f32,
    prev_delta: bool,
    prev_p: Vec3A,
    specular_chain: bool,
    eta: f32,
    depth: u32,
    /// Mitsuba's `valid_ray` (`path::sample_valid_at_start`): the sample's radiance counts.
    valid: bool,
    /// The camera ray's hit is already in `Wavefront::hits` (traced by the caller).
    traced: bool,
    // This bounce's draws.
    u_dir: Vec2,
    u_lobe: f32,
    u_rr: f32,
    light_draw: Option<(usize, LightDraw)>,
}

/// A shadow ray of next-event estimation and what it adds to its path when unoccluded.
#[derive(Clone, Copy, Default)]
struct ShadowRay {
    path: u32,
    origin: Vec3A,
    dir: Vec3A,
    tmax: f32,
    contribution: Vec3A,
}

/// Reusable buffers of the wavefront loop (one per worker thread).
#[derive(Default)]
pub struct Wavefront {
    paths: Vec<PathState>,
    live: Vec<u32>,
    /// Each path's last closest hit (valid for the paths in `surfaced`).
    hits: Vec<SurfaceHit>,
    /// Stage 1's draws of each live path (same order): the light's and Russian roulette's
    /// numbers, the light sample's, the BSDF direction's, the BSDF lobe's (x).
    draws: Vec<[Vec2; 4]>,
    escaped: Vec<u32>,
    surfaced: Vec<u32>,
    shadow: Vec<ShadowRay>,
    // The escaped paths' environment lookups.
    env_sums: Vec<Vec3A>,
    env_dirs: Vec<Vec3>,
    env_spreads: Vec<f32>,
    env_want_pdf: Vec<bool>,
    env_values: Vec<(Vec3, f32)>,
    // The surface stage's lane path: its outputs before they are merged with the scalar
    // `shade`'s.
    lane_live: Vec<u32>,
    lane_shadow: Vec<ShadowRay>,
    merge_live: Vec<u32>,
    merge_shadow: Vec<ShadowRay>,
    lane_chunks: lanes::LaneChunks,
    // The surfaced paths' environment-map light samples.
    env_draw_paths: Vec<u32>,
    env_draw_us: Vec<Vec2>,
    env_draws: Vec<Option<EnvSample>>,
}

impl Wavefront {
    /// Radiance along each camera ray of `cameras`, written to `out` (same order). `requests` is
    /// the count of sampler requests the camera rays took (where each path's draws resume).
    #[allow(clippy::too_many_arguments)]
    pub fn radiance<S: Sampler>(
        &mut self,
        scene: &RenderScene,
        cameras: &[CameraPath],
        requests: u32,
        settings: PathSettings,
        mut samplers: PathSamplers<'_, S>,
        rays: &mut RayCount,
        out: &mut Vec<Vec3A>,
    ) {
        out.clear();
        let max_depth = if settings.max_depth < 0 {
            u32::MAX
        } else {
            settings.max_depth as u32
        };
        if max_depth == 0 {
            out.resize(cameras.len(), Vec3A::ZERO);
            return;
        }
        let light_count = scene.lights.len();
        // Converted once (usize to f32 is several instructions on x86-64; the same value).
        let light_count_f32 = light_count as f32;
        let light_select_pdf = if light_count > 0 {
            1.0 / light_count as f32
        } else {
            0.0
        };
        self.paths.clear();
        self.paths.extend(cameras.iter().map(|c| PathState {
            sample: c.sample,
            requests,
            ray: Ray {
                origin: c.origin,
                dir: c.dir,
                tmax: f32::INFINITY,
            },
            cone: c.cone,
            throughput: Vec3A::ONE,
            result: Vec3A::ZERO,
            prev_bsdf_pdf: 0.0,
            prev_delta: true,
            prev_p: c.origin,
            specular_chain: true,
            eta: 1.0,
            depth: 0,
            valid: super::path::sample_valid_at_start(scene),
            traced: true,
            u_dir: Vec2::ZERO,
            u_lobe: 0.0,
            u_rr: 0.0,
            light_draw: None,
        }));
        self.live.clear();
        self.live.extend(0..cameras.len() as u32);
        self.hits.clear();
        self.hits
            .extend(cameras.iter().map(|c| c.first_hit.unwrap_or(NO_HIT)));

        while !self.live.is_empty() {
            // Stage 1: this bounce's numbers and the light draw, for every live path. With too
            // few live paths for a batch of environment-map light samples (see
            // `draw_env_lights`), each path samples the map on its own at shading time, and the
            // memory that sample will read is prefetched here, to overlap the traversal.
            let prefetch_env = self.live.len() < ENV_BATCH_MIN;
            match &mut samplers {
                // All the paths' requests at once (the lobe's number is its pair's x).
                PathSamplers::Shared(s) => s.next_2d_resumed(
                    self.live.iter().map(|&i| {
                        let path = &self.paths[i as usize];
                        (path.sample, path.requests)
                    }),
                    &mut self.draws,
                ),
                PathSamplers::PerPath(s) => S::next_2d_each(s, &self.live, &mut self.draws),
            }
            for (&i, &[light_rr, u_pos, u_dir, u_lobe]) in self.live.iter().zip(&self.draws) {
                let path = &mut self.paths[i as usize];
                path.u_dir = u_dir;
                path.u_lobe = u_lobe.x;
                path.requests += 4;
                path.u_rr = light_rr.y;
                let last_segment = path.depth + 1 >= max_depth;
                path.light_draw = (!last_segment && light_count > 0).then(|| {
                    let index =
                        ((light_rr.x * light_count_f32) as u32 as usize).min(light_count - 1);
                    let light = &scene.lights[index];
                    if let (Light::Env(env), true) = (light, prefetch_env) {
                        env.map.prefetch_sample(u_pos);
                    }
                    (index, light.draw(u_pos))
                });
            }

            // Stage 2: closest hits (any-hit on the last segment when no shape emits). Paths
            // whose last segment is blocked end here.
            self.escaped.clear();
            self.surfaced.clear();
            for &i in &self.live {
                let path = &mut self.paths[i as usize];
                let last_segment = path.depth + 1 >= max_depth;
                // Each hit is written once, into its path's slot (no copy out and back).
                let slot = &mut self.hits[i as usize];
                let found = if path.traced {
                    // The camera ray's hit, traced by the caller, is in its slot already.
                    path.traced = false;
                    rays.closest += 1;
                    cameras[i as usize].first_hit.is_some()
                } else if last_segment && !scene.has_area_lights {
                    // The slot keeps the last bounce's hit, which no stage reads again: the
                    // path ends here either way.
                    rays.shadow += 1;
                    if scene.visible(path.ray.origin, path.ray.dir, path.ray.tmax) {
                        self.escaped.push(i);
                    }
                    continue;
                } else {
                    rays.closest += 1;
                    closest_hit(scene, &path.ray, slot)
                };
                if found {
                    self.surfaced.push(i);
                } else {
                    self.escaped.push(i);
                }
            }

            // Stage 3: escaped rays see the lights at infinity; their paths end. Environment maps
            // are looked up for all of them at once (directions to uv in SIMD lanes).
            self.escaped
                .retain(|&i| self.paths[i as usize].depth > 0 || !scene.hide_emitters);
            if !self.escaped.is_empty() {
                self.escaped_radiance(scene, settings, light_select_pdf);
            }

            // The environment-map light samples of the paths that reached a surface, drawn all at
            // once in SIMD lanes (not in stage 1: an escaped path's would be wasted).
            if !self.surfaced.is_empty() {
                self.draw_env_lights(scene, settings);
            }

            // Stage 4: surfaces: emission, the BSDF sample, the light connection (queued as a
            // shadow ray) and the path's continuation.
            self.shadow.clear();
            self.live.clear();
            // The scalar stage of one path, its shadow ray queued.
            let shade_one = |path: &mut PathState,
                             hit: &SurfaceHit,
                             i: u32,
                             live: &mut Vec<u32>,
                             shadow: &mut Vec<ShadowRay>| {
                if let Some(ray) = shade(
                    scene,
                    path,
                    hit,
                    settings,
                    max_depth,
                    light_select_pdf,
                    i,
                    live,
                ) {
                    shadow.push(ray);
                }
            };
            if scene.lanes.any && lanes::lanes_enabled() {
                // The lanes take the paths they can as they come and hand the others to the
                // scalar `shade`, whose outputs go to the stage's lists; the lanes' go to lists of
                // their own, merged after (both ascend by path: merged, they are the scalar
                // stage's order).
                let (live, shadow) = (&mut self.live, &mut self.shadow);
                self.lane_live.clear();
                self.lane_shadow.clear();
                lanes::shade_lanes(
                    &mut self.lane_chunks,
                    lanes::LaneWork {
                        paths: &mut self.paths,
                        hits: &self.hits,
                        indices: &self.surfaced,
                        params: lanes::LaneParams::new(
                            scene,
                            settings,
                            max_depth,
                            light_select_pdf,
                        ),
                        live: &mut self.lane_live,
                        shadow: &mut self.lane_shadow,
                        scalar: &mut |path, hit, i| shade_one(path, hit, i, live, shadow),
                    },
                );
                lanes::merge_by(
                    &mut self.live,
                    &mut self.lane_live,
                    &mut self.merge_live,
                    |&i| i,
                );
                lanes::merge_by(
                    &mut self.shadow,
                    &mut self.lane_shadow,
                    &mut self.merge_shadow,
                    |r| r.path,
                );
            } else {
                for &i in &self.surfaced {
                    shade_one(
                        &mut self.paths[i as usize],
                        &self.hits[i as usize],
                        i,
                        &mut self.live,
                        &mut self.shadow,
                    );
                }
            }

            // Stage 5: shadow rays, traced together (as packets where the CPU has them).
            rays.shadow += self.shadow.len() as u64;
            let (shadow, paths) = (&self.shadow, &mut self.paths);
            scene.visible_batch(
                shadow.len(),
                |i| Ray {
                    origin: shadow[i].origin,
                    dir: shadow[i].dir,
                    tmax: shadow[i].tmax,
                },
                |i| paths[shadow[i].path as usize].result += shadow[i].contribution,
            );
        }
        out.extend(
            self.paths
                .iter()
                .map(|p| if p.valid { p.result } else { Vec3A::ZERO }),
        );
    }
}

impl Wavefront {
    /// Samples, for every surfaced path whose light draw is an environment map's, the map's
    /// direction, radiance and density with [`torrey_light::EnvMap::sample_batch`] (the bits of
    /// the one-sample code), and leaves them in the draw for [`Light::connect`] to read.
    fn draw_env_lights(&mut self, scene: &RenderScene, settings: PathSettings) {
        if settings.env_strategy == EnvStrategy::Uniform || !batched_env() {
            return;
        }
        for &li in &scene.infinite_lights {
            let Light::Env(env) = &scene.lights[li as usize] else {
                continue;
            };
            self.env_draw_paths.clear();
            self.env_draw_us.clear();
            for &i in &self.surfaced {
                if let Some((index, LightDraw::Deferred(u))) = self.paths[i as usize].light_draw {
                    if index == li as usize {
                        self.env_draw_paths.push(i);
                        self.env_draw_us.push(u);
                    }
                }
            }
            if self.env_draw_paths.len() < ENV_BATCH_MIN {
                // Left to `Light::connect` (the same bits).
                continue;
            }
            env.map
                .sample_batch(&self.env_draw_us, batch_simd(), &mut self.env_draws);
            for (&i, s) in self.env_draw_paths.iter().zip(&self.env_draws) {
                let draw = match s {
                    Some(s) => LightDraw::EnvSampled {
                        wi: s.direction.into(),
                        radiance: s.radiance.into(),
                        pdf: s.pdf,
                    },
                    None => LightDraw::EnvSampled {
                        wi: Vec3A::ZERO,
                        radiance: Vec3A::ZERO,
                        pdf: 0.0,
                    },
                };
                self.paths[i as usize].light_draw = Some((li as usize, draw));
            }
        }
    }

    /// Adds to every escaped path (`self.escaped`) the radiance of the lights at infinity along
    /// its ray: what `path::infinite_radiance` gives each, summed over the lights in the same order.
    fn escaped_radiance(
        &mut self,
        scene: &RenderScene,
        settings: PathSettings,
        light_select_pdf: f32,
    ) {
        // With one light at infinity (the usual case) each path's sum is that light's term, added
        // to the path at once; with several, the terms are summed per path in the lights' order
        // first. Either way the bits of the scalar loop: its sum starts at zero too.
        let single = scene.infinite_lights.len() == 1;
        if !single {
            self.env_sums.clear();
            self.env_sums.resize(self.escaped.len(), Vec3A::ZERO);
        }
        let mis = settings.env_strategy == EnvStrategy::ImportanceMis;
        for &li in &scene.infinite_lights {
            let light = &scene.lights[li as usize];
            if let (Light::Env(env), true) = (light, batched_env()) {
                self.env_dirs.clear();
                self.env_spreads.clear();
                self.env_want_pdf.clear();
                for &i in &self.escaped {
                    let path = &self.paths[i as usize];
                    self.env_dirs.push(path.ray.dir.into());
                    self.env_spreads
                        .push(if path.specular_chain && settings.mipmapping {
                            path.cone.spread
                        } else {
                            0.0
                        });
                    // Only a BSDF-sampled (non-delta) bounce weighs the sky by MIS below.
                    self.env_want_pdf.push(!path.prev_delta && mis);
                }
                env.map.eval_pdf_batch(
                    &self.env_dirs,
                    &self.env_spreads,
                    &self.env_want_pdf,
                    batch_simd(),
                    &mut self.env_values,
                );
                let term = |path: &PathState, (le, pdf): (Vec3, f32)| {
                    let le = Vec3A::from(le);
                    match (!path.prev_delta).then_some(path.prev_bsdf_pdf) {
                        None => Some(le),
                        Some(_) if !mis => None,
                        Some(bsdf_pdf) => {
                            Some(le * power_heuristic(bsdf_pdf, pdf * light_select_pdf))
                        }
                    }
                };
                if single {
                    for (&i, &value) in self.escaped.iter().zip(&self.env_values) {
                        let path = &mut self.paths[i as usize];
                        let sum = Vec3A::ZERO + term(path, value).unwrap_or(Vec3A::ZERO);
                        path.result += path.throughput * sum;
                    }
                    return;
                }
                for ((&i, &value), sum) in self
                    .escaped
                    .iter()
                    .zip(&self.env_values)
                    .zip(&mut self.env_sums)
                {
                    if let Some(t) = term(&self.paths[i as usize], value) {
                        *sum += t;
                    }
                }
            } else {
                if single {
                    self.env_sums.clear();
                    self.env_sums.resize(self.escaped.len(), Vec3A::ZERO);
                }
                for (&i, sum) in self.escaped.iter().zip(&mut self.env_sums) {
                    let path = &self.paths[i as usize];
                    let spread = if path.specular_chain && settings.mipmapping {
                        path.cone.spread
                    } else {
                        0.0
                    };
                    *sum += match (!path.prev_delta).then_some(path.prev_bsdf_pdf) {
                        None => light.radiance_infinite(path.ray.dir, spread),
                        Some(_) if !mis => continue,
                        Some(bsdf_pdf) => {
                            let (le, pdf) = light.eval_infinite(path.ray.dir, spread);
                            le * power_heuristic(bsdf_pdf, pdf * light_select_pdf)
                        }
                    };
                }
            }
        }
        for (&i, &sum) in self.escaped.iter().zip(&self.env_sums) {
            let path = &mut self.paths[i as usize];
            path.result += path.throughput * sum;
        }
    }
}

/// [`RenderScene::intersect`] into `slot`: whether the ray hits. Without instances, the hit's
/// geometry is computed straight into the slot ([`RenderScene::surface_into`]); through
/// `intersect`'s `Option` it was built on the stack and copied, 128 bytes whose loads waited on
/// the callee's narrower stores.
#[inline(always)]
fn closest_hit(scene: &RenderScene, ray: &Ray, slot: &mut SurfaceHit) -> bool {
    if scene.instances.is_some() {
        return match scene.intersect(ray) {
            Some(hit) => {
                *slot = hit;
                true
            }
            None => false,
        };
    }
    match scene.accel.intersect(ray) {
        Some(hit) => {
            scene.surface_into(ray, &hit, slot);
            true
        }
        None => false,
    }
}

/// The hit slot of a path whose camera ray missed (never read: such a path escapes).
const NO_HIT: SurfaceHit = SurfaceHit {
    t: 0.0,
    p: Vec3A::ZERO,
    ng: Vec3A::Z,
    ns: Vec3A::Z,
    uv: Vec2::ZERO,
    dpdu: Vec3A::ZERO,
    dpdv: Vec3A::ZERO,
    bary: Vec2::ZERO,
    shape: 0,
    prim: 0,
};

/// Whether escaped rays look environment maps up in batches (the default); the environment
/// variable `TORREY_WAVEFRONT_ENV=scalar` makes them call the one-ray lookup per path instead
/// (the same bits; for measuring what the batch gains).
fn batched_env() -> bool {
    static BATCHED: OnceLock<bool> = OnceLock::new();
    *BATCHED.get_or_init(|| {
        !std::env::var("TORREY_WAVEFRONT_ENV").is_ok_and(|v| v.eq_ignore_ascii_case("scalar"))
    })
}

/// The fewest environment-map light samples worth a batch in SIMD lanes: a step costs about the
/// same for one sample as for sixteen, so below this the paths sample on their own (and stage 1
/// prefetches for them). Measured (AVX-512, one thread): at 4 spp, where no pixel's batch reaches
/// it, materials_mitsuba 0.36 s batched against 0.33 s; envmap_sky at 16 spp 0.56 s with 1,
/// 0.54-0.55 s with 4 to 12; at 256 spp 2.05-2.13 s with 1, 2.05-2.07 s with 8.
const ENV_BATCH_MIN: usize = 8;

/// The instruction set of the batched environment lookups: the traversal's ([`Simd::detect`],
/// which `TORREY_SIMD` caps).
fn batch_simd() -> BatchSimd {
    match Simd::detect() {
        Simd::Portable => BatchSimd::Portable,
        Simd::Avx2 => BatchSimd::Avx2,
        Simd::Avx512 => BatchSimd::Avx512,
    }
}

/// One surface interaction of `path` at `hit`: adds emission, returns the shadow ray of the light
/// sample (if any) and pushes the path onto `live` when it continues.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn shade(
    scene: &RenderScene,
    path: &mut PathState,
    hit: &SurfaceHit,
    settings: PathSettings,
    max_depth: u32,
    light_select_pdf: f32,
    index: u32,
    live: &mut Vec<u32>,
) -> Option<ShadowRay> {
    let ray = path.ray;
    let wo = -ray.dir;
    let shape = &scene.shapes[hit.shape as usize];
    let emitters_visible = path.depth > 0 || !scene.hide_emitters;
    if let (Some(li), true) = (shape.area_light, emitters_visible) {
        if hit.ng.dot(wo) > 0.0 {
            let light = &scene.lights[li as usize];
            if let crate::lights::Light::Area(area) = light {
                let radiance = area.radiance_at(&scene.textures, hit.uv);
                let w = if path.prev_delta {
                    1.0
                } else {
                    let pdf = light.pdf_area_hit(path.prev_p, ray.dir, hit.t, hit.ng, hit.uv)
                        * light_select_pdf;
                    power_heuristic(path.prev_bsdf_pdf, pdf)
                };
                path.result += path.throughput * radiance * w;
            }
        }
    }
    if path.depth + 1 >= max_depth {
        path.valid |= !scene.materials[shape.material as usize].passes_through();
        return None;
    }

    // Cones only matter where they filter (textures, environment maps), as in `path::radiance`.
    let track_cones = settings.mipmapping && scene.uses_cones;
    if track_cones {
        path.cone = path.cone.at_distance(hit.t);
    }
    let material = &scene.materials[shape.material as usize];
    let footprint = if settings.mipmapping && material.is_textured() {
        path.cone.footprint(ray.dir, hit.ng, hit.dpdu, hit.dpdv)
    } else {
        Footprint::POINT
    };
    let (frame, perturbation) = material.shading_frame(&scene.textures, hit, wo, footprint);
    let wo_local = frame.to_local(wo);
    let attribute_point = scene.attribute_point(hit);
    let bsdf = material.bsdf_facing(
        &TextureQuery {
            textures: &scene.textures,
            at: attribute_point.as_ref(),
            uv: hit.uv,
            footprint,
        },
        perturbation,
        wo_local,
    );
    let bsdf_sample = bsdf.sample(wo_local, path.u_dir, path.u_lobe);
    path.valid |= !bsdf_sample.is_some_and(|bs| bs.is_null());

    let mut shadow = None;
    if let (true, Some((light_index, draw))) = (bsdf.flags().has_smooth(), path.light_draw) {
        let light = &scene.lights[light_index];
        let uniform_env = settings.env_strategy == EnvStrategy::Uniform;
        if let Some(ls) = light.connect(draw, hit.p, uniform_env, &scene.textures) {
            let wi_local = frame.to_local(ls.wi);
            let f = bsdf.eval(wo_local, wi_local);
            if f.max_element() > 0.0 && ls.pdf > 0.0 {
                let (origin, dir, tmax) = shadow_ray(hit.p, hit.ng, &ls);
                let light_pdf = ls.pdf * light_select_pdf;
                let w = if ls.is_delta
                    || (light.is_infinite() && settings.env_strategy != EnvStrategy::ImportanceMis)
                {
                    1.0
                } else {
                    power_heuristic(light_pdf, bsdf.pdf(wo_local, wi_local))
                };
                shadow = Some(ShadowRay {
                    path: index,
                    origin,
                    dir,
                    tmax,
                    contribution: path.throughput * f * ls.radiance * (w / light_pdf),
                });
            }
        }
    }

    let Some(bs) = bsdf_sample else {
        return shadow;
    };
    if bs.weight.max_element().is_nan() || bs.weight.max_element() <= 0.0 {
        return shadow;
    }
    path.throughput *= bs.weight;
    let wi = frame.to_world(bs.wi);
    if !bs.is_delta() {
        if track_cones {
            path.cone.spread += bsdf.roughness() * settings.footprint_scale;
        }
        path.specular_chain = false;
    }
    path.eta *= bs.eta;
    path.prev_bsdf_pdf = bs.pdf;
    path.prev_delta = bs.is_delta();
    path.prev_p = hit.p;
    path.ray = Ray {
        origin: offset_origin(hit.p, hit.ng, wi),
        dir: wi,
        tmax: f32::INFINITY,
    };
    path.depth += 1;
    if path.depth as i32 >= settings.rr_depth {
        let q = (path.throughput.max_element() * path.eta * path.eta).min(0.95);
        if path.u_rr >= q {
            return shadow;
        }
        path.throughput /= q;
    }
    live.push(index);
    shadow
}
