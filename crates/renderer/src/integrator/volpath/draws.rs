//! The volumetric path tracer's random numbers.
//!
//! A path takes a fixed number of requests per segment from the pixel's sampler (a bounce's four
//! and one for the free flight), so that with Sobol points the same dimension serves the same
//! decision in every sample of the pixel (the first bounces are stratified). The numbers whose
//! count varies from path to path (delta and ratio tracking's tentative collisions after the
//! first) come from the path's own stream, which also takes over every draw once the path has
//! used [`SAMPLER_REQUESTS`]: past the sampler's table of precomputed Sobol columns (40 requests,
//! the camera's among them) each Sobol point costs about a hundred operations, and a deep random
//! walk in a dense medium (64 bounces in bunny-sss) spent a sixth of its time there.
//!
//! The stream is a PCG32 seeded by the path's first request, a point that differs between the
//! samples of a pixel: its numbers are independent of the sampler's.

use crate::sampler::{PcgSampler, Sampler};
use glam::Vec2;

/// Requests a path takes from the pixel's sampler (its first, the seed, included) before its own
/// stream takes over: with the camera's, within the Sobol sampler's table.
pub const SAMPLER_REQUESTS: u32 = 32;

/// A path's source of numbers: the pixel's sampler, then its own stream.
pub struct PathDraws<'a, S: Sampler> {
    sampler: &'a mut S,
    requests: u32,
    /// Numbers whose count varies (tracking), and all of them past the sampler's requests.
    pub stream: PcgSampler,
}

impl<'a, S: Sampler> PathDraws<'a, S> {
    /// The draws of a path whose camera ray came from `sampler`.
    pub fn new(sampler: &'a mut S) -> Self {
        let seed = sampler.next_2d();
        let key = ((seed.x.to_bits() as u64) << 32) | seed.y.to_bits() as u64;
        PathDraws {
            sampler,
            requests: 1,
            stream: PcgSampler::new(key, 0x0076_6f6c_7061_7468),
        }
    }

    /// The next fixed request: the sampler's while it lasts, then the stream's.
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        if self.requests < SAMPLER_REQUESTS {
            self.requests += 1;
            self.sampler.next_2d()
        } else {
            self.stream.next_2d()
        }
    }

    /// A number of the path's own stream.
    #[inline]
    pub fn stream_1d(&mut self) -> f32 {
        self.stream.next_1d()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::SobolSampler;

    /// The first requests are the sampler's, in order; later ones and the stream's are uniform
    /// and differ between the samples of a pixel.
    #[test]
    fn sampler_first_then_the_paths_own_stream() {
        let n = 4096u32;
        let (mut deep_sum, mut stream_sum) = (0.0f64, 0.0f64);
        let mut firsts = Vec::new();
        for i in 0..n {
            let mut sobol = SobolSampler::new(7, 3);
            sobol.start_sample(i);
            let mut reference = sobol.clone();
            let mut draws = PathDraws::new(&mut sobol);
            reference.next_2d();
            for _ in 1..SAMPLER_REQUESTS {
                assert_eq!(draws.next_2d(), reference.next_2d());
            }
            let deep = draws.next_2d();
            let s = draws.stream_1d();
            assert!((0.0..1.0).contains(&deep.x) && (0.0..1.0).contains(&deep.y));
            assert!((0.0..1.0).contains(&s));
            deep_sum += (deep.x + deep.y) as f64 / 2.0;
            stream_sum += s as f64;
            firsts.push(deep.x.to_bits());
        }
        for mean in [deep_sum / n as f64, stream_sum / n as f64] {
            assert!((mean - 0.5).abs() < 0.02, "mean {mean}");
        }
        firsts.sort_unstable();
        firsts.dedup();
        assert!(
            firsts.len() as u32 > n - 4,
            "streams repeat: {}",
            firsts.len()
        );
    }
}
