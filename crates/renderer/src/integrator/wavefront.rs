//! The path tracer run as a wavefront: a batch of paths advances one bounce at a time through
//! stages (the bounce's sampler draws for every live path, their closest hits, escaped rays'
//! environment lookups, the surface step, the shadow rays, then compaction of the paths still
//! alive), instead of following one path to its end before starting the next.
//!
//! The estimator is the scalar loop's ([`super::path`]): both drive the same [`PathState`], whose
//! step at a surface is [`PathState::scatter`], with the same sampler dimensions per bounce
//! (four requests, drawn whatever the branches), and each path's radiance is summed in the same
//! order. With the same sampler state the two loops give bit-identical radiance per sample
//! (tests in `render.rs`). What the batch buys: the sampler's draws of all paths at once (in SIMD
//! lanes), escaped rays' environment lookups and the surfaced paths' environment-map light
//! samples in SIMD lanes, shadow rays traced as packets where they are coherent, and
//! independent work between one path's dependent chains.

use super::path_state::{BounceDraws, Guides, LightPick, PathContext, PathState, ShadowRay};
use super::{EnvStrategy, PathSettings, RayCount};
use crate::accel::Simd;
use crate::lights::{Light, LightDraw};
use crate::ray::Ray;
use crate::sampler::Sampler;
use crate::sampling::power_heuristic;
use crate::scene::RenderScene;
use crate::shapes::SurfaceHit;
use glam::{Vec2, Vec3, Vec3A};
use std::sync::OnceLock;
use torrey_light::{BatchSimd, EnvSample};
use torrey_texture::RayCone;

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
    /// The sample's lens point (zero for cameras without a lens), for its AOVs.
    pub lens: Vec2,
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

/// A path's place in the batch besides its [`PathState`].
#[derive(Clone, Copy)]
struct Slot {
    /// The sample's global index and the sampler requests it drew so far.
    sample: u32,
    requests: u32,
    /// The camera ray's hit is already in `Wavefront::hits` (traced by the caller).
    traced: bool,
}

/// Reusable buffers of the wavefront loop (one per worker thread).
#[derive(Default)]
pub struct Wavefront {
    paths: Vec<PathState>,
    slots: Vec<Slot>,
    /// Each path's draws of its current bounce.
    draws: Vec<BounceDraws>,
    live: Vec<u32>,
    /// Each path's last closest hit (valid for the paths in `surfaced`).
    hits: Vec<SurfaceHit>,
    /// Stage 1's numbers of each live path (same order).
    numbers: Vec<[Vec2; 4]>,
    escaped: Vec<u32>,
    surfaced: Vec<u32>,
    /// The surface stage's shadow rays, with their paths.
    shadow: Vec<(u32, ShadowRay)>,
    // The escaped paths' environment lookups.
    env_sums: Vec<Vec3A>,
    env_dirs: Vec<Vec3>,
    env_spreads: Vec<f32>,
    env_want_pdf: Vec<bool>,
    env_values: Vec<(Vec3, f32)>,
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
        self.paths.clear();
        self.paths.extend(
            cameras
                .iter()
                .map(|c| PathState::camera(c.origin, c.dir, c.cone)),
        );
        if settings.max_depth == 0 {
            out.resize(cameras.len(), Vec3A::ZERO);
            return;
        }
        let ctx = PathContext::new(scene, settings);
        self.slots.clear();
        self.slots.extend(cameras.iter().map(|c| Slot {
            sample: c.sample,
            requests,
            traced: true,
        }));
        self.draws.clear();
        self.draws.resize(cameras.len(), BounceDraws::NONE);
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
                PathSamplers::Shared(s) => s.next_2d_resumed(
                    self.live.iter().map(|&i| {
                        let slot = &self.slots[i as usize];
                        (slot.sample, slot.requests)
                    }),
                    &mut self.numbers,
                ),
                PathSamplers::PerPath(s) => S::next_2d_each(s, &self.live, &mut self.numbers),
            }
            for (&i, &numbers) in self.live.iter().zip(&self.numbers) {
                self.slots[i as usize].requests += 4;
                let draws = if self.paths[i as usize].last_segment(&ctx) {
                    BounceDraws::NONE
                } else {
                    BounceDraws::new(&ctx, numbers)
                };
                if let (LightPick::Chosen { index, .. }, true) = (draws.light, prefetch_env) {
                    if let Light::Env(env) = &scene.lights[index] {
                        env.map.prefetch_sample(numbers[1]);
                    }
                }
                self.draws[i as usize] = draws;
            }

            // Stage 2: closest hits (any-hit on the last segment when no shape emits). Paths
            // whose last segment is blocked end here.
            self.escaped.clear();
            self.surfaced.clear();
            for &i in &self.live {
                let path = &self.paths[i as usize];
                let slot = &mut self.slots[i as usize];
                // Each hit is written once, into its path's slot (no copy out and back).
                let hit = &mut self.hits[i as usize];
                let found = if slot.traced {
                    // The camera ray's hit, traced by the caller, is in its slot already.
                    slot.traced = false;
                    rays.closest += 1;
                    cameras[i as usize].first_hit.is_some()
                } else if path.last_segment(&ctx) && !scene.has_area_lights {
                    // The slot keeps the last bounce's hit, which no stage reads again: the
                    // path ends here either way.
                    rays.shadow += 1;
                    if scene.visible(path.ray.origin, path.ray.dir, path.ray.tmax) {
                        self.escaped.push(i);
                    }
                    continue;
                } else {
                    rays.closest += 1;
                    closest_hit(scene, &path.ray, hit)
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
                .retain(|&i| self.paths[i as usize].sees_emitters(&ctx));
            if !self.escaped.is_empty() {
                self.escaped_radiance(&ctx);
            }

            // The environment-map light samples of the paths that reached a surface, drawn all at
            // once in SIMD lanes (not in stage 1: an escaped path's would be wasted).
            if !self.surfaced.is_empty() {
                self.draw_env_lights(&ctx);
            }

            // Stage 4: the surface step of every path that found a surface; its shadow ray
            // queued.
            self.shadow.clear();
            self.live.clear();
            for &i in &self.surfaced {
                let (shadow, continues) = self.paths[i as usize].scatter(
                    &ctx,
                    &self.hits[i as usize],
                    &self.draws[i as usize],
                );
                if let Some(s) = shadow {
                    self.shadow.push((i, s));
                }
                if continues {
                    self.live.push(i);
                }
            }

            // Stage 5: shadow rays, traced together (as packets where the CPU has them).
            rays.shadow += self.shadow.len() as u64;
            let (shadow, paths) = (&self.shadow, &mut self.paths);
            scene.visible_batch(
                shadow.len(),
                |k| Ray {
                    origin: shadow[k].1.origin,
                    dir: shadow[k].1.dir,
                    tmax: shadow[k].1.tmax,
                },
                |k| paths[shadow[k].0 as usize].result += shadow[k].1.contribution,
            );
        }
        out.extend(self.paths.iter().map(|p| p.radiance(&ctx)));
    }

    /// The guides of the paths of the last [`Wavefront::radiance`] call, in its order.
    pub fn guides(&self) -> impl Iterator<Item = Guides> + '_ {
        self.paths.iter().map(|p| p.guides)
    }
}

