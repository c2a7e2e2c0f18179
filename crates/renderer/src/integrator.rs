//! Unidirectional path tracing with next-event estimation, combined with BSDF sampling by
//! multiple importance sampling (power heuristic), as Mitsuba 3's `path` integrator does.
//!
//! Depth counts path segments like Mitsuba's `max_depth`: 1 shows only emitters seen directly,
//! 2 adds direct lighting, -1 is unbounded. Russian roulette starts at `rr_depth`.
//!
//! Ray cones: every camera ray starts with the pixel's spread angle times 1/sqrt(spp) (the share
//! of the pixel one sample stands for); the cone's width grows with distance, and its elliptical
//! footprint on a surface filters textures anisotropically. Delta (mirror) bounces keep the spread;
//! a rough bounce adds its lobe width (`BsdfModel::roughness`, about one radian for diffuse) times
//! the same 1/sqrt(spp), so textures seen through diffuse interreflection are looked up prefiltered
//! and every filter vanishes as the sample count grows. Environment maps are filtered by the
//! cone only along purely specular chains; after a rough bounce they are read at full resolution so
//! that light sampling and BSDF sampling see the same radiance (their MIS combination stays unbiased).

use crate::geometry::{offset_origin, Ray};
use crate::sampling::{power_heuristic, Frame};
use crate::scene::{RenderScene, SurfaceHit};
use glam::{Vec2, Vec3A};
use torrey_texture::{Footprint, RayCone};

/// A source of uniform numbers in [0, 1).
pub trait Sampler {
    /// Begins sample number `index` of the current pixel (sequences that depend on the sample
    /// index, like Sobol, restart their dimensions here; independent samplers ignore it).
    fn start_sample(&mut self, _index: u32) {}
    /// Goes back to sample `index` after its first `requests` draws (`next_1d` and `next_2d`
    /// calls each count one), when other samples were started in between: the camera rays of a
    /// pixel's packet are drawn first, then each path is followed in turn. A stream of
    /// independent numbers just continues; a low-discrepancy sampler returns to the sample's
    /// next dimension.
    fn resume_sample(&mut self, _index: u32, _requests: u32) {}
    fn next_1d(&mut self) -> f32;
    fn next_2d(&mut self) -> Vec2 {
        Vec2::new(self.next_1d(), self.next_1d())
    }
}

#[derive(Clone, Copy, Debug)]
pub struct PathSettings {
    pub max_depth: i32,
    pub rr_depth: i32,
    /// Filter textures by the ray cone's footprint (mip-mapping). Off: finest level, bilinear,
    /// as Mitsuba does; used to measure what mip-mapping changes.
    pub mipmapping: bool,
    /// Scale of every ray-cone spread: `torrey_texture::spp_scale(spp)` = 1/sqrt(spp).
    pub footprint_scale: f32,
    /// How lights at infinity are sampled; the default is luminance importance sampling with MIS.
    pub env_strategy: EnvStrategy,
}

/// Strategies for lights at infinity, kept selectable so their noise can be compared (issue: env
/// sampling (a) uniform, (b) luminance-importance, (c) importance + MIS). (a) and (b) count the
/// environment only through light samples: BSDF-sampled rays that escape add nothing after the
/// first rough bounce, which keeps each estimator unbiased on its own.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum EnvStrategy {
    Uniform,
    Importance,
    #[default]
    ImportanceMis,
}

/// Rays traced, by query kind, for the rays-per-second report.
#[derive(Clone, Copy, Debug, Default)]
pub struct RayCount {
    /// Closest-hit queries (camera rays and path continuations).
    pub closest: u64,
    /// Any-hit queries: shadow rays, and last path segments in scenes without area lights.
    pub shadow: u64,
}

