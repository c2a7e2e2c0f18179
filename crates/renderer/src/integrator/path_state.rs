//! The path tracer's state and its step at a surface, written once for both drivers (the scalar
//! loop of [`super::path`] and the wavefront of [`super::wavefront`]), as Mitsuba's `path.cpp`
//! and `volpath.cpp` keep one loop state.
//!
//! Each bounce draws the same four sampler requests whatever its branches ([`BounceDraws`]),
//! before its ray is traced: they do not depend on the hit, so the sampler's work overlaps the
//! traversal. At a surface, [`PathState::scatter`] adds the surface's emission (weighted by MIS
//! against light sampling), builds the [`ShadingPoint`], samples the BSDF, connects to the
//! bounce's light sample (a [`ShadowRay`] for the driver to trace) and continues the path with
//! Russian roulette. A ray that escapes sees the lights at infinity ([`PathState::escape`]).
//!
//! Depth counts path segments like Mitsuba's `max_depth`: 1 shows only emitters seen directly,
//! 2 adds direct lighting. Russian roulette starts at `rr_depth`.
//!
//! Transmission needs nothing special: BSDFs take `wo` and `wi` on either side of the surface,
//! rays leave from the side their direction points to ([`offset_origin`]), next-event
//! estimation is skipped at purely delta surfaces (glass, mirrors) and emission found after a
//! delta bounce is counted with MIS weight 1, so light reaches the camera through glass along
//! BSDF-sampled specular chains, from area lights and environment maps alike.
//!
//! Ray cones: every camera ray starts with the pixel's spread angle times 1/sqrt(spp) (the share
//! of the pixel one sample stands for); the cone's width grows with distance, and its elliptical
//! footprint on a surface filters textures anisotropically. Delta (mirror) bounces keep the spread;
//! a rough bounce adds its lobe width (`Bsdf::roughness`, about one radian for diffuse) times
//! the same 1/sqrt(spp), so textures seen through diffuse interreflection are looked up prefiltered
//! and every filter vanishes as the sample count grows. After a rough bounce the footprint is
//! filtered as the circle of its area (`RayCone::widened`): one trilinear probe, not up to 33
//! along the ellipse, where the lobe's blur hides the ellipse's stretch. Environment maps are
//! filtered by the cone only along purely specular chains; after a rough bounce they are read at
//! full resolution so that light sampling and BSDF sampling see the same radiance (their MIS
//! combination stays unbiased).

use super::shading::{emission_pdf, hit_emission, ShadingPoint};
use super::{EnvStrategy, PathSettings};
use crate::bsdfs::BsdfFlags;
use crate::lights::{EarlyChoice, LightDraw};
use crate::ray::{offset_origin, Ray};
use crate::sampling::power_heuristic;
use crate::scene::RenderScene;
use crate::shapes::SurfaceHit;
use glam::{Vec2, Vec3, Vec3A};
use torrey_texture::RayCone;

/// What a render's paths share: the scene and the settings.
#[derive(Clone, Copy)]
pub struct PathContext<'a> {
    pub scene: &'a RenderScene,
    pub settings: PathSettings,
    /// The probability of choosing each light at infinity (anywhere the same).
    pub infinite_select_pdf: f32,
    /// Cones only matter where they filter: textures (mip-mapping) and environment maps.
    track_cones: bool,
    /// Every sample counts from the start ([`PathState::radiance`]): the camera sees a light at
    /// infinity.
    valid_at_start: bool,
    /// The volumetric path tracer's rules at surfaces (Mitsuba's `volpath`): index-matched
    /// (null) crossings are not bounces and carry the path's medium across the surface.
    pub volumetric: bool,
}

impl<'a> PathContext<'a> {
    pub fn new(scene: &'a RenderScene, settings: PathSettings) -> Self {
        Self {
            scene,
            settings,
            infinite_select_pdf: scene.light_selection.pmf_unbounded(),
            track_cones: settings.mipmapping && scene.uses_cones,
            valid_at_start: !settings.hide_emitters && !scene.infinite_lights.is_empty(),
            volumetric: false,
        }
    }

