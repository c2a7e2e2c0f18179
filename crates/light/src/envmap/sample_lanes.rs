//! [`EnvMap::sample_batch`]: [`EnvMap::sample`] for many random pairs at once, in SIMD lanes.
//!
//! The one-sample code is a chain of dependent steps (two alias picks, four density reads, two
//! square-root warps, two sine/cosine polynomials, a bilinear radiance lookup) with little
//! parallelism inside it. Run over [`BATCH_LANES`] samples side by side, each step is one
//! vector instruction for all of them and the table reads become gathers. Every lane does the
//! one-sample code's operations in its order (no fused multiply-adds, no approximate
//! reciprocals), so the results are its bits; the rare lanes the lane code does not cover (a
//! coordinate outside the unit square, which the sampler never produces) take the one-sample
//! code itself.

use super::{row_v, sample_linear, BatchSimd, EnvMap, EnvSample, BATCH_LANES};
use crate::alias::AliasSlot;
use crate::unit::{clamp_unit, ONE_MINUS_EPSILON};
use glam::{Vec2, Vec3};
use torrey_fastmath as fastmath;

const LANES: usize = BATCH_LANES;

/// How many chunks of [`LANES`] samples ahead `sample_batch` hints the tables' reads.
const PREFETCH_CHUNKS: usize = 1;

/// One step of samples in structure-of-arrays form: the random pairs in, the samples out.
#[derive(Default)]
struct SampleLanes {
    ux: [f32; LANES],
    uy: [f32; LANES],
    dir_x: [f32; LANES],
    dir_y: [f32; LANES],
    dir_z: [f32; LANES],
    red: [f32; LANES],
    green: [f32; LANES],
    blue: [f32; LANES],
    pdf: [f32; LANES],
    /// The lane's result is not valid: the one-sample code decides it.
    fallback: [bool; LANES],
}

/// `t as i32` for a lane: a plain truncating conversion (one vector instruction for all lanes)
/// in place of the saturating `as`, whose NaN and range fix-ups the compiler builds lane by
/// lane. `t` is first clamped into [`lo`, `hi`] (NaN to `lo`); callers pass a range that holds
/// every `t` whose result they use, so those results are `as`'s.
#[inline(always)]
fn trunc_lane(t: f32, lo: f32, hi: f32) -> i32 {
    let t = t.max(lo).min(hi);
    debug_assert!(lo >= -2147483648.0 && hi < 2147483648.0);
    // SAFETY: `t` is finite (max of NaN and `lo` is `lo`) and in [lo, hi], inside i32's range
    // (every caller's bounds are).
    unsafe { t.to_int_unchecked::<i32>() }
}

/// [`super::floor_frac`] for a lane whose `t` matters only in [-2, 2^24] (texel coordinates of
/// a lookup inside the map); others give garbage, without undefined behaviour.
#[inline(always)]
fn floor_frac_lane(t: f32) -> (i32, f32) {
    let k = trunc_lane(t, -2.0, 16_777_216.0);
    let k = if k as f32 > t { k - 1 } else { k };
    (k, t - k as f32)
}

/// The first half of [`crate::alias::pick`] on a table of `n` slots, for a lane: the slot to
/// read and the fraction of `u` left.
#[inline(always)]
fn pick_slot(n: u32, u: f32) -> (u32, f32) {
    let t = u * n as f32;
    // t is in [0, n) (u in [0, 1)), below 2^31: the signed conversion (one AVX2 instruction, the
    // unsigned one a sequence) gives `t as u32`; a compare and select rather than `Ord::min`,
    // whose three-way compare the loop vectoriser does not take.
    let k = trunc_lane(t, 0.0, n as f32) as u32;
    let k = if k < n - 1 { k } else { n - 1 };
    let frac = (t - k as f32).min(ONE_MINUS_EPSILON);
    (k, frac)
}

/// The second half of [`crate::alias::pick`], given the slot `k` read (`q`, `alias`): the
/// chosen index and the rest of `u`. Plain selects, which become blends across lanes.
#[inline(always)]
fn pick_choose(k: u32, frac: f32, q: f32, alias: u32) -> (u32, f32) {
    let own = frac < q;
    let index = if own { k } else { alias };
    let lo = if own { 0.0 } else { q };
    let width = if own { q } else { 1.0 - q };
    let rest = ((frac - lo) / width).clamp(0.0, ONE_MINUS_EPSILON);
    (index, rest)
}

