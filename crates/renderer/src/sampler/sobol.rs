//! Shuffled, Owen-scrambled Sobol points (Burley 2020, "Practical Hash-based Owen Scrambling").
//! Every 2D request draws from the first two Sobol dimensions, with the sample index shuffled and
//! the point scrambled by hashes of (pixel seed, dimension), so each dimension pair is a
//! well-stratified (0,2)-sequence in its own right and dimension pairs stay decorrelated. At equal
//! sample counts this lowers the error of pixel anti-aliasing, light and BSDF sampling without
//! changing the expected value.
//!
//! A point costs three Laine-Karras permutations and three bit reversals (which x86-64 has no
//! instruction for), about a hundred scalar operations per 2D request. The renderer's sampler
//! ([`SobolSampler::tabled`]) therefore computes them a column at a time: a request (dimension)
//! for a block of up to [`BLOCK`] consecutive samples of the pixel, the sample index in SIMD lanes
//! (AVX2 or AVX-512 where the CPU has them), when the first sample of the block reaches it. The
//! points are exactly those of the one-at-a-time formulas.

use super::{to_unit, Sampler};
#[cfg(target_arch = "x86_64")]
use crate::accel::Simd;
use glam::Vec2;

/// Samples per block of the table: a column covers this many consecutive sample indices.
const BLOCK: usize = 64;
/// Requests per sample the table holds: a camera ray with a lens and nine bounces of four
/// draws. Deeper requests are computed one at a time.
const TABLE_REQUESTS: usize = 40;
/// Columns computed at once when a sample reaches one not yet computed (one bounce's draws).
const FILL_STEP: u32 = 4;

/// One pixel's sample `index` of a shuffled, scrambled Sobol sequence; call `start_sample`
/// before each sample. Dimensions are consumed in order by `next_1d` / `next_2d`.
#[derive(Clone)]
pub struct SobolSampler {
    pixel_seed: u32,
    /// The sample index, and with its bits reversed (the input of every dimension's shuffle).
    index: u32,
    index_reversed: u32,
    dimension: u32,
    /// Samples per pixel (the last block's length), when known.
    spp: u32,
    table: Option<Box<Table>>,
}

/// Points of a block of samples, computed a request (column) at a time.
#[derive(Clone)]
struct Table {
    /// The block's first sample index and its sample count.
    base: u32,
    len: u32,
    /// Requests computed so far for every sample of the block.
    filled: u32,
    /// `x[request][sample - base]`, `y[...]`.
    x: [[f32; BLOCK]; TABLE_REQUESTS],
    y: [[f32; BLOCK]; TABLE_REQUESTS],
}

impl SobolSampler {
    /// A sampler that computes each point when it is drawn (tests, and callers that draw few
    /// samples per pixel).
    pub fn new(seed: u64, pixel: u64) -> Self {
        Self {
            pixel_seed: pixel_seed(seed, pixel),
            index: 0,
            index_reversed: 0,
            dimension: 0,
            spp: u32::MAX,
            table: None,
        }
    }

    /// A sampler that computes its points a column at a time (the same points as
    /// [`SobolSampler::new`]), for a pixel whose sample indices end before `spp` (0 to spp - 1,
    /// or a sub-range of them). `spp` only sizes the last block: indices at or past it are
    /// still drawn correctly, one at a time. Its table (20 KiB) is reused by
    /// [`SobolSampler::restart`] for the next pixel.
    pub fn tabled(seed: u64, pixel: u64, spp: u32) -> Self {
        let mut sampler = Self::new(seed, pixel);
        sampler.spp = spp.max(1);
        sampler.table = Some(Box::new(Table {
            base: 0,
            len: 0,
            filled: 0,
            x: [[0.0; BLOCK]; TABLE_REQUESTS],
            y: [[0.0; BLOCK]; TABLE_REQUESTS],
        }));
        sampler
    }

    /// Starts over for another pixel, keeping the table's memory.
    pub fn restart(&mut self, seed: u64, pixel: u64, spp: u32) {
        self.pixel_seed = pixel_seed(seed, pixel);
        self.spp = spp.max(1);
        if let Some(table) = &mut self.table {
            table.len = 0;
        }
    }

    /// The seed of the next dimension (pair); one hash per request.
    #[inline]
    fn dimension_seed(&mut self) -> u32 {
        let s = dimension_seed(self.pixel_seed, self.dimension);
        self.dimension += 1;
        s
    }