    /// The context of the volumetric path tracer.
    pub fn volumetric(scene: &'a RenderScene, settings: PathSettings) -> Self {
        Self {
            volumetric: true,
            ..Self::new(scene, settings)
        }
    }

    /// Lights at infinity are weighed by MIS against BSDF sampling.
    #[inline(always)]
    pub fn infinite_mis(&self) -> bool {
        self.settings.env_strategy == EnvStrategy::ImportanceMis
    }
}

/// The light a bounce samples for next-event estimation ([`crate::lights::LightSelection`]).
#[derive(Clone, Copy, Debug)]
pub enum LightPick {
    None,
    /// Chosen before the ray is traced, with probability `pmf` wherever the hit is, its sample
    /// started ([`crate::lights::Light::draw`]).
    Chosen {
        index: usize,
        pmf: f32,
        draw: LightDraw,
    },
    /// To be chosen from the light tree at the shading point with number `u`; `u_pos` is its
    /// sample's pair.
    AtHit {
        u: f32,
        u_pos: Vec2,
    },
}

/// One bounce's random numbers: the light to sample and its draw, the BSDF direction's pair and
/// its lobe's number, Russian roulette's number.
#[derive(Clone, Copy, Debug)]
pub struct BounceDraws {
    pub light: LightPick,
    pub u_dir: Vec2,
    pub u_lobe: f32,
    pub u_rr: f32,
}

impl BounceDraws {
    /// A bounce that draws nothing (the last segment only looks for emission).
    pub const NONE: BounceDraws = BounceDraws {
        light: LightPick::None,
        u_dir: Vec2::ZERO,
        u_lobe: 0.0,
        u_rr: 0.0,
    };

    /// The bounce's draws from its four sampler requests: the light's choice and Russian
    /// roulette's number, the light sample's pair, the BSDF direction's pair and the lobe's
    /// number (x). As much of the light's choice and sample as does not depend on the hit is
    /// made here, before the ray is traced, so that it overlaps the traversal.
    #[inline(always)]
    pub fn new(ctx: &PathContext, [light_rr, u_pos, u_dir, u_lobe]: [Vec2; 4]) -> Self {
        let scene = ctx.scene;
        let light = match scene.light_selection.choose_early(light_rr.x) {
            EarlyChoice::None => LightPick::None,
            EarlyChoice::Light { index, pmf } => LightPick::Chosen {
                index,
                pmf,
                draw: scene.lights[index].draw(u_pos),
            },
            EarlyChoice::Tree(u) => LightPick::AtHit { u, u_pos },
        };
        BounceDraws {
            light,
            ..Self::without_light([light_rr, u_pos, u_dir, u_lobe])
        }
    }

    /// [`BounceDraws::new`] for a bounce that samples no light (a medium that samples no
    /// emitters): the same numbers in the same places, and no light chosen or drawn.
    #[inline(always)]
    pub fn without_light([light_rr, _, u_dir, u_lobe]: [Vec2; 4]) -> Self {
        BounceDraws {
            light: LightPick::None,
            u_dir,
            u_lobe: u_lobe.x,
            u_rr: light_rr.y,
        }
    }

    /// The bounce's light at the shading point `p` (normal `n`): its index, the probability of
    /// its choice there and its draw. None when there is no light to sample.
    #[inline(always)]
    pub fn light_at(
        &self,
        scene: &RenderScene,
        p: Vec3A,
        n: Vec3A,
    ) -> Option<(usize, f32, LightDraw)> {
        match self.light {
            LightPick::None => None,
            LightPick::Chosen { index, pmf, draw } => Some((index, pmf, draw)),
            LightPick::AtHit { u, u_pos } => {
                let (index, pmf) = scene.light_selection.choose_at(u, p, n)?;
                Some((index, pmf, scene.lights[index].draw(u_pos)))
            }
        }
    }
}

