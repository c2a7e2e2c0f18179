//! Mitsuba 3's `direct` integrator with several samples per shading point: the emission seen by
//! the camera ray, then `emitter_samples` light samples and `bsdf_samples` BSDF samples at its
//! first hit, combined by the power heuristic on the pdfs scaled by each technique's share of the
//! samples (Mitsuba's `m_frac_lum`, `m_frac_bsdf`), each technique's sum divided by its count.
//!
//! With one sample of each this is the path tracer at `max_depth` 2 (the same estimator), which is
//! what [`super::Integrator::from_desc`] makes of it; this file is for other counts, whose noise
//! differs (and which Mitsuba's verdict would see: it divides by the reference's per-sample
//! variance). The shading point, the emission at a hit and the light connection are the path
//! tracer's ([`super::shading`]).

use super::path_state::infinite_radiance;
use super::shading::{emission_pdf, hit_emission, ShadingPoint};
use super::{EnvStrategy, PathSettings, RayCount};
use crate::lights::EarlyChoice;
use crate::ray::{offset_origin, Ray};
use crate::sampler::Sampler;
use crate::sampling::power_heuristic;
use crate::scene::RenderScene;
use crate::shapes::SurfaceHit;
use glam::Vec3A;
use torrey_texture::RayCone;

/// Mitsuba's `direct` with other than one emitter and one BSDF sample per hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectIntegrator {
    pub emitter_samples: u32,
    pub bsdf_samples: u32,
    /// Camera rays see no emitter.
    pub hide_emitters: bool,
}

/// Radiance along the camera ray (`first_hit`: its closest hit, traced by the render loop), with
/// `emitter_samples` light samples and `bsdf_samples` BSDF samples at the first hit.
#[allow(clippy::too_many_arguments)]
pub fn radiance(
    scene: &RenderScene,
    integrator: &DirectIntegrator,
    dir: Vec3A,
    cone: RayCone,
    settings: PathSettings,
    sampler: &mut impl Sampler,
    rays: &mut RayCount,
    first_hit: Option<SurfaceHit>,
) -> Vec3A {
    let DirectIntegrator {
        emitter_samples,
        bsdf_samples,
        hide_emitters,
    } = *integrator;
    let selection = &scene.light_selection;
    let infinite_select_pdf = selection.pmf_unbounded();
    let total = (emitter_samples + bsdf_samples).max(1) as f32;
    let (frac_lum, frac_bsdf) = (emitter_samples as f32 / total, bsdf_samples as f32 / total);
    rays.closest += 1;
    let Some(hit) = first_hit else {
        if hide_emitters {
            return Vec3A::ZERO;
        }
        let spread = if settings.mipmapping {
            cone.spread
        } else {
            0.0
        };
        return infinite_radiance(
            scene,
            dir,
            spread,
            None,
            infinite_select_pdf,
            settings.env_strategy,
        );
    };
    let mut result = Vec3A::ZERO;
    if !hide_emitters {
        if let Some((radiance, _)) = hit_emission(scene, &hit, dir) {
            result += radiance;
        }
    }

    let cone = cone.at_distance(hit.t);
    let at = scene.attribute_point(&hit);
    let sp = ShadingPoint::new(scene, &hit, dir, &cone, settings.mipmapping, at.as_ref());
    let mis_env = settings.env_strategy == EnvStrategy::ImportanceMis;

    // Emitter sampling (only where the BSDF has a smooth lobe, as Mitsuba).
    if !scene.lights.is_empty() && sp.bsdf.flags().has_smooth() {
        let uniform_env = settings.env_strategy == EnvStrategy::Uniform;
        for _ in 0..emitter_samples {
            let u_light = sampler.next_1d();
            let u_pos = sampler.next_2d();
            let (index, light_select_pdf) = match selection.choose_early(u_light) {
                EarlyChoice::None => continue,
                EarlyChoice::Light { index, pmf } => (index, pmf),
                EarlyChoice::Tree(u) => match selection.choose_at(u, hit.p, sp.frame.n) {
                    Some(choice) => choice,
                    None => continue,
                },
            };
            let light = &scene.lights[index];
            let Some(c) = sp.connect(scene, &hit, light, light.draw(u_pos), uniform_env) else {
                continue;
            };
            rays.shadow += 1;
            if !scene.visible(c.origin, c.dir, c.tmax) {
                continue;
            }
            let light_pdf = c.ls.pdf * light_select_pdf;
            // Lights BSDF samples cannot reach (delta lights; environments when only light
            // samples count them) take the whole weight.
            let w = if c.ls.is_delta || (light.is_infinite() && !mis_env) {
                1.0
            } else {
                power_heuristic(light_pdf * frac_lum, c.bsdf_pdf * frac_bsdf)
            };
            // Mitsuba 3.9.1 divides by the count only the MIS-weighted samples: a delta light's
            // sample keeps weight 1 each (its `direct` renders point lights emitter_samples
            // times too bright; pixels follow Mitsuba).
            let share = if c.ls.is_delta {
                1.0
            } else {
                emitter_samples as f32
            };
            result += c.f * c.ls.radiance * (w / (light_pdf * share));
        }
    }

    // BSDF sampling: emission found along the sampled direction.
    for _ in 0..bsdf_samples {
        let u_lobe = sampler.next_1d();
        let u_dir = sampler.next_2d();
        let Some(bs) = sp.bsdf.sample(sp.wo, u_dir, u_lobe) else {
            continue;
        };
        let w_max = bs.weight.max_element();
        if w_max.is_nan() || w_max <= 0.0 {
            continue;
        }
        let wi = sp.frame.to_world(bs.wi);
        let delta = bs.is_delta();
        // The light-sampling pdf of this direction, scaled by its share; none after a delta lobe.
        let weight = |light_pdf: f32| {
            if delta {
                1.0
            } else {
                power_heuristic(bs.pdf * frac_bsdf, light_pdf * frac_lum)
            }
        };
        rays.closest += 1;
        let ray = Ray {
            origin: offset_origin(hit.p, hit.ng, wi),
            dir: wi,
            tmax: f32::INFINITY,
        };
        let le = match scene.intersect(&ray) {
            None => {
                let spread = if delta && settings.mipmapping {
                    cone.spread
                } else {
                    0.0
                };
                let mut sum = Vec3A::ZERO;
                for &li in &scene.infinite_lights {
                    let light = &scene.lights[li as usize];
                    if delta {
                        sum += light.radiance_infinite(wi, spread);
                    } else if mis_env || emitter_samples == 0 {
                        let (le, pdf) = light.eval_infinite(wi, spread);
                        sum += le * weight(pdf * infinite_select_pdf);
                    }
                }
                sum
            }
            Some(h) => match hit_emission(scene, &h, wi) {
                Some((radiance, index)) => {
                    let select = selection.pmf(index, hit.p, sp.frame.n);
                    let light = &scene.lights[index];
                    radiance * weight(emission_pdf(light, hit.p, wi, h.t, &h, select))
                }
                None => Vec3A::ZERO,
            },
        };
        result += bs.weight * le / bsdf_samples as f32;
    }
    result
}
