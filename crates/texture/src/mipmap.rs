//! Box-filtered mip pyramids and filtered lookups into them.
//!
//! Each coarser level is an exact box-filter resampling of the one above (fractional weights for
//! odd and non-power-of-two sizes), so every level keeps the mean of the original image and a
//! pattern averages out instead of aliasing when the renderer asks for a wide footprint.

use std::borrow::Cow;

use glam::{Vec2, Vec3, Vec3A};

use crate::image::{Codes8, Image};
use crate::packed::{LodLookup, PackedLevel, Texels};

/// How texel indices outside the image are mapped back inside; applied per axis to integer
/// texel indices so bilinear neighbours wrap the same way as the lookup point.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum WrapMode {
    /// Tile the image (Mitsuba's default `repeat`).
    #[default]
    Repeat,
    /// Tile with every other copy flipped, so the edges always match.
    Mirror,
    /// Extend the edge texels outward.
    Clamp,
}

/// How texels are combined: bilinear (with trilinear mip blending) or nearest-texel at level 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum FilterType {
    /// Bilinear within a level and linear between levels (Mitsuba's default `bilinear`).
    #[default]
    Bilinear,
    /// The nearest texel of the finest level; no pyramid blending (crisp pixel-art look).
    Nearest,
}

impl WrapMode {
    /// Maps an integer texel index into `0..n` (`n >= 1`).
    #[inline]
    fn apply(self, i: i64, n: i64) -> i64 {
        if (0..n).contains(&i) {
            return i; // the common case: no division
        }
        match self {
            WrapMode::Repeat => i.rem_euclid(n),
            WrapMode::Clamp => i.clamp(0, n - 1),
            WrapMode::Mirror => {
                let m = i.rem_euclid(2 * n);
                if m >= n {
                    2 * n - 1 - m
                } else {
                    m
                }
            }
        }
    }

    /// `(apply(i, n), apply(i + 1, n))` for a bilinear pair of neighbours, `n >= 1`: no wrapping
    /// at all when both are inside (the common case), at most one division otherwise.
    #[inline]
    pub(crate) fn apply_pair(self, i: i32, n: u32) -> (usize, usize) {
        // `i as u32` maps negatives above `u32::MAX / 2`, so one compare covers 0 <= i < n - 1.
        if (i as u32) < n - 1 {
            return (i as usize, i as usize + 1);
        }
        self.apply_pair_outside(i, n)
    }

    #[inline]
    fn apply_pair_outside(self, i: i32, n: u32) -> (usize, usize) {
        if n > i32::MAX as u32 / 2 {
            // Not reachable for real images; the general i64 path keeps it exact.
            let (i, n) = (i as i64, n as i64);
            return (self.apply(i, n) as usize, self.apply(i + 1, n) as usize);
        }
        // `i` comes from a float below 2^23 in magnitude, so `i + 1` and `2 * n` fit in i32.
        let n = n as i32;
        let (a, b) = match self {
            WrapMode::Repeat => {
                // Power-of-two sizes (most textures and their mip levels) need no division:
                // two's complement `&` is rem_euclid there.
                let a = if n & (n - 1) == 0 {
                    i & (n - 1)
                } else {
                    i.rem_euclid(n)
                };
                (a, if a + 1 == n { 0 } else { a + 1 })
            }
            WrapMode::Clamp => (i.clamp(0, n - 1), (i + 1).clamp(0, n - 1)),
            WrapMode::Mirror => {
                let m = if n & (n - 1) == 0 {
                    i & (2 * n - 1)
                } else {
                    i.rem_euclid(2 * n)
                };
                let m1 = if m + 1 == 2 * n { 0 } else { m + 1 };
                let fold = |m: i32| if m >= n { 2 * n - 1 - m } else { m };
                (fold(m), fold(m1))
            }
        };
        (a as usize, b as usize)
    }
}

/// A mip pyramid: level 0 is the image itself, each next level about half the size, down to 1x1.
#[derive(Clone, Debug)]
pub struct MipMap {
    levels: Levels,
    wrap: WrapMode,
    filter: FilterType,
}

/// Where a pyramid's texels are: one copy, in one of two layouts.
#[derive(Clone, Debug)]
enum Levels {
    /// Three floats per texel.
    Rgb(Vec<Image>),
    /// 16-byte texels ([`MipMap::with_packed_texels`]).
    Packed(Box<[PackedLevel]>),
}

/// One level's texels, row by row from the top, whichever their layout.
#[derive(Clone, Copy)]
struct LevelTexels<'a> {
    width: u32,
    height: u32,
    data: TexelData<'a>,
}

#[derive(Clone, Copy)]
enum TexelData<'a> {
    Rgb(&'a [Vec3]),
    Packed(&'a Texels),
}

impl LevelTexels<'_> {
    /// Texel `k` (row-major); panics past the end.
    #[inline(always)]
    fn get(&self, k: usize) -> Vec3 {
        match self.data {
            TexelData::Rgb(px) => px[k],
            TexelData::Packed(px) => px.get(k).into(),
        }
    }

    /// Texel `k` without the bounds check.
    ///
    /// # Safety
    /// `k < width * height` (every level holds that many texels).
    #[inline(always)]
    unsafe fn get_unchecked(&self, k: usize) -> Vec3 {
        // SAFETY: the caller's k < width * height, and both layouts hold that many texels.
        unsafe {
            match self.data {
                TexelData::Rgb(px) => *px.get_unchecked(k),
                TexelData::Packed(px) => px.get_unchecked(k).into(),
            }
        }
    }
}

