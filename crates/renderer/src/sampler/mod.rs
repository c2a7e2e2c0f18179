//! Sample generators for the integrator: a trait the integrator and the render loop draw from,
//! and its implementations, one per file.
//!
//! - [`PcgSampler`]: independent uniform numbers (Mitsuba's `independent`).
//! - [`SobolSampler`]: shuffled, Owen-scrambled Sobol points (torrey's default).

mod independent;
mod sobol;

pub use independent::PcgSampler;
pub use sobol::SobolSampler;

use glam::Vec2;

/// Which sample generator a render uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SamplerKind {
    /// Independent uniform random numbers (PCG32).
    Independent,
    /// Shuffled, Owen-scrambled Sobol points.
    #[default]
    Sobol,
}

/// A source of uniform numbers in [0, 1).
pub trait Sampler {
    /// Begins sample number `index` of the current pixel (sequences that depend on the sample
    /// index, like Sobol, restart their dimensions here; independent samplers ignore it).
    fn start_sample(&mut self, _index: u32) {}
    /// Goes back to sample `index` after its first `requests` draws (`next_1d` and `next_2d`
    /// calls each count one), when other samples were started in between: the camera rays of a
    /// pixel's packet are drawn first, then each path is followed in turn. A stream of
    /// independent numbers just continues; a low-discrepancy sampler returns to the sample's
    /// next dimension.
    fn resume_sample(&mut self, _index: u32, _requests: u32) {}
    /// Where the current sample stands now, for [`Sampler::restore`]: a sampler whose
    /// `resume_sample` recomputes its state (the independent one rehashes its stream) returns
    /// that state, so that going back costs a copy; the others return nothing.
    #[inline]
    fn checkpoint(&self) -> [u64; 2] {
        [0; 2]
    }
    /// The same as `resume_sample(index, requests)`, given the [`Sampler::checkpoint`] taken
    /// right after the first `requests` draws of sample `index`.
    #[inline]
    fn restore(&mut self, _checkpoint: [u64; 2], index: u32, requests: u32) {
        self.resume_sample(index, requests);
    }
    /// A 1D request's number. The wavefront loop takes it as the x of the pair `next_2d` would
    /// draw at the same request ([`Sampler::next_2d_each`] draws pairs only): a sampler must
    /// give the same number both ways.
    fn next_1d(&mut self) -> f32;
    fn next_2d(&mut self) -> Vec2 {
        Vec2::new(self.next_1d(), self.next_1d())
    }
    /// The next `R` requests (as [`Sampler::next_2d`]) of each sampler `samplers[i]`, for `i` in
    /// `indices` in that order, into `out` (replacing its contents): the wavefront loop's
    /// per-path streams drawn a bounce at a time. One `next_2d` after the other by default;
    /// [`PcgSampler`] computes a stream's numbers side by side in SIMD lanes (the same
    /// numbers).
    fn next_2d_each<const R: usize>(
        samplers: &mut [Self],
        indices: &[u32],
        out: &mut Vec<[Vec2; R]>,
    ) where
        Self: Sized,
    {
        next_2d_one_by_one(samplers, indices, out)
    }
    /// The next `R` requests (as [`Sampler::next_2d`]) of each sample `(index, requests)` of
    /// `samples`, resumed there as [`Sampler::resume_sample`] does, into `out` (replacing its
    /// contents): the wavefront loop's shared sampler drawn a bounce at a time. Where it leaves
    /// the current sample is unspecified (callers resume or start one next). Resumed one after
    /// the other by default; [`SobolSampler`] reads its table's columns directly.
    fn next_2d_resumed<const R: usize>(
        &mut self,
        samples: impl Iterator<Item = (u32, u32)>,
        out: &mut Vec<[Vec2; R]>,
    ) where
        Self: Sized,
    {
        out.clear();
        out.extend(samples.map(|(index, requests)| {
            self.resume_sample(index, requests);
            std::array::from_fn(|_| self.next_2d())
        }));
    }
}

/// [`Sampler::next_2d_each`] one `next_2d` after the other: the default, and PCG's fallback
/// past its jump table.
fn next_2d_one_by_one<S: Sampler, const R: usize>(
    samplers: &mut [S],
    indices: &[u32],
    out: &mut Vec<[Vec2; R]>,
) {
    out.clear();
    out.extend(indices.iter().map(|&i| {
        let sampler = &mut samplers[i as usize];
        std::array::from_fn(|_| sampler.next_2d())
    }));
}

/// 24 random mantissa bits: uniform in [0, 1) and never rounds up to 1.
#[inline]
fn to_unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}
