//! What a render writes per sample besides the radiance ([`SampleChannels`]): Mitsuba's `aov`
//! integrator (the image of the integrator it wraps, with alpha, and the AOVs of the camera
//! ray's first hit, as Mitsuba 3.9.1 computes and names them) and the denoiser's guides (the
//! path's [`Guides`]). The film averages them over each pixel's samples with the radiance's
//! weights ([`crate::film::TileFilm::add_sample_with`]), as Mitsuba's film does.
//!
//! The AOVs read the hit's surface with uv and its derivatives always computed, and the shading
//! point's BSDF with unfiltered textures (Mitsuba's lookups). `albedo` is Mitsuba's
//! `eval_diffuse_reflectance`: a diffuse's reflectance, a plastic's diffuse reflectance, a
//! principled's base colour, a blend's blend of its children's, otherwise the BSDF's value
//! towards the normal times π (zero for delta BSDFs). `depth` is the distance from the camera's
//! near plane (Mitsuba's rays start there), `duv_dx`/`duv_dy` the uv change to the ray one pixel
//! over, scaled by 1/sqrt(spp) (Mitsuba's ray differentials), `shape_index` the shape's place
//! in the scene plus one (0 where the ray misses), `prim_index` the triangle within its mesh.

use super::path_state::Guides;
use super::shading::ShadingPoint;
use crate::accel::ClosestHit;
use crate::bsdfs::{Bsdf, SidedBsdf};
use crate::cameras::CameraSample;
use crate::ray::Ray;
use crate::scene::RenderScene;
use crate::shapes::SurfaceHit;
use glam::{Vec2, Vec3A};
use torrey_parser::{AovKind, Aovs};
use torrey_texture::RayCone;

/// The channels of the denoiser's guides, after the AOVs.
pub const GUIDE_CHANNELS: [&str; 6] = [
    "albedo.R", "albedo.G", "albedo.B", "normal.X", "normal.Y", "normal.Z",
];

/// What a render writes per sample besides the radiance, in this order: with Mitsuba's `aov`
/// integrator, the wrapped integrator's image as `<name>.R/G/B/A` (when it wraps one) and the
/// AOVs; with `guides`, the denoiser's albedo and normal ([`GUIDE_CHANNELS`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SampleChannels {
    pub aovs: Option<Aovs>,
    pub guides: bool,
}

impl SampleChannels {
    /// The channel names, in order.
    pub fn names(&self) -> Vec<String> {
        let mut names = Vec::new();
        if let Some(aovs) = &self.aovs {
            if let Some(inner) = &aovs.inner {
                names.extend(["R", "G", "B", "A"].map(|c| format!("{inner}.{c}")));
            }
            names.extend(aovs.channel_names());
        }
        if self.guides {
            names.extend(GUIDE_CHANNELS.map(String::from));
        }
        names
    }

    /// Whether the first channels are the wrapped integrator's image (`<name>.R/G/B/A`).
    pub fn writes_inner_image(&self) -> bool {
        self.aovs.as_ref().is_some_and(|a| a.inner.is_some())
    }

    pub fn len(&self) -> usize {
        self.names().len()
    }

    pub fn is_empty(&self) -> bool {
        self.aovs.is_none() && !self.guides
    }
}

/// One camera sample as the AOVs see it.
#[derive(Clone, Copy, Debug)]
pub struct CameraRay {
    pub origin: Vec3A,
    pub dir: Vec3A,
    /// Film position and lens point of the sample.
    pub film: Vec2,
    pub lens: Vec2,
}

/// Computes a render's [`SampleChannels`] per sample.
pub struct AovWriter<'a> {
    scene: &'a RenderScene,
    aovs: Vec<AovKind>,
    /// Write the wrapped integrator's image (`<name>.R/G/B/A`).
    inner: bool,
    guides: bool,
    /// Take the guides at the camera ray's first hit: `direct`, whose paths do not go on.
    first_hit_guides: bool,
    /// Each shape's first primitive (`prim_index` counts within a shape).
    first_prim: Vec<u32>,
    /// 1/sqrt(spp), Mitsuba's ray differential scale.
    differential_scale: f32,
    /// Camera rays that miss are valid (alpha 1): they see an environment.
    background_alpha: bool,
}