/// For one axis of a box-filter downsample from `src` to `dst` texels: for each destination
/// texel, the source texels it covers and their weights (summing to 1). A destination texel
/// spans `src / dst` source texels, so an odd size gets a 3-texel window with fractional ends.
fn box_weights(src: usize, dst: usize) -> Vec<Vec<(usize, f32)>> {
    let scale = src as f64 / dst as f64;
    (0..dst)
        .map(|i| {
            let lo = i as f64 * scale;
            let hi = (i + 1) as f64 * scale;
            let first = lo.floor() as usize;
            let last = (hi.ceil() as usize).min(src);
            (first..last)
                .filter_map(|j| {
                    let overlap = (hi.min(j as f64 + 1.0) - lo.max(j as f64)).max(0.0);
                    (overlap > 1e-12).then_some((j, (overlap / scale) as f32))
                })
                .collect()
        })
        .collect()
}

/// One exact box-filter step: each axis halves (rounding down, never below 1).
fn downsample(img: &Image) -> Image {
    let (w, h) = (img.width as usize, img.height as usize);
    let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
    let wx = box_weights(w, nw);
    let wy = box_weights(h, nh);
    // Horizontal pass into an nw x h buffer, then vertical pass; rows in parallel (a large
    // texture's pyramid is the longest single task of a scene's build).
    use rayon::prelude::*;
    const ROWS: usize = 16;
    let mut tmp = vec![Vec3::ZERO; nw * h];
    tmp.par_chunks_mut(nw)
        .with_min_len(ROWS)
        .enumerate()
        .for_each(|(y, out_row)| {
            let row = &img.pixels[y * w..(y + 1) * w];
            for (out, taps) in out_row.iter_mut().zip(&wx) {
                *out = taps.iter().map(|&(j, k)| row[j] * k).sum();
            }
        });
    let mut out = vec![Vec3::ZERO; nw * nh];
    out.par_chunks_mut(nw)
        .with_min_len(ROWS)
        .zip(&wy)
        .for_each(|(out_row, taps)| {
            for (x, out) in out_row.iter_mut().enumerate() {
                *out = taps.iter().map(|&(j, k)| tmp[j * nw + x] * k).sum();
            }
        });
    Image::new(nw as u32, nh as u32, out)
}

impl MipMap {
    /// Builds the whole pyramid up front (about 1/3 more memory than the image) so lookups never
    /// allocate. An empty image is replaced by a single black texel rather than panicking later.
    pub fn new(image: Image, wrap: WrapMode, filter: FilterType) -> Self {
        let image = if image.width == 0 || image.height == 0 || image.pixels.is_empty() {
            Image::filled(1, 1, Vec3::ZERO)
        } else {
            image
        };
        // Every level then holds at least width * height texels (level 0 checked here, the
        // others are built that size), which the lookups rely on.
        assert!(
            image.pixels.len() >= image.width as usize * image.height as usize,
            "image has fewer pixels than width * height"
        );
        let mut levels = vec![image];
        loop {
            let last = levels.last().expect("at least one level");
            if last.width == 1 && last.height == 1 {
                break;
            }
            let next = downsample(last);
            levels.push(next);
        }
        Self {
            levels: Levels::Rgb(levels),
            wrap,
            filter,
        }
    }

    /// The pyramid with its levels as 16-byte texels instead of three floats, which the filtered
    /// lookups (`lookup_lod_a`, [`MipMap::lookup_aniso`]) read with one aligned load each: the
    /// same values to the bit, about half the instructions per bilinear lookup, for 16/12 of the
    /// memory (an 8-bit image's finest level less: [`MipMap::with_packed_texels_from`]). One
    /// copy only (a textured interior's pyramids are hundreds of megabytes). For the renderer's
    /// bitmaps with bilinear filtering; an environment map keeps its own texel records.
    pub fn with_packed_texels(self) -> Self {
        self.with_packed_texels_from(None)
    }

    /// [`MipMap::with_packed_texels`], the finest level kept as `codes` (3 bytes a texel) when
    /// they are the 8-bit codes level 0 was decoded from (checked: otherwise 16-byte texels).
    pub fn with_packed_texels_from(mut self, codes: Option<Codes8>) -> Self {
        if self.filter == FilterType::Bilinear {
            if let Levels::Rgb(levels) = &self.levels {
                let mut codes = codes;
                let packed = levels
                    .iter()
                    .map(|img| PackedLevel::new(img, self.wrap, codes.take()))
                    .collect();
                self.levels = Levels::Packed(packed);
            }
        }
        self
    }

    /// Number of levels, including level 0 and the final 1x1.
    pub fn levels(&self) -> usize {
        match &self.levels {
            Levels::Rgb(l) => l.len(),
            Levels::Packed(l) => l.len(),
        }
    }