/// A shadow ray of next-event estimation and what it adds to its path when unoccluded.
#[derive(Clone, Copy, Debug, Default)]
pub struct ShadowRay {
    pub origin: Vec3A,
    pub dir: Vec3A,
    pub tmax: f32,
    pub contribution: Vec3A,
}

/// One path between bounces.
#[derive(Clone, Copy, Debug)]
pub struct PathState {
    /// The ray to trace next.
    pub ray: Ray,
    pub cone: RayCone,
    pub throughput: Vec3A,
    pub result: Vec3A,
    /// The density of the BSDF sample that produced `ray` (for MIS at emitters it finds), and
    /// whether it came from a delta lobe (camera rays count as delta: weight 1).
    pub prev_bsdf_pdf: f32,
    pub prev_delta: bool,
    /// Where `ray` left from, and the shading normal there (for the light choice's probability
    /// in MIS).
    pub prev_p: Vec3A,
    pub prev_n: Vec3A,
    /// Every bounce so far was specular (environment maps are then filtered by the cone).
    pub specular_chain: bool,
    /// Product of the relative IORs crossed (Mitsuba's `eta`): radiance inside glass is scaled
    /// by 1/η², which Russian roulette must not mistake for an absorbing path.
    pub eta: f32,
    /// Segments traced before `ray`.
    pub depth: u32,
    /// The path met a surface that is not a `null` crossing (Mitsuba's `valid_ray`; see
    /// [`PathState::radiance`]).
    pub valid: bool,
    /// The medium `ray` travels in (volumetric path tracer; None: vacuum).
    pub medium: Option<u32>,
    /// How far `ray`'s origin lies from `prev_p` along `ray` (past index-matched crossings;
    /// always 0 in the path tracer): emission found on `ray` is `travelled` + t away from the
    /// scattering event whose sample produced it.
    pub travelled: f32,
    /// The denoiser's guides, taken at the path's first non-delta hit when
    /// [`PathSettings::guides`] asks for them.
    pub guides: Guides,
}

/// The roughness ([`crate::bsdfs::Bsdf::roughness`], about the microfacet alpha) up to which a
/// glossy lobe counts as specular for the denoiser's guides: they are taken further along, as
/// Cycles does below the same value (a near-mirror's albedo is its reflection's).
const GUIDE_SPECULAR_ROUGHNESS: f32 = 0.075;

/// A path's guides for the denoiser, taken at its first hit whose BSDF has a non-delta lobe
/// wider than [`GUIDE_SPECULAR_ROUGHNESS`] (through mirrors, glass and near-mirrors, as Cycles
/// takes them): the albedo, the weight of the BSDF sample drawn there (an unbiased estimate of
/// the directional albedo: exactly the reflectance of a diffuse surface) times the delta chain's
/// throughput, clamped to [0, 1]; and the shading normal. A real scattering in a medium before
/// such a hit takes them too, as Cycles does (a phase function counts as diffuse): the
/// throughput with the medium's albedo in it, and the normal facing the ray that arrived. Zero
/// where the path escapes or ends before either. (Unaligned vectors: the path state, which every
/// wavefront stage reads, stays small.)
#[derive(Clone, Copy, Debug, Default)]
pub struct Guides {
    pub albedo: Vec3,
    pub normal: Vec3,
    pub taken: bool,
}
impl PathState {
    /// A path starting with the camera ray from `origin` along `dir`.
    #[inline(always)]
    pub fn camera(origin: Vec3A, dir: Vec3A, cone: RayCone) -> Self {
        PathState {
            ray: Ray {
                origin,
                dir,
                tmax: f32::INFINITY,
            },
            cone,
            throughput: Vec3A::ONE,
            result: Vec3A::ZERO,
            prev_bsdf_pdf: 0.0,
            prev_delta: true,
            prev_p: origin,
            prev_n: Vec3A::ZERO,
            specular_chain: true,
            eta: 1.0,
            depth: 0,
            guides: Guides::default(),
            valid: false,
            medium: None,
            travelled: 0.0,
        }
    }

