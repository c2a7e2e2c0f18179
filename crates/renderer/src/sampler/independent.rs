//! Independent uniform numbers (Mitsuba's `independent` sampler), from PCG32 streams indexed by
//! (seed, pixel, sample).

use super::{next_2d_one_by_one, to_unit, Sampler};
#[cfg(target_arch = "x86_64")]
use crate::accel::Simd;
use glam::Vec2;

/// Independent uniform numbers from PCG32, one stream per (pixel, sample index): a sample's
/// numbers depend only on the seed, the pixel and the sample's global index, never on the samples
/// drawn before it, so any range of a pixel's samples can be rendered alone (a render split by
/// sample ranges draws exactly the numbers of the one-piece render).
///
/// Every request (`next_1d` or `next_2d`) takes a fixed budget of two PCG32 outputs (`next_1d`
/// uses the first), so `resume_sample` finds request `k` of a sample at output `2k` of its stream
/// without knowing which kinds of requests came before. The per-sample reseed (two hashes) and the
/// second step of `next_1d` cost less than the inlining of the hand-written PCG32 saves: a cbox
/// render took 3% fewer instructions than with one `pcg_rand` stream per pixel (callgrind).
#[derive(Clone)]
pub struct PcgSampler {
    rng: Pcg32,
    /// Hash of (render seed, pixel): the root of this pixel's per-sample streams.
    pixel_key: u64,
}

impl PcgSampler {
    /// The sampler of one pixel (`stream`, the pixel index) of a render with `seed`; it starts at
    /// sample 0.
    pub fn new(seed: u64, stream: u64) -> Self {
        let pixel_key = mix64(mix64(seed ^ 0x6a09_e667_f3bc_c909) ^ stream);
        let mut sampler = Self {
            rng: Pcg32::new(0, 0),
            pixel_key,
        };
        sampler.start_sample(0);
        sampler
    }
}

impl Sampler for PcgSampler {
    #[inline]
    fn start_sample(&mut self, index: u32) {
        let key = mix64(self.pixel_key ^ (index as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15));
        self.rng = Pcg32::new(key, mix64(key));
    }

    #[inline]
    fn resume_sample(&mut self, index: u32, requests: u32) {
        self.start_sample(index);
        for _ in 0..2 * requests {
            self.rng.next_u32();
        }
    }

    /// The stream's state: restoring it skips the rehash and the steps of `resume_sample`.
    #[inline]
    fn checkpoint(&self) -> [u64; 2] {
        [self.rng.state, self.rng.increment]
    }

    #[inline]
    fn restore(&mut self, [state, increment]: [u64; 2], _index: u32, _requests: u32) {
        self.rng = Pcg32 { state, increment };
    }

    #[inline]
    fn next_1d(&mut self) -> f32 {
        let x = self.rng.next_u32();
        self.rng.next_u32();
        to_unit(x)
    }

    #[inline]
    fn next_2d(&mut self) -> glam::Vec2 {
        let x = self.rng.next_u32();
        glam::Vec2::new(to_unit(x), to_unit(self.rng.next_u32()))
    }

    /// Each stream's numbers of the `R` requests at once: PCG32's state `n` steps ahead is an
    /// affine function of the current state and increment ([`JUMPS`]), so the `2R` outputs
    /// (up to eight) are computed side by side in SIMD lanes (AVX-512 or AVX2 where
    /// the CPU has them) instead of as a chain of dependent 64-bit multiplies, and stored as
    /// they come, already in request order.
    fn next_2d_each<const R: usize>(
        samplers: &mut [Self],
        indices: &[u32],
        out: &mut Vec<[Vec2; R]>,
    ) {
        out.clear();
        if 2 * R >= JUMPS.len() {
            // More numbers than the table jumps to: one stream after the other.
            return next_2d_one_by_one(samplers, indices, out);
        }
        out.resize(indices.len(), [Vec2::ZERO; R]);
        #[cfg(target_arch = "x86_64")]
        {
            let dq = std::arch::is_x86_feature_detected!("avx512dq");
            match Simd::detect() {
                // SAFETY: (each arm) the level, and AVX512DQ where used, were detected on this
                // CPU.
                Simd::Avx512 if dq => return unsafe { each_avx512(samplers, indices, out) },
                // SAFETY: Simd::Avx2 or Simd::Avx512 was detected on this CPU, either of which has
                // AVX2; `2 * R < JUMPS.len()` was checked above.
                Simd::Avx512 | Simd::Avx2 => return unsafe { each_avx2(samplers, indices, out) },
                Simd::Portable => {}
            }
        }
        each_lanes(samplers, indices, out)
    }
}

