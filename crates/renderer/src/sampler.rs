//! Sample generators for the integrator.
//!
//! - [`PcgSampler`]: independent uniform numbers from a PCG32 stream (Mitsuba's `independent`).
//! - [`SobolSampler`]: shuffled, Owen-scrambled Sobol points (Burley 2020, "Practical Hash-based
//!   Owen Scrambling"). Every 2D request draws from the first two Sobol dimensions, with the sample
//!   index shuffled and the point scrambled by hashes of (pixel seed, dimension), so each dimension
//!   pair is a well-stratified (0,2)-sequence in its own right and dimension pairs stay decorrelated.
//!   At equal sample counts this lowers the error of pixel anti-aliasing, light and BSDF sampling
//!   without changing the expected value.

use crate::integrator::Sampler;

/// Which sample generator a render uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SamplerKind {
    /// Independent uniform random numbers (PCG32).
    Independent,
    /// Shuffled, Owen-scrambled Sobol points.
    #[default]
    Sobol,
}

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
}

/// PCG32 (O'Neill's XSH-RR output on a 64-bit LCG), kept here so that a sampler's per-sample
/// reseed is two words, without the allocation `pcg_rand`'s seeder makes.
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
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
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

/// 24 random mantissa bits: uniform in [0, 1) and never rounds up to 1.
#[inline]
fn to_unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// One pixel's sample `index` of a shuffled, scrambled Sobol sequence; call `start_sample`
/// before each sample. Dimensions are consumed in order by `next_1d` / `next_2d`.
pub struct SobolSampler {
    pixel_seed: u32,
    /// The sample index with its bits reversed (the input of every dimension's shuffle).
    index_reversed: u32,
    dimension: u32,
}

impl SobolSampler {
    pub fn new(seed: u64, pixel: u64) -> Self {
        let pixel_seed = hash(hash(seed as u32 ^ hash((seed >> 32) as u32)) ^ pixel as u32)
            ^ hash((pixel >> 32) as u32 ^ 0x9e37_79b9);
        Self {
            pixel_seed,
            index_reversed: 0,
            dimension: 0,
        }
    }

    /// The seed of the next dimension (pair); one hash per request.
    #[inline]
    fn dimension_seed(&mut self) -> u32 {
        let s = hash(self.pixel_seed ^ self.dimension.wrapping_mul(0x9e37_79b9));
        self.dimension += 1;
        s
    }
}

impl Sampler for SobolSampler {
    #[inline]
    fn start_sample(&mut self, index: u32) {
        self.index_reversed = index.reverse_bits();
        self.dimension = 0;
    }

    #[inline]
    fn resume_sample(&mut self, index: u32, requests: u32) {
        self.start_sample(index);
        self.dimension = requests;
    }

    #[inline]
    fn next_1d(&mut self) -> f32 {
        let seed = self.dimension_seed();
        let i = self.shuffled_index(seed);
        // Owen-scrambled Sobol dimension 0: owen(reverse(i)) = reverse(lk(i)).
        to_unit(laine_karras(i, hash(seed ^ 0x63d8_3595)).reverse_bits())
    }

    #[inline]
    fn next_2d(&mut self) -> glam::Vec2 {
        let seed = self.dimension_seed();
        let i = self.shuffled_index(seed);
        let x = laine_karras(i, hash(seed ^ 0x63d8_3595)).reverse_bits();
        // owen_scramble(sobol_dim1(i)), with the first bit reversal folded into the table.
        let y = laine_karras(sobol_dim1_reversed(i), hash(seed ^ 0x2c1b_3c6d)).reverse_bits();
        glam::Vec2::new(to_unit(x), to_unit(y))
    }
}

impl SobolSampler {
    /// This dimension's shuffle of the sample index: `owen_scramble(index, seed)`, with the
    /// index's bit reversal done once per sample in `start_sample`.
    #[inline]
    fn shuffled_index(&self, seed: u32) -> u32 {
        laine_karras(self.index_reversed, seed).reverse_bits()
    }
}