impl Wavefront {
    /// Samples, for every surfaced path whose light draw is an environment map's, the map's
    /// direction, radiance and density with [`torrey_light::EnvMap::sample_batch`] (the bits of
    /// the one-sample code), and leaves them in the draw for [`Light::connect`] to read.
    fn draw_env_lights(&mut self, ctx: &PathContext) {
        let scene = ctx.scene;
        if ctx.settings.env_strategy == EnvStrategy::Uniform || !batched_env() {
            return;
        }
        for &li in &scene.infinite_lights {
            let Light::Env(env) = &scene.lights[li as usize] else {
                continue;
            };
            self.env_draw_paths.clear();
            self.env_draw_us.clear();
            for &i in &self.surfaced {
                if let LightPick::Chosen {
                    index,
                    draw: LightDraw::Deferred(u),
                    ..
                } = self.draws[i as usize].light
                {
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
                if let LightPick::Chosen { draw: d, .. } = &mut self.draws[i as usize].light {
                    *d = draw;
                }
            }
        }
    }

    /// Adds to every escaped path (`self.escaped`) the radiance of the lights at infinity along
    /// its ray: what `path_state::infinite_radiance` gives each, summed over the lights in the same order.
    fn escaped_radiance(&mut self, ctx: &PathContext) {
        let (scene, light_select_pdf) = (ctx.scene, ctx.infinite_select_pdf);
        // With one light at infinity (the usual case) each path's sum is that light's term, added
        // to the path at once; with several, the terms are summed per path in the lights' order
        // first. Either way the bits of the scalar loop: its sum starts at zero too.
        let single = scene.infinite_lights.len() == 1;
        if !single {
            self.env_sums.clear();
            self.env_sums.resize(self.escaped.len(), Vec3A::ZERO);
        }
        let mis = ctx.infinite_mis();
        for &li in &scene.infinite_lights {
            let light = &scene.lights[li as usize];
            if let (Light::Env(env), true) = (light, batched_env()) {
                self.env_dirs.clear();
                self.env_spreads.clear();
                self.env_want_pdf.clear();
                for &i in &self.escaped {
                    let path = &self.paths[i as usize];
                    self.env_dirs.push(path.ray.dir.into());
                    self.env_spreads.push(path.escape_spread(ctx));
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
                    match path.mis_bsdf_pdf() {
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
                    let spread = path.escape_spread(ctx);
                    *sum += match path.mis_bsdf_pdf() {
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
