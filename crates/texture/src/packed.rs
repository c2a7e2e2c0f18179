//! One mip level stored for the renderer's bitmap lookups: 16-byte texels, or an 8-bit image's
//! codes.
//!
//! [`crate::Image`] keeps three floats per texel (12 bytes), so a bilinear lookup there is twelve
//! scalar loads and lerps. Here each texel is a [`Vec3A`] (RGB plus an unused lane): one aligned
//! load per texel and the lerps run on whole vectors. Every lane does the same IEEE operations in
//! the same order as the scalar path (`a * (1 - f) + b * f`; Rust never fuses them), so the
//! results are the same to the bit; `MipMap`'s tests check that. The finest level of an 8-bit
//! image keeps its 3-byte codes instead, each texel read through the code table into the same
//! [`Vec3A`]: the same values, a fifth of the memory (most lookups at high sample counts read the
//! finest level, whose texels otherwise come from main memory).

use glam::{Vec2, Vec3A};

use crate::image::{Codes8, Image};
use crate::mipmap::{floor_i32, MipMap, WrapMode, TWO_POW_23};

/// A pyramid level's texels, with what its bilinear lookup precomputes.
#[derive(Clone, Debug)]
pub(crate) struct PackedLevel {
    /// `width * height` texels, row by row from the top.
    texels: Texels,
    width: u32,
    height: u32,
    /// `(width, height)` as floats.
    size: Vec2,
    /// How column (x) and row (y) indices wrap.
    wrap_x: AxisWrap,
    wrap_y: AxisWrap,
}

/// A level's texels in one of two layouts.
#[derive(Clone, Debug)]
pub(crate) enum Texels {
    /// RGB plus an unused lane.
    Float(Box<[Vec3A]>),
    /// An 8-bit image's codes and their table.
    Codes8(Codes8),
}

impl Texels {
    /// Texel `k`.
    ///
    /// # Safety
    /// `k` is below the level's `width * height`.
    #[inline(always)]
    pub(crate) unsafe fn get_unchecked(&self, k: usize) -> Vec3A {
        // SAFETY: (both arms) k < width * height, the texel count of either layout.
        unsafe {
            match self {
                Texels::Float(px) => *px.get_unchecked(k),
                Texels::Codes8(c) => Vec3A::from_array(c.value(*c.texels.get_unchecked(k))),
            }
        }
    }

    /// Texel `k`; panics past the end.
    #[inline(always)]
    pub(crate) fn get(&self, k: usize) -> Vec3A {
        match self {
            Texels::Float(px) => px[k],
            Texels::Codes8(c) => Vec3A::from_array(c.value(c.texels[k])),
        }
    }
}

impl PackedLevel {
    /// The level `img` (which holds at least `width * height` pixels) for lookups that wrap with
    /// `wrap`: its `codes` when given and `img` holds exactly their values (an 8-bit image's
    /// finest level), else 16-byte texels.
    pub(crate) fn new(img: &Image, wrap: WrapMode, codes: Option<Codes8>) -> Self {
        let n = img.width as usize * img.height as usize;
        use rayon::prelude::*;
        let codes = codes.filter(|c| {
            c.texels.len() == n
                && c.texels
                    .par_iter()
                    .zip(&img.pixels[..n])
                    .with_min_len(1 << 14)
                    // Bit for bit (a NaN never matches).
                    .all(|(&codes, p)| {
                        c.value(codes).map(f32::to_bits) == p.to_array().map(f32::to_bits)
                    })
        });
        let texels = match codes {
            Some(c) => Texels::Codes8(c),
            None => Texels::Float(
                img.pixels[..n]
                    .par_iter()
                    .with_min_len(1 << 14)
                    .map(|&p| p.into())
                    .collect(),
            ),
        };
        Self {
            texels,
            width: img.width,
            height: img.height,
            size: Vec2::new(img.width as f32, img.height as f32),
            wrap_x: AxisWrap::new(wrap, img.width),
            wrap_y: AxisWrap::new(wrap, img.height),
        }
    }

    pub(crate) fn width(&self) -> u32 {
        self.width
    }

    pub(crate) fn height(&self) -> u32 {
        self.height
    }

    /// The `width * height` texels, row by row from the top.
    pub(crate) fn texels(&self) -> &Texels {
        &self.texels
    }

    /// `MipMap::lookup_level`'s bilinear value at `uv`, to the bit; None for coordinates at or
    /// beyond 2^23 texels or non-finite ones (the caller takes the general path).
    #[inline(always)]
    pub(crate) fn bilinear(&self, uv: Vec2) -> Option<Vec3A> {
        let x = uv.x * self.size.x - 0.5;
        let y = uv.y * self.size.y - 0.5;
        if !(x.abs() < TWO_POW_23 && y.abs() < TWO_POW_23) {
            return None;
        }
        let (i, j) = (floor_i32(x), floor_i32(y));
        let (fx, fy) = (x - i as f32, y - j as f32);
        let (c0, c1) = self.wrap_x.pair(i);
        let (r0, r1) = self.wrap_y.pair(j);
        let w = self.width as usize;
        let (r0, r1) = (r0 * w, r1 * w);
        let px = &self.texels;
        debug_assert!(r0.max(r1) + c0.max(c1) < w * self.height as usize);
        // SAFETY: `AxisWrap::pair` returns columns < width and rows < height, and `texels` holds
        // exactly width * height texels.
        let at = |k: usize| unsafe { px.get_unchecked(k) };
        let top = at(r0 + c0) * (1.0 - fx) + at(r0 + c1) * fx;
        let bottom = at(r1 + c0) * (1.0 - fx) + at(r1 + c1) * fx;
        Some(top * (1.0 - fy) + bottom * fy)
    }
}