/// Radiance arriving at the camera along the primary ray; `rays` counts the queries traced.
/// `first_hit`, when given, is the primary ray's closest hit, already traced (in a packet with
/// the pixel's other samples).
#[allow(clippy::too_many_arguments)]
pub fn radiance(
    scene: &RenderScene,
    origin: Vec3A,
    dir: Vec3A,
    cone: RayCone,
    settings: PathSettings,
    sampler: &mut impl Sampler,
    rays: &mut RayCount,
    mut first_hit: Option<Option<SurfaceHit>>,
) -> Vec3A {
    let max_depth = if settings.max_depth < 0 {
        u32::MAX
    } else {
        settings.max_depth as u32
    };
    if max_depth == 0 {
        return Vec3A::ZERO;
    }
    let light_count = scene.lights.len();
    let light_select_pdf = if light_count > 0 {
        1.0 / light_count as f32
    } else {
        0.0
    };

    let mut result = Vec3A::ZERO;
    let mut throughput = Vec3A::ONE;
    let mut ray = Ray {
        origin,
        dir,
        tmax: f32::INFINITY,
    };
    let mut cone = cone;
    // Pdf of the BSDF sample that produced `ray` (for MIS at emitters it hits).
    let mut prev_bsdf_pdf = 0.0f32;
    let mut prev_delta = true;
    let mut prev_p = origin;
    let mut specular_chain = true;
    let mut depth: u32 = 0;

    loop {
        // This bounce's random numbers, drawn before tracing: they do not depend on the hit, so
        // the sampler's hashing overlaps with the traversal instead of waiting for it, and every
        // bounce uses the same sampler dimensions (4 draws) whichever branches it takes.
        let light_rr = sampler.next_2d();
        let u_pos = sampler.next_2d();
        let u_dir = sampler.next_2d();
        let u_lobe = sampler.next_1d();
        let (u_light, u_rr) = (light_rr.x, light_rr.y);

        let last_segment = depth + 1 >= max_depth;
        // Next-event estimation's light, and the part of its sample that does not depend on the
        // hit (a point on an emitting mesh), made before tracing for the same reason: the
        // chain of dependent operations overlaps the traversal. Wasted when the ray escapes or
        // hits a mirror.
        let light_draw = (!last_segment && light_count > 0).then(|| {
            // Through u32: float-to-usize conversion costs a dozen instructions, u32 one.
            let index = ((u_light * light_count as f32) as u32 as usize).min(light_count - 1);
            (index, scene.lights[index].draw(u_pos))
        });
        let hit = if let Some(hit) = first_hit.take() {
            rays.closest += 1;
            hit
        } else if last_segment && !scene.has_area_lights {
            // Without area lights a hit on the last segment adds nothing: only whether the ray
            // escapes to the lights at infinity matters, which an any-hit query answers sooner.
            rays.shadow += 1;
            if !scene.visible(ray.origin, ray.dir, ray.tmax) {
                break;
            }
            None
        } else {
            rays.closest += 1;
            scene.intersect(&ray)
        };
        let Some(hit) = hit else {
            result += infinite_radiance(
                scene,
                throughput,
                ray.dir,
                if specular_chain && settings.mipmapping {
                    cone.spread
                } else {
                    0.0
                },
                (!prev_delta).then_some(prev_bsdf_pdf),
                light_select_pdf,
                settings.env_strategy,
            );
            break;
        };
        let wo = -ray.dir;
        let shape = &scene.shapes[hit.shape as usize];

        // Emission from an area light hit (one-sided: only along its normal).
        if let Some(li) = shape.area_light {
            if hit.ng.dot(wo) > 0.0 {
                let light = &scene.lights[li as usize];
                if let crate::light::LightKind::Area { radiance, .. } = light.kind {
                    let w = if prev_delta {
                        1.0
                    } else {
                        let pdf =
                            light.pdf_area_hit(prev_p, ray.dir, hit.t, hit.ng) * light_select_pdf;
                        power_heuristic(prev_bsdf_pdf, pdf)
                    };
                    result += throughput * radiance * w;
                }
            }
        }

        if last_segment {
            break;
        }

        // Shading frame, with the normal map applied and turned towards wo when two-sided.
        cone = cone.at_distance(hit.t);
        let material = &scene.materials[shape.material as usize];
        let footprint = if settings.mipmapping && material.is_textured() {
            cone.footprint(
                ray.dir.into(),
                hit.ng.into(),
                hit.dpdu.into(),
                hit.dpdv.into(),
            )
        } else {
            Footprint::POINT
        };
        let Some(frame) = shading_frame(scene, &hit, wo, material, footprint) else {
            break; // the back of a one-sided bsdf is black
        };
        let wo_local = frame.to_local(wo);
        if wo_local.z <= 0.0 {
            break;
        }
        let reflectance = material
            .reflectance
            .eval(&scene.textures, hit.uv, footprint);
        let model = material.model;

        // The BSDF sample that continues the path, drawn before next-event estimation although
        // used after it: it depends only on this hit, so its dependent chain of a division, a
        // polynomial and square roots overlaps the shadow ray's traversal instead of waiting
        // for it (4% faster renders, the same images).
        let bsdf_sample = model.sample_inline_diffuse(reflectance, wo_local, u_dir, u_lobe);

        // Next-event estimation.
        if let (false, Some((index, draw))) = (model.is_delta(), light_draw) {
            let light = &scene.lights[index];
            let uniform_env = settings.env_strategy == EnvStrategy::Uniform;
            if let Some(ls) = light.connect(draw, hit.p, uniform_env) {
                let wi_local = frame.to_local(ls.wi);
                let f = model.eval(reflectance, wo_local, wi_local);
                if f.max_element() > 0.0 && ls.pdf > 0.0 {
                    let origin = offset_origin(hit.p, hit.ng, ls.wi);
                    let tmax = if ls.dist.is_finite() {
                        ls.dist * (1.0 - 2e-4)
                    } else {
                        f32::INFINITY
                    };
                    rays.shadow += 1;
                    if scene.visible(origin, ls.wi, tmax) {
                        let light_pdf = ls.pdf * light_select_pdf;
                        let w = if ls.is_delta
                            || (light.is_infinite()
                                && settings.env_strategy != EnvStrategy::ImportanceMis)
                        {
                            1.0
                        } else {
                            power_heuristic(light_pdf, model.pdf(reflectance, wo_local, wi_local))
                        };
                        result += throughput * f * ls.radiance * (w / light_pdf);
                    }
                }
            }
        }

        // BSDF sampling continues the path.
        let Some(bs) = bsdf_sample else {
            break;
        };
        if bs.weight.max_element().is_nan() || bs.weight.max_element() <= 0.0 {
            break;
        }
        throughput *= bs.weight;
        let wi = frame.to_world(bs.wi);
        if !bs.is_delta {
            cone.spread += model.roughness() * settings.footprint_scale;
            specular_chain = false;
        }
        prev_bsdf_pdf = bs.pdf;
        prev_delta = bs.is_delta;
        prev_p = hit.p;
        ray = Ray {
            origin: offset_origin(hit.p, hit.ng, wi),
            dir: wi,
            tmax: f32::INFINITY,
        };
        depth += 1;

        // Russian roulette, as Mitsuba: survive with probability min(max throughput, 0.95).
        if depth as i32 >= settings.rr_depth {
            let q = throughput.max_element().min(0.95);
            if u_rr >= q {
                break;
            }
            throughput /= q;
        }
    }
    result
}

