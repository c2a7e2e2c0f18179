//! What `sample` returns: one sampled scattering direction.

use super::BsdfFlags;
use glam::Vec3A;

/// One sampled scattering direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// The sampled direction (local frame).
    pub wi: Vec3A,
    /// f·|cos θi| / pdf, including the probability of the lobe choice: the path throughput
    /// multiplier. For delta lobes it is the lobe's reflectance divided by its selection
    /// probability.
    pub weight: Vec3A,
    /// Solid-angle density of `wi` (non-delta lobes, times their selection probability, exactly
    /// what `pdf` returns); `f32::INFINITY` for a delta lobe, so that
    /// [`crate::sampling::power_heuristic`] gives such samples MIS weight 1.
    pub pdf: f32,
    /// Relative index of refraction crossed along `wi`, Mitsuba's `BSDFSample::eta`: η_t/η_i
    /// (the side `wi` enters over the side `wo` is on; 1.5 entering glass from air) for a
    /// refraction, 1 for a reflection. The integrator multiplies them up and Russian roulette
    /// uses throughput·η², as Mitsuba does (radiance is scaled by 1/η² crossing into glass).
    pub eta: f32,
    /// The lobe that was sampled: exactly one of reflection/transmission and one of
    /// diffuse/glossy/delta.
    pub lobe: BsdfFlags,
}

impl BsdfSample {
    /// A reflection sample (eta 1) from lobe `lobe`.
    #[inline(always)]
    pub fn reflection(wi: Vec3A, weight: Vec3A, pdf: f32, lobe: BsdfFlags) -> Self {
        Self {
            wi,
            weight,
            pdf,
            eta: 1.0,
            lobe,
        }
    }

    /// The sample came from a delta lobe: skip light-sampling MIS, emission is taken unweighted.
    #[inline(always)]
    pub fn is_delta(&self) -> bool {
        self.lobe.contains(BsdfFlags::DELTA)
    }

    /// A crossing of a `null` surface (Mitsuba's `BSDFFlags::Null`), not a scattering.
    #[inline(always)]
    pub fn is_null(&self) -> bool {
        self.lobe.contains(BsdfFlags::NULL)
    }
}
