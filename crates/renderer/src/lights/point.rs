//! An isotropic point light (Mitsuba's `point`): intensity / r², reached only by light sampling.

use super::light_bounds::{luminance, DirectionCone, LightBounds};
use super::LightSample;
use glam::Vec3A;

/// A point light: position and radiant intensity.
pub struct PointLight {
    pub position: Vec3A,
    pub intensity: Vec3A,
}

impl PointLight {
    /// Its bounds for the light tree: a point emitting 4π I in every direction.
    pub fn bounds(&self) -> LightBounds {
        LightBounds::point(
            self.position,
            4.0 * std::f32::consts::PI * luminance(self.intensity),
            DirectionCone::SPHERE,
            0.0,
        )
    }

    /// The connection from `p`: a delta sample, so no MIS.
    #[inline(always)]
    pub fn sample(&self, p: Vec3A) -> Option<LightSample> {
        let d = self.position - p;
        let dist2 = d.length_squared();
        if dist2 == 0.0 {
            return None;
        }
        let dist = dist2.sqrt();
        Some(LightSample {
            wi: d / dist,
            dist,
            radiance: self.intensity / dist2,
            pdf: 1.0,
            is_delta: true,
        })
    }
}