impl<'a> AovWriter<'a> {
    /// `spp` is the whole render's, `hide_emitters` the integrator's; `first_hit_guides` takes
    /// the guides at the first hit (for integrators whose paths give none).
    pub fn new(
        scene: &'a RenderScene,
        channels: &SampleChannels,
        spp: u32,
        hide_emitters: bool,
        first_hit_guides: bool,
    ) -> Self {
        let mut first_prim = vec![u32::MAX; scene.shapes.len()];
        for (i, p) in scene.prims.iter().enumerate() {
            let f = &mut first_prim[p.shape as usize];
            *f = (*f).min(i as u32);
        }
        let aovs = channels.aovs.as_ref();
        Self {
            scene,
            aovs: aovs.map_or(Vec::new(), |a| a.list.iter().map(|a| a.kind).collect()),
            inner: aovs.is_some_and(|a| a.inner.is_some()),
            guides: channels.guides,
            first_hit_guides,
            first_prim,
            differential_scale: 1.0 / (spp.max(1) as f32).sqrt(),
            background_alpha: !hide_emitters && !scene.infinite_lights.is_empty(),
        }
    }

    /// The values of one sample, whose camera ray is `ray` with first hit `hit` (between the
    /// clip planes), radiance `radiance` and guides `guides`, into `out` (one per channel).
    pub fn sample(
        &self,
        ray: &CameraRay,
        hit: Option<&SurfaceHit>,
        radiance: Vec3A,
        guides: Guides,
        out: &mut [f32],
    ) {
        let mut k = 0;
        let mut put = |values: &[f32]| {
            out[k..k + values.len()].copy_from_slice(values);
            k += values.len();
        };
        if self.inner {
            let alpha = if hit.is_some() || self.background_alpha {
                1.0
            } else {
                0.0
            };
            put(&[radiance.x, radiance.y, radiance.z, alpha]);
        }
        let full = match hit {
            Some(h) if !self.aovs.is_empty() || self.first_hit_guides => Some(self.surface(ray, h)),
            _ => None,
        };
        for &kind in &self.aovs {
            let Some(h) = &full else {
                put(&[0.0; 3][..kind.suffixes().len()]);
                continue;
            };
            let v3 = |v: Vec3A| [v.x, v.y, v.z];
            match kind {
                AovKind::Albedo => put(&v3(self.albedo(ray, h).0)),
                AovKind::Depth => {
                    let near = self.scene.camera().clip_range(ray.dir).0;
                    put(&[(h.p - ray.origin).dot(ray.dir) - near]);
                }
                AovKind::Position => put(&v3(h.p)),
                AovKind::Uv => put(&[h.uv.x, h.uv.y]),
                AovKind::GeoNormal => put(&v3(h.ng)),
                AovKind::ShNormal => put(&v3(h.ns)),
                AovKind::DpDu => put(&v3(h.dpdu)),
                AovKind::DpDv => put(&v3(h.dpdv)),
                AovKind::DuvDx => put(&self.uv_partial(ray, h, Vec2::X).to_array()),
                AovKind::DuvDy => put(&self.uv_partial(ray, h, Vec2::Y).to_array()),
                AovKind::PrimIndex => {
                    let first = self.first_prim[h.shape as usize];
                    put(&[h.prim.saturating_sub(first) as f32]);
                }
                AovKind::ShapeIndex => put(&[(h.shape + 1) as f32]),
            }
        }
        if self.guides {
            let guides = match (&full, self.first_hit_guides) {
                (Some(h), true) => {
                    let (albedo, normal) = self.albedo(ray, h);
                    Guides {
                        albedo: albedo.clamp(Vec3A::ZERO, Vec3A::ONE).into(),
                        normal: normal.into(),
                        taken: true,
                    }
                }
                _ => guides,
            };
            let (a, n) = (guides.albedo, guides.normal);
            put(&[a.x, a.y, a.z, n.x, n.y, n.z]);
        }
        debug_assert_eq!(k, out.len());
    }

    /// The hit's surface with uv and its derivatives (which the render computes only where a
    /// material reads them). Hits inside instances keep what the render computed.
    fn surface(&self, ray: &CameraRay, hit: &SurfaceHit) -> SurfaceHit {
        let scene = self.scene;
        if scene.instances.is_some() {
            return *hit;
        }
        let prim = &scene.prims[hit.prim as usize];
        // The ray from where `hit.t` was measured (the pinhole, or the near plane when the
        // camera ray was traced again from there).
        let traced = Ray {
            origin: hit.p - ray.dir * hit.t,
            dir: ray.dir,
            tmax: f32::INFINITY,
        };
        let closest = ClosestHit {
            t: hit.t,
            prim: hit.prim,
            b1: hit.bary.x,
            b2: hit.bary.y,
        };
        scene.shapes[prim.shape as usize].surface(&scene.mesh, prim, &traced, &closest, true)
    }

