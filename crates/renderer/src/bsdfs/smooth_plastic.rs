//! Mitsuba's `plastic`: a diffuse base under a smooth dielectric coating. Light is reflected
//! specularly by the coating (exact Fresnel), or refracts in, scatters diffusely with internal
//! reflections at the coating (the diffuse Fresnel reflectance F_dr), and refracts out:
//! ρ_d / (1 − F_dr) (or ρ_d / (1 − ρ_d F_dr) with `nonlinear`) · (1 − F_i)(1 − F_o) / η² · cos/π.
//! (The torrey dialect's `plastic` is the course's model, [`super::Plastic`].)

use super::fresnel::{fresnel_dielectric, fresnel_diffuse_reflectance};
use super::{reflect_z, BsdfFlags, BsdfSample};
use crate::sampling::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use crate::textures::{ColorSource, TextureQuery};
use glam::{Vec2, Vec3A};

/// The material's parameters.
#[derive(Clone, Copy, Debug)]
pub struct SmoothPlasticParams {
    pub diffuse_reflectance: ColorSource,
    pub specular_reflectance: ColorSource,
    pub eta: f32,
    pub nonlinear: bool,
    /// Probability weight of the specular lobe, s / (d + s) with s and d the mean specular and
    /// diffuse reflectances (Mitsuba's `specular_sampling_weight`; textures count as 0.5).
    pub specular_sampling_weight: f32,
}

impl SmoothPlasticParams {
    #[inline(always)]
    pub fn resolve(&self, q: &TextureQuery) -> SmoothPlastic {
        let inv_eta = 1.0 / self.eta;
        SmoothPlastic {
            diffuse_reflectance: q.color(self.diffuse_reflectance),
            specular_reflectance: q.color(self.specular_reflectance),
            eta: self.eta,
            nonlinear: self.nonlinear,
            fdr_int: fresnel_diffuse_reflectance(inv_eta),
            specular_sampling_weight: self.specular_sampling_weight,
        }
    }

    pub fn is_textured(&self) -> bool {
        self.diffuse_reflectance.is_textured() || self.specular_reflectance.is_textured()
    }
}

/// The sampling weight of a specular lobe against a diffuse one from their constant values.
pub fn specular_sampling_weight(diffuse: ColorSource, specular: ColorSource) -> f32 {
    let mean = |c: ColorSource| match c {
        ColorSource::Constant(v) => v.element_sum() / 3.0,
        ColorSource::Texture(_) => 0.5,
    };
    let (d, s) = (mean(diffuse), mean(specular));
    if d + s > 0.0 {
        s / (d + s)
    } else {
        0.5
    }
}

/// Mitsuba's plastic at a hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SmoothPlastic {
    pub diffuse_reflectance: Vec3A,
    pub specular_reflectance: Vec3A,
    pub eta: f32,
    pub nonlinear: bool,
    pub fdr_int: f32,
    pub specular_sampling_weight: f32,
}

impl SmoothPlastic {
    pub const FLAGS: BsdfFlags = BsdfFlags::DELTA_REFLECTION.union(BsdfFlags::DIFFUSE_REFLECTION);

    /// The diffuse base with its internal reflections, before the interface terms.
    #[inline]
    fn base(&self) -> Vec3A {
        let d = self.diffuse_reflectance;
        if self.nonlinear {
            d / (Vec3A::ONE - d * self.fdr_int)
        } else {
            d / (1.0 - self.fdr_int)
        }
    }

    /// The probability of sampling the specular lobe at Fresnel reflectance `f_i`.
    #[inline]
    fn prob_specular(&self, f_i: f32) -> f32 {
        let s = f_i * self.specular_sampling_weight;
        let d = (1.0 - f_i) * (1.0 - self.specular_sampling_weight);
        s / (s + d)
    }

    #[inline]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Vec3A {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return Vec3A::ZERO;
        }
        let f_i = fresnel_dielectric(wo.z, self.eta).0;
        let f_o = fresnel_dielectric(wi.z, self.eta).0;
        self.base()
            * (cosine_hemisphere_pdf(wi.z) * (1.0 - f_i) * (1.0 - f_o) / (self.eta * self.eta))
    }

    #[inline]
    pub fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return 0.0;
        }
        let f_i = fresnel_dielectric(wo.z, self.eta).0;
        (1.0 - self.prob_specular(f_i)) * cosine_hemisphere_pdf(wi.z)
    }

    #[inline]
    pub fn sample(&self, wo: Vec3A, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        if !(wo.z > 0.0) {
            return None;
        }
        let f_i = fresnel_dielectric(wo.z, self.eta).0;
        let ps = self.prob_specular(f_i);
        if u_lobe < ps {
            Some(BsdfSample::reflection(
                reflect_z(wo),
                self.specular_reflectance * (f_i / ps),
                f32::INFINITY,
                BsdfFlags::DELTA_REFLECTION,
            ))
        } else {
            let wi = square_to_cosine_hemisphere(u);
            let pdf = (1.0 - ps) * cosine_hemisphere_pdf(wi.z);
            (pdf > 0.0).then(|| {
                BsdfSample::reflection(
                    wi,
                    self.eval(wo, wi) / pdf,
                    pdf,
                    BsdfFlags::DIFFUSE_REFLECTION,
                )
            })
        }
    }
}