/// [`fastmath::sin_cos_2pi`] for `t` in [0, 1], and whether `t` was (other `t` give garbage).
#[inline(always)]
fn sin_cos_2pi_lane(t: f32) -> (f32, f32, bool) {
    let inside = (0.0..=1.0).contains(&t);
    // Saturating, so garbage in is garbage out, not undefined behaviour.
    let q = trunc_lane(4.0 * t + 0.5, -8.0, 8.0);
    let (s, c) = fastmath::sin_cos_eighth((t - q as f32 * 0.25) * (2.0 * std::f32::consts::PI));
    let q = q as u32;
    let (a, b) = if q & 1 != 0 { (c, s) } else { (s, c) };
    let sin_sign = (q & 2) << 30;
    let cos_sign = ((q + 1) & 2) << 30;
    (
        f32::from_bits(a.to_bits() ^ sin_sign),
        f32::from_bits(b.to_bits() ^ cos_sign),
        inside,
    )
}

/// The four texel records and the two weights of `EnvMap::bilinear_finest_with_density` at `uv`
/// (`BilinearTaps::new`'s arithmetic, with `f32::clamp` spelt out: its check of the bounds, a
/// panic, would keep a loop out of SIMD lanes), and whether `uv` is in the range it covers (else
/// the records are 0 and the caller redoes the lane with the one-sample code).
#[inline(always)]
fn finest_taps(env: &EnvMap, uv: Vec2) -> ([u32; 4], f32, f32, bool) {
    let half = 0.5 * env.inv_size.y;
    let mut v = row_v(uv.y, env.size.y);
    if v < half {
        v = half;
    }
    if v > 1.0 - half {
        v = 1.0 - half;
    }
    let x = uv.x * env.size.x - 0.5;
    let y = v * env.size.y - 0.5;
    let ok = x >= -1.0 && x < env.size.x && y >= -1.0 && y < env.size.y;
    let (i, fx) = floor_frac_lane(x);
    let (j, fy) = floor_frac_lane(y);
    let (w, h) = (env.width as i32, env.height as i32);
    let (c0, c1) = (
        if i < 0 { w - 1 } else { i },
        if i + 1 >= w { 0 } else { i + 1 },
    );
    let (r0, r1) = (
        if j < 0 { h - 1 } else { j },
        if j + 1 >= h { 0 } else { j + 1 },
    );
    let index = |r: i32, c: i32| if ok { (r * w + c) as u32 } else { 0 };
    (
        [index(r0, c0), index(r0, c1), index(r1, c0), index(r1, c1)],
        fx,
        fy,
        ok,
    )
}

/// One component of the bilinear interpolation of four texel records (top-left, top-right,
/// bottom-left, bottom-right): the `Vec4` arithmetic of `bilinear_finest_with_density`, on
/// plain floats (a `Vec4` is an SSE register type, which the loop vectoriser cannot put in
/// lanes).
#[inline(always)]
fn bilerp(t: [f32; 4], fx: f32, fy: f32) -> f32 {
    let top = t[0] * (1.0 - fx) + t[1] * fx;
    let bottom = t[2] * (1.0 - fx) + t[3] * fx;
    top * (1.0 - fy) + bottom * fy
}

/// What a lane's sample needs after its patch and the density at the patch's corners: the
/// bilinear warp, the direction, the density, and the radiance lookup's taps.
struct Warped {
    dir: Vec3,
    pdf: f32,
    /// The bilinear lookup's four texel records (top-left, top-right, bottom-left,
    /// bottom-right), and its weights.
    taps: [u32; 4],
    fx: f32,
    fy: f32,
    /// The lane left the range the lane code covers: the one-sample code decides it.
    fallback: bool,
}

/// The texel records of patch (`row`, `column`)'s corners, in `EnvMap::sample`'s order.
#[inline(always)]
fn patch_corners(env: &EnvMap, row: u32, column: u32) -> [u32; 4] {
    let width = env.width as u32;
    let column1 = if column + 1 == width { 0 } else { column + 1 };
    let (top, bottom) = (row * width, (row + 1) * width);
    [
        top + column,
        top + column1,
        bottom + column,
        bottom + column1,
    ]
}

