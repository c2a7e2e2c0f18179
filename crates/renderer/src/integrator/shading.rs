//! What every integrator does at a surface hit, written once: the shading point (the ray cone's
//! footprint, the shading frame with normal or bump maps, the BSDF resolved at the hit: pbrt-v4's
//! `SurfaceInteraction::GetBSDF`), the emission of an emitting surface towards the viewer, and the
//! connection to a light sample (next-event estimation's BSDF value, pdfs and shadow ray).

use crate::bsdfs::SidedBsdf;
use crate::lights::{Light, LightDraw, LightSample};
use crate::ray::offset_origin;
use crate::sampling::Frame;
use crate::scene::RenderScene;
use crate::shapes::attributes::AttributePoint;
use crate::shapes::SurfaceHit;
use crate::textures::TextureQuery;
use glam::Vec3A;
use torrey_texture::{Footprint, RayCone};

/// A surface hit ready to scatter: its shading frame, the direction towards the viewer in it,
/// and the side of the BSDF that direction sees.
#[derive(Clone, Copy)]
pub struct ShadingPoint<'a> {
    pub frame: Frame,
    /// Towards the viewer, in `frame`.
    pub wo: Vec3A,
    pub bsdf: SidedBsdf<'a>,
}

impl<'a> ShadingPoint<'a> {
    /// The shading point of `hit`, found along `dir`. With `mipmapping`, textures are filtered by
    /// the footprint of `cone` (already grown to the hit) on the surface. `at` is
    /// [`RenderScene::attribute_point`] of the hit, made by the caller: the BSDF may keep a
    /// reference to it (a blend resolves its children lazily), which keeps the per-hit BSDF small.
    #[inline(always)]
    pub fn new(
        scene: &'a RenderScene,
        hit: &SurfaceHit,
        dir: Vec3A,
        cone: &RayCone,
        mipmapping: bool,
        at: Option<&'a AttributePoint<'a>>,
    ) -> Self {
        let shape = &scene.shapes[hit.shape as usize];
        let material = &scene.materials[shape.material as usize];
        let footprint = if mipmapping && material.is_textured() {
            cone.footprint(dir, hit.ng, hit.dpdu, hit.dpdv)
        } else {
            Footprint::POINT
        };
        let wo = -dir;
        let (frame, perturbation) = material.shading_frame(&scene.textures, hit, wo, footprint);
        let wo = frame.to_local(wo);
        let bsdf = material.bsdf_facing(
            &TextureQuery {
                textures: &scene.textures,
                at,
                uv: hit.uv,
                footprint,
            },
            perturbation,
            wo,
        );
        Self { frame, wo, bsdf }
    }

    /// Next-event estimation's connection from this point (at `hit`) to light `light`, sampled
    /// with `draw`: None when it carries nothing (no sample, a zero BSDF value or pdf).
    /// `uniform_env` samples environment maps uniformly (only to measure importance sampling).
    #[inline(always)]
    pub fn connect(
        &self,
        scene: &RenderScene,
        hit: &SurfaceHit,
        light: &Light,
        draw: LightDraw,
        uniform_env: bool,
    ) -> Option<LightConnection> {
        let ls = light.connect(draw, hit.p, uniform_env, &scene.textures)?;
        let wi = self.frame.to_local(ls.wi);
        // A delta light's sample takes no MIS weight: the BSDF's pdf is not needed.
        let (f, bsdf_pdf) = if ls.is_delta {
            (self.bsdf.eval(self.wo, wi), 0.0)
        } else {
            self.bsdf.eval_pdf(self.wo, wi)
        };
        if !(f.max_element() > 0.0 && ls.pdf > 0.0) {
            return None;
        }
        let (origin, dir, tmax) = shadow_ray(hit.p, hit.ng, &ls);
        Some(LightConnection {
            ls,
            f,
            bsdf_pdf,
            origin,
            dir,
            tmax,
        })
    }
}

/// A light sample connected to a shading point: its value once the shadow ray is unoccluded is
/// `f · ls.radiance / pdf` times the MIS weight the integrator gives it.
#[derive(Clone, Copy, Debug)]
pub struct LightConnection {
    pub ls: LightSample,
    /// f(wo, wi)·|cos θi|.
    pub f: Vec3A,
    /// The BSDF's density of sampling `wi`: the other technique's pdf in MIS (0 for a delta
    /// light, which takes no MIS weight).
    pub bsdf_pdf: f32,
    /// The shadow ray ([`shadow_ray`]).
    pub origin: Vec3A,
    pub dir: Vec3A,
    pub tmax: f32,
}

