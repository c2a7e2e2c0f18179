//! Mitsuba's `conductor`: a smooth metal, a perfect mirror weighted by the exact conductor
//! Fresnel reflectance of the complex IOR η + ik (one-sided: black from behind).

use super::fresnel::fresnel_conductor;
use super::{reflect_z, BsdfFlags, BsdfSample};
use crate::textures::{ColorSource, TextureQuery};
use glam::Vec3A;

/// The material's parameters: η and k relative to the outside (RGB), the specular tint.
#[derive(Clone, Copy, Debug)]
pub struct ConductorParams {
    pub eta: ColorSource,
    pub k: ColorSource,
    pub specular_reflectance: ColorSource,
}

impl ConductorParams {
    #[inline(always)]
    pub fn resolve(&self, q: &TextureQuery) -> Conductor {
        Conductor {
            eta: q.color(self.eta),
            k: q.color(self.k),
            specular_reflectance: q.color(self.specular_reflectance),
        }
    }

    pub fn is_textured(&self) -> bool {
        self.eta.is_textured() || self.k.is_textured() || self.specular_reflectance.is_textured()
    }
}

/// A smooth conductor at a hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conductor {
    pub eta: Vec3A,
    pub k: Vec3A,
    pub specular_reflectance: Vec3A,
}

impl Conductor {
    pub const FLAGS: BsdfFlags = BsdfFlags::DELTA_REFLECTION;

    #[inline(always)]
    pub fn eval(&self, _wo: Vec3A, _wi: Vec3A) -> Vec3A {
        Vec3A::ZERO
    }

    #[inline(always)]
    pub fn pdf(&self, _wo: Vec3A, _wi: Vec3A) -> f32 {
        0.0
    }

    #[inline]
    pub fn sample(&self, wo: Vec3A) -> Option<BsdfSample> {
        if !(wo.z > 0.0) {
            return None;
        }
        Some(BsdfSample::reflection(
            reflect_z(wo),
            self.specular_reflectance * fresnel_conductor(wo.z, self.eta, self.k),
            f32::INFINITY,
            Self::FLAGS,
        ))
    }
}