    /// The sample's radiance once the path has ended. Mitsuba 3's `path` integrator counts a
    /// sample only if `valid_ray` holds: the camera sees a light at infinity (an environment
    /// map or a constant background, `hide_emitters` off), or the path reached a surface whose
    /// BSDF sample there was not a `null` crossing. So emitters with a `null` BSDF seen against
    /// nothing count for nothing: the 400 small `null` rectangle lamps of
    /// ../shared/scenes/mitsuba-real/stage-lights seen against the black sky (issue 34). This
    /// follows the `llvm_ad_rgb` variant the references come from: it samples the BSDF at every
    /// vertex, the last one too (torrey asks the material there,
    /// [`crate::scene::Material::passes_through`]); Mitsuba's scalar variants also count a path
    /// whose last vertex is an emitter.
    #[inline(always)]
    pub fn radiance(&self, ctx: &PathContext) -> Vec3A {
        if self.valid || ctx.valid_at_start {
            self.result
        } else {
            Vec3A::ZERO
        }
    }

    /// `ray` is the path's last segment: what it finds is looked at for emission only.
    #[inline(always)]
    pub fn last_segment(&self, ctx: &PathContext) -> bool {
        self.depth + 1 >= ctx.settings.max_depth
    }

    /// Emitters seen along `ray` count (camera rays see none with `hide_emitters`).
    #[inline(always)]
    pub fn sees_emitters(&self, ctx: &PathContext) -> bool {
        self.depth > 0 || !ctx.settings.hide_emitters
    }

    /// The cone spread at which an escaped ray reads environment maps: the cone's along purely
    /// specular chains, the finest level after a rough bounce.
    #[inline(always)]
    pub fn escape_spread(&self, ctx: &PathContext) -> f32 {
        if self.specular_chain && ctx.settings.mipmapping {
            self.cone.spread
        } else {
            0.0
        }
    }

    /// The density of the BSDF sample behind `ray` for MIS with light sampling; None after a
    /// delta bounce (and for camera rays): weight 1.
    #[inline(always)]
    pub fn mis_bsdf_pdf(&self) -> Option<f32> {
        (!self.prev_delta).then_some(self.prev_bsdf_pdf)
    }

    /// `ray` escaped: adds the radiance of the lights at infinity along it.
    #[inline(always)]
    pub fn escape(&mut self, ctx: &PathContext) {
        if !self.sees_emitters(ctx) {
            return;
        }
        self.result += self.throughput
            * infinite_radiance(
                ctx.scene,
                self.ray.dir,
                self.escape_spread(ctx),
                self.mis_bsdf_pdf(),
                ctx.infinite_select_pdf,
                ctx.settings.env_strategy,
            );
    }