    /// The tabled point of the current sample's next request, if the table holds it.
    #[inline(always)]
    fn tabled_point(&mut self) -> Option<(f32, f32)> {
        let table = self.table.as_deref_mut()?;
        let sample = self.index.wrapping_sub(table.base);
        let request = self.dimension;
        if sample >= table.len || request as usize >= TABLE_REQUESTS {
            return None;
        }
        if request >= table.filled {
            table.fill(self.pixel_seed, request + FILL_STEP);
        }
        self.dimension += 1;
        // SAFETY: (both reads) request < TABLE_REQUESTS, sample < len <= BLOCK.
        unsafe {
            let x = *table
                .x
                .get_unchecked(request as usize)
                .get_unchecked(sample as usize);
            let y = *table
                .y
                .get_unchecked(request as usize)
                .get_unchecked(sample as usize);
            Some((x, y))
        }
    }
}

/// The per-pixel seed of the sequence.
fn pixel_seed(seed: u64, pixel: u64) -> u32 {
    hash(hash(seed as u32 ^ hash((seed >> 32) as u32)) ^ pixel as u32)
        ^ hash((pixel >> 32) as u32 ^ 0x9e37_79b9)
}

/// The seed of request `dimension` of a pixel.
#[inline]
fn dimension_seed(pixel_seed: u32, dimension: u32) -> u32 {
    hash(pixel_seed ^ dimension.wrapping_mul(0x9e37_79b9))
}

/// The scrambling seeds of a request's x and y from its dimension seed.
#[inline]
fn axis_seeds(seed: u32) -> (u32, u32) {
    (hash(seed ^ 0x63d8_3595), hash(seed ^ 0x2c1b_3c6d))
}

impl Table {
    /// Computes the requests from `filled` up to `upto` (at most [`TABLE_REQUESTS`]) for the
    /// block's samples.
    #[cold]
    #[inline(never)]
    fn fill(&mut self, pixel_seed: u32, upto: u32) {
        let upto = upto.min(TABLE_REQUESTS as u32);
        // Whole vectors (sixteen lanes with AVX-512, eight otherwise): the few extra samples
        // past the block's end are computed and never read.
        let n = (self.len as usize)
            .next_multiple_of(column_lanes_width())
            .min(BLOCK);
        for request in self.filled..upto {
            let seed = dimension_seed(pixel_seed, request);
            let (sx, sy) = axis_seeds(seed);
            let (x, y) = (
                &mut self.x[request as usize][..n],
                &mut self.y[request as usize][..n],
            );
            column(self.base, seed, sx, sy, x, y);
        }
        self.filled = upto;
    }
}

/// The samples one vector of [`column`] computes: sixteen with AVX-512, else eight.
fn column_lanes_width() -> usize {
    #[cfg(target_arch = "x86_64")]
    if Simd::detect() == Simd::Avx512 {
        return 16;
    }
    8
}

