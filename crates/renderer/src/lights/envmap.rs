//! An environment map at infinity (Mitsuba's `envmap`), importance-sampled by luminance
//! ([`torrey_light::EnvMap`] holds the map, its mip pyramid and its sampling tables).

use super::LightSample;
use crate::sampling::{square_to_uniform_sphere, uniform_sphere_pdf};
use glam::{Vec2, Vec3A};
use torrey_light::EnvMap;

/// A lat-long environment map, rotated into the world.
pub struct EnvLight {
    pub map: EnvMap,
}

impl EnvLight {
    /// A direction drawn by luminance; `uniform` draws it uniformly over the sphere instead
    /// (only to measure what importance sampling gains).
    #[inline(always)]
    pub fn sample(&self, u: Vec2, uniform: bool) -> Option<LightSample> {
        if uniform {
            let wi = square_to_uniform_sphere(u);
            return Some(LightSample {
                wi,
                dist: f32::INFINITY,
                radiance: self.map.eval(wi.into(), 0.0).into(),
                pdf: uniform_sphere_pdf(),
                is_delta: false,
            });
        }
        self.sample_importance(u)
    }

    /// Importance-samples the map. Out of line (the other lights' arms are small) so that
    /// inlining the map's sampling does not bloat the area-light path.
    #[inline(never)]
    fn sample_importance(&self, u: Vec2) -> Option<LightSample> {
        let s = self.map.sample(u)?;
        Some(LightSample {
            wi: s.direction.into(),
            dist: f32::INFINITY,
            radiance: s.radiance.into(),
            pdf: s.pdf,
            is_delta: false,
        })
    }

    /// Radiance along an escaped ray `dir`, filtered by `spread`, and the density of
    /// [`EnvLight::sample`] there.
    #[inline(always)]
    pub fn eval_pdf(&self, dir: Vec3A, spread: f32) -> (Vec3A, f32) {
        let (l, p) = self.map.eval_pdf(dir.into(), spread);
        (l.into(), p)
    }

    /// Radiance along `dir` alone (no density lookup).
    #[inline(always)]
    pub fn eval(&self, dir: Vec3A, spread: f32) -> Vec3A {
        self.map.eval(dir.into(), spread).into()
    }
}
