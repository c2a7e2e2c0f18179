//! Lambertian reflection (`diffuse`): reflectance / π, sampled cosine-weighted.

use super::{BsdfFlags, BsdfSample};
use crate::sampling::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use crate::textures::{ColorSource, TextureQuery};
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;

/// The material's parameters: `reflectance` (colour or texture).
#[derive(Clone, Copy, Debug)]
pub struct DiffuseParams {
    pub reflectance: ColorSource,
}

impl DiffuseParams {
    #[inline(always)]
    pub fn resolve(&self, q: &TextureQuery) -> Diffuse {
        Diffuse {
            reflectance: q.color(self.reflectance),
        }
    }
}

/// Lambertian reflection at a hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Diffuse {
    pub reflectance: Vec3A,
}

impl Diffuse {
    pub const FLAGS: BsdfFlags = BsdfFlags::DIFFUSE_REFLECTION;

    #[inline(always)]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Vec3A {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return Vec3A::ZERO;
        }
        self.reflectance * (FRAC_1_PI * wi.z)
    }

    #[inline(always)]
    pub fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return 0.0;
        }
        cosine_hemisphere_pdf(wi.z)
    }

    /// A cosine-weighted direction: the weight is the reflectance exactly.
    #[inline(always)]
    pub fn sample(&self, wo: Vec3A, u: Vec2) -> Option<BsdfSample> {
        if !(wo.z > 0.0) {
            return None;
        }
        let wi = square_to_cosine_hemisphere(u);
        (wi.z > 0.0).then(|| {
            BsdfSample::reflection(
                wi,
                self.reflectance,
                cosine_hemisphere_pdf(wi.z),
                Self::FLAGS,
            )
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ρ = R cos θi / π, and it integrates to R (checked by the statistical tests in
    /// `bsdfs/tests.rs`).
    #[test]
    fn closed_form() {
        let d = Diffuse {
            reflectance: Vec3A::new(0.2, 0.4, 0.6),
        };
        let wo = Vec3A::new(0.3, 0.1, 0.9).normalize();
        let wi = Vec3A::new(-0.2, 0.5, 0.7).normalize();
        let v = d.eval(wo, wi);
        assert!(
            (v - d.reflectance * wi.z / std::f32::consts::PI)
                .abs()
                .max_element()
                < 1e-7
        );
        assert_eq!(d.eval(wo, -wi), Vec3A::ZERO);
        assert!((d.pdf(wo, wi) - wi.z / std::f32::consts::PI).abs() < 1e-7);
    }
}