    /// Mitsuba's `eval_diffuse_reflectance` of the BSDF at `hit`, with unfiltered textures, and
    /// the shading normal.
    fn albedo(&self, ray: &CameraRay, hit: &SurfaceHit) -> (Vec3A, Vec3A) {
        let at = self.scene.attribute_point(hit);
        let cone = RayCone::from_pixel(0.0);
        let sp = ShadingPoint::new(self.scene, hit, ray.dir, &cone, false, at.as_ref());
        (diffuse_reflectance(&sp.bsdf, sp.wo), sp.frame.n)
    }

    /// Mitsuba's `compute_uv_partials`: where the ray one pixel over along `step` (its direction
    /// moved towards it by the differential scale) meets the hit's tangent plane, in uv.
    fn uv_partial(&self, ray: &CameraRay, hit: &SurfaceHit, step: Vec2) -> Vec2 {
        let camera = self.scene.camera();
        let (o_x, d_x) = camera.generate_ray(&CameraSample {
            film: ray.film + step,
            lens: ray.lens,
        });
        let s = self.differential_scale;
        // Mitsuba's rays (and their differentials) start on the near plane.
        let near = camera.clip_range(ray.dir).0;
        let o = ray.origin + ray.dir * near;
        let o_x = o + (o_x - ray.origin) * s;
        let d_x = ray.dir + (d_x - ray.dir) * s;
        let n = hit.ng;
        let t_x = (n.dot(hit.p) - n.dot(o_x)) / n.dot(d_x);
        let dp = d_x * t_x - (hit.p - o_x);
        let (a00, a01, a11) = (
            hit.dpdu.dot(hit.dpdu),
            hit.dpdu.dot(hit.dpdv),
            hit.dpdv.dot(hit.dpdv),
        );
        let inv_det = 1.0 / (a00 * a11 - a01 * a01);
        let inv_det = if inv_det.is_finite() { inv_det } else { 0.0 };
        let (b0, b1) = (hit.dpdu.dot(dp), hit.dpdv.dot(dp));
        let uv = Vec2::new(a11 * b0 - a01 * b1, a00 * b1 - a01 * b0) * inv_det;
        if uv.is_finite() {
            uv
        } else {
            Vec2::ZERO
        }
    }
}

/// Mitsuba's `eval_diffuse_reflectance` of the side of a BSDF that `wo` sees.
pub fn diffuse_reflectance(bsdf: &SidedBsdf, wo: Vec3A) -> Vec3A {
    // A two-sided material seen from behind is its front seen from the front (Mitsuba's
    // `twosided` flips the incident direction).
    let wo = if bsdf.mirrored {
        Vec3A::new(wo.x, wo.y, -wo.z)
    } else {
        wo
    };
    of_bsdf(&bsdf.bsdf, wo)
}

fn of_bsdf(bsdf: &Bsdf, wo: Vec3A) -> Vec3A {
    match bsdf {
        Bsdf::Diffuse(b) => b.reflectance,
        Bsdf::SmoothPlastic(b) => b.diffuse_reflectance,
        Bsdf::RoughPlastic(b) => b.diffuse_reflectance,
        Bsdf::Principled(b) => b.base_color,
        Bsdf::PrincipledThin(b) => b.base_color,
        // The course's materials (not Mitsuba's): their colour.
        Bsdf::Plastic(b) => b.reflectance,
        Bsdf::Phong(b) => b.reflectance,
        Bsdf::Blinn(b) => b.reflectance,
        Bsdf::BlinnMicrofacet(b) => b.reflectance,
        Bsdf::Blend(b) => {
            let child = |i: usize| of_bsdf(&b.children[i].resolve(&b.q), wo);
            child(0) * (1.0 - b.weight) + child(1) * b.weight
        }
        // Mitsuba's default: the value towards the normal, times π.
        other => other.eval(wo, Vec3A::Z) * std::f32::consts::PI,
    }
}
