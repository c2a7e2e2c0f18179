//! A constant environment (Mitsuba's `constant` emitter, and the torrey dialect's `<background>`):
//! the same radiance from every direction, sampled uniformly over the sphere.

use super::LightSample;
use crate::sampling::{square_to_uniform_sphere, uniform_sphere_pdf};
use glam::{Vec2, Vec3A};

/// Radiance arriving from every direction at infinity.
pub struct ConstantLight {
    pub radiance: Vec3A,
}

impl ConstantLight {
    /// A direction uniform over the sphere.
    #[inline(always)]
    pub fn sample(&self, u: Vec2) -> Option<LightSample> {
        let wi = square_to_uniform_sphere(u);
        Some(LightSample {
            wi,
            dist: f32::INFINITY,
            radiance: self.radiance,
            pdf: uniform_sphere_pdf(),
            is_delta: false,
        })
    }

    /// Radiance along an escaped ray and the density [`ConstantLight::sample`] gives it.
    #[inline(always)]
    pub fn eval(&self) -> (Vec3A, f32) {
        (self.radiance, uniform_sphere_pdf())
    }
}