    /// The path's step at `hit`, the closest hit of `ray`, with this bounce's `draws`: adds the
    /// surface's emission; unless this was the last segment, connects to the light sample
    /// (returned as a shadow ray for the driver to trace, its contribution added if unoccluded)
    /// and samples the BSDF to continue. Returns the shadow ray and whether the path goes on.
    #[inline(always)]
    pub fn scatter(
        &mut self,
        ctx: &PathContext,
        hit: &SurfaceHit,
        draws: &BounceDraws,
    ) -> (Option<ShadowRay>, bool) {
        let scene = ctx.scene;
        let dir = self.ray.dir;
        if self.sees_emitters(ctx) {
            if let Some((radiance, index)) = hit_emission(scene, hit, dir) {
                let w = if self.prev_delta {
                    1.0
                } else {
                    let select = scene.light_selection.pmf(index, self.prev_p, self.prev_n);
                    let t = self.travelled + hit.t;
                    let pdf = emission_pdf(&scene.lights[index], self.prev_p, dir, t, hit, select);
                    power_heuristic(self.prev_bsdf_pdf, pdf)
                };
                self.result += self.throughput * radiance * w;
            }
        }
        let last_segment = self.last_segment(ctx);
        // The volumetric path tracer goes on through index-matched surfaces on its last segment
        // (they are no bounce), as Mitsuba's `volpath` does.
        if last_segment && !(ctx.volumetric && self.may_pass(ctx, hit)) {
            let material = scene.shapes[hit.shape as usize].material;
            self.valid |= !scene.materials[material as usize].passes_through();
            return (None, false);
        }

        if ctx.track_cones {
            self.cone = self.cone.at_distance(hit.t);
        }
        let at = scene.attribute_point(hit);
        let sp = ShadingPoint::new(
            scene,
            hit,
            dir,
            &self.cone,
            ctx.settings.mipmapping,
            at.as_ref(),
        );
        // The BSDF sample that continues the path, drawn before next-event estimation although
        // used after it: it depends only on this hit, so its dependent chain of a division, a
        // polynomial and square roots overlaps the light connection instead of waiting for it.
        let bsdf_sample = sp.bsdf.sample(sp.wo, draws.u_dir, draws.u_lobe);
        self.valid |= !bsdf_sample.is_some_and(|bs| bs.is_null());
        // (`taken` first: the roughness is not asked once the guides are in.)
        if ctx.settings.guides
            && !self.guides.taken
            && sp.bsdf.flags().has_smooth()
            && sp.bsdf.roughness() > GUIDE_SPECULAR_ROUGHNESS
        {
            let weight = bsdf_sample.map_or(Vec3A::ZERO, |s| s.weight);
            self.take_guides(self.throughput * weight, sp.frame.n);
        }

        let mut shadow = None;
        let light = match sp.bsdf.flags().has_smooth() && !last_segment {
            true => draws.light_at(scene, hit.p, sp.frame.n),
            false => None,
        };
        if let Some((index, select_pdf, draw)) = light {
            let light = &scene.lights[index];
            let uniform_env = ctx.settings.env_strategy == EnvStrategy::Uniform;
            if let Some(c) = sp.connect(scene, hit, light, draw, uniform_env) {
                let light_pdf = c.ls.pdf * select_pdf;
                let w = if c.ls.is_delta || (light.is_infinite() && !ctx.infinite_mis()) {
                    1.0
                } else {
                    power_heuristic(light_pdf, c.bsdf_pdf)
                };
                shadow = Some(ShadowRay {
                    origin: c.origin,
                    dir: c.dir,
                    tmax: c.tmax,
                    contribution: self.throughput * c.f * c.ls.radiance * (w / light_pdf),
                });
            }
        }

        let Some(bs) = bsdf_sample else {
            return (shadow, false);
        };
        if bs.weight.max_element().is_nan() || bs.weight.max_element() <= 0.0 {
            return (shadow, false);
        }
        self.throughput *= bs.weight;
        let wi = sp.frame.to_world(bs.wi);
        if ctx.volumetric {
            self.medium = scene
                .media
                .after_crossing(self.medium, hit.shape, hit.ng, wi);
            if bs.lobe.contains(BsdfFlags::NULL) {
                // Index-matched: the same ray goes on; not a bounce.
                self.travelled += hit.t;
                self.ray = Ray {
                    origin: offset_origin(hit.p, hit.ng, wi),
                    dir: wi,
                    tmax: f32::INFINITY,
                };
                return (shadow, true);
            }
            if last_segment {
                return (shadow, false);
            }
            self.travelled = 0.0;
        }
        if !bs.is_delta() {
            if ctx.track_cones {
                self.cone = self
                    .cone
                    .widened(sp.bsdf.roughness() * ctx.settings.footprint_scale);
            }
            self.specular_chain = false;
        }
        self.eta *= bs.eta;
        self.prev_bsdf_pdf = bs.pdf;
        self.prev_delta = bs.is_delta();
        self.prev_p = hit.p;
        self.prev_n = sp.frame.n;
        self.ray = Ray {
            origin: offset_origin(hit.p, hit.ng, wi),
            dir: wi,
            tmax: f32::INFINITY,
        };
        self.depth += 1;

        (shadow, self.roulette(ctx, draws.u_rr))
    }

