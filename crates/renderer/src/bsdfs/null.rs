//! Mitsuba's `null`: an invisible surface. Rays pass straight through (a delta transmission
//! with weight 1 and η 1; the crossing counts as a bounce, as in Mitsuba's `path`), light
//! sampling skips it and shadow rays are blocked by it, as Mitsuba's `path` integrator does.
//! `mask` is a blend of `null` and its nested BSDF.

use super::{Bsdf, BsdfFlags, BsdfParams, BsdfSample};
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

impl Bsdf<'_> {
    /// What passes straight through towards `wo`, index-matched (Mitsuba's
    /// `eval_null_transmission`): 1 for `null`, a thin dielectric's transmission, a blend's
    /// mix; 0 for every other model. Shadow rays of the volumetric path tracer are weighted by
    /// it at each surface they cross.
    pub fn null_transmission(&self, wo: Vec3A) -> Vec3A {
        match self {
            Bsdf::Null(_) => Vec3A::ONE,
            Bsdf::ThinDielectric(b) => b.null_transmission(wo),
            Bsdf::Blend(b) => b.null_transmission(wo),
            _ => Vec3A::ZERO,
        }
    }
}

impl BsdfParams {
    /// Whether a ray may pass straight through (see [`Bsdf::null_transmission`]).
    pub fn may_pass(&self) -> bool {
        match self {
            BsdfParams::Null | BsdfParams::ThinDielectric(_) => true,
            BsdfParams::Blend(b) => b.children.iter().any(BsdfParams::may_pass),
            _ => false,
        }
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
            assert!(s.lobe.contains(BsdfFlags::NULL));
        }
        assert_eq!(Null.eval(wo, -wo), Vec3A::ZERO);
    }
}
