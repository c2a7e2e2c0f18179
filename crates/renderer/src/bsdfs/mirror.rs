//! The torrey course's `mirror`: perfect specular reflection weighted by Schlick Fresnel with
//! F0 = reflectance.

use super::fresnel::schlick_fresnel;
use super::{reflect_z, BsdfFlags, BsdfSample};
use crate::textures::{ColorSource, TextureQuery};
use glam::Vec3A;

/// The material's parameters: `reflectance` (Schlick's F0; colour or texture).
#[derive(Clone, Copy, Debug)]
pub struct MirrorParams {
    pub reflectance: ColorSource,
}

impl MirrorParams {
    #[inline(always)]
    pub fn resolve(&self, q: &TextureQuery) -> Mirror {
        Mirror {
            reflectance: q.color(self.reflectance),
        }
    }
}

/// A Schlick-Fresnel mirror at a hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mirror {
    pub reflectance: Vec3A,
}

impl Mirror {
    pub const FLAGS: BsdfFlags = BsdfFlags::DELTA_REFLECTION;

    /// A delta lobe: nothing to evaluate for a given pair of directions.
    #[inline(always)]
    pub fn eval(&self, _wo: Vec3A, _wi: Vec3A) -> Vec3A {
        Vec3A::ZERO
    }

    #[inline(always)]
    pub fn pdf(&self, _wo: Vec3A, _wi: Vec3A) -> f32 {
        0.0
    }

    #[inline(always)]
    pub fn sample(&self, wo: Vec3A) -> Option<BsdfSample> {
        if !(wo.z > 0.0) {
            return None;
        }
        Some(BsdfSample::reflection(
            reflect_z(wo),
            schlick_fresnel(self.reflectance, wo.z),
            f32::INFINITY,
            Self::FLAGS,
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reflects_exactly_with_schlick_weight() {
        let m = Mirror {
            reflectance: Vec3A::new(0.9, 0.5, 0.1),
        };
        let wo = Vec3A::new(0.3, -0.4, 0.5).normalize();
        let s = m.sample(wo).unwrap();
        assert_eq!(s.wi, Vec3A::new(-wo.x, -wo.y, wo.z));
        assert_eq!(s.weight, schlick_fresnel(m.reflectance, wo.z));
        assert!(s.pdf.is_infinite() && s.is_delta());
        assert!(s.lobe.contains(BsdfFlags::REFLECTION) && s.eta == 1.0);
        assert_eq!(m.eval(wo, s.wi), Vec3A::ZERO);
        assert!(m.sample(-wo).is_none());
    }
}