    /// Level `i`'s texels (the coarsest for `i` past it).
    #[inline(always)]
    fn texels(&self, i: usize) -> LevelTexels<'_> {
        match &self.levels {
            Levels::Rgb(l) => {
                let img = &l[i.min(l.len() - 1)];
                LevelTexels {
                    width: img.width,
                    height: img.height,
                    data: TexelData::Rgb(&img.pixels),
                }
            }
            Levels::Packed(l) => {
                let p = &l[i.min(l.len() - 1)];
                LevelTexels {
                    width: p.width(),
                    height: p.height(),
                    data: TexelData::Packed(p.texels()),
                }
            }
        }
    }

    /// Level `i`'s packed texels, when the pyramid has them.
    #[inline(always)]
    fn packed(&self, i: usize) -> Option<&PackedLevel> {
        match &self.levels {
            Levels::Packed(l) => l.get(i),
            Levels::Rgb(_) => None,
        }
    }

    /// Level `i` of the pyramid (0 = full resolution); `i` is clamped to the coarsest level.
    /// Borrowed from a pyramid of three-float texels; a packed one's is copied out (for the
    /// build's tables, not for lookups).
    pub fn level(&self, i: usize) -> Cow<'_, Image> {
        match &self.levels {
            Levels::Rgb(l) => Cow::Borrowed(&l[i.min(l.len() - 1)]),
            Levels::Packed(_) => {
                let t = self.texels(i);
                let n = t.width as usize * t.height as usize;
                Cow::Owned(Image::new(
                    t.width,
                    t.height,
                    (0..n).map(|k| t.get(k)).collect(),
                ))
            }
        }
    }

    /// Width of level 0 in texels.
    pub fn width(&self) -> u32 {
        self.texels(0).width
    }

    /// Height of level 0 in texels.
    pub fn height(&self) -> u32 {
        self.texels(0).height
    }

    /// The wrap mode used for every lookup.
    pub fn wrap(&self) -> WrapMode {
        self.wrap
    }

    /// The filter used for every lookup.
    pub fn filter(&self) -> FilterType {
        self.filter
    }

    /// Bilinear (or nearest) lookup within one level; uv (0,0) = top-left corner of texel (0,0),
    /// texel centres at ((i + 0.5)/W, (j + 0.5)/H) as in Mitsuba. Non-finite uv reads texel 0.
    #[inline]
    pub fn lookup_level(&self, level: usize, uv: Vec2) -> Vec3 {
        let img = self.texels(level);
        match self.filter {
            FilterType::Nearest => {
                let x = uv.x * img.width as f32;
                let y = uv.y * img.height as f32;
                let (w, h) = (img.width as i64, img.height as i64);
                let i = self.wrap.apply(floor_index(x), w) as usize;
                let j = self.wrap.apply(floor_index(y), h) as usize;
                img.get(j * img.width as usize + i)
            }
            FilterType::Bilinear => {
                let x = uv.x * img.width as f32 - 0.5;
                let y = uv.y * img.height as f32 - 0.5;
                if !(x.abs() < TWO_POW_23 && y.abs() < TWO_POW_23) {
                    // Huge or non-finite coordinates (NaN fails the compare too).
                    return self.bilinear_general(img, x, y);
                }
                // Here floor is exact by truncation, and `x - floor(x)` is what
                // `x - x.floor()` gives (x = a - 0.5 is never -0.0, so no signed-zero case).
                let (i, j) = (floor_i32(x), floor_i32(y));
                let (fx, fy) = (x - i as f32, y - j as f32);
                let (c0, c1) = self.wrap.apply_pair(i, img.width);
                let (r0, r1) = self.wrap.apply_pair(j, img.height);
                let w = img.width as usize;
                let (r0, r1) = (r0 * w, r1 * w);
                debug_assert!(r1.max(r0) + c1.max(c0) < w * img.height as usize);
                // SAFETY: apply_pair returns columns < width and rows < height, and every level
                // holds at least width * height texels (checked in `MipMap::new`).
                let at = |k: usize| unsafe { img.get_unchecked(k) };
                let top = at(r0 + c0) * (1.0 - fx) + at(r0 + c1) * fx;
                let bottom = at(r1 + c0) * (1.0 - fx) + at(r1 + c1) * fx;
                top * (1.0 - fy) + bottom * fy
            }
        }
    }

    /// The gradient of the finest level's bilinear interpolant of `f(texel)` at `uv`, with
    /// respect to the texel coordinates (x, y): what Mitsuba's bitmap `eval_1_grad` computes
    /// (before its uv transform and resolution factors). Zero for nearest filtering (piecewise
    /// constant) and for non-finite uv.
    pub fn bilinear_gradient(&self, uv: Vec2, f: impl Fn(Vec3) -> f32) -> Vec2 {
        let img = self.texels(0);
        if self.filter == FilterType::Nearest {
            return Vec2::ZERO;
        }
        let x = uv.x * img.width as f32 - 0.5;
        let y = uv.y * img.height as f32 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return Vec2::ZERO;
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (i, j) = (fix(x0), fix(y0));
        let (w, h) = (img.width as i64, img.height as i64);
        let col = |i: i64| self.wrap.apply(i, w) as usize;
        let row = |j: i64| self.wrap.apply(j, h) as usize * img.width as usize;
        let at = |r: usize, c: usize| f(img.get(r + c));
        let (c0, c1, r0, r1) = (col(i), col(i + 1), row(j), row(j + 1));
        let (f00, f10, f01, f11) = (at(r0, c0), at(r0, c1), at(r1, c0), at(r1, c1));
        Vec2::new(
            (1.0 - fy) * (f10 - f00) + fy * (f11 - f01),
            (1.0 - fx) * (f01 - f00) + fx * (f11 - f10),
        )
    }

    /// The bilinear lookup for any coordinates (texel space, minus the half-texel offset), with
    /// libm floor and i64 wrapping: the reference the fast path in `lookup_level` matches.
    #[cold]
    #[inline(never)]
    fn bilinear_general(&self, img: LevelTexels, x: f32, y: f32) -> Vec3 {
        let (w, h) = (img.width as i64, img.height as i64);
        let wrap = self.wrap;
        let row = |j: i64| wrap.apply(j, h) as usize * img.width as usize;
        let col = |i: i64| wrap.apply(i, w) as usize;
        let px = |k: usize| img.get(k);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (fx, fy) = if fx.is_finite() && fy.is_finite() {
            (fx, fy)
        } else {
            (0.0, 0.0)
        };
        let (i, j) = (fix(x0), fix(y0));
        // Wrap each of the two columns and rows once, then fetch the 4 texels.
        let (c0, c1) = (col(i), col(i + 1));
        let (r0, r1) = (row(j), row(j + 1));
        let top = px(r0 + c0) * (1.0 - fx) + px(r0 + c1) * fx;
        let bottom = px(r1 + c0) * (1.0 - fx) + px(r1 + c1) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// The continuous pyramid level for a filter width `footprint` in uv units:
    /// log2(footprint * max(width, height)) clamped to [0, levels - 1]; 0 for a zero, negative
    /// or NaN footprint.
    pub fn level_for_footprint(&self, footprint: f32) -> f32 {
        let texels = footprint * self.width().max(self.height()) as f32;
        if texels.is_nan() || texels <= 1.0 {
            return 0.0;
        }
        texels.log2().min((self.levels() - 1) as f32)
    }

    /// Trilinear lookup; `footprint` is the filter width in uv units (0 → finest level bilinear).
    /// level = log2(footprint * max(width, height)), clamped to the pyramid. With
    /// [`FilterType::Nearest`] the footprint is ignored and level 0's nearest texel is returned.
    pub fn lookup(&self, uv: Vec2, footprint: f32) -> Vec3 {
        if self.filter == FilterType::Nearest {
            return self.lookup_level(0, uv);
        }
        self.lookup_lod(uv, self.level_for_footprint(footprint))
    }

    /// [`MipMap::lookup_level`] as a [`Vec3A`], from the packed texels when there are some
    /// (bilinear filter, coordinates below 2^23 texels): the same value to the bit.
    #[inline(always)]
    pub(crate) fn lookup_level_a(&self, level: usize, uv: Vec2) -> Vec3A {
        if let Some(v) = self.packed(level).and_then(|p| p.bilinear(uv)) {
            return v;
        }
        self.lookup_level_slow(level, uv)
    }

    #[cold]
    #[inline(never)]
    fn lookup_level_slow(&self, level: usize, uv: Vec2) -> Vec3A {
        self.lookup_level(level, uv).into()
    }

    /// [`MipMap::lookup_lod`] as a [`Vec3A`], from the packed texels when there are some: the
    /// same value to the bit.
    #[inline]
    pub(crate) fn lookup_lod_a(&self, uv: Vec2, level: f32) -> Vec3A {
        self.lod_lookup(level).at(uv)
    }

    /// Trilinear lookups at `level` (finite, in [0, levels - 1]) with the levels resolved once.
    #[inline(always)]
    pub(crate) fn lod_lookup(&self, level: f32) -> LodLookup<'_> {
        debug_assert!(level >= 0.0 && level <= (self.levels() - 1) as f32);
        // `level` is finite and in [0, levels - 1], so truncation is floor.
        let l0 = level as u32 as usize;
        let t = level - l0 as f32;
        let blend = !(t <= 0.0 || l0 + 1 >= self.levels());
        LodLookup {
            mip: self,
            level,
            lo: self.packed(l0),
            hi: if blend { self.packed(l0 + 1) } else { None },
            t,
        }
    }

    /// [`MipMap::lookup_lod`] as a [`Vec3A`]: where the packed texels cannot answer.
    #[cold]
    #[inline(never)]
    pub(crate) fn lookup_lod_slow(&self, uv: Vec2, level: f32) -> Vec3A {
        self.lookup_lod(uv, level).into()
    }

    /// Trilinear lookup at a continuous pyramid `level`, finite and in [0, levels - 1].
    #[inline]
    pub fn lookup_lod(&self, uv: Vec2, level: f32) -> Vec3 {
        debug_assert!(level >= 0.0 && level <= (self.levels() - 1) as f32);
        // `level` is finite and in [0, levels - 1], so truncation is floor.
        let l0 = level as usize;
        let t = level - l0 as f32;
        let a = self.lookup_level(l0, uv);
        if t <= 0.0 || l0 + 1 >= self.levels() {
            return a;
        }
        a * (1.0 - t) + self.lookup_level(l0 + 1, uv) * t
    }
}

