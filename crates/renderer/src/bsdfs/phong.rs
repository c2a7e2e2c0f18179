//! The torrey course's `phong`: a normalised Phong lobe around the mirror direction,
//! ρ = R (n+1)/(2π) max(r·wi, 0)^n (no cos θi factor: ρ is R times the sampling density).

use super::{reflect_z, BsdfFlags, BsdfSample};
use crate::sampling::{cosine_power_pdf, square_to_cosine_power, Frame};
use crate::textures::{ColorSource, FloatSource, TextureQuery};
use glam::{Vec2, Vec3A};
use std::f32::consts::TAU;
use torrey_fastmath::powf;

/// The material's parameters: `reflectance` (colour or texture) and the Phong `exponent`.
#[derive(Clone, Copy, Debug)]
pub struct PhongParams {
    pub reflectance: ColorSource,
    pub exponent: FloatSource,
}

impl PhongParams {
    #[inline(always)]
    pub fn resolve(&self, q: &TextureQuery) -> Phong {
        Phong {
            reflectance: q.color(self.reflectance),
            exponent: q.float(self.exponent),
        }
    }
}

/// The course's Phong lobe at a hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Phong {
    pub reflectance: Vec3A,
    pub exponent: f32,
}

impl Phong {
    pub const FLAGS: BsdfFlags = BsdfFlags::GLOSSY_REFLECTION;

    #[inline(always)]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Vec3A {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return Vec3A::ZERO;
        }
        let c = reflect_z(wo).dot(wi);
        if c <= 0.0 {
            return Vec3A::ZERO;
        }
        self.reflectance * ((self.exponent + 1.0) / TAU * powf(c, self.exponent))
    }

    /// The density of [`Phong::sample`]; directions it proposes below the surface are rejected,
    /// so it integrates to the acceptance rate, below one.
    #[inline(always)]
    pub fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return 0.0;
        }
        cosine_power_pdf(reflect_z(wo).dot(wi), self.exponent)
    }

    /// The lobe sampled exactly (ρ / pdf = R); only the horizon rejects.
    #[inline(always)]
    pub fn sample(&self, wo: Vec3A, u: Vec2) -> Option<BsdfSample> {
        if !(wo.z > 0.0) {
            return None;
        }
        let r = reflect_z(wo);
        let local = square_to_cosine_power(u, self.exponent);
        let wi = Frame::from_normal(r).to_world(local);
        let pdf = cosine_power_pdf(local.z, self.exponent);
        (wi.z > 0.0 && pdf > 0.0).then_some(BsdfSample::reflection(
            wi,
            self.reflectance,
            pdf,
            Self::FLAGS,
        ))
    }

    /// About the lobe's standard deviation, sqrt(2/(n+2)) radians (at most 1).
    pub fn roughness(&self) -> f32 {
        (2.0 / (self.exponent.max(0.0) + 2.0)).sqrt().min(1.0)
    }
}