/// `EnvMap::sample` from the chosen patch on: the warp inside it (corner densities `w`), the
/// direction and its density, and the taps of `EnvMap::bilinear_finest` (`BilinearTaps::new`'s
/// arithmetic).
#[inline(always)]
fn warp(
    env: &EnvMap,
    row: u32,
    column: u32,
    v_in_patch: f32,
    u_in_patch: f32,
    w: [f32; 4],
) -> Warped {
    let [w00, w10, w01, w11] = w;
    let t = sample_linear(w00 + w10, w01 + w11, v_in_patch);
    let (left, right) = (w00 * (1.0 - t) + w01 * t, w10 * (1.0 - t) + w11 * t);
    let s = sample_linear(left, right, u_in_patch);
    let p_uv = left * (1.0 - s) + right * s;
    let mut su = (column as f32 + 0.5 + s) * env.inv_size.x;
    if su >= 1.0 {
        su -= 1.0;
    }
    let uv = Vec2::new(su, (row as f32 + t) * env.inv_bands).min(Vec2::splat(ONE_MINUS_EPSILON));
    // `EnvMap::uv_to_local_dir_sin`.
    let (sin_theta, cos_theta, theta_ok) = sin_cos_2pi_lane(0.5 * uv.y);
    let (sin_phi, cos_phi, phi_ok) = sin_cos_2pi_lane(uv.x);
    let local = Vec3::new(sin_phi * sin_theta, cos_theta, -cos_phi * sin_theta);
    let pdf = EnvMap::solid_angle_pdf(p_uv, sin_theta);
    let dir = env.to_world * local;
    let (taps, fx, fy, taps_ok) = finest_taps(env, uv);
    Warped {
        dir,
        pdf,
        taps,
        fx,
        fy,
        fallback: !(theta_ok && phi_ok && taps_ok),
    }
}

/// The bilinear interpolation of the taps' radiance (`bilinear_finest`), times the map's scale.
#[inline(always)]
fn interpolate(env: &EnvMap, rgb: [Vec3; 4], fx: f32, fy: f32) -> Vec3 {
    let c = |c: usize| bilerp([rgb[0][c], rgb[1][c], rgb[2][c], rgb[3][c]], fx, fy);
    Vec3::new(c(0), c(1), c(2)) * env.scale
}

/// The table reads, each the caller's SAFETY: an alias table's slot is below its length and its
/// aliases are its indices (`build_slots`); `row_slots` is one table of `height - 1` slots, so a
/// picked row is a band and `column_slots` holds one table of `width` slots per band; the
/// corners of a patch (a band's row and the next, columns below width) and the taps of
/// [`warp`] (rows below height, columns below width, or 0) are records of `texels`, which holds
/// width x height of them.
struct Tables {
    rows: *const AliasSlot,
    columns: *const AliasSlot,
    /// The records as plain floats: a `Vec4` is an SSE register type, which the loop
    /// vectoriser cannot put in lanes.
    texels: *const [f32; 4],
}

impl Tables {
    #[inline(always)]
    fn new(env: &EnvMap) -> Self {
        Self {
            rows: env.row_slots.as_ptr(),
            columns: env.column_slots.as_ptr(),
            texels: env.texels.as_ptr() as *const [f32; 4],
        }
    }

    /// # Safety
    /// `k` is a slot of the row table.
    #[inline(always)]
    unsafe fn row_slot(&self, k: u32) -> AliasSlot {
        // SAFETY: the caller's contract: `k` is below the row table's length; `rows` points at
        // `env.row_slots`, which the `&EnvMap` these tables were made from keeps alive while they
        // are used.
        unsafe { *self.rows.add(k as usize) }
    }

    /// # Safety
    /// `k` is a slot of the column tables.
    #[inline(always)]
    unsafe fn column_slot(&self, k: u32) -> AliasSlot {
        // SAFETY: the caller's contract: `k` is below the column tables' length; `columns` points
        // at `env.column_slots`, which the `&EnvMap` these tables were made from keeps alive while
        // they are used.
        unsafe { *self.columns.add(k as usize) }
    }

    /// # Safety
    /// `k` is a texel record.
    #[inline(always)]
    unsafe fn texel(&self, k: u32) -> [f32; 4] {
        // SAFETY: the caller's contract: `k` is below `texels`' length (width x height records);
        // `texels` points at `env.texels`, which the `&EnvMap` these tables were made from keeps
        // alive while they are used.
        unsafe { *self.texels.add(k as usize) }
    }
}

