//! Mitsuba's `roughconductor`: a microfacet metal (Beckmann or GGX, anisotropic), exact
//! conductor Fresnel, Smith shadowing, visible-normal sampling.

use super::fresnel::fresnel_conductor;
use super::microfacet::{Microfacet, MicrofacetKind};
use super::{BsdfFlags, BsdfSample};
use crate::textures::{ColorSource, FloatSource, TextureQuery};
use glam::{Vec2, Vec3A};

/// The material's parameters: the distribution, α_u and α_v (floats or textures), η and k
/// (RGB, relative to the outside) and the specular tint.
#[derive(Clone, Copy, Debug)]
pub struct RoughConductorParams {
    pub kind: MicrofacetKind,
    pub alpha_u: FloatSource,
    pub alpha_v: FloatSource,
    /// Mitsuba's `sample_visible`: sample visible normals (true) or D(m) cos θm.
    pub sample_visible: bool,
    pub eta: ColorSource,
    pub k: ColorSource,
    pub specular_reflectance: ColorSource,
}

impl RoughConductorParams {
    #[inline(always)]
    pub fn resolve(&self, q: &TextureQuery) -> RoughConductor {
        RoughConductor {
            distr: Microfacet::new(self.kind, q.float(self.alpha_u), q.float(self.alpha_v))
                .with_visible(self.sample_visible),
            eta: q.color(self.eta),
            k: q.color(self.k),
            specular_reflectance: q.color(self.specular_reflectance),
        }
    }

    pub fn is_textured(&self) -> bool {
        self.alpha_u.is_textured()
            || self.alpha_v.is_textured()
            || self.eta.is_textured()
            || self.k.is_textured()
            || self.specular_reflectance.is_textured()
    }
}

/// A rough conductor at a hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughConductor {
    pub distr: Microfacet,
    pub eta: Vec3A,
    pub k: Vec3A,
    pub specular_reflectance: Vec3A,
}

impl RoughConductor {
    pub const FLAGS: BsdfFlags = BsdfFlags::GLOSSY_REFLECTION;

    /// F(wo·h) D(h) G(wo, wi) / (4 cos θo): f·cos θi.
    #[inline]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Vec3A {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return Vec3A::ZERO;
        }
        let h = (wo + wi).normalize();
        self.eval_at(wo, wi, h, self.distr.d(h))
    }

    /// [`RoughConductor::eval`] at the half vector `h` with D(h) = `d`.
    #[inline(always)]
    fn eval_at(&self, wo: Vec3A, wi: Vec3A, h: Vec3A, d: f32) -> Vec3A {
        if d == 0.0 {
            return Vec3A::ZERO;
        }
        let g = self.distr.g(wo, wi, h);
        let f = fresnel_conductor(wo.dot(h), self.eta, self.k);
        self.specular_reflectance * f * (d * g / (4.0 * wo.z))
    }

    /// [`RoughConductor::eval`] and [`RoughConductor::pdf`] together, sharing the half vector
    /// and D: what `sample` weighs with (the same bits as the two calls).
    #[inline]
    pub fn eval_pdf(&self, wo: Vec3A, wi: Vec3A) -> (Vec3A, f32) {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return (Vec3A::ZERO, 0.0);
        }
        let h = (wo + wi).normalize();
        let d = self.distr.d(h);
        let c = wo.dot(h);
        let pdf = if c > 0.0 {
            self.distr.pdf_given_d(wo, h, d) / (4.0 * c)
        } else {
            0.0
        };
        (self.eval_at(wo, wi, h, d), pdf)
    }

    /// Visible-normal density over the reflection Jacobian 1 / (4 wo·h).
    #[inline]
    pub fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return 0.0;
        }
        let h = (wo + wi).normalize();
        let c = wo.dot(h);
        if !(c > 0.0) {
            return 0.0;
        }
        self.distr.pdf(wo, h) / (4.0 * c)
    }

    #[inline]
    pub fn sample(&self, wo: Vec3A, u: Vec2) -> Option<BsdfSample> {
        if !(wo.z > 0.0) {
            return None;
        }
        let m = self.distr.sample(wo, u);
        let wi = (m * (2.0 * wo.dot(m)) - wo).normalize();
        if !(wi.z > 0.0) {
            return None;
        }
        let (f, pdf) = self.eval_pdf(wo, wi);
        if !(pdf > 0.0) {
            return None;
        }
        Some(BsdfSample::reflection(wi, f / pdf, pdf, Self::FLAGS))
    }

    /// About the lobe's angular width.
    pub fn roughness(&self) -> f32 {
        self.distr.alpha_u.max(self.distr.alpha_v).min(1.0)
    }
}
