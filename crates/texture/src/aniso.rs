//! Anisotropic lookups: an elliptical [`Footprint`] filtered by trilinear probes along its major
//! axis, as GPUs do, with the level chosen by the minor axis.
//!
//! In level-0 texels, let the footprint's semi-axes be `major >= minor`. Then:
//! - `major <= 1`: the footprint fits in the bilinear reconstruction's own support; the lookup is
//!   the finest level's bilinear value, exactly (so high sample counts converge to the unfiltered
//!   image, which is what Mitsuba renders).
//! - the minor semi-axis is widened to at least `major / MAX_ANISOTROPY`, and the probes' own
//!   filter radius is `rho = max(minor, 1)` texels: each probe is a trilinear lookup at level
//!   log2(rho), whose bilinear tent at that level is `rho` level-0 texels wide each side.
//! - the probes lie on the major axis within `spread = sqrt(major^2 - rho^2)` of the centre (the
//!   probe's own width removed in quadrature, so the total reaches `major` and `spread` goes to
//!   zero continuously as the footprint becomes round or shrinks to a texel), `rho` apart from the
//!   centre outwards, weighted by the biweight kernel (1 - t^2)^2 of their position t in [-1, 1]
//!   along the axis. A new probe enters at the ends with zero weight, so the lookup is
//!   continuous in the footprint as well as in uv.
//!
//! The weights are normalised and every pyramid level keeps the image's mean, so a constant stays
//! constant and the filter integrates to one. Every lookup costs at most [`MAX_PROBES`] trilinear
//! probes, whatever the footprint; an [`Footprint::isotropic`] one (after a rough bounce) costs
//! one, at the level of the circle of the ellipse's area.

use glam::{Vec2, Vec3A};

use crate::footprint::Footprint;
use crate::mipmap::{FilterType, MipMap};

/// Largest ratio of major to minor axis that is filtered as such; beyond it the minor axis is
/// widened (the footprint blurs across the view instead of under-filtering along it). 16 is GPUs'
/// highest setting and covers view angles down to about 3.6 degrees above the surface.
pub const MAX_ANISOTROPY: f32 = 16.0;

/// Most probes one lookup takes: one every `rho` texels over the major diameter at the largest
/// anisotropy.
pub const MAX_PROBES: usize = 2 * MAX_ANISOTROPY as usize + 1;

impl MipMap {
    /// The texture filtered over the elliptical footprint `fp` (uv units) centred at
    /// `uv + fp.shift`; see the module documentation. [`FilterType::Nearest`] ignores the footprint.
    pub fn lookup_aniso(&self, uv: Vec2, fp: Footprint) -> Vec3A {
        let uv = uv + fp.shift;
        if self.filter() == FilterType::Nearest || fp.is_point() {
            return self.lookup_level_a(0, uv);
        }
        let size = Vec2::new(self.width() as f32, self.height() as f32);
        let top = self.levels() - 1;
        let texels = Footprint::new(fp.a * size, fp.b * size);
        if texels.is_point() {
            // Only a footprint so large that it overflowed in texels gets here.
            return self.lookup_level_a(top, uv);
        }
        // The major semi-axis is at most sqrt(|a|^2 + |b|^2): most lookups at high sample
        // counts stop here without the eigen-decomposition.
        if texels.a.length_squared() + texels.b.length_squared() <= 1.0 {
            return self.lookup_level_a(0, uv);
        }
        if fp.isotropic {
            return self.lookup_isotropic(uv, texels);
        }
        let (major, minor) = texels.principal_axes();
        let major_len = major.length();
        if major_len.is_nan() || major_len <= 1.0 {
            // Within a texel (NaN too): bilinear.
            return self.lookup_level_a(0, uv);
        }
        let minor_len = minor.length().max(major_len / MAX_ANISOTROPY);
        let rho = minor_len.max(1.0);
        // rho = 1 (a minor axis within a texel, the usual anisotropic case) is level 0 exactly,
        // without the libm call.
        let lod = if rho == 1.0 { 0.0 } else { rho.log2() };
        if lod >= top as f32 {
            // Wider than the whole image: the coarsest level (1x1, the mean).
            return self.lookup_level_a(top, uv);
        }
        let spread = (major_len * major_len - rho * rho).max(0.0).sqrt();
        // Probes every rho texels from the centre out to the spread; a probe enters at the ends
        // with zero weight, so the result is continuous as the footprint grows.
        let m = ((spread / rho) as usize).min(MAX_PROBES / 2);
        if m == 0 {
            return self.lookup_lod_a(uv, lod);
        }
        // One probe step (rho texels along the major axis) in uv units, and in units of spread.
        let step = major * (rho / major_len) / size;
        let dt = rho / spread;
        let probe = self.lod_lookup(lod);
        let mut sum = probe.at(uv);
        let mut weights = 1.0;
        for k in 1..=m {
            let t = k as f32 * dt;
            let w = (1.0 - t * t) * (1.0 - t * t);
            let off = step * k as f32;
            sum += (probe.at(uv + off) + probe.at(uv - off)) * w;
            weights += 2.0 * w;
        }
        sum / weights
    }