/// The radiance that the emitting surface at `hit` sends back along the ray `dir` that found it,
/// and its light's index (for the pdf of light sampling); None when the surface does not emit or
/// is seen from behind (area lights emit along their normal only).
#[inline(always)]
pub fn hit_emission(scene: &RenderScene, hit: &SurfaceHit, dir: Vec3A) -> Option<(Vec3A, usize)> {
    let li = scene.shapes[hit.shape as usize].area_light? as usize;
    if hit.ng.dot(-dir).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    match &scene.lights[li] {
        Light::Area(area) => Some((area.radiance_at(&scene.textures, hit.uv), li)),
        _ => None,
    }
}

/// The solid-angle density with which light sampling from `from` (the light chosen with
/// probability `select_pdf`) would produce the direction `dir` that reached `hit` on `light`,
/// `t` away from `from`.
#[inline(always)]
pub fn emission_pdf(
    light: &Light,
    from: Vec3A,
    dir: Vec3A,
    t: f32,
    hit: &SurfaceHit,
    select_pdf: f32,
) -> f32 {
    light.pdf_area_hit(from, dir, t, hit.ng, hit.uv) * select_pdf
}

/// The shadow ray of light sample `ls` from `p` (geometric normal `ng`): origin, direction and
/// length. As Mitsuba's `spawn_ray_to`, a ray to a point at finite distance is aimed from the
/// offset origin at that point, not sent parallel to `ls.wi`: shifted by the offset, a ray to a
/// point near a sphere light's silhouette enters the sphere before reaching it, which darkened the
/// ground around a sphere lamp by up to half (the sphere lamp of
/// tests/scenes/mitsuba/area_reflective.xml).
#[inline(always)]
pub fn shadow_ray(p: Vec3A, ng: Vec3A, ls: &LightSample) -> (Vec3A, Vec3A, f32) {
    let origin = offset_origin(p, ng, ls.wi);
    if !ls.dist.is_finite() {
        return (origin, ls.wi, f32::INFINITY);
    }
    let to_target = p + ls.wi * ls.dist - origin;
    let len = to_target.length();
    if len.is_nan() || len <= 0.0 {
        return (origin, ls.wi, 0.0);
    }
    (origin, to_target / len, len * (1.0 - 2e-4))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ray::Ray;
    use crate::shapes::sphere::{intersect_sphere, sample_sphere_solid_angle};
    use glam::Vec3;
    use torrey_testkit::Rng;

    /// Shadow rays from the ground beside a sphere lamp to points sampled on it, many near its
    /// silhouette (the rim of the cone it subtends): none enters the sphere before its end. Sent
    /// parallel to the sampled direction from the offset origin instead, 3% of them did at
    /// this distance.
    #[test]
    fn shadow_rays_reach_points_near_a_sphere_lights_silhouette() {
        let (center, radius) = (Vec3::new(0.35, 0.45, 0.0), 0.3);
        let p = Vec3A::ZERO;
        let mut rng = Rng::new(4);
        let mut checked = 0;
        for k in 0..20_000 {
            // Half the samples in the outer 1% of the cone's cos range.
            let mut u = rng.vec2();
            if k % 2 == 0 {
                u.x = 0.99 + 0.01 * u.x;
            }
            let s = sample_sphere_solid_angle(center, radius, p.into(), u).expect("outside");
            let to = Vec3A::from(s.point) - p;
            let dist = to.length();
            let ls = LightSample {
                wi: to / dist,
                dist,
                radiance: Vec3A::ONE,
                pdf: s.pdf,
                is_delta: false,
            };
            if Vec3A::from(s.normal).dot(ls.wi) >= 0.0 {
                continue; // not front-facing: the light rejects it
            }
            let (origin, dir, tmax) = shadow_ray(p, Vec3A::Y, &ls);
            let ray = Ray { origin, dir, tmax };
            let blocked = intersect_sphere(&ray, center.into(), radius, 0.0, tmax);
            assert!(blocked.is_none(), "{u}: hit at {blocked:?} before {tmax}");
            checked += 1;
        }
        assert!(checked > 15_000);
    }
}
