//! A light at infinity shining along one direction (Mitsuba's `directional`): the same
//! irradiance on every surface facing it, reached only by light sampling.

use super::LightSample;
use glam::Vec3A;

/// A directional light: `irradiance` (W/m²) on a surface facing it.
pub struct DirectionalLight {
    /// Unit direction from any point towards the light (minus the direction light travels).
    pub to_light: Vec3A,
    pub irradiance: Vec3A,
}

impl DirectionalLight {
    /// The connection from any point: a delta sample at infinite distance, so no MIS.
    #[inline(always)]
    pub fn sample(&self) -> Option<LightSample> {
        Some(LightSample {
            wi: self.to_light,
            dist: f32::INFINITY,
            radiance: self.irradiance,
            pdf: 1.0,
            is_delta: true,
        })
    }
}