    /// [`Footprint::isotropic`]'s lookup of `texels` (the footprint in level-0 texels) at `uv`:
    /// one trilinear probe at the level of the radius `rho = sqrt(major · minor)`, the circle of
    /// the ellipse's area; bilinear at level 0 for `rho <= 1`. A round footprint gets what the
    /// anisotropic lookup gives it (its probes reduce to the centre one).
    fn lookup_isotropic(&self, uv: Vec2, texels: Footprint) -> Vec3A {
        let rho = texels.a.perp_dot(texels.b).abs().sqrt();
        // Not above one texel (NaN too): bilinear.
        if rho.is_nan() || rho <= 1.0 {
            return self.lookup_level_a(0, uv);
        }
        let lod = rho.log2();
        if lod >= (self.levels() - 1) as f32 {
            return self.lookup_level_a(self.levels() - 1, uv);
        }
        self.lookup_lod_a(uv, lod)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Image;
    use crate::mipmap::WrapMode;
    use glam::Vec3;

    /// `lookup_aniso` as a `Vec3`, from the packed texels: what the renderer's bitmaps read.
    trait Aniso3 {
        fn aniso(&self, uv: Vec2, fp: Footprint) -> Vec3;
    }

    impl Aniso3 for MipMap {
        fn aniso(&self, uv: Vec2, fp: Footprint) -> Vec3 {
            self.lookup_aniso(uv, fp).into()
        }
    }

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

    /// Stripes one texel wide varying along x only (`along_x`) or along y only.
    fn stripes(n: u32, along_x: bool) -> MipMap {
        let px = (0..n * n)
            .map(|k| {
                let i = if along_x { k % n } else { k / n };
                Vec3::splat((i % 2) as f32)
            })
            .collect();
        MipMap::new(Image::new(n, n, px), WrapMode::Repeat, FilterType::Bilinear)
            .with_packed_texels()
    }

    fn random_footprint(rng: &mut torrey_testkit::Rng, scale: f32) -> Footprint {
        let s = scale * rng.f32();
        Footprint::new(
            Vec2::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)) * s,
            Vec2::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)) * s * rng.f32(),
        )
    }

    #[test]
    fn constant_texture_is_that_constant() {
        let c = Vec3::new(0.25, 0.5, 0.75);
        let mut rng = torrey_testkit::Rng::new(1);
        for wrap in [WrapMode::Repeat, WrapMode::Mirror, WrapMode::Clamp] {
            let mip = MipMap::new(Image::filled(37, 20, c), wrap, FilterType::Bilinear)
                .with_packed_texels();
            for k in 0..2000 {
                let fp = random_footprint(&mut rng, [0.01, 0.1, 1.0, 100.0][k % 4]);
                let uv = Vec2::new(rng.range(-2.0, 3.0), rng.range(-2.0, 3.0));
                let v = mip.aniso(uv, fp);
                assert!(v.abs_diff_eq(c, 1e-5), "{wrap:?} {fp:?} {uv}: {v}");
            }
        }
    }

    #[test]
    fn footprint_within_a_texel_is_the_bilinear_lookup() {
        let mip = MipMap::new(pattern(64, 32), WrapMode::Repeat, FilterType::Bilinear)
            .with_packed_texels();
        let mut rng = torrey_testkit::Rng::new(2);
        for _ in 0..2000 {
            let uv = Vec2::new(rng.range(-1.0, 2.0), rng.range(-1.0, 2.0));
            // Semi-axes of at most one texel (1/64 in u, 1/32 in v) in any direction.
            let dir = Vec2::from_angle(rng.range(0.0, 6.3));
            let fp = Footprint::new(
                dir * Vec2::new(1.0 / 64.0, 1.0 / 32.0) * rng.f32(),
                dir.perp() * Vec2::new(1.0 / 64.0, 1.0 / 32.0) * rng.f32(),
            );
            assert_eq!(mip.aniso(uv, fp), mip.lookup_level(0, uv), "{fp:?}");
        }
        let uv = Vec2::new(0.3, 0.4);
        assert_eq!(mip.aniso(uv, Footprint::POINT), mip.lookup_level(0, uv));
    }

    #[test]
    fn footprint_along_an_axis_filters_only_along_it() {
        let n = 64;
        let mut rng = torrey_testkit::Rng::new(3);
        for k in 0..500 {
            let uv = Vec2::new(rng.f32(), rng.f32());
            // Up to 12 texels long along v, a fraction of a texel across.
            let len = (1.5 + 10.5 * rng.f32()) / n as f32;
            let fp = Footprint::new(
                Vec2::new(0.0, len),
                Vec2::new(0.3 * rng.f32() / n as f32, 0.0),
            );
            // Stripes that vary along u only: filtering along v changes nothing.
            let across = stripes(n, true);
            let got = across.aniso(uv, fp);
            let want = across.lookup_level(0, uv);
            assert!(got.abs_diff_eq(want, 1e-5), "{k}: {got} vs {want}");
            // Stripes that vary along v are averaged towards their mean 0.5.
            let along = stripes(n, false);
            let got = along.aniso(uv, fp).x;
            let plain = along.lookup_level(0, uv).x;
            assert!(
                (got - 0.5).abs() <= (plain - 0.5).abs() + 1e-5,
                "{k}: {got} vs {plain}"
            );
            if len * n as f32 > 4.0 {
                assert!((got - 0.5).abs() < 0.1, "{k} len {len}: {got}");
            }
        }
    }

    #[test]
    fn filter_integrates_to_one() {
        // The average of the filtered texture over one period equals the texture's mean: each
        // texel's total weight, integrated over all lookup positions, is one texel's area.
        let mut img = Image::filled(16, 16, Vec3::ZERO);
        img.pixels[5 * 16 + 9] = Vec3::ONE;
        let mip = MipMap::new(img, WrapMode::Repeat, FilterType::Bilinear).with_packed_texels();
        let m = 1.0 / 256.0;
        for fp in [
            Footprint::new(Vec2::new(0.2, 0.05), Vec2::new(-0.01, 0.02)),
            Footprint::new(Vec2::new(0.0, 0.4), Vec2::new(0.03, 0.0)),
            Footprint::circle(0.15),
            Footprint::new(Vec2::new(3.0, 2.0), Vec2::new(0.0, 0.1)),
            Footprint::new(Vec2::new(0.2, 0.05), Vec2::new(-0.01, 0.02)).isotropic(),
            Footprint::new(Vec2::new(0.0, 0.4), Vec2::new(0.03, 0.0)).isotropic(),
        ] {
            let g = 256;
            let mut sum = 0.0f64;
            for j in 0..g {
                for i in 0..g {
                    let uv = Vec2::new((i as f32 + 0.5) / g as f32, (j as f32 + 0.5) / g as f32);
                    sum += mip.aniso(uv, fp).x as f64;
                }
            }
            let mean = sum / (g * g) as f64;
            assert!((mean - m).abs() < 2e-3 * m, "{fp:?}: {mean} vs {m}");
        }
    }

    #[test]
    fn isotropic_footprint_is_trilinear() {
        let mip = MipMap::new(pattern(64, 64), WrapMode::Repeat, FilterType::Bilinear)
            .with_packed_texels();
        for r in [2.0f32, 3.0, 7.5, 20.0] {
            let uv = Vec2::new(0.31, 0.62);
            let got = mip.aniso(uv, Footprint::circle(r / 64.0));
            let want = mip.lookup_lod(uv, r.log2());
            assert!(got.abs_diff_eq(want, 1e-5), "{r}: {got} vs {want}");
        }
    }

    /// An isotropic footprint (after a rough bounce) is one trilinear probe at the radius of the
    /// circle of its area, whatever its stretch; round, it is what the anisotropic lookup gives.
    #[test]
    fn isotropic_lookups_take_one_probe_at_the_area_radius() {
        let mip = MipMap::new(pattern(64, 32), WrapMode::Repeat, FilterType::Bilinear)
            .with_packed_texels();
        let size = Vec2::new(64.0, 32.0);
        let uv = Vec2::new(0.31, 0.62);
        for (major, minor, angle) in [(40.0f32, 2.5f32, 0.3f32), (9.0, 4.0, 1.2), (3.0, 0.2, 2.0)] {
            let dir = Vec2::from_angle(angle);
            let fp = Footprint::new(dir * major / size, dir.perp() * minor / size);
            let got = mip.aniso(uv, fp.isotropic());
            let rho = (major * minor).sqrt();
            let want = if rho > 1.0 {
                mip.lookup_lod(uv, rho.log2())
            } else {
                mip.lookup_level(0, uv)
            };
            assert!(
                got.abs_diff_eq(want, 1e-4),
                "{major}x{minor}: {got} vs {want}"
            );
            // The stretched footprint's anisotropic lookup filters differently.
            if major / minor > 2.0 {
                assert!(
                    !mip.aniso(uv, fp).abs_diff_eq(want, 1e-3),
                    "{major}x{minor}"
                );
            }
        }
        for r in [0.5f32, 2.0, 7.5] {
            let fp = Footprint::circle(r / 64.0)
                .transformed(glam::Mat2::from_diagonal(Vec2::new(1.0, 2.0)));
            let (iso, aniso) = (mip.aniso(uv, fp.isotropic()), mip.aniso(uv, fp));
            assert!(iso.abs_diff_eq(aniso, 1e-5), "{r}: {iso} vs {aniso}");
        }
        // The flag survives the maps a bitmap applies (its uv transform, the spp scale).
        let fp = Footprint::circle(0.1).isotropic();
        assert!(fp.scaled(0.5).isotropic && fp.transformed(glam::Mat2::IDENTITY).isotropic);
    }

    #[test]
    fn continuous_in_uv_and_footprint() {
        let mip = MipMap::new(pattern(37, 20), WrapMode::Repeat, FilterType::Bilinear)
            .with_packed_texels();
        let uv = Vec2::new(0.41, 0.27);
        let dir = Vec2::from_angle(0.3);
        // Grow the major axis from 0.5 to 200 texels, the minor from 0.1 to 3 texels.
        let mut prev = mip.aniso(uv, Footprint::POINT);
        let steps = 4000;
        for k in 0..=steps {
            let t = k as f32 / steps as f32;
            let major = 0.5 * 400f32.powf(t) / 37.0;
            let minor = 0.1 * 30f32.powf(t) / 37.0;
            let cur = mip.aniso(uv, Footprint::new(dir * major, dir.perp() * minor));
            assert!(
                (cur - prev).abs().max_element() < 0.03,
                "step {k}: {prev} -> {cur}"
            );
            prev = cur;
        }
    }

    #[test]
    fn huge_and_non_finite_footprints_stay_finite() {
        let mip =
            MipMap::new(pattern(5, 3), WrapMode::Clamp, FilterType::Bilinear).with_packed_texels();
        let top = mip.level(mip.levels() - 1).pixels[0];
        let huge = Footprint::new(Vec2::new(1e30, 0.0), Vec2::new(0.0, 1e29));
        assert!(mip.aniso(Vec2::new(0.5, 0.5), huge).abs_diff_eq(top, 1e-6));
        let inf = Footprint::new(Vec2::new(1e38, 0.0), Vec2::ZERO);
        assert!(mip.aniso(Vec2::new(0.5, 0.5), inf).abs_diff_eq(top, 1e-6));
        let long = Footprint::new(Vec2::new(1e30, 0.0), Vec2::ZERO);
        assert!(mip.aniso(Vec2::new(0.5, 0.5), long).is_finite());
        for uv in [Vec2::NAN, Vec2::new(1e30, -1e30), Vec2::INFINITY] {
            let _ = mip.aniso(uv, Footprint::circle(0.3));
        }
        let nearest = MipMap::new(pattern(8, 8), WrapMode::Repeat, FilterType::Nearest);
        let uv = Vec2::new(0.3, 0.6);
        assert_eq!(
            nearest.aniso(uv, Footprint::circle(0.5)),
            nearest.lookup_level(0, uv)
        );
    }

    /// The packed texels give the pyramid's own values to the bit, through every branch of the
    /// filter (point, within a texel, one trilinear probe, probes along the axis, the coarsest
    /// level), for power-of-two and other sizes, every wrap mode, inside and far outside [0, 1].
    #[test]
    fn packed_texels_give_the_same_bits() {
        let mut rng = torrey_testkit::Rng::new(21);
        for wrap in [WrapMode::Repeat, WrapMode::Mirror, WrapMode::Clamp] {
            for (w, h) in [(64, 32), (37, 20), (256, 256), (1, 1), (1, 8), (768, 3)] {
                let plain = MipMap::new(pattern(w, h), wrap, FilterType::Bilinear);
                let packed = plain.clone().with_packed_texels();
                for k in 0..3000 {
                    let span = [1.0, 5.0, 1e5][k % 3];
                    let uv = Vec2::new(rng.range(-span, span), rng.range(-span, span));
                    let scale = [0.0, 0.3 / w as f32, 4.0 / w as f32, 0.1, 10.0][k % 5];
                    let fp = random_footprint(&mut rng, scale)
                        .with_shift(Vec2::new(rng.range(-0.01, 0.01), 0.0));
                    let (a, b) = (plain.lookup_aniso(uv, fp), packed.lookup_aniso(uv, fp));
                    assert_eq!(
                        Vec3::from(a).to_array().map(f32::to_bits),
                        Vec3::from(b).to_array().map(f32::to_bits),
                        "{wrap:?} {w}x{h} {uv} {fp:?}"
                    );
                }
                for uv in [Vec2::NAN, Vec2::new(1e30, -3e9), Vec2::INFINITY] {
                    let fp = Footprint::circle(0.2);
                    let (a, b) = (plain.lookup_aniso(uv, fp), packed.lookup_aniso(uv, fp));
                    assert_eq!(
                        Vec3::from(a).to_array().map(f32::to_bits),
                        Vec3::from(b).to_array().map(f32::to_bits)
                    );
                }
            }
        }
    }
}