    /// Russian roulette after a bounce, as Mitsuba's: from `rr_depth` on the path survives with
    /// probability min(max throughput · η², 0.95) (`u` decides). Returns whether it goes on.
    #[inline(always)]
    pub fn roulette(&mut self, ctx: &PathContext, u: f32) -> bool {
        if self.depth as i32 >= ctx.settings.rr_depth {
            let q = (self.throughput.max_element() * self.eta * self.eta).min(0.95);
            if u >= q {
                return false;
            }
            self.throughput /= q;
        }
        true
    }

    /// The path scattered in a medium at `p`, `t` along its ray, into `wi` with density `pdf`
    /// (the phase function's); `count_fully`: emitters the new ray finds are not weighed by MIS
    /// (the medium samples no emitters).
    pub fn scattered_in_medium(
        &mut self,
        ctx: &PathContext,
        t: f32,
        p: Vec3A,
        wi: Vec3A,
        pdf: f32,
        count_fully: bool,
    ) {
        if ctx.settings.guides {
            // The throughput carries the scattering's weight, the medium's albedo.
            self.take_guides(self.throughput, -self.ray.dir);
        }
        if ctx.track_cones {
            // Like a diffuse bounce: the widest lobe.
            self.cone = self
                .cone
                .at_distance(t)
                .widened(ctx.settings.footprint_scale);
        }
        self.specular_chain = false;
        self.prev_bsdf_pdf = pdf;
        self.prev_delta = count_fully;
        self.prev_p = p;
        // No surface: the light choice's probability there has no orientation to weigh.
        self.prev_n = Vec3A::ZERO;
        self.travelled = 0.0;
        // Mitsuba's `volpath`: a scattering in a medium makes the sample count.
        self.valid = true;
        self.ray = Ray {
            origin: p,
            dir: wi,
            tmax: f32::INFINITY,
        };
    }

    /// The denoiser's guides ([`Guides`]), unless the path took them already.
    #[inline(always)]
    fn take_guides(&mut self, albedo: Vec3A, normal: Vec3A) {
        if !self.guides.taken {
            self.guides = Guides {
                albedo: albedo.clamp(Vec3A::ZERO, Vec3A::ONE).into(),
                normal: normal.into(),
                taken: true,
            };
        }
    }
}

impl PathState {
    /// Whether the surface at `hit` may let the ray pass straight through (a `null`, a thin
    /// dielectric, a mask).
    #[inline]
    pub fn may_pass(&self, ctx: &PathContext, hit: &SurfaceHit) -> bool {
        let scene = ctx.scene;
        scene.materials[scene.shapes[hit.shape as usize].material as usize]
            .bsdf
            .may_pass()
    }
}

/// The radiance of the lights at infinity seen along an escaped ray `dir`, weighted against light
/// sampling by MIS; `bsdf_pdf` is the density of the BSDF sample that chose `dir` (None after a
/// delta bounce or for camera rays: weight 1), `light_select_pdf` the probability of choosing
/// each of them. `spread` filters environment maps (0: finest level).
pub fn infinite_radiance(
    scene: &RenderScene,
    dir: Vec3A,
    spread: f32,
    bsdf_pdf: Option<f32>,
    light_select_pdf: f32,
    strategy: EnvStrategy,
) -> Vec3A {
    let mut sum = Vec3A::ZERO;
    for &li in &scene.infinite_lights {
        let light = &scene.lights[li as usize];
        sum += match bsdf_pdf {
            None => light.radiance_infinite(dir, spread),
            // Counted through light samples only.
            Some(_) if strategy != EnvStrategy::ImportanceMis => continue,
            Some(bsdf_pdf) => {
                let (le, pdf) = light.eval_infinite(dir, spread);
                le * power_heuristic(bsdf_pdf, pdf * light_select_pdf)
            }
        };
    }
    sum
}