/// `throughput` times the radiance of the lights at infinity seen along an escaped ray `dir`,
/// weighted against light sampling by MIS; `prev_bsdf_pdf` is the pdf of the BSDF sample that
/// chose `dir` (None after a delta bounce or for camera rays: weight 1). `spread` filters
/// environment maps (0: finest level).
fn infinite_radiance(
    scene: &RenderScene,
    throughput: Vec3A,
    dir: Vec3A,
    spread: f32,
    prev_bsdf_pdf: Option<f32>,
    light_select_pdf: f32,
    strategy: EnvStrategy,
) -> Vec3A {
    let mut sum = Vec3A::ZERO;
    for &li in &scene.infinite_lights {
        let light = &scene.lights[li as usize];
        sum += match prev_bsdf_pdf {
            None => light.radiance_infinite(dir, spread),
            // Counted through light samples only.
            Some(_) if strategy != EnvStrategy::ImportanceMis => continue,
            Some(bsdf_pdf) => {
                let (le, pdf) = light.eval_infinite(dir, spread);
                le * power_heuristic(bsdf_pdf, pdf * light_select_pdf)
            }
        };
    }
    throughput * sum
}

/// The local shading frame at a hit, its normal on the side `wo` leaves from; None when that is
/// the back of a one-sided material.
///
/// Without a normal map the side is decided by the shading normal, as Mitsuba's `twosided` does.
/// With one, the side is decided by the geometric normal, the map perturbs the normal on that side
/// (n = 2 rgb - 1 in the frame t = dp/du made orthogonal to ns, b = ns x t), and a perturbed normal
/// that would face away from `wo` is bent back until it is just visible, so normal-mapped surfaces
/// never turn black or leak light at grazing angles.
#[inline(always)]
fn shading_frame(
    scene: &RenderScene,
    hit: &SurfaceHit,
    wo: Vec3A,
    material: &crate::scene::Material,
    footprint: Footprint,
) -> Option<Frame> {
    let Some(tex) = material.normal_map else {
        // The common case, inline in the path loop; normal maps take the call below.
        let ns = hit.ns;
        if ns.dot(wo) >= 0.0 {
            return Some(Frame::from_normal(ns));
        }
        return material.two_sided.then(|| Frame::from_normal(-ns));
    };
    normal_mapped_frame(scene, hit, wo, material, tex, footprint)
}

/// [`shading_frame`] for a material with normal map `tex`.
#[inline(never)]
fn normal_mapped_frame(
    scene: &RenderScene,
    hit: &SurfaceHit,
    wo: Vec3A,
    material: &crate::scene::Material,
    tex: u32,
    footprint: Footprint,
) -> Option<Frame> {
    let front = hit.ng.dot(wo) >= 0.0;
    if !front && !material.two_sided {
        return None;
    }
    let rgb = scene.textures[tex as usize].eval(hit.uv, footprint);
    let local = (rgb * 2.0 - Vec3A::ONE).normalize_or(Vec3A::Z);
    let ns = hit.ns;
    let t = (hit.dpdu - ns * ns.dot(hit.dpdu)).normalize_or(crate::scene::orthonormal_basis(ns).0);
    let b = ns.cross(t);
    let mut n = (t * local.x + b * local.y + ns * local.z).normalize_or(ns);
    if !front {
        n = -n;
    }
    const MIN_COS: f32 = 0.01;
    let cos = n.dot(wo);
    if cos < MIN_COS {
        n = (n + wo * (MIN_COS - cos)).normalize_or(n);
    }
    Some(Frame::from_normal(n))
}