/// One request's points for samples `base`, `base + 1`, ... (as many as `x` holds), in the
/// widest SIMD lanes the CPU has (`Simd::detect`).
fn column(base: u32, seed: u32, sx: u32, sy: u32, x: &mut [f32], y: &mut [f32]) {
    #[cfg(target_arch = "x86_64")]
    {
        // GFNI reverses the bits of every byte in one instruction (the compiler's vector
        // `reverse_bits` uses it); without, a reversal costs a dozen.
        let gfni = std::arch::is_x86_feature_detected!("gfni");
        match Simd::detect() {
            // SAFETY: (each arm) the level, and GFNI where used, were detected on this CPU.
            Simd::Avx512 if gfni => return unsafe { column_avx512_gfni(base, seed, sx, sy, x, y) },
            // SAFETY: Simd::Avx512 was detected on this CPU.
            Simd::Avx512 => return unsafe { column_avx512(base, seed, sx, sy, x, y) },
            // SAFETY: Simd::Avx2 and GFNI were detected on this CPU.
            Simd::Avx2 if gfni => return unsafe { column_avx2_gfni(base, seed, sx, sy, x, y) },
            // SAFETY: Simd::Avx2 was detected on this CPU.
            Simd::Avx2 => return unsafe { column_avx2(base, seed, sx, sy, x, y) },
            Simd::Portable => {}
        }
    }
    column_lanes(base, seed, sx, sy, x, y)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,gfni")]
unsafe fn column_avx2_gfni(base: u32, seed: u32, sx: u32, sy: u32, x: &mut [f32], y: &mut [f32]) {
    column_lanes(base, seed, sx, sy, x, y)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx2,gfni")]
unsafe fn column_avx512_gfni(base: u32, seed: u32, sx: u32, sy: u32, x: &mut [f32], y: &mut [f32]) {
    column_lanes(base, seed, sx, sy, x, y)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn column_avx2(base: u32, seed: u32, sx: u32, sy: u32, x: &mut [f32], y: &mut [f32]) {
    column_lanes(base, seed, sx, sy, x, y)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vl,avx2")]
unsafe fn column_avx512(base: u32, seed: u32, sx: u32, sy: u32, x: &mut [f32], y: &mut [f32]) {
    column_lanes(base, seed, sx, sy, x, y)
}

/// The loop of [`column`], written for the compiler to vectorise over samples: the formulas of
/// [`SobolSampler::next_2d`], without tables (the dimension-1 matrix as bit operations) and
/// with an integer-to-float conversion that has a vector instruction.
#[inline(always)]
fn column_lanes(base: u32, seed: u32, sx: u32, sy: u32, x: &mut [f32], y: &mut [f32]) {
    for (k, (x, y)) in x.iter_mut().zip(y.iter_mut()).enumerate() {
        let i = laine_karras(base.wrapping_add(k as u32).reverse_bits(), seed).reverse_bits();
        let unit = |v: u32| (v >> 8) as i32 as f32 * (1.0 / (1u32 << 24) as f32);
        *x = unit(laine_karras(i, sx).reverse_bits());
        *y = unit(laine_karras(sobol_dim1_reversed_bits(i), sy).reverse_bits());
    }
}

impl Sampler for SobolSampler {
    #[inline]
    fn start_sample(&mut self, index: u32) {
        self.index = index;
        self.index_reversed = index.reverse_bits();
        self.dimension = 0;
        if let Some(table) = &mut self.table {
            if index.wrapping_sub(table.base) >= table.len {
                // The block starts at the first sample drawn in it, not at a multiple of
                // BLOCK: a pass or a sample range that starts mid-block (32..64 of a time
                // limit's doubling passes) then fills only the columns' samples it draws.
                table.base = index;
                table.len = if table.base < self.spp {
                    (self.spp - table.base).min(BLOCK as u32)
                } else {
                    BLOCK as u32
                };
                table.filled = 0;
            }
        }
    }

    #[inline]
    fn resume_sample(&mut self, index: u32, requests: u32) {
        self.start_sample(index);
        self.dimension = requests;
    }

    /// The table's point inline (two loads), the rest out of line: not inlined, the call cost
    /// more than the lookup (a cbox render spent 4.7% of its instructions in `next_2d`).
    #[inline(always)]
    fn next_1d(&mut self) -> f32 {
        match self.tabled_point() {
            Some((x, _)) => x,
            None => self.untabled_1d(),
        }
    }

    #[inline(always)]
    fn next_2d(&mut self) -> glam::Vec2 {
        match self.tabled_point() {
            Some((x, y)) => glam::Vec2::new(x, y),
            None => self.untabled_2d(),
        }
    }

    /// Each sample's points read straight from the table's columns when its block is the
    /// table's and its requests are in the table (the wavefront's batch is one block): no
    /// per-sample restart (whose index reversal costs a dozen instructions) and one fill check
    /// per sample instead of one per request. Other samples are resumed one at a time.
    #[inline]
    fn next_2d_resumed<const R: usize>(
        &mut self,
        samples: impl Iterator<Item = (u32, u32)>,
        out: &mut Vec<[Vec2; R]>,
    ) {
        out.clear();
        for (index, requests) in samples {
            out.push([Vec2::ZERO; R]);
            let points = out.last_mut().expect("just pushed");
            let tabled = match self.table.as_deref_mut() {
                Some(table) => table.points(self.pixel_seed, index, requests, points),
                None => false,
            };
            if !tabled {
                self.resume_sample(index, requests);
                *points = std::array::from_fn(|_| self.next_2d());
            }
        }
    }
}

impl Table {
    /// Writes to `points` requests `requests..requests + R` of sample `index` (the points
    /// [`Sampler::next_2d`] draws there), if the table's block holds the sample and the
    /// requests are within [`TABLE_REQUESTS`] (computing columns not yet filled); whether it
    /// did. Written in place: returned by value, the points went through the stack.
    #[inline(always)]
    fn points<const R: usize>(
        &mut self,
        pixel_seed: u32,
        index: u32,
        requests: u32,
        points: &mut [Vec2; R],
    ) -> bool {
        let sample = index.wrapping_sub(self.base) as usize;
        let end = requests as usize + R;
        if sample >= self.len as usize || end > TABLE_REQUESTS {
            return false;
        }
        if end > self.filled as usize {
            self.fill(pixel_seed, requests + (R as u32).max(FILL_STEP));
        }
        let start = requests as usize;
        for (r, point) in points.iter_mut().enumerate() {
            *point = Vec2::new(self.x[start + r][sample], self.y[start + r][sample]);
        }
        true
    }
}

impl SobolSampler {
    /// [`Sampler::next_1d`] of a request the table does not hold.
    #[inline(never)]
    fn untabled_1d(&mut self) -> f32 {
        let seed = self.dimension_seed();
        let i = self.shuffled_index(seed);
        // Owen-scrambled Sobol dimension 0: owen(reverse(i)) = reverse(lk(i)).
        to_unit(laine_karras(i, axis_seeds(seed).0).reverse_bits())
    }

    /// [`Sampler::next_2d`] of a request the table does not hold.
    #[inline(never)]
    fn untabled_2d(&mut self) -> glam::Vec2 {
        let seed = self.dimension_seed();
        let i = self.shuffled_index(seed);
        let (sx, sy) = axis_seeds(seed);
        let x = laine_karras(i, sx).reverse_bits();
        // owen_scramble(sobol_dim1(i)), with the first bit reversal folded into the table.
        let y = laine_karras(sobol_dim1_reversed(i), sy).reverse_bits();
        glam::Vec2::new(to_unit(x), to_unit(y))
    }

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

/// `sobol_dim1(i).reverse_bits()` without tables. Sobol dimension 1's generator matrix is
/// Pascal's triangle mod 2: by Lucas' theorem, bit m of the reversed point is the XOR of the
/// index bits k whose positions contain m's bits (k & m == m). That superset sum is five
/// shift-mask-XOR steps, one per bit of the position.
#[inline(always)]
fn sobol_dim1_reversed_bits(i: u32) -> u32 {
    let mut v = i;
    v ^= (v >> 1) & 0x5555_5555;
    v ^= (v >> 2) & 0x3333_3333;
    v ^= (v >> 4) & 0x0f0f_0f0f;
    v ^= (v >> 8) & 0x00ff_00ff;
    v ^= (v >> 16) & 0x0000_ffff;
    v
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
    use crate::sampler::PcgSampler;

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

    /// `next_2d_resumed` gives, bit for bit, what resuming each sample and drawing it one
    /// request at a time gives: samples of the table's block and of others (before and after
    /// it, which move the table), requests from 0 to past the table's end, an odd count in no
    /// order; for the tabled sampler and the one-at-a-time one. And a 1D request's number is
    /// the x of the pair a 2D one draws there (the wavefront loop takes it so), for both
    /// samplers.
    #[test]
    fn resumed_batches_draw_the_one_at_a_time_points() {
        // First the middle block's samples with requests rising one at a time (each batch
        // reaching one column past the last), then a mix.
        let rising = (0..43u32).map(|k| (64 + k * 37 % 64, k));
        let samples: Vec<(u32, u32)> = (0..77u32)
            .map(|k| {
                let index = match k % 11 {
                    3 => 130 + k,          // a later block (spp 150: the partial one)
                    7 => k / 2,            // the first block again
                    _ => 64 + k * 29 % 64, // the middle block, in no order
                };
                (index, (k * 13) % 43) // requests 0..42: some cross TABLE_REQUESTS
            })
            .collect();
        let samples: Vec<(u32, u32)> = rising.chain(samples).collect();
        for mut batched in [SobolSampler::tabled(9, 5, 150), SobolSampler::new(9, 5)] {
            let mut single = batched.clone();
            for round in 0..2 {
                let mut out = Vec::new();
                batched.next_2d_resumed::<4>(samples.iter().copied(), &mut out);
                assert_eq!(out.len(), samples.len());
                for (&(index, requests), got) in samples.iter().zip(&out) {
                    single.resume_sample(index, requests);
                    let want: [Vec2; 4] = std::array::from_fn(|_| single.next_2d());
                    assert_eq!(
                        got.map(|v| v.to_array()),
                        want.map(|v| v.to_array()),
                        "sample {index}, requests {requests}, round {round}"
                    );
                }
            }
        }
        let mut a = SobolSampler::tabled(2, 8, 64);
        let mut b = PcgSampler::new(2, 8);
        for index in [0u32, 5, 63, 64, 200] {
            for requests in [0u32, 3, 39, 40, 41] {
                a.resume_sample(index, requests);
                let x = a.next_1d();
                a.resume_sample(index, requests);
                assert_eq!(x, a.next_2d().x, "Sobol sample {index}, request {requests}");
                b.resume_sample(index, requests);
                let x = b.next_1d();
                b.resume_sample(index, requests);
                assert_eq!(x, b.next_2d().x, "PCG sample {index}, request {requests}");
            }
        }
    }

    /// The table-free dimension 1 equals the tables' for every bit and for random indices.
    #[test]
    fn sobol_dimension_one_bit_operations_match_the_tables() {
        let mut rng = torrey_testkit::Rng::new(5);
        let bits = (0..32).map(|b| 1u32 << b);
        let random = (0..10_000).map(|_| (rng.range(0.0, 1.0) * 4_294_967_000.0) as u32);
        for i in bits.chain(random).chain([0, u32::MAX]) {
            assert_eq!(
                sobol_dim1_reversed_bits(i),
                sobol_dim1_reversed(i),
                "index {i}"
            );
        }
    }

    /// The tabled sampler draws exactly the points of the one-at-a-time one, with packets'
    /// out-of-order starts and resumes, across block boundaries, past the table's requests,
    /// when restarted for another pixel, and in passes that start mid-block, whatever the SIMD
    /// level.
    #[test]
    fn tabled_sampler_matches_the_one_at_a_time_points() {
        let spp = 150; // two full blocks and a partial one
        let mut tabled = SobolSampler::tabled(7, 3, spp);
        for pixel in [3u64, 1 << 40] {
            tabled.restart(7, pixel, spp);
            let mut plain = SobolSampler::new(7, pixel);
            for index in (0..spp).step_by(8) {
                // A packet: eight samples' first request, then each sample resumed.
                for k in index..(index + 8).min(spp) {
                    tabled.start_sample(k);
                    plain.start_sample(k);
                    assert_eq!(tabled.next_2d(), plain.next_2d(), "sample {k}");
                }
                for k in index..(index + 8).min(spp) {
                    tabled.resume_sample(k, 1);
                    plain.resume_sample(k, 1);
                    let requests = 1 + (k % 13) * 4; // paths of different lengths
                    for r in 0..requests {
                        if r % 4 == 3 {
                            assert_eq!(tabled.next_1d(), plain.next_1d(), "sample {k} {r}");
                        } else {
                            assert_eq!(tabled.next_2d(), plain.next_2d(), "sample {k} {r}");
                        }
                    }
                }
            }
        }
        // Passes and sample ranges that start mid-block (a block then starts at their first
        // sample), on a sampler restarted per pixel and pass as a render's tiles do.
        for range in [37..101u32, 101..150, 1..3, 3..4] {
            tabled.restart(7, 5, range.end);
            let mut plain = SobolSampler::new(7, 5);
            for k in range {
                tabled.start_sample(k);
                plain.start_sample(k);
                for r in 0..(k % 11) * 4 {
                    assert_eq!(tabled.next_2d(), plain.next_2d(), "sample {k} {r}");
                }
            }
        }
    }

    /// Every SIMD version of the column loop this CPU runs gives the portable loop's points
    /// (whichever level `Simd::detect` picks, the others are checked here too).
    #[test]
    fn column_kernels_agree() {
        let reference = |base| {
            let (mut x, mut y) = ([0.0f32; BLOCK], [0.0f32; BLOCK]);
            column_lanes(base, 11, 22, 33, &mut x, &mut y);
            (x, y)
        };
        for base in [0u32, 64, 4_294_967_232] {
            let want = reference(base);
            #[cfg(target_arch = "x86_64")]
            {
                let (mut x, mut y) = ([0.0f32; BLOCK], [0.0f32; BLOCK]);
                if crate::accel::x86_64::avx2::available() {
                    // SAFETY: checked just above.
                    unsafe { column_avx2(base, 11, 22, 33, &mut x, &mut y) };
                    assert_eq!((x, y), want, "avx2, base {base}");
                }
                if crate::accel::x86_64::avx512::available() {
                    // SAFETY: checked just above.
                    unsafe { column_avx512(base, 11, 22, 33, &mut x, &mut y) };
                    assert_eq!((x, y), want, "avx512, base {base}");
                }
            }
            // And the portable loop gives the reference formulas' points.
            for (k, (&x, &y)) in want.0.iter().zip(&want.1).enumerate() {
                let i = laine_karras((base + k as u32).reverse_bits(), 11).reverse_bits();
                assert_eq!(x, to_unit(laine_karras(i, 22).reverse_bits()));
                assert_eq!(
                    y,
                    to_unit(owen_scramble(sobol_dim1(i), 33)),
                    "base {base} k {k}"
                );
            }
        }
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