/// 2^23: from here on every f32 is an integer, and below it `as i32` cannot overflow.
pub(crate) const TWO_POW_23: f32 = 8_388_608.0;

/// `x.floor() as i32` for |x| < 2^23 (the caller checks): truncate towards zero, then step
/// down once if that rounded a negative non-integer up. No libm call (baseline x86-64 has no
/// SSE4.1 `roundss`, so `f32::floor` is a function call there).
#[inline(always)]
pub(crate) fn floor_i32(x: f32) -> i32 {
    debug_assert!(x.abs() < TWO_POW_23);
    // SAFETY: |x| < 2^23 (the caller's check) is finite and fits i32 after truncation.
    let t: i32 = unsafe { x.to_int_unchecked() };
    t - ((t as f32) > x) as i32
}

/// `fix(v.floor())`: the nearest path's texel index (NaN → 0, saturating far outside).
#[inline]
fn floor_index(v: f32) -> i64 {
    if v.abs() < TWO_POW_23 {
        floor_i32(v) as i64
    } else {
        fix(v.floor())
    }
}

/// Float texel coordinate to an integer index without overflow (`as` saturates, NaN → 0).
#[inline]
fn fix(v: f32) -> i64 {
    // Keep well inside i64 so `i + 1` and `2 * n` arithmetic cannot overflow.
    v.clamp(-1.0e15, 1.0e15) as i64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `f32::floor` built on `floor_i32`, bit for bit for every input (signed zeros,
    /// infinities and NaN included).
    fn floor_f32(x: f32) -> f32 {
        if x.abs() < TWO_POW_23 {
            // copysign keeps -0.0 (the only negative input whose floor is zero).
            (floor_i32(x) as f32).copysign(x)
        } else {
            x // already an integer, or infinite / NaN
        }
    }

    #[test]
    fn cast_floor_matches_libm_floor() {
        let check = |x: f32| {
            let want = x.floor();
            let got = floor_f32(x);
            assert!(
                got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                "floor({x:e}) = {got:e}, want {want:e}"
            );
            if x.abs() < TWO_POW_23 {
                assert_eq!(floor_i32(x), want as i32, "floor_i32({x:e})");
            }
            // The nearest path's index helper equals the original `fix(v.floor())`.
            assert_eq!(floor_index(x), fix(want), "floor_index({x:e})");
        };
        // Dense sweep through [-1100, 1100] in 1/64 steps (hits every integer and half-integer
        // exactly, both signs) plus quarter-ulp neighbourhoods of integers.
        for k in -70_400..=70_400 {
            let x = k as f32 / 64.0;
            check(x);
            check(f32::from_bits(x.to_bits().wrapping_add(1)));
            check(f32::from_bits(x.to_bits().wrapping_sub(1)));
        }
        // Every float bit pattern near the 2^23 boundary, and a stride over all of f32.
        for base in [TWO_POW_23, -TWO_POW_23, 1.0, -1.0, 0.5, -0.5] {
            let b = base.to_bits();
            for d in 0..4096u32 {
                check(f32::from_bits(b.wrapping_add(d)));
                check(f32::from_bits(b.wrapping_sub(d)));
            }
        }
        for bits in (0..=u32::MAX).step_by(9973) {
            check(f32::from_bits(bits));
        }
        for x in [
            0.0,
            -0.0,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            1e-45,
            -1e-45,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MAX,
            f32::MIN,
            8_388_607.5,
            -8_388_607.5,
            16_777_216.0,
            -16_777_217.0,
        ] {
            check(x);
        }
    }

    #[test]
    fn wrap_pairs_match_per_index_wrapping() {
        for wrap in [WrapMode::Repeat, WrapMode::Mirror, WrapMode::Clamp] {
            for n in [1u32, 2, 3, 4, 5, 7, 8, 37, 256] {
                let ni = n as i64;
                for i in -(5 * n as i32 + 3)..=5 * n as i32 + 3 {
                    let want = (
                        wrap.apply(i as i64, ni) as usize,
                        wrap.apply(i as i64 + 1, ni) as usize,
                    );
                    assert_eq!(wrap.apply_pair(i, n), want, "{wrap:?} n {n} i {i}");
                }
                for i in [-8_388_608, -8_388_607, 8_388_606, 8_388_607, -1_000_001] {
                    let want = (
                        wrap.apply(i as i64, ni) as usize,
                        wrap.apply(i as i64 + 1, ni) as usize,
                    );
                    assert_eq!(wrap.apply_pair(i, n), want, "{wrap:?} n {n} i {i}");
                }
            }
        }
    }

    /// An 8-bit image's pyramid with its finest level kept as codes gives every lookup the bits
    /// of the 16-byte layout; codes that are not the image's values are not used.
    #[test]
    fn coded_finest_level_matches_the_float_texels() {
        use crate::color::{srgb8_lut, unorm8_lut};
        use crate::footprint::Footprint;
        let mut rng = torrey_testkit::Rng::new(0xC0DE);
        for (table, wrap, (w, h)) in [
            (srgb8_lut(), WrapMode::Repeat, (37, 20)),
            (unorm8_lut(), WrapMode::Mirror, (64, 64)),
            (srgb8_lut(), WrapMode::Clamp, (1, 5)),
        ] {
            let texels: Box<[[u8; 3]]> = (0..w * h)
                .map(|_| std::array::from_fn(|_| (rng.next_u64() % 256) as u8))
                .collect();
            let px = texels
                .iter()
                .map(|c| Vec3::from_array(c.map(|v| table[v as usize])))
                .collect();
            let mip = MipMap::new(Image::new(w, h, px), wrap, FilterType::Bilinear);
            let floats = mip.clone().with_packed_texels();
            let codes = Codes8 { texels, table };
            let coded = mip.clone().with_packed_texels_from(Some(codes.clone()));
            assert!(matches!(
                coded.packed(0).unwrap().texels(),
                Texels::Codes8(_)
            ));
            for level in 0..mip.levels() {
                assert_eq!(*coded.level(level), *floats.level(level));
            }
            let bits = |v: Vec3A| v.to_array().map(f32::to_bits);
            for k in 0..3000 {
                let uv = Vec2::new(rng.range(-3.0, 3.0), rng.range(-3.0, 3.0));
                assert_eq!(
                    bits(coded.lookup_level_a(0, uv)),
                    bits(floats.lookup_level_a(0, uv))
                );
                let fp = Footprint::new(
                    Vec2::new(rng.range(-0.2, 0.2), rng.range(-0.2, 0.2)),
                    Vec2::new(rng.range(-0.05, 0.05), rng.range(-0.05, 0.05)),
                );
                let fp = if k % 4 == 0 { Footprint::POINT } else { fp };
                assert_eq!(
                    bits(coded.lookup_aniso(uv, fp)),
                    bits(floats.lookup_aniso(uv, fp))
                );
            }
            // Codes of another image: the 16-byte layout, the image's own values.
            let mut wrong = codes.clone();
            wrong.texels[0][0] = wrong.texels[0][0].wrapping_add(1);
            let checked = mip.clone().with_packed_texels_from(Some(wrong));
            assert!(matches!(
                checked.packed(0).unwrap().texels(),
                Texels::Float(_)
            ));
            assert_eq!(*checked.level(0), *floats.level(0));
        }
    }

    #[test]
    fn fast_bilinear_matches_general_path() {
        let mut rng = torrey_testkit::Rng::new(0x5EED);
        for wrap in [WrapMode::Repeat, WrapMode::Mirror, WrapMode::Clamp] {
            for (w, h) in [(37, 20), (1, 5), (5, 1), (64, 64), (1, 1), (2, 3), (32, 7)] {
                let mip = MipMap::new(pattern(w, h), wrap, FilterType::Bilinear);
                let packed = mip.clone().with_packed_texels();
                assert_eq!(packed.levels(), mip.levels());
                for level in 0..mip.levels() {
                    // The packed pyramid keeps no other copy: its level, copied out, is the same.
                    assert_eq!(*packed.level(level), *mip.level(level));
                    let img = mip.texels(level);
                    let (fw, fh) = (img.width as f32, img.height as f32);
                    for k in 0..4000 {
                        // Inside, a few tiles out, far out (up to ~1e5 texels), both signs.
                        let span = [1.0, 6.0, 3000.0][k % 3];
                        let uv = Vec2::new(rng.range(-span, span), rng.range(-span, span));
                        let uv = if k % 7 == 0 {
                            // Exactly on texel centres and edges.
                            let i = (rng.next_u64() % 200) as f32 - 100.0;
                            let j = (rng.next_u64() % 200) as f32 - 100.0;
                            let off = [0.0, 0.5][k % 2];
                            Vec2::new((i + off) / fw, (j + off) / fh)
                        } else {
                            uv
                        };
                        let fast = mip.lookup_level(level, uv);
                        let x = uv.x * fw - 0.5;
                        let y = uv.y * fh - 0.5;
                        let general = mip.bilinear_general(img, x, y);
                        assert_eq!(
                            fast.to_array().map(f32::to_bits),
                            general.to_array().map(f32::to_bits),
                            "{wrap:?} {w}x{h} level {level} uv {uv}"
                        );
                        // The scalar paths read the packed texels to the same bits.
                        let from_packed = packed.lookup_level(level, uv);
                        assert_eq!(
                            from_packed.to_array().map(f32::to_bits),
                            fast.to_array().map(f32::to_bits),
                            "packed scalar {wrap:?} {w}x{h} level {level} uv {uv}"
                        );
                        // The packed texels (the renderer's bitmaps) give the same bits.
                        let simd = Vec3::from(packed.lookup_level_a(level, uv));
                        assert_eq!(
                            simd.to_array().map(f32::to_bits),
                            fast.to_array().map(f32::to_bits),
                            "packed {wrap:?} {w}x{h} level {level} uv {uv}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn non_finite_and_huge_uv_read_texel_zero_or_saturate() {
        let img = pattern(5, 3);
        for wrap in [WrapMode::Repeat, WrapMode::Mirror, WrapMode::Clamp] {
            let mip = MipMap::new(img.clone(), wrap, FilterType::Bilinear);
            let near = MipMap::new(img.clone(), wrap, FilterType::Nearest);
            // NaN → index 0 and weight 0 on both axes: texel (0, 0) exactly.
            assert_eq!(mip.lookup_level(0, Vec2::NAN), img.pixels[0], "{wrap:?}");
            assert_eq!(near.lookup_level(0, Vec2::NAN), img.pixels[0], "{wrap:?}");
            // Non-finite or beyond-2^23 coordinates go through the general path unchanged.
            for uv in [
                Vec2::new(f32::INFINITY, 0.3),
                Vec2::new(0.3, f32::NEG_INFINITY),
                Vec2::new(f32::NAN, 0.7),
                Vec2::new(-1e30, 1e30),
                Vec2::new(3e6, -2e6),
            ] {
                let (x, y) = (uv.x * 5.0 - 0.5, uv.y * 3.0 - 0.5);
                assert_eq!(
                    mip.lookup_level(0, uv),
                    mip.bilinear_general(mip.texels(0), x, y)
                );
                let _ = near.lookup_level(0, uv);
            }
        }
    }

    fn mean(img: &Image) -> Vec3 {
        let s: glam::DVec3 = img.pixels.iter().map(|p| p.as_dvec3()).sum();
        (s / img.pixels.len() as f64).as_vec3()
    }

    /// A deterministic, non-symmetric test pattern.
    fn pattern(w: u32, h: u32) -> Image {
        let px = (0..w * h)
            .map(|k| {
                let (x, y) = ((k % w) as f32, (k / w) as f32);
                Vec3::new(
                    (x * 0.37 + y * 1.3).sin().abs(),
                    ((x * y) as u32 % 7) as f32 / 7.0,
                    if (x as u32 + y as u32).is_multiple_of(2) {
                        1.0
                    } else {
                        0.1
                    },
                )
            })
            .collect();
        Image::new(w, h, px)
    }

    #[test]
    fn box_weights_sum_to_one_and_cover_every_texel() {
        for (src, dst) in [(37, 18), (5, 2), (3, 1), (8, 4), (1, 1), (20, 10)] {
            let wts = box_weights(src, dst);
            let mut per_src = vec![0.0f32; src];
            for taps in &wts {
                let s: f32 = taps.iter().map(|t| t.1).sum();
                assert!((s - 1.0).abs() < 1e-6, "{src}->{dst}: {s}");
                for &(j, k) in taps {
                    per_src[j] += k;
                }
            }
            // Every source texel contributes dst/src in total: nothing is dropped.
            for v in per_src {
                assert!((v - dst as f32 / src as f32).abs() < 1e-6);
            }
        }
        // Odd size: 5 -> 2 takes a 3-texel window with a half-weight middle texel.
        let w = box_weights(5, 2);
        assert_eq!(w[0].len(), 3);
        assert!((w[0][2].1 - 0.2).abs() < 1e-6);
    }

    #[test]
    fn every_level_keeps_the_mean() {
        for (w, h) in [(37, 20), (1, 5), (5, 1), (64, 64), (33, 17), (2, 3)] {
            let img = pattern(w, h);
            let m0 = mean(&img);
            let mip = MipMap::new(img, WrapMode::Repeat, FilterType::Bilinear);
            let last = mip.level(mip.levels() - 1);
            assert_eq!((last.width, last.height), (1, 1), "{w}x{h}");
            for i in 0..mip.levels() {
                let m = mean(&mip.level(i));
                assert!(m.abs_diff_eq(m0, 1e-5), "{w}x{h} level {i}: {m} vs {m0}");
            }
        }
        let mip = MipMap::new(pattern(37, 20), WrapMode::Repeat, FilterType::Bilinear);
        let sizes: Vec<(u32, u32)> = (0..mip.levels())
            .map(|i| (mip.level(i).width, mip.level(i).height))
            .collect();
        assert_eq!(
            sizes,
            vec![(37, 20), (18, 10), (9, 5), (4, 2), (2, 1), (1, 1)]
        );
        assert_eq!(
            MipMap::new(pattern(256, 256), WrapMode::Repeat, FilterType::Bilinear).levels(),
            9
        );
    }

    #[test]
    fn constant_texture_is_constant_everywhere() {
        let c = Vec3::new(0.25, 0.5, 0.75);
        let mip = MipMap::new(
            Image::filled(13, 7, c),
            WrapMode::Mirror,
            FilterType::Bilinear,
        );
        for i in 0..mip.levels() {
            assert!(mip.level(i).pixels.iter().all(|p| p.abs_diff_eq(c, 1e-6)));
        }
        for fp in [0.0, 1e-3, 0.05, 0.3, 1.0, 100.0, f32::NAN, -1.0] {
            for uv in [
                Vec2::new(0.1, 0.9),
                Vec2::new(-3.3, 7.1),
                Vec2::new(0.5, 0.5),
            ] {
                assert!(mip.lookup(uv, fp).abs_diff_eq(c, 1e-5), "fp {fp} uv {uv}");
            }
        }
    }

    #[test]
    fn bilinear_hits_texel_centres_and_interpolates() {
        let img = Image::new(2, 1, vec![Vec3::ZERO, Vec3::ONE]);
        let mip = MipMap::new(img, WrapMode::Clamp, FilterType::Bilinear);
        assert!(mip
            .lookup_level(0, Vec2::new(0.25, 0.5))
            .abs_diff_eq(Vec3::ZERO, 1e-6));
        assert!(mip
            .lookup_level(0, Vec2::new(0.75, 0.5))
            .abs_diff_eq(Vec3::ONE, 1e-6));
        assert!(mip
            .lookup_level(0, Vec2::new(0.5, 0.5))
            .abs_diff_eq(Vec3::splat(0.5), 1e-6));
        assert!(mip
            .lookup_level(0, Vec2::new(0.375, 0.2))
            .abs_diff_eq(Vec3::splat(0.25), 1e-6));
        // The 1x1 level is the mean.
        assert!(mip
            .lookup_level(1, Vec2::new(0.1, 0.1))
            .abs_diff_eq(Vec3::splat(0.5), 1e-6));
    }

    #[test]
    fn wrap_modes_outside_unit_square() {
        // 4x1 ramp 0, 1, 2, 3 read with nearest so indices are exact.
        let img = Image::new(4, 1, (0..4).map(|i| Vec3::splat(i as f32)).collect());
        let at = |wrap, u: f32| {
            MipMap::new(img.clone(), wrap, FilterType::Nearest)
                .lookup(Vec2::new(u, 0.5), 0.0)
                .x
        };
        // u = 1.125 → texel 4.5 → index 4.
        assert_eq!(at(WrapMode::Repeat, 1.125), 0.0);
        assert_eq!(at(WrapMode::Mirror, 1.125), 3.0);
        assert_eq!(at(WrapMode::Clamp, 1.125), 3.0);
        // u = 1.375 → index 5.
        assert_eq!(at(WrapMode::Repeat, 1.375), 1.0);
        assert_eq!(at(WrapMode::Mirror, 1.375), 2.0);
        // u = -0.125 → index -1.
        assert_eq!(at(WrapMode::Repeat, -0.125), 3.0);
        assert_eq!(at(WrapMode::Mirror, -0.125), 0.0);
        assert_eq!(at(WrapMode::Clamp, -0.125), 0.0);
        // u = -1.125 → index -5.
        assert_eq!(at(WrapMode::Repeat, -1.125), 3.0);
        assert_eq!(at(WrapMode::Mirror, -1.125), 3.0);
        assert_eq!(at(WrapMode::Clamp, -7.0), 0.0);
        // Bilinear repeat across the seam blends the last and first texels.
        let mip = MipMap::new(img.clone(), WrapMode::Repeat, FilterType::Bilinear);
        assert!((mip.lookup_level(0, Vec2::new(1.0, 0.5)).x - 1.5).abs() < 1e-5);
        assert!((mip.lookup_level(0, Vec2::new(0.0, 0.5)).x - 1.5).abs() < 1e-5);
        let clamp = MipMap::new(img, WrapMode::Clamp, FilterType::Bilinear);
        assert!((clamp.lookup_level(0, Vec2::new(1.0, 0.5)).x - 3.0).abs() < 1e-5);
        // Non-finite uv does not panic.
        let _ = clamp.lookup(Vec2::new(f32::NAN, f32::INFINITY), f32::INFINITY);
        let _ = mip.lookup(Vec2::new(-1e30, 1e30), 0.01);
    }

    #[test]
    fn level_grows_monotonically_with_footprint() {
        let mip = MipMap::new(pattern(64, 32), WrapMode::Repeat, FilterType::Bilinear);
        assert_eq!(mip.levels(), 7);
        assert_eq!(mip.level_for_footprint(0.0), 0.0);
        assert!((mip.level_for_footprint(1.0 / 64.0) - 0.0).abs() < 1e-6);
        assert!((mip.level_for_footprint(4.0 / 64.0) - 2.0).abs() < 1e-6);
        assert_eq!(mip.level_for_footprint(10.0), 6.0);
        let mut prev = -1.0;
        for k in 0..200 {
            let fp = 1e-3 * 1.05f32.powi(k);
            let l = mip.level_for_footprint(fp);
            assert!(l >= prev, "footprint {fp}");
            prev = l;
        }
    }

    #[test]
    fn trilinear_is_continuous_in_uv_and_footprint() {
        let mip = MipMap::new(pattern(37, 20), WrapMode::Repeat, FilterType::Bilinear);
        // Max channel value is 1 and the steepest bilinear slope is one texel-difference per
        // texel, so a step of 1e-4 in uv (0.0037 texels) changes a value by far less than 0.01.
        let steps = 3000;
        for &fp in &[0.0f32, 0.02, 0.1, 0.4] {
            let mut prev = mip.lookup(Vec2::new(-0.1, 0.3 - 0.03), fp);
            for k in 1..steps {
                let u = -0.1 + k as f32 * 1e-4 * 4.0;
                let cur = mip.lookup(Vec2::new(u, 0.3 + 0.3 * u), fp);
                assert!(
                    (cur - prev).abs().max_element() < 0.02,
                    "fp {fp} u {u} {prev} {cur}"
                );
                prev = cur;
            }
        }
        // Through level boundaries: footprint sweeps across integer levels.
        let uv = Vec2::new(0.31, 0.77);
        let mut prev = mip.lookup(uv, 1.0 / 37.0);
        for k in 1..2000 {
            let fp = (1.0 / 37.0) * 1.001f32.powi(k * 3);
            let cur = mip.lookup(uv, fp);
            assert!((cur - prev).abs().max_element() < 0.01, "fp {fp}");
            prev = cur;
        }
    }

    #[test]
    fn nearest_ignores_footprint() {
        let img = pattern(8, 8);
        let mip = MipMap::new(img.clone(), WrapMode::Repeat, FilterType::Nearest);
        let uv = Vec2::new(0.3, 0.6); // texel (2, 4)
        assert_eq!(mip.lookup(uv, 0.0), img.get(2, 4));
        assert_eq!(mip.lookup(uv, 0.5), img.get(2, 4));
    }

    #[test]
    fn empty_image_does_not_panic() {
        let mip = MipMap::new(
            Image::new(0, 0, vec![]),
            WrapMode::Repeat,
            FilterType::Bilinear,
        );
        assert_eq!(mip.levels(), 1);
        assert_eq!(mip.lookup(Vec2::new(0.5, 0.5), 0.1), Vec3::ZERO);
    }
}
