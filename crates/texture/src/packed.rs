//! One mip level stored as 16-byte texels for the renderer's bitmap lookups.
//!
//! [`crate::Image`] keeps three floats per texel (12 bytes), so a bilinear lookup there is twelve
//! scalar loads and lerps. Here each texel is a [`Vec3A`] (RGB plus an unused lane): one aligned
//! load per texel and the lerps run on whole vectors. Every lane does the same IEEE operations in
//! the same order as the scalar path (`a * (1 - f) + b * f`; Rust never fuses them), so the
//! results are the same to the bit; `MipMap`'s tests check that.

use glam::{Vec2, Vec3A};

use crate::image::Image;
use crate::mipmap::{floor_i32, MipMap, WrapMode, TWO_POW_23};

/// A pyramid level as 16-byte texels, with what its bilinear lookup precomputes.
#[derive(Clone, Debug)]
pub(crate) struct PackedLevel {
    /// `width * height` texels, row by row from the top.
    texels: Box<[Vec3A]>,
    width: u32,
    height: u32,
    /// `(width, height)` as floats.
    size: Vec2,
    /// For `Repeat` wrapping of a power-of-two width (height): `width - 1` (`height - 1`), so a
    /// column (row) index wraps by one `&`; `None` otherwise.
    mask_x: Option<i32>,
    mask_y: Option<i32>,
}

impl PackedLevel {
    /// The level `img` (which holds at least `width * height` pixels) as packed texels, for
    /// lookups that wrap with `wrap`.
    pub(crate) fn new(img: &Image, wrap: WrapMode) -> Self {
        let n = img.width as usize * img.height as usize;
        let texels: Box<[Vec3A]> = img.pixels[..n].iter().map(|&p| p.into()).collect();
        let mask = |n: u32| {
            (wrap == WrapMode::Repeat && n.is_power_of_two() && n <= 1 << 30)
                .then_some(n as i32 - 1)
        };
        Self {
            texels,
            width: img.width,
            height: img.height,
            size: Vec2::new(img.width as f32, img.height as f32),
            mask_x: mask(img.width),
            mask_y: mask(img.height),
        }
    }

    /// `MipMap::lookup_level`'s bilinear value at `uv`, to the bit; None for coordinates at or
    /// beyond 2^23 texels or non-finite ones (the caller takes the general path).
    #[inline(always)]
    pub(crate) fn bilinear(&self, wrap: WrapMode, uv: Vec2) -> Option<Vec3A> {
        let x = uv.x * self.size.x - 0.5;
        let y = uv.y * self.size.y - 0.5;
        if !(x.abs() < TWO_POW_23 && y.abs() < TWO_POW_23) {
            return None;
        }
        let (i, j) = (floor_i32(x), floor_i32(y));
        let (fx, fy) = (x - i as f32, y - j as f32);
        let (c0, c1) = pair(wrap, i, self.width, self.mask_x);
        let (r0, r1) = pair(wrap, j, self.height, self.mask_y);
        let w = self.width as usize;
        let (r0, r1) = (r0 * w, r1 * w);
        let px = &self.texels;
        debug_assert!(r0.max(r1) + c0.max(c1) < px.len());
        // SAFETY: `pair` returns columns < width and rows < height, and `texels` holds exactly
        // width * height texels.
        let at = |k: usize| unsafe { *px.get_unchecked(k) };
        let top = at(r0 + c0) * (1.0 - fx) + at(r0 + c1) * fx;
        let bottom = at(r1 + c0) * (1.0 - fx) + at(r1 + c1) * fx;
        Some(top * (1.0 - fy) + bottom * fy)
    }
}

/// `wrap.apply_pair(i, n)`; with a power-of-two `Repeat` mask, two `&`s and no branch (the same
/// pair: `(i + 1) & mask` is the wrapped successor of `i & mask`).
#[inline(always)]
fn pair(wrap: WrapMode, i: i32, n: u32, mask: Option<i32>) -> (usize, usize) {
    match mask {
        // |i| < 2^23, so i + 1 cannot overflow.
        Some(m) => ((i & m) as usize, ((i + 1) & m) as usize),
        None => wrap.apply_pair(i, n),
    }
}

/// Trilinear lookups at one continuous pyramid level with the two levels and their blend weight
/// resolved once: what the probes of one anisotropic lookup share. `at` gives
/// `MipMap::lookup_lod`'s value to the bit.
pub(crate) struct LodLookup<'a> {
    pub(crate) mip: &'a MipMap,
    pub(crate) level: f32,
    pub(crate) wrap: WrapMode,
    /// The finer level's packed texels (None: the pyramid has none; every lookup takes the
    /// general path).
    pub(crate) lo: Option<&'a PackedLevel>,
    /// The coarser level's, when it is blended in (weight `t > 0`).
    pub(crate) hi: Option<&'a PackedLevel>,
    pub(crate) t: f32,
}

impl LodLookup<'_> {
    /// The trilinear value at `uv`.
    #[inline(always)]
    pub(crate) fn at(&self, uv: Vec2) -> Vec3A {
        if let Some(a) = self.lo.and_then(|lo| lo.bilinear(self.wrap, uv)) {
            match self.hi {
                None => return a,
                Some(hi) => {
                    if let Some(b) = hi.bilinear(self.wrap, uv) {
                        return a * (1.0 - self.t) + b * self.t;
                    }
                }
            }
        }
        self.mip.lookup_lod_slow(uv, self.level)
    }
}
