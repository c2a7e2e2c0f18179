//! The torrey course's `plastic`: a white Schlick-Fresnel mirror (F0 = ((η−1)/(η+1))², F at the
//! view angle) over a diffuse base weighted by 1 − F. (Mitsuba's `plastic` is a different model.)

use super::fresnel::{schlick_f0, schlick_weight};
use super::{reflect_z, BsdfFlags, BsdfSample};
use crate::sampling::{cosine_hemisphere_pdf, square_to_cosine_hemisphere};
use crate::textures::{ColorSource, TextureQuery};
use glam::{Vec2, Vec3A};
use std::f32::consts::FRAC_1_PI;

/// The material's parameters: the base's `reflectance` (colour or texture) and the coating's
/// relative index of refraction `eta`.
#[derive(Clone, Copy, Debug)]
pub struct PlasticParams {
    pub reflectance: ColorSource,
    pub eta: f32,
}

impl PlasticParams {
    #[inline(always)]
    pub fn resolve(&self, q: &TextureQuery) -> Plastic {
        Plastic {
            reflectance: q.color(self.reflectance),
            eta: self.eta,
        }
    }
}

/// The course's plastic at a hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plastic {
    pub reflectance: Vec3A,
    pub eta: f32,
}

impl Plastic {
    pub const FLAGS: BsdfFlags = BsdfFlags::DELTA_REFLECTION.union(BsdfFlags::DIFFUSE_REFLECTION);

    /// Scalar Fresnel at the view angle: the weight of the specular lobe and the probability
    /// with which [`Plastic::sample`] picks it.
    #[inline(always)]
    pub fn fresnel(eta: f32, cos_o: f32) -> f32 {
        let f0 = schlick_f0(eta);
        f0 + (1.0 - f0) * schlick_weight(cos_o)
    }

    #[inline(always)]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Vec3A {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return Vec3A::ZERO;
        }
        let f = Self::fresnel(self.eta, wo.z);
        self.reflectance * ((1.0 - f) * FRAC_1_PI * wi.z)
    }

    #[inline(always)]
    pub fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        if !(wo.z > 0.0 && wi.z > 0.0) {
            return 0.0;
        }
        (1.0 - Self::fresnel(self.eta, wo.z)) * cosine_hemisphere_pdf(wi.z)
    }

    /// Specular with probability F (weight 1: value F over probability F), else the diffuse
    /// base cosine-weighted.
    #[inline(always)]
    pub fn sample(&self, wo: Vec3A, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        if !(wo.z > 0.0) {
            return None;
        }
        let f = Self::fresnel(self.eta, wo.z);
        if u_lobe < f {
            Some(BsdfSample::reflection(
                reflect_z(wo),
                Vec3A::ONE,
                f32::INFINITY,
                BsdfFlags::DELTA_REFLECTION,
            ))
        } else {
            // (1 − F) R cos/π over (1 − F) cos/π.
            let wi = square_to_cosine_hemisphere(u);
            (wi.z > 0.0).then(|| {
                BsdfSample::reflection(
                    wi,
                    self.reflectance,
                    (1.0 - f) * cosine_hemisphere_pdf(wi.z),
                    BsdfFlags::DIFFUSE_REFLECTION,
                )
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_form() {
        // F0 for η = 1.5 is 0.04; at normal incidence the base keeps 96%.
        assert!((Plastic::fresnel(1.5, 1.0) - 0.04).abs() < 1e-7);
        let p = Plastic {
            reflectance: Vec3A::splat(0.5),
            eta: 1.5,
        };
        let wo = Vec3A::Z;
        let wi = Vec3A::new(0.6, 0.0, 0.8);
        let v = p.eval(wo, wi);
        let expected = 0.5 * 0.96 * 0.8 / std::f32::consts::PI;
        assert!((v.x - expected).abs() < 1e-6, "{v}");
    }
}