/// Direction numbers of Sobol dimension 1: v_0 = 1/2, v_{k+1} = v_k xor (v_k >> 1) (Pascal's
/// triangle mod 2), folded into one XOR table per index byte so a point costs four lookups.
const SOBOL1_TABLES: [[u32; 256]; 4] = {
    let mut v = [0u32; 32];
    v[0] = 1 << 31;
    let mut k = 1;
    while k < 32 {
        v[k] = v[k - 1] ^ (v[k - 1] >> 1);
        k += 1;
    }
    let mut t = [[0u32; 256]; 4];
    let mut b = 0;
    while b < 4 {
        let mut byte = 0;
        while byte < 256 {
            let mut acc = 0u32;
            let mut j = 0;
            while j < 8 {
                if byte & (1 << j) != 0 {
                    acc ^= v[8 * b + j];
                }
                j += 1;
            }
            t[b][byte] = acc;
            byte += 1;
        }
        b += 1;
    }
    t
};

/// [`SOBOL1_TABLES`] with every entry bit-reversed: XOR commutes with bit reversal, so these
/// give `sobol_dim1(i).reverse_bits()` without the reversal (which x86-64 has no instruction for).
const SOBOL1_REVERSED_TABLES: [[u32; 256]; 4] = {
    let mut t = SOBOL1_TABLES;
    let mut b = 0;
    while b < 4 {
        let mut byte = 0;
        while byte < 256 {
            t[b][byte] = t[b][byte].reverse_bits();
            byte += 1;
        }
        b += 1;
    }
    t
};

/// `sobol_dim1(i).reverse_bits()`.
#[inline]
fn sobol_dim1_reversed(i: u32) -> u32 {
    let t = &SOBOL1_REVERSED_TABLES;
    t[0][(i & 255) as usize]
        ^ t[1][((i >> 8) & 255) as usize]
        ^ t[2][((i >> 16) & 255) as usize]
        ^ t[3][(i >> 24) as usize]
}

/// Sobol dimension 1 for index `i`, as a 32-bit fixed-point fraction (the reference that
/// [`sobol_dim1_reversed`] is tested against).
#[cfg(test)]
fn sobol_dim1(i: u32) -> u32 {
    let t = &SOBOL1_TABLES;
    t[0][(i & 255) as usize]
        ^ t[1][((i >> 8) & 255) as usize]
        ^ t[2][((i >> 16) & 255) as usize]
        ^ t[3][(i >> 24) as usize]
}

/// Burley's improved Laine-Karras permutation: each output bit depends only on the input bits
/// below it.
#[inline]
fn laine_karras(mut v: u32, seed: u32) -> u32 {
    v = v.wrapping_add(seed);
    v ^= v.wrapping_mul(0x6c50_b47c);
    v ^= v.wrapping_mul(0xb82f_1e52);
    v ^= v.wrapping_mul(0xc7af_e638);
    v ^= v.wrapping_mul(0x8d22_f6e6);
    v
}

/// Hash-based nested uniform (Owen) scrambling of a fixed-point fraction: each bit is flipped
/// depending only on the more significant bits. The sampler computes it with some bit reversals
/// folded away; this is the reference the tests compare against.
#[cfg(test)]
fn owen_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

