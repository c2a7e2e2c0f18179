//! The torrey course's `blinn` (its `blinnphong`): normalised Blinn-Phong with Schlick Fresnel at
//! the half vector, ρ = (n+2)/(4π(2−2^(−n/2))) F(h) (n·h)^n, sampled by the half vector.

use super::fresnel::schlick_fresnel;
use super::{BsdfFlags, BsdfSample};
use crate::sampling::{cosine_power_pdf, square_to_cosine_power};
use crate::textures::{ColorSource, FloatSource, TextureQuery};
use glam::{Vec2, Vec3A};
use std::f32::consts::{PI, TAU};
use torrey_fastmath::{exp2, powf};

/// The material's parameters: `reflectance` (Schlick's F0; colour or texture) and the
/// `exponent`.
#[derive(Clone, Copy, Debug)]
pub struct BlinnParams {
    pub reflectance: ColorSource,
    pub exponent: FloatSource,
}

impl BlinnParams {
    #[inline(always)]
    pub fn resolve(&self, q: &TextureQuery) -> Blinn {
        Blinn {
            reflectance: q.color(self.reflectance),
            exponent: q.float(self.exponent),
        }
    }
}

/// The course's Blinn-Phong at a hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Blinn {
    pub reflectance: Vec3A,
    pub exponent: f32,
}

/// Blinn-Phong normalisation (Gotanda 2010), as the course gives it: (n+2)/(4π(2−2^(−n/2))).
pub(super) fn blinn_norm(exponent: f32) -> f32 {
    (exponent + 2.0) / (4.0 * PI * (2.0 - exp2(-0.5 * exponent)))
}

/// Density of the half vector h ∝ (n·h)^n that blinn and blinn_microfacet sample, as the course
/// prescribes (it reuses the Blinn-Phong sampler for the microfacet model): (n+1)/(2π) (n·h)^n.
pub(super) fn half_vector_pdf(h: Vec3A, exponent: f32) -> f32 {
    cosine_power_pdf(h.z, exponent)
}

/// The solid-angle density of `wi` under half-vector sampling from `wo`.
#[inline(always)]
pub(super) fn half_vector_pdf_wi(wo: Vec3A, wi: Vec3A, exponent: f32) -> f32 {
    if !(wo.z > 0.0 && wi.z > 0.0) {
        return 0.0;
    }
    let Some(h) = (wo + wi).try_normalize() else {
        return 0.0;
    };
    half_vector_pdf(h, exponent) / (4.0 * wo.dot(h))
}

/// A half vector drawn ∝ (n·h)^n and `wo` reflected about it: (wi, pdf, wo·h), or None below
/// the surface.
#[inline(always)]
pub(super) fn sample_half_vector(wo: Vec3A, u: Vec2, exponent: f32) -> Option<(Vec3A, f32, f32)> {
    if !(wo.z > 0.0) {
        return None;
    }
    let h = square_to_cosine_power(u, exponent);
    let wo_h = wo.dot(h);
    if wo_h <= 0.0 {
        return None;
    }
    let wi = (2.0 * wo_h) * h - wo;
    let pdf = half_vector_pdf(h, exponent) / (4.0 * wo_h);
    if wi.z <= 0.0 || !(pdf > 0.0) {
        return None;
    }
    Some((wi, pdf, wo_h))
}

impl Blinn {
    pub const FLAGS: BsdfFlags = BsdfFlags::GLOSSY_REFLECTION;

    #[inline(always)]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Vec3A {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return Vec3A::ZERO;
        }
        let Some(h) = (wo + wi).try_normalize() else {
            return Vec3A::ZERO;
        };
        let fresnel = schlick_fresnel(self.reflectance, h.dot(wi));
        fresnel * (blinn_norm(self.exponent) * powf(h.z, self.exponent))
    }

    #[inline(always)]
    pub fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        half_vector_pdf_wi(wo, wi, self.exponent)
    }

    #[inline(always)]
    pub fn sample(&self, wo: Vec3A, u: Vec2) -> Option<BsdfSample> {
        let exponent = self.exponent;
        let (wi, pdf, wo_h) = sample_half_vector(wo, u, exponent)?;
        let fresnel = schlick_fresnel(self.reflectance, wo_h);
        // ρ / pdf with the (n·h)^n factors cancelled.
        let weight = fresnel * (blinn_norm(exponent) * TAU / (exponent + 1.0) * 4.0 * wo_h);
        Some(BsdfSample::reflection(wi, weight, pdf, Self::FLAGS))
    }

    /// Twice the Phong lobe's width: reflected directions spread twice as wide as half vectors.
    pub fn roughness(&self) -> f32 {
        (2.0 * (2.0 / (self.exponent.max(0.0) + 2.0)).sqrt()).min(1.0)
    }
}
