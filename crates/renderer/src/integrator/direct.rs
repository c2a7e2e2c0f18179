//! Mitsuba 3's `direct` integrator with several samples per shading point: the emission seen by
//! the camera ray, then `emitter_samples` light samples and `bsdf_samples` BSDF samples at its
//! first hit, combined by the power heuristic on the pdfs scaled by each technique's share of the
//! samples (Mitsuba's `m_frac_lum`, `m_frac_bsdf`), each technique's sum divided by its count.
//!
//! With one sample of each this is the path tracer at `max_depth` 2 (the same estimator), which is
//! what the scene builder uses then; this file is for other counts, whose noise differs (and
//! which Mitsuba's verdict would see: it divides by the reference's per-sample variance).

use super::path::{infinite_radiance, shadow_ray};
use super::{EnvStrategy, PathSettings, RayCount};
use crate::ray::{offset_origin, Ray};
use crate::sampler::Sampler;
use crate::sampling::power_heuristic;
use crate::scene::RenderScene;
use crate::shapes::SurfaceHit;
use crate::textures::TextureQuery;
use glam::Vec3A;
use torrey_texture::{Footprint, RayCone};

/// Radiance along the camera ray (`first_hit`: its closest hit, traced by the render loop), with
/// `emitter_samples` light samples and `bsdf_samples` BSDF samples at the first hit.
#[allow(clippy::too_many_arguments)]
pub fn radiance(
    scene: &RenderScene,
    dir: Vec3A,
    cone: RayCone,
    settings: PathSettings,
    sampler: &mut impl Sampler,
    rays: &mut RayCount,
    first_hit: Option<SurfaceHit>,
    (emitter_samples, bsdf_samples): (u32, u32),
) -> Vec3A {
    let light_count = scene.lights.len();
    let light_select_pdf = if light_count > 0 {
        1.0 / light_count as f32
    } else {
        0.0
    };
    let total = (emitter_samples + bsdf_samples).max(1) as f32;
    let (frac_lum, frac_bsdf) = (emitter_samples as f32 / total, bsdf_samples as f32 / total);
    rays.closest += 1;
    let hit = first_hit;
    let camera_sees_emitters = !scene.hide_emitters;
    let Some(hit) = hit else {
        if !camera_sees_emitters {
            return Vec3A::ZERO;
        }
        let spread = if settings.mipmapping {
            cone.spread
        } else {
            0.0
        };
        return infinite_radiance(
            scene,
            Vec3A::ONE,
            dir,
            spread,
            None,
            light_select_pdf,
            settings.env_strategy,
        );
    };
    let mut result = Vec3A::ZERO;
    let wo = -dir;
    let shape = &scene.shapes[hit.shape as usize];
    if let (Some(li), true) = (shape.area_light, camera_sees_emitters) {
        if let (crate::lights::Light::Area(area), true) =
            (&scene.lights[li as usize], hit.ng.dot(wo) > 0.0)
        {
            result += area.radiance_at(&scene.textures, hit.uv);
        }
    }

    let cone = cone.at_distance(hit.t);
    let material = &scene.materials[shape.material as usize];
    let footprint = if settings.mipmapping && material.is_textured() {
        cone.footprint(dir, hit.ng, hit.dpdu, hit.dpdv)
    } else {
        Footprint::POINT
    };
    let (frame, perturbation) = material.shading_frame(&scene.textures, &hit, wo, footprint);
    let wo_local = frame.to_local(wo);
    let attribute_point = scene.attribute_point(&hit);
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
    let mis_env = settings.env_strategy == EnvStrategy::ImportanceMis;

    // Emitter sampling (only where the BSDF has a smooth lobe, as Mitsuba).
    if light_count > 0 && bsdf.flags().has_smooth() {
        let uniform_env = settings.env_strategy == EnvStrategy::Uniform;
        for _ in 0..emitter_samples {
            let u_light = sampler.next_1d();
            let u_pos = sampler.next_2d();
            let index = ((u_light * light_count as f32) as u32 as usize).min(light_count - 1);
            let light = &scene.lights[index];
            let Some(ls) = light.connect(light.draw(u_pos), hit.p, uniform_env, &scene.textures)
            else {
                continue;
            };
            let wi_local = frame.to_local(ls.wi);
            let f = bsdf.eval(wo_local, wi_local);
            if !(f.max_element() > 0.0 && ls.pdf > 0.0) {
                continue;
            }
            let (o, d, tmax) = shadow_ray(hit.p, hit.ng, &ls);
            rays.shadow += 1;
            if !scene.visible(o, d, tmax) {
                continue;
            }
            let light_pdf = ls.pdf * light_select_pdf;
            // Lights BSDF samples cannot reach (delta lights; environments when only light
            // samples count them) take the whole weight.
            let w = if ls.is_delta || (light.is_infinite() && !mis_env) {
                1.0
            } else {
                power_heuristic(
                    light_pdf * frac_lum,
                    bsdf.pdf(wo_local, wi_local) * frac_bsdf,
                )
            };
            // Mitsuba 3.9.1 divides by the count only the MIS-weighted samples: a delta light's
            // sample keeps weight 1 each (its `direct` renders point lights emitter_samples
            // times too bright; pixels follow Mitsuba).
            let share = if ls.is_delta {
                1.0
            } else {
                emitter_samples as f32
            };
            result += f * ls.radiance * (w / (light_pdf * share));
        }
    }

    // BSDF sampling: emission found along the sampled direction.
    for _ in 0..bsdf_samples {
        let u_lobe = sampler.next_1d();
        let u_dir = sampler.next_2d();
        let Some(bs) = bsdf.sample(wo_local, u_dir, u_lobe) else {
            continue;
        };
        let w_max = bs.weight.max_element();
        if w_max.is_nan() || w_max <= 0.0 {
            continue;
        }
        let wi = frame.to_world(bs.wi);
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
                        sum += le * weight(pdf * light_select_pdf);
                    }
                }
                sum
            }
            Some(h) => {
                let shape = &scene.shapes[h.shape as usize];
                match shape.area_light {
                    Some(li) if h.ng.dot(-wi) > 0.0 => {
                        let light = &scene.lights[li as usize];
                        match light {
                            crate::lights::Light::Area(area) => {
                                let pdf = light.pdf_area_hit(hit.p, wi, h.t, h.ng, h.uv);
                                area.radiance_at(&scene.textures, h.uv)
                                    * weight(pdf * light_select_pdf)
                            }
                            _ => Vec3A::ZERO,
                        }
                    }
                    _ => Vec3A::ZERO,
                }
            }
        };
        result += bs.weight * le / bsdf_samples as f32;
    }
    result
}