/// A 32-bit integer hash (Wellons' lowbias32).
#[inline]
fn hash(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sampler's fast path (reversals folded into tables and `start_sample`) gives exactly
    /// the shuffled, Owen-scrambled Sobol points of the reference formulas.
    #[test]
    fn sobol_fast_path_matches_the_reference() {
        let mut sampler = SobolSampler::new(3, 41);
        for index in [0u32, 1, 2, 3, 7, 8, 100, 1023, 65_537, 0xdead_beef] {
            sampler.start_sample(index);
            for dimension in 0..6u32 {
                let seed = hash(sampler.pixel_seed ^ dimension.wrapping_mul(0x9e37_79b9));
                let i = owen_scramble(index, seed);
                let (x, y) = if dimension % 2 == 0 {
                    let p = sampler.next_2d();
                    (p.x, Some(p.y))
                } else {
                    (sampler.next_1d(), None)
                };
                let ref_x = to_unit(laine_karras(i, hash(seed ^ 0x63d8_3595)).reverse_bits());
                assert_eq!(x, ref_x, "index {index} dimension {dimension}");
                if let Some(y) = y {
                    let ref_y = to_unit(owen_scramble(sobol_dim1(i), hash(seed ^ 0x2c1b_3c6d)));
                    assert_eq!(y, ref_y, "index {index} dimension {dimension}");
                }
            }
        }
    }

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

    #[test]
    fn sobol_dimension_one_matches_known_values() {
        // The first points of Sobol dimension 1 (direction numbers 1/2, 3/4, 5/8, ..., no Gray code).
        let expect = [0.0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875];
        for (i, e) in expect.iter().enumerate() {
            assert_eq!(sobol_dim1(i as u32) as f64 / 4294967296.0, *e, "index {i}");
        }
    }

    /// The first 2^m points of every dimension pair are a (0, m, 2)-net: each of the 2^m
    /// elementary intervals of any shape holds exactly one point. Scrambling keeps that.
    #[test]
    fn sobol_pairs_are_stratified() {
        let m = 6;
        let n = 1u32 << m;
        for pixel in [0u64, 17, 123_456] {
            let mut s = SobolSampler::new(42, pixel);
            let mut points: Vec<Vec<glam::Vec2>> = vec![Vec::new(); 3];
            for i in 0..n {
                s.start_sample(i);
                for p in points.iter_mut() {
                    p.push(s.next_2d());
                }
            }
            for pts in &points {
                for kx in 0..=m {
                    let (nx, ny) = (1u32 << kx, 1u32 << (m - kx));
                    let mut seen = vec![0u32; n as usize];
                    for p in pts {
                        let cx = (p.x * nx as f32) as u32;
                        let cy = (p.y * ny as f32) as u32;
                        seen[(cy * nx + cx) as usize] += 1;
                    }
                    assert!(
                        seen.iter().all(|&c| c == 1),
                        "pixel {pixel}: not a net for {nx}x{ny}"
                    );
                }
            }
        }
    }

    #[test]
    fn sobol_is_uniform_across_pixels_and_dimensions() {
        // One sample per pixel over many pixels must still be uniform (no shared pattern).
        let mut bins = [0u32; 16];
        let n = 64_000;
        for pixel in 0..n {
            let mut s = SobolSampler::new(1, pixel);
            s.start_sample(0);
            s.next_1d();
            let v = s.next_2d();
            bins[(v.x * 4.0) as usize * 4 + (v.y * 4.0) as usize] += 1;
        }
        let e = n as f64 / 16.0;
        let chi2: f64 = bins.iter().map(|&o| (o as f64 - e).powi(2) / e).sum();
        assert!(chi2 < 37.7, "chi2 = {chi2}"); // 15 dof, 0.999 quantile
    }

    /// Integrating a smooth 2D function, scrambled Sobol converges much faster than random.
    #[test]
    fn sobol_beats_independent_on_a_smooth_integrand() {
        let f = |x: f32, y: f32| (x * y * 3.0).sin() + x * x;
        let exact = {
            let k = 2000;
            let mut s = 0.0f64;
            for i in 0..k {
                for j in 0..k {
                    s += f((i as f32 + 0.5) / k as f32, (j as f32 + 0.5) / k as f32) as f64;
                }
            }
            s / (k * k) as f64
        };
        let trials = 200;
        let n = 64;
        let (mut err_sobol, mut err_pcg) = (0.0f64, 0.0f64);
        for t in 0..trials {
            let mut s = SobolSampler::new(9, t);
            let mut p = PcgSampler::new(9, t);
            let (mut a, mut b) = (0.0f64, 0.0f64);
            for i in 0..n {
                s.start_sample(i as u32);
                let v = s.next_2d();
                a += f(v.x, v.y) as f64;
                let w = p.next_2d();
                b += f(w.x, w.y) as f64;
            }
            err_sobol += (a / n as f64 - exact).powi(2);
            err_pcg += (b / n as f64 - exact).powi(2);
        }
        assert!(
            err_sobol * 10.0 < err_pcg,
            "sobol mse {err_sobol}, independent mse {err_pcg}"
        );
    }
}
