//! Mitsuba's `null`: an invisible surface. Rays pass straight through (a delta transmission
//! with weight 1 and η 1; the crossing counts as a bounce, as in Mitsuba's `path`), light
//! sampling skips it and shadow rays are blocked by it, as Mitsuba's `path` integrator does.
//! `mask` is a blend of `null` and its nested BSDF.

use super::{BsdfFlags, BsdfSample};
use glam::Vec3A;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Null;

impl Null {
    pub const FLAGS: BsdfFlags = BsdfFlags::DELTA_TRANSMISSION.union(BsdfFlags::NULL);

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
        (wo.z != 0.0 && wo.z.is_finite()).then(|| BsdfSample {
            wi: -wo,
            weight: Vec3A::ONE,
            pdf: f32::INFINITY,
            eta: 1.0,
            lobe: Self::FLAGS,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_straight_through() {
        let wo = Vec3A::new(0.3, -0.2, 0.9).normalize();
        for w in [wo, -wo] {
            let s = Null.sample(w).unwrap();
            assert_eq!(s.wi, -w);
            assert_eq!(s.weight, Vec3A::ONE);
            assert!(s.is_delta() && s.lobe.contains(BsdfFlags::TRANSMISSION) && s.eta == 1.0);
        }
        assert_eq!(Null.eval(wo, -wo), Vec3A::ZERO);
    }
}