impl SampleLanes {
    /// [`EnvMap::sample`] on every lane (a samplable map), unused lanes included (they hold
    /// (0, 0), a valid pair), in one loop over the lanes: AVX-512's, where the table reads
    /// become gathers.
    #[inline(always)]
    fn body_fused(&mut self, env: &EnvMap) {
        let tables = Tables::new(env);
        let (row_count, width) = (env.row_slots.len() as u32, env.width as u32);
        for k in 0..LANES {
            let (slot, frac) = pick_slot(row_count, clamp_unit(self.uy[k]));
            // SAFETY: `slot` is below `row_count`, the row table's length (`pick_slot` keeps it
            // below n); see `Tables`.
            let s = unsafe { tables.row_slot(slot) };
            let (row, v_in_patch) = pick_choose(slot, frac, s.q, s.alias);
            let (slot, frac) = pick_slot(width, clamp_unit(self.ux[k]));
            // SAFETY: `row` is a slot of the row table or its alias (an index of that table,
            // `build_slots`), so a band, below height - 1; `slot` is below width (`pick_slot`);
            // `column_slots` holds width slots per band (see `Tables`).
            let s = unsafe { tables.column_slot(row * width + slot) };
            let (column, u_in_patch) = pick_choose(slot, frac, s.q, s.alias);
            // (Arrays spelt out rather than mapped: `map` keeps the loop scalar.)
            let c = patch_corners(env, row, column);
            // SAFETY: the corners of patch (`row`, `column`), a band and a column below width, are
            // records of rows `row` and `row + 1` < height and columns below width
            // (`patch_corners`), inside `texels` (see `Tables`).
            let density = |i: u32| unsafe { tables.texel(i)[3] };
            let w = [density(c[0]), density(c[1]), density(c[2]), density(c[3])];
            let warped = warp(env, row, column, v_in_patch, u_in_patch, w);
            let rgb = |i: u32| {
                // SAFETY: the taps of `warp` (`finest_taps`) are 0 or records of rows below height
                // and columns below width, inside `texels` (see `Tables`).
                let t = unsafe { tables.texel(i) };
                Vec3::new(t[0], t[1], t[2])
            };
            let t = warped.taps;
            let rgb = [rgb(t[0]), rgb(t[1]), rgb(t[2]), rgb(t[3])];
            let radiance = interpolate(env, rgb, warped.fx, warped.fy);
            self.store(k, &warped, radiance);
        }
    }

    /// [`Self::body_fused`] with the table reads and the arithmetic in separate loops over the
    /// lanes: for AVX2 and the portable code, where one loop holding both stays scalar (the
    /// compiler finds gathers too dear there), while these arithmetic loops become SIMD code.
    #[inline(always)]
    fn body_split(&mut self, env: &EnvMap) {
        let tables = Tables::new(env);
        let (row_count, width) = (env.row_slots.len() as u32, env.width as u32);
        let mut slot = [0u32; LANES];
        let mut frac = [0f32; LANES];
        let mut q = [0f32; LANES];
        let mut alias = [0u32; LANES];
        let mut row = [0u32; LANES];
        let mut column = [0u32; LANES];
        let mut v_in_patch = [0f32; LANES];
        let mut u_in_patch = [0f32; LANES];
        let mut texel = [[0u32; LANES]; 4];
        let mut weight = [[0f32; LANES]; 4];
        let mut fx = [0f32; LANES];
        let mut fy = [0f32; LANES];
        let mut rgb = [[[0f32; LANES]; 3]; 4];
        for k in 0..LANES {
            (slot[k], frac[k]) = pick_slot(row_count, clamp_unit(self.uy[k]));
        }
        for k in 0..LANES {
            // SAFETY: `slot[k]` is below `row_count`, the row table's length (`pick_slot` keeps it
            // below n); see `Tables`.
            let s = unsafe { tables.row_slot(slot[k]) };
            (q[k], alias[k]) = (s.q, s.alias);
        }
        // (Separate arrays for the column pick: rewriting the row pick's in place leaves the
        // loop scalar.)
        let mut column_slot = [0u32; LANES];
        let mut column_frac = [0f32; LANES];
        for k in 0..LANES {
            (row[k], v_in_patch[k]) = pick_choose(slot[k], frac[k], q[k], alias[k]);
            (column_slot[k], column_frac[k]) = pick_slot(width, clamp_unit(self.ux[k]));
        }
        for k in 0..LANES {
            // SAFETY: `row[k]` is a slot of the row table or its alias (an index of that table,
            // `build_slots`), so a band, below height - 1; `column_slot[k]` is below width
            // (`pick_slot`); `column_slots` holds width slots per band (see `Tables`).
            let s = unsafe { tables.column_slot(row[k] * width + column_slot[k]) };
            (q[k], alias[k]) = (s.q, s.alias);
        }
        for k in 0..LANES {
            (column[k], u_in_patch[k]) =
                pick_choose(column_slot[k], column_frac[k], q[k], alias[k]);
            let c = patch_corners(env, row[k], column[k]);
            // Four stores spelt out: a loop over them leaves the lanes' loop scalar.
            (texel[0][k], texel[1][k], texel[2][k], texel[3][k]) = (c[0], c[1], c[2], c[3]);
        }
        for n in 0..4 {
            for k in 0..LANES {
                // SAFETY: `texel[n][k]` is a corner of a patch (`patch_corners` of a band and a
                // column below width): a record of a row below height and a column below width,
                // inside `texels` (see `Tables`).
                weight[n][k] = unsafe { tables.texel(texel[n][k])[3] };
            }
        }
        for k in 0..LANES {
            let w = [weight[0][k], weight[1][k], weight[2][k], weight[3][k]];
            let warped = warp(env, row[k], column[k], v_in_patch[k], u_in_patch[k], w);
            let t = warped.taps;
            (texel[0][k], texel[1][k], texel[2][k], texel[3][k]) = (t[0], t[1], t[2], t[3]);
            (fx[k], fy[k]) = (warped.fx, warped.fy);
            self.store(k, &warped, Vec3::ZERO);
        }
        for n in 0..4 {
            for k in 0..LANES {
                // SAFETY: `texel[n][k]` now holds the taps of `warp` (`finest_taps`): 0 or records
                // of rows below height and columns below width, inside `texels` (see `Tables`).
                let t = unsafe { tables.texel(texel[n][k]) };
                (rgb[n][0][k], rgb[n][1][k], rgb[n][2][k]) = (t[0], t[1], t[2]);
            }
        }
        for k in 0..LANES {
            let tap = |n: usize| Vec3::new(rgb[n][0][k], rgb[n][1][k], rgb[n][2][k]);
            let radiance = interpolate(env, [tap(0), tap(1), tap(2), tap(3)], fx[k], fy[k]);
            (self.red[k], self.green[k], self.blue[k]) = (radiance.x, radiance.y, radiance.z);
        }
    }