/// `JUMPS[n]`: PCG32's state after `n` steps from state `s` with increment `c` is
/// `s * JUMPS[n].0 + c * JUMPS[n].1` (wrapping): `(A^n, A^(n-1) + ... + A + 1)` for the
/// multiplier `A`.
const JUMPS: [(u64, u64); 9] = {
    let mut jumps = [(1u64, 0u64); 9];
    let mut n = 1;
    while n < jumps.len() {
        let (a, c) = jumps[n - 1];
        jumps[n] = (
            a.wrapping_mul(Pcg32::MULTIPLIER),
            c.wrapping_mul(Pcg32::MULTIPLIER).wrapping_add(1),
        );
        n += 1;
    }
    jumps
};

/// [`each_lanes`] in AVX-512 written out: a stream's eight jumps are one vector of 64-bit
/// lanes (the compiler's own vectorisation of the loop took three times the instructions).
/// `2R` must be below `JUMPS.len()`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512bw,avx512vl,avx2")]
unsafe fn each_avx512<const R: usize>(
    samplers: &mut [PcgSampler],
    indices: &[u32],
    out: &mut [[Vec2; R]],
) {
    use std::arch::x86_64::*;
    assert!(2 * R < JUMPS.len(), "more numbers than the jumps");
    let (mut a, mut c) = ([0i64; 8], [0i64; 8]);
    for (n, &(an, cn)) in JUMPS[..8].iter().enumerate() {
        (a[n], c[n]) = (an as i64, cn as i64);
    }
    // SAFETY: (all the loads and stores) the arrays hold eight 64-bit lanes; `out[k]` holds
    // `2R` <= 8 consecutive f32 (`Vec2` is two f32, `repr(C)`), and the store's mask covers
    // only those.
    let (a, c) = unsafe {
        (
            _mm512_loadu_si512(a.as_ptr().cast()),
            _mm512_loadu_si512(c.as_ptr().cast()),
        )
    };
    let scale = _mm256_set1_ps(1.0 / (1u32 << 24) as f32);
    let mask = ((1u32 << (2 * R)) - 1) as u8;
    for (&i, out) in indices.iter().zip(out) {
        let rng = &mut samplers[i as usize].rng;
        let (state, increment) = (rng.state, rng.increment);
        let old = _mm512_add_epi64(
            _mm512_mullo_epi64(_mm512_set1_epi64(state as i64), a),
            _mm512_mullo_epi64(_mm512_set1_epi64(increment as i64), c),
        );
        // `Pcg32::output` of each state: the XOR-shift truncated to 32 bits, rotated
        // by the state's top five bits; then `to_unit`.
        let xorshifted = _mm512_cvtepi64_epi32(_mm512_srli_epi64::<27>(_mm512_xor_si512(
            _mm512_srli_epi64::<18>(old),
            old,
        )));
        let rotation = _mm512_cvtepi64_epi32(_mm512_srli_epi64::<59>(old));
        let bits = _mm256_rorv_epi32(xorshifted, rotation);
        let units = _mm256_mul_ps(_mm256_cvtepi32_ps(_mm256_srli_epi32::<8>(bits)), scale);
        // SAFETY: `out` (one `[Vec2; R]`) holds `2R` <= 8 consecutive f32 (`Vec2` is two f32,
        // `repr(C)`), and the store's mask covers only those.
        unsafe { _mm256_mask_storeu_ps(out.as_mut_ptr().cast(), mask, units) };
        rng.state = rng.state_after(2 * R);
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn each_avx2<const R: usize>(
    samplers: &mut [PcgSampler],
    indices: &[u32],
    out: &mut [[Vec2; R]],
) {
    each_lanes(samplers, indices, out)
}

/// The loop of [`PcgSampler::next_2d_each`] (`2R` < `JUMPS.len()`), written for the compiler
/// to vectorise over one stream's outputs: [`Pcg32::next_u32`]'s output of the state `n` steps
/// ahead and [`to_unit`], for the eight `n` of a vector (the unused ones cost nothing extra).
#[inline(always)]
fn each_lanes<const R: usize>(samplers: &mut [PcgSampler], indices: &[u32], out: &mut [[Vec2; R]]) {
    const N: usize = JUMPS.len() - 1;
    for (&i, out) in indices.iter().zip(out) {
        let rng = &mut samplers[i as usize].rng;
        let mut units = [0f32; N];
        for (n, unit) in units.iter_mut().enumerate() {
            let bits = Pcg32::output(rng.state_after(n));
            // `to_unit`, with a conversion that has a vector instruction (the value fits in 24
            // bits: the same float).
            *unit = (bits >> 8) as i32 as f32 * (1.0 / (1u32 << 24) as f32);
        }
        rng.state = rng.state_after(2 * R);
        for (r, u) in out.iter_mut().enumerate() {
            *u = Vec2::new(units[2 * r], units[2 * r + 1]);
        }
    }
}

/// PCG32 (O'Neill's XSH-RR output on a 64-bit LCG), kept here so that a sampler's per-sample
/// reseed is two words, without the allocation `pcg_rand`'s seeder makes.
#[derive(Clone)]
struct Pcg32 {
    state: u64,
    increment: u64,
}

impl Pcg32 {
    const MULTIPLIER: u64 = 6_364_136_223_846_793_005;

    /// State `state`, on stream `stream` (any odd increment is a full-period stream).
    #[inline]
    fn new(state: u64, stream: u64) -> Self {
        Self {
            state,
            increment: (stream << 1) | 1,
        }
    }

    #[inline]
    fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(Self::MULTIPLIER)
            .wrapping_add(self.increment);
        Self::output(old)
    }

    /// XSH-RR: the output of state `old` (the XOR-shift truncated to 32 bits, rotated by the
    /// state's top five bits).
    #[inline(always)]
    fn output(old: u64) -> u32 {
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }

    /// The state `n` steps ahead (`n` < `JUMPS.len()`), without stepping through them.
    #[inline(always)]
    fn state_after(&self, n: usize) -> u64 {
        let (a, c) = JUMPS[n];
        self.state
            .wrapping_mul(a)
            .wrapping_add(self.increment.wrapping_mul(c))
    }
}

/// A 64-bit finaliser (SplitMix64's): spreads every input bit over the output, so neighbouring
/// pixels and sample indices get unrelated PCG states and streams.
#[inline]
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pcg_is_uniform_and_deterministic() {
        let mut a = PcgSampler::new(7, 3);
        let mut b = PcgSampler::new(7, 3);
        let mut c = PcgSampler::new(7, 4);
        let mut bins = [0u32; 10];
        let mut differs = false;
        for _ in 0..100_000 {
            let x = a.next_1d();
            assert_eq!(x, b.next_1d());
            differs |= x != c.next_1d();
            assert!((0.0..1.0).contains(&x));
            bins[(x * 10.0) as usize] += 1;
        }
        assert!(differs, "different streams must differ");
        // Chi-square with 9 degrees of freedom; 27.9 is the 0.999 quantile.
        let chi2: f64 = bins
            .iter()
            .map(|&o| (o as f64 - 10_000.0).powi(2) / 10_000.0)
            .sum();
        assert!(chi2 < 27.9, "chi2 = {chi2}");
    }

    /// A sample's numbers depend only on (seed, pixel, sample index): resuming a sample after
    /// others were started in between, or starting it without the samples before it, gives the
    /// numbers of drawing it in sequence; and numbers of neighbouring samples and pixels are
    /// uncorrelated (chi-square of pairs in a 4x4 grid).
    #[test]
    fn pcg_samples_are_indexed_and_resumable() {
        let draw = |s: &mut PcgSampler| [s.next_2d().x, s.next_1d(), s.next_2d().y, s.next_1d()];
        let mut seq = PcgSampler::new(5, 77);
        let reference: Vec<[f32; 4]> = (0..20u32)
            .map(|i| {
                seq.start_sample(i);
                draw(&mut seq)
            })
            .collect();
        let mut alone = PcgSampler::new(5, 77);
        alone.start_sample(13);
        assert_eq!(draw(&mut alone), reference[13]);
        // Camera rays of samples 8..16 first (one 2D request each), then each path resumed.
        let mut packed = PcgSampler::new(5, 77);
        let mut firsts = Vec::new();
        for i in 8..16 {
            packed.start_sample(i);
            firsts.push(packed.next_2d().x);
        }
        for i in 8..16u32 {
            packed.resume_sample(i, 1);
            let rest = [packed.next_1d(), packed.next_2d().y, packed.next_1d()];
            let r = reference[i as usize];
            assert_eq!([firsts[i as usize - 8], rest[0], rest[1], rest[2]], r);
        }
        // The same with checkpoints taken after each camera draw, restored instead of resumed.
        let mut checkpoints = Vec::new();
        for i in 8..16 {
            packed.start_sample(i);
            packed.next_2d();
            checkpoints.push(packed.checkpoint());
        }
        for i in 8..16u32 {
            packed.restore(checkpoints[i as usize - 8], i, 1);
            let rest = [packed.next_1d(), packed.next_2d().y, packed.next_1d()];
            let r = reference[i as usize];
            assert_eq!([rest[0], rest[1], rest[2]], [r[1], r[2], r[3]]);
        }
        let mut bins = [0u32; 16];
        let n = 64_000u32;
        for i in 0..n {
            let (mut a, mut b) = (
                PcgSampler::new(1, i as u64 / 4),
                PcgSampler::new(1, i as u64 / 4 + 1),
            );
            a.start_sample(i % 4);
            b.start_sample(i % 4 + 1);
            let (u, v) = (a.next_1d(), b.next_1d());
            bins[(u * 4.0) as usize * 4 + (v * 4.0) as usize] += 1;
        }
        let e = n as f64 / 16.0;
        let chi2: f64 = bins.iter().map(|&o| (o as f64 - e).powi(2) / e).sum();
        assert!(chi2 < 37.7, "chi2 = {chi2}"); // 15 dof, 0.999 quantile
    }

    /// `next_2d_each` of every instruction set this CPU has, against `next_2d` one stream at a
    /// time: the same bits for streams at different points of different samples (resumed after
    /// 0 to 6 requests of both kinds), an odd count of indices in no order, a few streams left
    /// out (they must not move), 1 to 4 requests per stream; and the streams continue alike.
    #[test]
    fn pcg_streams_in_lanes_draw_the_scalar_numbers() {
        /// One way of drawing the streams' next `R` requests.
        type Each<const R: usize> = dyn Fn(&mut [PcgSampler], &[u32], &mut Vec<[Vec2; R]>);
        fn check<const R: usize>(each: &Each<R>) {
            let mut streams: Vec<PcgSampler> = (0..41u32)
                .map(|k| {
                    let mut s = PcgSampler::new(11, 1000 + k as u64 / 3);
                    s.resume_sample(k * 7 % 64, 0);
                    for r in 0..k % 7 {
                        if r % 2 == 0 {
                            s.next_1d();
                        } else {
                            s.next_2d();
                        }
                    }
                    s
                })
                .collect();
            let mut scalar = streams.clone();
            // 37 of the 41 streams (odd, not a multiple of any vector width), shuffled.
            let indices: Vec<u32> = (0..41u32)
                .map(|k| k * 17 % 41)
                .filter(|k| k % 10 != 3)
                .collect();
            assert_eq!(indices.len(), 37);
            for round in 0..3 {
                let mut out = Vec::new();
                each(&mut streams, &indices, &mut out);
                assert_eq!(out.len(), indices.len());
                for (&i, got) in indices.iter().zip(&out) {
                    let want: [Vec2; R] = std::array::from_fn(|_| scalar[i as usize].next_2d());
                    assert_eq!(
                        got.map(|v| v.to_array()),
                        want.map(|v| v.to_array()),
                        "stream {i}, round {round}, {R} requests"
                    );
                }
            }
            for (k, (a, b)) in streams.iter_mut().zip(&mut scalar).enumerate() {
                assert_eq!(a.next_1d(), b.next_1d(), "stream {k} after the draws");
                assert_eq!(a.next_2d(), b.next_2d(), "stream {k} after the draws");
            }
        }
        fn all<const R: usize>() {
            check::<R>(&|s, i, o| PcgSampler::next_2d_each(s, i, o));
            if 2 * R >= JUMPS.len() {
                return;
            }
            check::<R>(&|s, i, o| {
                o.clear();
                o.resize(i.len(), [Vec2::ZERO; R]);
                each_lanes(s, i, o)
            });
            #[cfg(target_arch = "x86_64")]
            {
                if std::arch::is_x86_feature_detected!("avx2") {
                    check::<R>(&|s, i, o| {
                        o.clear();
                        o.resize(i.len(), [Vec2::ZERO; R]);
                        // SAFETY: AVX2 was detected.
                        unsafe { each_avx2(s, i, o) }
                    });
                }
                if crate::accel::Simd::detect() == Simd::Avx512
                    && std::arch::is_x86_feature_detected!("avx512dq")
                {
                    check::<R>(&|s, i, o| {
                        o.clear();
                        o.resize(i.len(), [Vec2::ZERO; R]);
                        // SAFETY: AVX-512 (F, BW, VL, DQ) and AVX2 were detected.
                        unsafe { each_avx512(s, i, o) }
                    });
                }
            }
        }
        all::<1>();
        all::<3>();
        all::<4>();
        // Past the jump table: the one-at-a-time fallback.
        all::<5>();
    }
}
