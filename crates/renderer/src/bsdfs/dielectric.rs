//! Mitsuba's `dielectric`: a smooth interface between two dielectrics (glass, water), with
//! exact Fresnel reflection and refraction on both sides and total internal reflection.

use super::fresnel::{fresnel_dielectric, refract};
use super::{reflect_z, BsdfFlags, BsdfSample};
use crate::textures::{ColorSource, TextureQuery};
use glam::Vec3A;

/// The material's parameters: `eta` = int_ior / ext_ior and the specular tints.
#[derive(Clone, Copy, Debug)]
pub struct DielectricParams {
    pub eta: f32,
    pub specular_reflectance: ColorSource,
    pub specular_transmittance: ColorSource,
}

impl DielectricParams {
    #[inline(always)]
    pub fn resolve(&self, q: &TextureQuery) -> Dielectric {
        Dielectric {
            eta: self.eta,
            specular_reflectance: q.color(self.specular_reflectance),
            specular_transmittance: q.color(self.specular_transmittance),
        }
    }
}

/// A smooth dielectric at a hit; the normal points to the outside (η_ext).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dielectric {
    pub eta: f32,
    pub specular_reflectance: Vec3A,
    pub specular_transmittance: Vec3A,
}

impl Dielectric {
    pub const FLAGS: BsdfFlags = BsdfFlags::DELTA_REFLECTION.union(BsdfFlags::DELTA_TRANSMISSION);

    #[inline(always)]
    pub fn eval(&self, _wo: Vec3A, _wi: Vec3A) -> Vec3A {
        Vec3A::ZERO
    }

    #[inline(always)]
    pub fn pdf(&self, _wo: Vec3A, _wi: Vec3A) -> f32 {
        0.0
    }

    /// Reflection with probability R, else refraction; radiance crossing the interface is
    /// scaled by (η_i/η_t)² (solid-angle compression), as Mitsuba does in radiance mode.
    #[inline]
    pub fn sample(&self, wo: Vec3A, u_lobe: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 || !wo.z.is_finite() {
            return None;
        }
        let (r, cos_t, eta_it, eta_ti) = fresnel_dielectric(wo.z, self.eta);
        if u_lobe <= r {
            Some(BsdfSample::reflection(
                reflect_z(wo),
                self.specular_reflectance,
                f32::INFINITY,
                BsdfFlags::DELTA_REFLECTION,
            ))
        } else {
            Some(BsdfSample {
                wi: refract(wo, Vec3A::Z, cos_t, eta_ti),
                weight: self.specular_transmittance * (eta_ti * eta_ti),
                pdf: f32::INFINITY,
                eta: eta_it,
                lobe: BsdfFlags::DELTA_TRANSMISSION,
            })
        }
    }
}

/// Mitsuba's `thindielectric`: a thin slab (a window pane) as one surface: the two interfaces'
/// internal reflections summed, transmission straight through (no offset, no refraction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinDielectric {
    pub eta: f32,
    pub specular_reflectance: Vec3A,
    pub specular_transmittance: Vec3A,
}

/// `thindielectric` has the same parameters as `dielectric`.
#[derive(Clone, Copy, Debug)]
pub struct ThinDielectricParams(pub DielectricParams);

impl ThinDielectricParams {
    #[inline(always)]
    pub fn resolve(&self, q: &TextureQuery) -> ThinDielectric {
        let d = self.0.resolve(q);
        ThinDielectric {
            eta: d.eta,
            specular_reflectance: d.specular_reflectance,
            specular_transmittance: d.specular_transmittance,
        }
    }
}

impl ThinDielectric {
    pub const FLAGS: BsdfFlags = BsdfFlags::DELTA_REFLECTION
        .union(BsdfFlags::DELTA_TRANSMISSION)
        .union(BsdfFlags::NULL);

    /// What passes straight through the slab towards `wo` (Mitsuba's
    /// `eval_null_transmission`): (1 − its reflectance) times the transmittance tint.
    #[inline]
    pub fn null_transmission(&self, wo: Vec3A) -> Vec3A {
        self.specular_transmittance * (1.0 - self.reflectance(wo.z))
    }

    /// Reflectance of the slab: R + T²R/(1 − R²) with R the single interface's.
    #[inline]
    pub fn reflectance(&self, cos: f32) -> f32 {
        let r = fresnel_dielectric(cos.abs(), self.eta).0;
        if r < 1.0 {
            let t = 1.0 - r;
            r + t * t * r / (1.0 - r * r)
        } else {
            r
        }
    }

    #[inline(always)]
    pub fn eval(&self, _wo: Vec3A, _wi: Vec3A) -> Vec3A {
        Vec3A::ZERO
    }

    #[inline(always)]
    pub fn pdf(&self, _wo: Vec3A, _wi: Vec3A) -> f32 {
        0.0
    }

    #[inline]
    pub fn sample(&self, wo: Vec3A, u_lobe: f32) -> Option<BsdfSample> {
        if wo.z == 0.0 || !wo.z.is_finite() {
            return None;
        }
        let r = self.reflectance(wo.z);
        Some(if u_lobe <= r {
            BsdfSample::reflection(
                reflect_z(wo),
                self.specular_reflectance,
                f32::INFINITY,
                BsdfFlags::DELTA_REFLECTION,
            )
        } else {
            BsdfSample {
                wi: -wo,
                weight: self.specular_transmittance,
                pdf: f32::INFINITY,
                eta: 1.0,
                // Straight through: index-matched, as Mitsuba flags it.
                lobe: BsdfFlags::DELTA_TRANSMISSION.union(BsdfFlags::NULL),
            }
        })
    }
}
