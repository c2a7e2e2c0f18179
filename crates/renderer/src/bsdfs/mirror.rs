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

/// [`Mirror::sample`] in select form, for the wavefront's lane kernel (one loop over lanes, no
/// branch): whether it samples (`wo_z > 0`; NaN does not) and its weight, the bits of
/// [`schlick_fresnel`] (the clamp written as the two selects `f32::clamp` makes). The sampled
/// direction is `reflect_z(wo)`, pdf infinite, a delta lobe: the kernel's.
#[inline(always)]
pub fn mirror_sample_select(reflectance: [f32; 3], wo_z: f32) -> (bool, [f32; 3]) {
    let m = 1.0 - wo_z;
    let m = if m < 0.0 { 0.0 } else { m };
    let m = if m > 1.0 { 1.0 } else { m };
    let m2 = m * m;
    let w = m2 * m2 * m;
    let f = reflectance.map(|f0| f0 + (1.0 - f0) * w);
    (wo_z > 0.0, f)
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

    /// The select form gives `sample`'s decision and weight bit for bit, at the edges too
    /// (cos 0, ±0, 1, just under 1, NaN, out of range; reflectance 0, 1, above 1, textured-like
    /// values).
    #[test]
    fn select_form_matches_sample_bit_for_bit() {
        let mut rng = torrey_testkit::Rng::new(5);
        let mut cosines = vec![
            0.0,
            -0.0,
            1.0,
            1.0f32.next_down(),
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            f32::NAN,
            1.5,
            -1.0,
            f32::INFINITY,
        ];
        cosines.extend((0..2000).map(|_| rng.f32() * 2.0 - 1.0));
        let reflectances = [
            [0.0; 3],
            [1.0; 3],
            [0.9, 0.5, 0.1],
            [1.7, 0.0, 0.999],
            [rng.f32(), rng.f32(), rng.f32()],
        ];
        for &c in &cosines {
            for &r in &reflectances {
                let m = Mirror {
                    reflectance: Vec3A::from_array(r),
                };
                // A direction whose local z is `c` exactly.
                let wo = Vec3A::new(0.25, -0.5, c);
                let (sampled, weight) = mirror_sample_select(r, c);
                match m.sample(wo) {
                    None => assert!(!sampled, "{c} {r:?}"),
                    Some(s) => {
                        assert!(sampled, "{c} {r:?}");
                        assert_eq!(
                            s.weight.to_array().map(f32::to_bits),
                            weight.map(f32::to_bits),
                            "{c} {r:?}"
                        );
                    }
                }
                // The weight of the unsampled lanes too (the kernel computes it for all).
                assert_eq!(
                    schlick_fresnel(Vec3A::from_array(r), c)
                        .to_array()
                        .map(f32::to_bits),
                    weight.map(f32::to_bits),
                    "{c} {r:?}"
                );
            }
        }
    }
}
