//! The torrey course's `blinn_microfacet`: a microfacet BRDF with a Blinn NDF, Schlick Fresnel
//! (F0 = reflectance) and Walter et al.'s rational fit of Smith shadowing,
//! ρ = F D G / (4 cos θo), sampled by the Blinn half vector as the course prescribes.

use super::blinn::{half_vector_pdf_wi, sample_half_vector};
use super::fresnel::schlick_fresnel;
use super::{BsdfFlags, BsdfSample};
use crate::textures::{ColorSource, FloatSource, TextureQuery};
use glam::{Vec2, Vec3A};
use std::f32::consts::TAU;
use torrey_fastmath::powf;

/// The material's parameters: `reflectance` (Schlick's F0; colour or texture) and the Blinn
/// `exponent` of the normal distribution.
#[derive(Clone, Copy, Debug)]
pub struct BlinnMicrofacetParams {
    pub reflectance: ColorSource,
    pub exponent: FloatSource,
}

impl BlinnMicrofacetParams {
    #[inline(always)]
    pub fn resolve(&self, q: &TextureQuery) -> BlinnMicrofacet {
        BlinnMicrofacet {
            reflectance: q.color(self.reflectance),
            exponent: q.float(self.exponent),
        }
    }
}

/// The course's microfacet model at a hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BlinnMicrofacet {
    pub reflectance: Vec3A,
    pub exponent: f32,
}

/// Walter et al.'s rational fit (EGSR 2007) of Smith's Beckmann G1, with the Blinn exponent
/// mapped to the equivalent Beckmann roughness α = sqrt(2/(n+2)), so a = sqrt(n/2+1)/tan θ.
/// `cos_theta` is the direction's cosine with the normal; the caller checks ω·h > 0.
pub(super) fn smith_g1_walter(cos_theta: f32, exponent: f32) -> f32 {
    if cos_theta <= 0.0 {
        return 0.0;
    }
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    // a = sqrt(n/2 + 1) cos θ / sin θ; compare a < 1.6 without dividing by a zero sine.
    let num = (0.5 * exponent + 1.0).sqrt() * cos_theta;
    if num >= 1.6 * sin_theta {
        return 1.0;
    }
    let a = num / sin_theta;
    (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
}

impl BlinnMicrofacet {
    pub const FLAGS: BsdfFlags = BsdfFlags::GLOSSY_REFLECTION;

    #[inline(always)]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Vec3A {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return Vec3A::ZERO;
        }
        let exponent = self.exponent;
        let Some(h) = (wo + wi).try_normalize() else {
            return Vec3A::ZERO;
        };
        let d = (exponent + 2.0) / TAU * powf(h.z, exponent);
        // wo·h = wi·h > 0 for two directions above the surface, so G1's ω·h test holds.
        let g = smith_g1_walter(wo.z, exponent) * smith_g1_walter(wi.z, exponent);
        let fresnel = schlick_fresnel(self.reflectance, h.dot(wi));
        fresnel * (d * g / (4.0 * wo.z))
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
        // F D G / (4 cos θo) over (n+1)/(2π) (n·h)^n / (4 wo·h).
        let g = smith_g1_walter(wo.z, exponent) * smith_g1_walter(wi.z, exponent);
        let weight = fresnel * ((exponent + 2.0) / (exponent + 1.0) * g * wo_h / wo.z);
        Some(BsdfSample::reflection(wi, weight, pdf, Self::FLAGS))
    }

    /// As for blinn: twice the half-vector lobe's width.
    pub fn roughness(&self) -> f32 {
        (2.0 * (2.0 / (self.exponent.max(0.0) + 2.0)).sqrt()).min(1.0)
    }
}