    /// Lane `k`'s results.
    #[inline(always)]
    fn store(&mut self, k: usize, warped: &Warped, radiance: Vec3) {
        (self.dir_x[k], self.dir_y[k], self.dir_z[k]) = (warped.dir.x, warped.dir.y, warped.dir.z);
        (self.red[k], self.green[k], self.blue[k]) = (radiance.x, radiance.y, radiance.z);
        self.pdf[k] = warped.pdf;
        self.fallback[k] = warped.fallback;
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn body_avx2(&mut self, env: &EnvMap) {
        self.body_split(env)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx2,fma")]
    fn body_avx512(&mut self, env: &EnvMap) {
        self.body_fused(env)
    }

    fn body_portable(&mut self, env: &EnvMap) {
        self.body_split(env)
    }

    #[inline]
    fn run(&mut self, env: &EnvMap, simd: BatchSimd) {
        match simd {
            #[cfg(target_arch = "x86_64")]
            BatchSimd::Avx512 if is_x86_feature_detected!("avx512f") => {
                // SAFETY: the CPU has AVX-512 F (checked).
                unsafe { self.body_avx512(env) }
            }
            #[cfg(target_arch = "x86_64")]
            BatchSimd::Avx2 | BatchSimd::Avx512
                if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") =>
            {
                // SAFETY: the CPU has AVX2 and FMA (checked).
                unsafe { self.body_avx2(env) }
            }
            _ => self.body_portable(env),
        }
    }
}

impl EnvMap {
    /// [`Self::sample`] of each pair of `us`, bit for bit, into `out` (cleared first), computed
    /// [`BATCH_LANES`] at a time in SIMD lanes (`simd` picks the instruction set the CPU was
    /// found to have; see the module doc).
    pub fn sample_batch(&self, us: &[Vec2], simd: BatchSimd, out: &mut Vec<Option<EnvSample>>) {
        out.clear();
        if !self.samplable {
            out.resize(us.len(), None);
            return;
        }
        // The slot and texel tables are megabytes read at random: the next chunks' reads are
        // hinted (`prefetch_sample`) while this one is computed, so their cache misses overlap
        // it rather than stall its gathers.
        let hint = |c: usize| {
            let start = (c * LANES).min(us.len());
            for &u in &us[start..(start + LANES).min(us.len())] {
                self.prefetch_sample(u);
            }
        };
        for c in 0..PREFETCH_CHUNKS {
            hint(c);
        }
        for (c, chunk) in us.chunks(LANES).enumerate() {
            hint(c + PREFETCH_CHUNKS);
            let mut lanes = SampleLanes::default();
            for (k, u) in chunk.iter().enumerate() {
                (lanes.ux[k], lanes.uy[k]) = (u.x, u.y);
            }
            lanes.run(self, simd);
            for (k, &u) in chunk.iter().enumerate() {
                out.push(if lanes.fallback[k] {
                    self.sample(u)
                } else if lanes.pdf[k] <= 0.0 {
                    None
                } else {
                    Some(EnvSample {
                        direction: Vec3::new(lanes.dir_x[k], lanes.dir_y[k], lanes.dir_z[k]),
                        radiance: Vec3::new(lanes.red[k], lanes.green[k], lanes.blue[k]),
                        pdf: lanes.pdf[k],
                    })
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat3;
    use torrey_testkit::Rng;
    use torrey_texture::Image;

    /// A map of `w` x `h` with smooth structure, a sun of 2000 and, when `dark_middle`, only the
    /// rows next to the poles lit (samples near the zenith and the nadir).
    fn map(w: u32, h: u32, dark_middle: bool) -> Image {
        let px = (0..w * h)
            .map(|k| {
                let (i, j) = (k % w, k / w);
                if dark_middle && j != 1 && j + 2 != h {
                    return glam::Vec3::ZERO;
                }
                let c = glam::Vec3::new(
                    0.2 + 0.8 * (i as f32 / w as f32),
                    0.1 + (j as f32 * 0.7).sin().abs(),
                    0.3 + ((i + 2 * j) % 5) as f32 * 0.2,
                );
                if (i, j) == (w / 3, h / 4) {
                    c * 2000.0
                } else {
                    c
                }
            })
            .collect();
        Image::new(w, h, px)
    }

    fn bits(s: Option<EnvSample>) -> Option<([u32; 3], [u32; 3], u32)> {
        s.map(|s| {
            (
                s.direction.to_array().map(f32::to_bits),
                s.radiance.to_array().map(f32::to_bits),
                s.pdf.to_bits(),
            )
        })
    }

    /// The batch gives `sample`'s bits at every SIMD level (the levels this CPU lacks run the
    /// portable code), for random pairs and the edges of the unit square, on maps with a sun,
    /// with only the rows next to the poles lit, one column wide, two rows high, rotated or not,
    /// and black; batch lengths that fill and do not fill the lanes.
    #[test]
    fn sample_batch_matches_sample_bit_for_bit() {
        let mut rng = Rng::new(31);
        let top = ONE_MINUS_EPSILON;
        let mut us: Vec<Vec2> = (0..1500).map(|_| rng.vec2()).collect();
        for a in [
            0.0,
            top,
            1.0,
            0.5,
            1e-30,
            top.next_down(),
            -0.25,
            1.5,
            f32::NAN,
        ] {
            for b in [0.0, top, 0.5, 1e-7, f32::NAN] {
                us.extend([Vec2::new(a, b), Vec2::new(b, a)]);
            }
        }
        let rotation = Mat3::from_axis_angle(Vec3::new(1.0, 2.0, -0.5).normalize(), 0.9);
        let maps = [
            (map(64, 32, false), Mat3::IDENTITY),
            (map(64, 32, false), rotation),
            (map(16, 8, true), rotation),
            (map(1, 5, false), Mat3::IDENTITY),
            (map(7, 2, false), rotation),
            (Image::filled(8, 4, Vec3::ZERO), Mat3::IDENTITY),
        ];
        let mut out = Vec::new();
        for (image, to_world) in maps {
            let env = EnvMap::new(image, 1.5, to_world);
            let want: Vec<_> = us.iter().map(|&u| bits(env.sample(u))).collect();
            for simd in [BatchSimd::Portable, BatchSimd::Avx2, BatchSimd::Avx512] {
                for len in [us.len(), 16, 5, 1, 0] {
                    env.sample_batch(&us[..len], simd, &mut out);
                    assert_eq!(out.len(), len);
                    for (k, &s) in out.iter().enumerate() {
                        assert_eq!(bits(s), want[k], "{simd:?} u {}", us[k]);
                    }
                }
            }
        }
    }
}
