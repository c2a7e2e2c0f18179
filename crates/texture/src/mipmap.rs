//! Box-filtered mip pyramids and filtered lookups into them.
//!
//! Each coarser level is an exact box-filter resampling of the one above (fractional weights for
//! odd and non-power-of-two sizes), so every level keeps the mean of the original image and a
//! pattern averages out instead of aliasing when the renderer asks for a wide footprint.

use glam::{Vec2, Vec3};

use crate::image::Image;

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
}

/// A mip pyramid: level 0 is the image itself, each next level about half the size, down to 1x1.
#[derive(Clone, Debug)]
pub struct MipMap {
    levels: Vec<Image>,
    wrap: WrapMode,
    filter: FilterType,
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
    // Horizontal pass into an nw x h buffer, then vertical pass.
    let mut tmp = vec![Vec3::ZERO; nw * h];
    for y in 0..h {
        let row = &img.pixels[y * w..(y + 1) * w];
        for (x, taps) in wx.iter().enumerate() {
            tmp[y * nw + x] = taps.iter().map(|&(j, k)| row[j] * k).sum();
        }
    }
    let mut out = vec![Vec3::ZERO; nw * nh];
    for (y, taps) in wy.iter().enumerate() {
        for x in 0..nw {
            out[y * nw + x] = taps.iter().map(|&(j, k)| tmp[j * nw + x] * k).sum();
        }
    }
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
            levels,
            wrap,
            filter,
        }
    }

    /// Number of levels, including level 0 and the final 1x1.
    pub fn levels(&self) -> usize {
        self.levels.len()
    }

    /// Level `i` of the pyramid (0 = full resolution); `i` is clamped to the coarsest level.
    pub fn level(&self, i: usize) -> &Image {
        &self.levels[i.min(self.levels.len() - 1)]
    }

    /// Width of level 0 in texels.
    pub fn width(&self) -> u32 {
        self.levels[0].width
    }

    /// Height of level 0 in texels.
    pub fn height(&self) -> u32 {
        self.levels[0].height
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
    pub fn lookup_level(&self, level: usize, uv: Vec2) -> Vec3 {
        let img = self.level(level);
        let (w, h) = (img.width as i64, img.height as i64);
        let x = uv.x * img.width as f32;
        let y = uv.y * img.height as f32;
        let wrap = self.wrap;
        let row = |j: i64| wrap.apply(j, h) as usize * img.width as usize;
        let col = |i: i64| wrap.apply(i, w) as usize;
        let px = &img.pixels;
        match self.filter {
            FilterType::Nearest => px[row(fix(y.floor())) + col(fix(x.floor()))],
            FilterType::Bilinear => {
                let (x, y) = (x - 0.5, y - 0.5);
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
                let top = px[r0 + c0] * (1.0 - fx) + px[r0 + c1] * fx;
                let bottom = px[r1 + c0] * (1.0 - fx) + px[r1 + c1] * fx;
                top * (1.0 - fy) + bottom * fy
            }
        }
    }

    /// The continuous pyramid level for a filter width `footprint` in uv units:
    /// log2(footprint * max(width, height)) clamped to [0, levels - 1]; 0 for a zero, negative
    /// or NaN footprint.
    pub fn level_for_footprint(&self, footprint: f32) -> f32 {
        let texels = footprint * self.width().max(self.height()) as f32;
        if texels.is_nan() || texels <= 1.0 {
            return 0.0;
        }
        texels.log2().min((self.levels.len() - 1) as f32)
    }

    /// Trilinear lookup; `footprint` is the filter width in uv units (0 → finest level bilinear).
    /// level = log2(footprint * max(width, height)), clamped to the pyramid. With
    /// [`FilterType::Nearest`] the footprint is ignored and level 0's nearest texel is returned.
    pub fn lookup(&self, uv: Vec2, footprint: f32) -> Vec3 {
        if self.filter == FilterType::Nearest {
            return self.lookup_level(0, uv);
        }
        let level = self.level_for_footprint(footprint);
        let l0 = level.floor();
        let t = level - l0;
        let l0 = l0 as usize;
        let a = self.lookup_level(l0, uv);
        if t <= 0.0 || l0 + 1 >= self.levels.len() {
            return a;
        }
        a * (1.0 - t) + self.lookup_level(l0 + 1, uv) * t
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
                let m = mean(mip.level(i));
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