/// One axis's index wrapping, as `WrapMode::apply_pair` computes it but without its division or
/// call for `Repeat`, where tiled textures read outside [0, 1] all the time.
#[derive(Clone, Copy, Debug)]
enum AxisWrap {
    /// `Repeat` of a power-of-two size: the index `& mask`.
    Mask(i32),
    /// `Repeat` of another size `n`: `(i + bias) mod n`, `bias` a multiple of `n` above 2^24 so the
    /// sum is non-negative, the remainder by Lemire's multiply with `magic` = 2^64 / n rounded up
    /// (exact for every u32 dividend; "Faster remainder by direct computation", 2019).
    Repeat { n: u32, bias: u32, magic: u64 },
    /// `Mirror` and `Clamp`: `WrapMode::apply_pair`.
    Other { wrap: WrapMode, n: u32 },
}

impl AxisWrap {
    fn new(wrap: WrapMode, n: u32) -> Self {
        match wrap {
            WrapMode::Repeat if n.is_power_of_two() && n <= 1 << 30 => Self::Mask(n as i32 - 1),
            WrapMode::Repeat if (1..=1 << 30).contains(&n) => Self::Repeat {
                n,
                bias: (1u32 << 24).div_ceil(n) * n,
                magic: (u64::MAX / n as u64).wrapping_add(1),
            },
            _ => Self::Other { wrap, n },
        }
    }

    /// `(wrap(i), wrap(i + 1))` for |i| < 2^23 + 1: `WrapMode::apply_pair`'s pair.
    #[inline(always)]
    fn pair(self, i: i32) -> (usize, usize) {
        match self {
            Self::Mask(m) => ((i & m) as usize, ((i + 1) & m) as usize),
            Self::Repeat { n, bias, magic } => {
                // i + bias is in [2^24 - 2^23 - 1, 2^24 + 2^30 + 2^23]: non-negative, below 2^32.
                let a = fast_mod((i as u32).wrapping_add(bias), n, magic);
                (a as usize, if a + 1 == n { 0 } else { a as usize + 1 })
            }
            Self::Other { wrap, n } => wrap.apply_pair(i, n),
        }
    }
}

/// `a % n` for any u32 `a` and `n >= 1`, with `magic = (u64::MAX / n).wrapping_add(1)`.
#[inline(always)]
fn fast_mod(a: u32, n: u32, magic: u64) -> u32 {
    let low = magic.wrapping_mul(a as u64);
    ((low as u128 * n as u128) >> 64) as u32
}

/// Trilinear lookups at one continuous pyramid level with the two levels and their blend weight
/// resolved once: what the probes of one anisotropic lookup share. `at` gives
/// `MipMap::lookup_lod`'s value to the bit.
pub(crate) struct LodLookup<'a> {
    pub(crate) mip: &'a MipMap,
    pub(crate) level: f32,
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
        if let Some(a) = self.lo.and_then(|lo| lo.bilinear(uv)) {
            match self.hi {
                None => return a,
                Some(hi) => {
                    if let Some(b) = hi.bilinear(uv) {
                        return a * (1.0 - self.t) + b * self.t;
                    }
                }
            }
        }
        self.mip.lookup_lod_slow(uv, self.level)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_mod_is_the_remainder() {
        let mut rng = torrey_testkit::Rng::new(7);
        let ns = [
            1u32,
            2,
            3,
            5,
            7,
            100,
            768,
            786,
            1000,
            4095,
            65_537,
            (1 << 30) - 1,
            1 << 30,
        ];
        for &n in &ns {
            let magic = (u64::MAX / n as u64).wrapping_add(1);
            for _ in 0..20_000 {
                let a = rng.next_u64() as u32;
                assert_eq!(fast_mod(a, n, magic), a % n, "{a} % {n}");
            }
            for a in [
                0,
                1,
                n - 1,
                n,
                n.wrapping_add(1),
                u32::MAX,
                u32::MAX - 1,
                1 << 24,
            ] {
                assert_eq!(fast_mod(a, n, magic), a % n, "{a} % {n}");
            }
        }
    }

    #[test]
    fn axis_pairs_match_the_wrap_modes() {
        let mut rng = torrey_testkit::Rng::new(8);
        for wrap in [WrapMode::Repeat, WrapMode::Mirror, WrapMode::Clamp] {
            for n in [1u32, 2, 3, 5, 8, 37, 256, 768, 786, 1023] {
                let axis = AxisWrap::new(wrap, n);
                let edge = 1 << 23;
                let near = (-3 * n as i32 - 2)..=(3 * n as i32 + 2);
                let ends = [-edge, -edge + 1, edge - 2, edge - 1, edge];
                let random = (0..2000).map(|_| (rng.next_u64() % (2 * edge as u64)) as i32 - edge);
                for i in near.chain(ends).chain(random) {
                    assert_eq!(axis.pair(i), wrap.apply_pair(i, n), "{wrap:?} n {n} i {i}");
                }
            }
        }
    }
}
