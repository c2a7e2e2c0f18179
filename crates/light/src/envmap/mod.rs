//! Lat-long environment map with luminance importance sampling, in Mitsuba 3's orientation.
//!
//! Local frame (before `to_world`): theta = pi v, phi = 2 pi u and
//! `d = (sin phi sin theta, cos theta, -cos phi sin theta)`, so +y is up, v = 0 (image row 0) is the
//! zenith and u = 0 looks down -z. Inverse: u = atan2(d.x, -d.z) / 2pi wrapped to [0, 1),
//! v = acos(d.y) / pi (computed with atan2 for precision at the poles).
//!
//! Texel placement, as Mitsuba 3.9.1's `envmap.cpp`: texel (i, j) is the radiance at
//! u = (i + 0.5) / W (column centres: its half-texel shift) and v = j / (H - 1) (row 0 exactly at
//! the zenith, row H - 1 exactly at the nadir), bilinear in between, u wrapping (the first column
//! follows the last). So the rows are not at cell centres: the lookup maps v to the texel-centred
//! coordinate (v (H - 1) + 0.5) / H of the (centre-based) mip pyramid. Coarser levels follow the
//! same rule with their own H (they only matter for wide ray cones, which Mitsuba does not filter).
//!
//! Sampling, as Mitsuba's (a piecewise-bilinear `Hierarchical2D` over the same grid): the density
//! over the unit square p(u, v) is the bilinear interpolant, on the texel grid above, of each
//! texel's Rec.709 luminance x sin(theta of its row), normalised. A patch (i, j) (between texels
//! (i, j) and (i + 1, j + 1), i + 1 wrapping; W x (H - 1) of them) is chosen by alias tables
//! (a marginal one over bands of rows, one per band over columns) with the mean of its corners
//! (the exact integral of the interpolant over it), then a point inside it by the bilinear warp.
//! The density over solid angle is p(u, v) / (2 pi^2 sin theta), with theta the direction's own
//! polar angle (exact Jacobian of the lat-long map). Since p is continuous and read from the same
//! four texels as the radiance, sample and pdf agree everywhere and `eval_pdf` gets both from one
//! bilinear lookup.
//!
//! Alias tables take one dependent memory read per level, where an inverse-cdf search reads a
//! guide table and then the cdf. Each finest-level texel is stored with its normalised sampling
//! weight in one 16-byte record, so the bilinear lookup of a sampled or escaped direction brings
//! its pdf along in the same cache lines. Environment-map work was about half of an envmap-lit render before this layout
//! (docs/performance.md, design decisions).

use crate::alias::AliasSlot;
use glam::{Mat3, Vec2, Vec3, Vec4};
use std::f32::consts::PI;
use torrey_fastmath as fastmath;
use torrey_texture::{FilterType, Image, MipMap, WrapMode};

mod batch;
mod sample_lanes;
mod sampling;

pub use batch::{BatchSimd, BATCH_LANES};
use sampling::{patch_weights, sample_linear, vertex_weights, SamplingTables};

/// Rec.709 luminance: the importance of a linear RGB radiance for sampling purposes.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// A direction sampled from an [`EnvMap`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvSample {
    /// Unit world direction pointing away from the scene, towards the sky.
    pub direction: Vec3,
    /// Radiance arriving from `direction` (finest level, scale applied).
    pub radiance: Vec3,
    /// Density over solid angle.
    pub pdf: f32,
}

/// Lat-long environment map in Mitsuba 3's orientation (see CONVENTIONS.md, "Environment map").
#[derive(Clone, Debug)]
pub struct EnvMap {
    /// Pyramid of the sanitised texels (non-negative, finite), row 0 = top = zenith.
    mip: MipMap,
    /// 1 / (angular size of the coarser texel axis), for ray-cone footprints.
    texels_per_radian: f32,
    width: usize,
    height: usize,
    /// (width, height) as f32, so the hot paths do not convert (usize to f32 costs a branch).
    size: Vec2,
    /// 1 / `size`.
    inv_size: Vec2,
    /// 1 / (number of bands of sampling patches, `height` - 1).
    inv_bands: f32,
    scale: f32,
    to_world: Mat3,
    to_local: Mat3,
    /// The finest level's texels: rgb in xyz, and in w the density over the unit square of
    /// choosing the patch whose top-left corner the texel is (marginal x conditional, as the
    /// alias tables realise them; 0 in the last row).
    texels: Vec<Vec4>,
    /// Alias table over bands of patches (`height` - 1 slots).
    row_slots: Vec<AliasSlot>,
    /// One alias table per row over its columns, `width` slots each, flattened.
    column_slots: Vec<AliasSlot>,
    /// False for an all-black map: nothing to sample, pdf is 0 everywhere.
    samplable: bool,
}

/// Negative, NaN and infinite texels become 0.
fn sanitised(mut image: Image) -> Image {
    for p in &mut image.pixels {
        *p = Vec3::select(p.cmpgt(Vec3::ZERO) & p.is_finite_mask(), *p, Vec3::ZERO);
    }
    image
}

/// The texel-centred v (what the mip pyramid's bilinear lookup takes) of the direction's v on a
/// level of `height` rows placed as Mitsuba places them (row j at v = j / (height - 1)).
#[inline(always)]
fn row_v(v: f32, height: f32) -> f32 {
    (v * (height - 1.0) + 0.5) / height
}

/// Makes `m` a proper orthonormal basis (Gram-Schmidt on its columns, keeping handedness), so that
/// the transform preserves solid angle and its inverse is the transpose. Degenerate input gives
/// the identity.
fn orthonormalize(m: Mat3) -> Mat3 {
    let x = m.x_axis.normalize_or_zero();
    let y = (m.y_axis - m.y_axis.dot(x) * x).normalize_or_zero();
    if x == Vec3::ZERO || y == Vec3::ZERO || !x.is_finite() || !y.is_finite() {
        return Mat3::IDENTITY;
    }
    let z = x.cross(y);
    let z = if m.determinant() < 0.0 { -z } else { z };
    Mat3::from_cols(x, y, z)
}

impl EnvMap {
    /// `to_world` is the rotation part of the emitter's toWorld; `scale` multiplies radiance.
    /// Negative/NaN/infinite texels become 0, a non-positive or NaN scale gives a black map, a
    /// non-rotation `to_world` is orthonormalised, and an empty image acts as a black 1x1 map.
    pub fn new(image: Image, scale: f32, to_world: Mat3) -> Self {
        let image = if image.width == 0
            || image.height == 0
            || image.pixels.len() != image.width as usize * image.height as usize
        {
            Image::filled(1, 2, Vec3::ZERO)
        } else if image.height == 1 {
            // One row is the radiance at the zenith and at the nadir alike (a map constant in v):
            // two equal rows, so that there is a band of patches between them.
            let mut pixels = image.pixels.clone();
            pixels.extend_from_slice(&image.pixels);
            sanitised(Image::new(image.width, 2, pixels))
        } else {
            sanitised(image)
        };
        Self::from_sanitised(image, scale, to_world)
    }

    fn from_sanitised(image: Image, scale: f32, to_world: Mat3) -> Self {
        let scale = if scale.is_finite() && scale > 0.0 {
            scale
        } else {
            0.0
        };
        let (width, height) = (image.width as usize, image.height as usize);
        let vertex = vertex_weights(&image);
        let tables = SamplingTables::new(&patch_weights(&vertex, width, height), width, height - 1);
        let samplable = tables.weight_sum > 0.0 && scale > 0.0;
        // The interpolant's integral over the unit square is the patches' mean weight; dividing
        // by it makes the interpolant of the stored weights the density p(u, v).
        let integral = tables.weight_sum / (width * (height - 1)) as f64;
        let norm = if samplable {
            (1.0 / integral) as f32
        } else {
            0.0
        };
        let texels = image
            .pixels
            .iter()
            .zip(&vertex)
            .map(|(rgb, &w)| rgb.extend(w * norm))
            .collect();
        let to_world = orthonormalize(to_world);
        let texel_angle = (PI / height as f32).max(2.0 * PI / width as f32);
        Self {
            mip: MipMap::new(image, WrapMode::Repeat, FilterType::Bilinear),
            texels_per_radian: 1.0 / texel_angle,
            width,
            height,
            size: Vec2::new(width as f32, height as f32),
            inv_size: Vec2::new(width as f32, height as f32).recip(),
            inv_bands: 1.0 / (height - 1) as f32,
            scale,
            to_world,
            to_local: to_world.transpose(),
            texels,
            row_slots: tables.row_slots,
            column_slots: tables.column_slots,
            samplable,
        }
    }

    /// Image width in texels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Image height in texels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// The (orthonormalised) local-to-world rotation.
    pub fn to_world(&self) -> Mat3 {
        self.to_world
    }

    /// Local lat-long uv of a local direction (need not be normalised), and sin(theta) of the
    /// normalised direction. A zero or non-finite direction reads as the zenith (+y), whose
    /// sin(theta) is 0.
    #[inline]
    fn local_dir_to_uv_sin(d: Vec3) -> (Vec2, f32) {
        Self::local_dir_to_uv_sin_inline(d)
    }

    /// [`Self::local_dir_to_uv_sin`], always inlined (the SIMD lanes of `eval_pdf_batch`).
    #[inline(always)]
    fn local_dir_to_uv_sin_inline(d: Vec3) -> (Vec2, f32) {
        // Both atan2s are scale-invariant, so the direction is not normalised first: that would
        // put a square root and a division in front of everything else on the lookup's critical
        // path. Only sin(theta), which the pdf needs, is taken of the normalised direction.
        let (r2, l2) = (d.x * d.x + d.z * d.z, d.length_squared());
        // A zero, NaN or overflowing direction reads as the zenith (as `normalize_or(Y)` would).
        let (d, r2, l2) = if l2 > 0.0 && l2.is_finite() {
            (d, r2, l2)
        } else {
            (Vec3::Y, 0.0, 1.0)
        };
        let r = r2.sqrt();
        let sin_theta = (r2 / l2).sqrt();
        let mut u = fastmath::atan2_inline(d.x, -d.z) * (0.5 / PI);
        if u < 0.0 {
            u += 1.0;
        }
        if u.is_nan() || u >= 1.0 {
            u = 0.0;
        }
        // atan2 rather than acos(d.y): acos loses half the digits near the poles.
        let v = (fastmath::atan2_inline(r, d.y) * (1.0 / PI)).clamp(0.0, 1.0);
        (Vec2::new(u, v), sin_theta)
    }

    /// Local lat-long uv of a local direction (need not be normalised).
    #[inline]
    fn local_dir_to_uv(d: Vec3) -> Vec2 {
        Self::local_dir_to_uv_sin(d).0
    }

    /// Local direction of a lat-long uv, and its sin(theta).
    #[inline]
    fn uv_to_local_dir_sin(uv: Vec2) -> (Vec3, f32) {
        // theta = pi v = 2 pi (v / 2), phi = 2 pi u; halving is exact.
        let (sin_theta, cos_theta) = fastmath::sin_cos_2pi(0.5 * uv.y);
        let (sin_phi, cos_phi) = fastmath::sin_cos_2pi(uv.x);
        (
            Vec3::new(sin_phi * sin_theta, cos_theta, -cos_phi * sin_theta),
            sin_theta,
        )
    }

    /// Local direction of a lat-long uv.
    #[inline]
    fn uv_to_local_dir(uv: Vec2) -> Vec3 {
        Self::uv_to_local_dir_sin(uv).0
    }

    /// Lat-long uv of a world direction (the inverse rotation is applied first).
    #[inline]
    pub fn dir_to_uv(&self, dir_world: Vec3) -> Vec2 {
        Self::local_dir_to_uv(self.to_local * dir_world)
    }

    /// Unit world direction of a lat-long uv.
    #[inline]
    pub fn uv_to_dir(&self, uv: Vec2) -> Vec3 {
        self.to_world * Self::uv_to_local_dir(uv)
    }

    /// Trilinear lookup of the direction's `uv` with Mitsuba's texel placement (module doc); u
    /// repeats (the map is periodic in phi). The pyramid is built with `Repeat`, which would
    /// blend the zenith row with the nadir row, so each level's v is clamped to its first/last
    /// texel centre here (the row remap keeps every v in [0, 1] inside already).
    #[inline]
    fn lookup(&self, uv: Vec2, footprint: f32) -> Vec3 {
        if footprint <= 0.0 {
            // Every lookup after a rough bounce: no pyramid level to choose.
            return self.bilinear_finest(uv);
        }
        let level = self.mip.level_for_footprint(footprint);
        // `level` is finite and in [0, levels - 1]: truncation is floor (without libm's call).
        let l0 = level as usize;
        let t = level - l0 as f32;
        let a = if l0 == 0 {
            self.bilinear_finest(uv)
        } else {
            self.lookup_level_clamped(l0, uv)
        };
        if t <= 0.0 || l0 + 1 >= self.mip.levels() {
            return a;
        }
        a * (1.0 - t) + self.lookup_level_clamped(l0 + 1, uv) * t
    }

    /// `lookup_level_clamped(0, uv)`, to the bit, read from the 16-byte texel records: one aligned
    /// load per texel, and the cell density comes along in the same cache lines.
    #[inline]
    fn bilinear_finest(&self, uv: Vec2) -> Vec3 {
        self.bilinear_finest_with_density(uv).truncate()
    }

    /// [`Self::bilinear_finest`] with, in w, the sampling density over the unit square p(u, v)
    /// (0 for a uv outside [0, 1]^2).
    #[inline]
    fn bilinear_finest_with_density(&self, uv: Vec2) -> Vec4 {
        let half = 0.5 * self.inv_size.y;
        let uv = Vec2::new(uv.x, row_v(uv.y, self.size.y));
        let Some(t) = BilinearTaps::new(uv, self.size, half, self.width, self.height) else {
            return self.lookup_level_texel_centred(0, uv).extend(0.0);
        };
        debug_assert!(t.index.iter().all(|&k| k < self.texels.len()));
        // SAFETY: `BilinearTaps::new` gives rows in [0, height) and columns in [0, width), and
        // `texels` holds width x height records (one per texel of the validated image).
        let texel = |k: usize| unsafe { *self.texels.get_unchecked(t.index[k]) };
        let top = texel(0) * (1.0 - t.fx) + texel(1) * t.fx;
        let bottom = texel(2) * (1.0 - t.fx) + texel(3) * t.fx;
        top * (1.0 - t.fy) + bottom * t.fy
    }

    #[inline]
    fn lookup_level_clamped(&self, level: usize, uv: Vec2) -> Vec3 {
        let h = self.mip.level(level).height as f32;
        self.lookup_level_texel_centred(level, Vec2::new(uv.x, row_v(uv.y, h)))
    }

    /// [`Self::lookup_level_clamped`] after the row remap: `uv` in the pyramid's texel-centred
    /// coordinates.
    #[inline]
    fn lookup_level_texel_centred(&self, level: usize, uv: Vec2) -> Vec3 {
        let img = self.mip.level(level);
        let size = Vec2::new(img.width as f32, img.height as f32);
        let half = 0.5 / size.y;
        let (w, h) = (img.width as usize, img.height as usize);
        let Some(t) = BilinearTaps::new(uv, size, half, w, h) else {
            let v = uv.y.clamp(half, 1.0 - half);
            return self.mip.lookup_level(level, Vec2::new(uv.x, v));
        };
        let px = &img.pixels;
        let top = px[t.index[0]] * (1.0 - t.fx) + px[t.index[1]] * t.fx;
        let bottom = px[t.index[2]] * (1.0 - t.fx) + px[t.index[3]] * t.fx;
        top * (1.0 - t.fy) + bottom * t.fy
    }

    /// Filter width in uv units (the MipMap's convention: texels = footprint x max(W, H)) for a
    /// ray cone of angle `spread`. The cone covers spread/pi of v and spread/(2 pi sin theta) of u;
    /// we take the isotropic angular size, i.e. spread divided by the coarser texel angle
    /// (max(pi/H, 2pi/W); equal for the usual 2:1 maps), ignoring the 1/sin theta stretch of u near
    /// the poles: that under-filters there a little rather than blurring the zenith.
    #[inline]
    fn footprint(&self, spread: f32) -> f32 {
        if spread.is_finite() && spread > 0.0 {
            spread * self.texels_per_radian / self.width.max(self.height) as f32
        } else {
            0.0
        }
    }

    /// Radiance arriving from world direction `dir` (pointing away from the scene, towards the
    /// sky). `spread` = ray-cone spread angle in radians; 0 -> finest level.
    #[inline]
    pub fn eval(&self, dir: Vec3, spread: f32) -> Vec3 {
        if self.scale == 0.0 {
            return Vec3::ZERO;
        }
        let uv = self.dir_to_uv(dir);
        self.lookup(uv, self.footprint(spread)) * self.scale
    }

    /// `(self.eval(dir, spread), self.pdf(dir))`, converting the direction to uv once: what a
    /// path that escapes to the sky needs for its MIS weight.
    #[inline]
    pub fn eval_pdf(&self, dir: Vec3, spread: f32) -> (Vec3, f32) {
        if self.scale == 0.0 {
            return (Vec3::ZERO, 0.0);
        }
        let (uv, sin_theta) = Self::local_dir_to_uv_sin(self.to_local * dir);
        self.eval_pdf_uv(uv, sin_theta, spread, true)
    }

    /// [`Self::eval_pdf`] of the direction with local `uv` and `sin_theta` (a map whose scale is
    /// not 0): the part `eval_pdf_batch` shares with it.
    /// With `want_pdf` false the density is not looked up (0 is returned in its place).
    #[inline]
    fn eval_pdf_uv(&self, uv: Vec2, sin_theta: f32, spread: f32, want_pdf: bool) -> (Vec3, f32) {
        let footprint = self.footprint(spread);
        if footprint <= 0.0 && self.samplable {
            // Radiance and density from the same four texel records.
            let l = self.bilinear_finest_with_density(uv);
            return (
                l.truncate() * self.scale,
                Self::solid_angle_pdf(l.w, sin_theta),
            );
        }
        let radiance = self.lookup(uv, footprint) * self.scale;
        if !want_pdf {
            return (radiance, 0.0);
        }
        (radiance, self.pdf_uv(uv, sin_theta))
    }

    /// The density over solid angle of a direction whose density over the unit square is `p_uv`.
    #[inline(always)]
    fn solid_angle_pdf(p_uv: f32, sin_theta: f32) -> f32 {
        if sin_theta.is_nan() || sin_theta <= 0.0 || p_uv.is_nan() || p_uv <= 0.0 {
            0.0
        } else {
            p_uv / (2.0 * PI * PI * sin_theta)
        }
    }
}

/// Asks the CPU to start loading the cache line at `p` (no effect on results; any address is
/// allowed, nothing is dereferenced).
#[inline(always)]
fn prefetch<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint and never faults, whatever the address.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p as *const i8)
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// The four texels and two weights of a bilinear lookup in one level of the map.
///
/// `MipMap::lookup_level`'s bilinear arithmetic, step for step (so the result is the same to the
/// bit), specialised to this map: u repeats, v is clamped to the first/last texel centre (`half`
/// texel of the level, in v), and the coordinates are at most one texel outside the image, so
/// wrapping is a compare instead of a division and floor is a truncation instead of a libm call.
struct BilinearTaps {
    /// Row-major indices of the top-left, top-right, bottom-left and bottom-right texels.
    index: [usize; 4],
    fx: f32,
    fy: f32,
}

impl BilinearTaps {
    /// `None` when `uv` is not in [0, 1] x [0, 1] (NaN or out of range): the generic path then.
    #[inline(always)]
    fn new(uv: Vec2, size: Vec2, half: f32, width: usize, height: usize) -> Option<Self> {
        let v = uv.y.clamp(half, 1.0 - half);
        let x = uv.x * size.x - 0.5;
        let y = v * size.y - 0.5;
        if !(x >= -1.0 && x < size.x && y >= -1.0 && y < size.y) {
            return None;
        }
        let (i, fx) = floor_frac(x);
        let (j, fy) = floor_frac(y);
        let (w, h) = (width as i32, height as i32);
        // x in [-1, W) puts i in [-1, W - 1]: only i can fall off the left edge and only i + 1 off
        // the right one (the same for rows); a tap is at most one texel outside.
        let first = |k: i32, n: i32| if k < 0 { n - 1 } else { k };
        let second = |k: i32, n: i32| if k >= n { 0 } else { k };
        let (c0, c1) = (first(i, w) as usize, second(i + 1, w) as usize);
        let (r0, r1) = (
            first(j, h) as usize * width,
            second(j + 1, h) as usize * width,
        );
        Some(Self {
            index: [r0 + c0, r0 + c1, r1 + c0, r1 + c1],
            fx,
            fy,
        })
    }
}

/// `(floor(t), t - floor(t))` for `t` in [-2^31, 2^31): what `MipMap::lookup_level` computes with
/// `f32::floor`, without the libm call that baseline x86-64 needs for it.
#[inline]
fn floor_frac(t: f32) -> (i32, f32) {
    let k = t as i32;
    let k = if k as f32 > t { k - 1 } else { k };
    (k, t - k as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::unit::ONE_MINUS_EPSILON;
    use torrey_testkit::{assert_chi_square, Rng};

    fn rotation() -> Mat3 {
        Mat3::from_axis_angle(Vec3::new(1.0, 2.0, -0.5).normalize(), 0.9)
    }

    /// A structured, strictly positive test map with a bright spot.
    fn test_image(w: u32, h: u32) -> Image {
        let px = (0..w * h)
            .map(|k| {
                let (i, j) = ((k % w) as f32, (k / w) as f32);
                let mut c = Vec3::new(
                    0.2 + 0.8 * (i / w as f32),
                    0.1 + (j * 0.7).sin().abs(),
                    0.3 + ((i + 2.0 * j) as u32 % 5) as f32 * 0.2,
                );
                if (k % w, k / w) == (w / 3, h / 4) {
                    c *= 40.0;
                }
                c
            })
            .collect();
        Image::new(w, h, px)
    }

    fn formula_dir(uv: Vec2) -> Vec3 {
        let (theta, phi) = (PI * uv.y, 2.0 * PI * uv.x);
        Vec3::new(
            phi.sin() * theta.sin(),
            theta.cos(),
            -phi.cos() * theta.sin(),
        )
    }

    #[test]
    fn orientation_matches_conventions() {
        let env = EnvMap::new(test_image(16, 8), 1.0, Mat3::IDENTITY);
        let close = |a: Vec3, b: Vec3| (a - b).length() < 1e-5;
        assert!(close(env.uv_to_dir(Vec2::new(0.0, 0.5)), -Vec3::Z));
        assert!(close(env.uv_to_dir(Vec2::new(0.25, 0.5)), Vec3::X));
        assert!(close(env.uv_to_dir(Vec2::new(0.5, 0.5)), Vec3::Z));
        assert!(close(env.uv_to_dir(Vec2::new(0.75, 0.5)), -Vec3::X));
        assert!(close(env.uv_to_dir(Vec2::new(0.3, 0.0)), Vec3::Y));
        assert!(close(env.uv_to_dir(Vec2::new(0.3, 1.0)), -Vec3::Y));
        for uv in [
            Vec2::new(0.1, 0.2),
            Vec2::new(0.6, 0.9),
            Vec2::new(0.95, 0.45),
        ] {
            assert!(close(env.uv_to_dir(uv), formula_dir(uv)));
        }
        // Each texel is seen from the direction of its column's centre and its row's line
        // (Mitsuba's placement: v = j / (H - 1)), with and without a rotation.
        for to_world in [Mat3::IDENTITY, rotation()] {
            let img = test_image(16, 8);
            let env = EnvMap::new(img.clone(), 2.0, to_world);
            // (Not on the poles, where u is undefined.)
            for (i, j) in [(0u32, 1u32), (5, 2), (15, 6), (8, 4)] {
                let uv = Vec2::new((i as f32 + 0.5) / 16.0, j as f32 / 7.0);
                let dir = to_world * formula_dir(uv);
                let got = env.eval(dir, 0.0);
                let want = img.get(i, j) * 2.0;
                assert!(
                    (got - want).length() < 1e-4 * want.length(),
                    "{got} vs {want}"
                );
            }
        }
    }

    /// The generic MipMap path that `lookup_level_clamped` specialises.
    fn generic_lookup(env: &EnvMap, level: usize, uv: Vec2) -> Vec3 {
        let h = env.mip.level(level).height as f32;
        let half = 0.5 / h;
        env.mip.lookup_level(
            level,
            Vec2::new(uv.x, row_v(uv.y, h).clamp(half, 1.0 - half)),
        )
    }

    /// Radiance of a 4x3 map whose texel (x, y) is (x, y, 0), along directions given by their
    /// lat-long uv: the values Mitsuba 3.9.1's `envmap` returns for the same map and directions
    /// (`eval` in scalar_rgb; the texel at u = (x + 0.5) / W, v = y / (H - 1), the seam blending
    /// the last column with the first).
    #[test]
    fn lookup_matches_mitsuba_3_9_1() {
        let px = (0..12)
            .map(|k| Vec3::new((k % 4) as f32, (k / 4) as f32, 0.0))
            .collect();
        let env = EnvMap::new(Image::new(4, 3, px), 1.0, Mat3::IDENTITY);
        let mitsuba = [
            ((0.125, 0.25), (0.0, 0.5)),
            ((0.0, 0.25), (1.5, 0.5)),
            ((0.25, 0.5), (0.5, 1.0)),
            ((0.375, 0.5), (1.0, 1.0)),
            ((0.125, 0.01), (0.0, 0.02)),
            ((0.125, 0.99), (0.0, 1.98)),
            ((0.9, 0.5), (2.7, 1.0)),
            ((0.99, 0.5), (1.62, 1.0)),
        ];
        for ((u, v), (r, g)) in mitsuba {
            let got = env.eval(formula_dir(Vec2::new(u, v)), 0.0);
            assert!(
                (got - Vec3::new(r, g, 0.0)).abs().max_element() < 2e-4,
                "uv ({u}, {v}): {got} vs Mitsuba's ({r}, {g}, 0)"
            );
        }
    }

    #[test]
    fn specialised_lookup_matches_mipmap_bit_for_bit() {
        let mut rng = Rng::new(26);
        for (w, h) in [(16u32, 8u32), (7, 5), (1, 1), (64, 32)] {
            let env = EnvMap::new(test_image(w, h), 1.0, Mat3::IDENTITY);
            for level in 0..env.mip.levels() {
                let img = env.mip.level(level);
                let (lw, lh) = (img.width as f32, img.height as f32);
                let mut uvs: Vec<Vec2> = (0..2000).map(|_| rng.vec2()).collect();
                // Texel edges and centres, the seam, the poles and a little outside.
                for k in 0..=2 * img.width.max(img.height) {
                    let t = k as f32 * 0.5;
                    uvs.extend([
                        Vec2::new(t / lw, t / lh),
                        Vec2::new((t / lw).next_up(), (t / lh).next_down()),
                    ]);
                }
                uvs.extend([
                    Vec2::ZERO,
                    Vec2::new(ONE_MINUS_EPSILON, ONE_MINUS_EPSILON),
                    Vec2::ONE,
                    Vec2::new(-0.3, 1.7),
                    Vec2::new(2.5, -0.1),
                    Vec2::new(f32::NAN, 0.5),
                    Vec2::new(0.5, f32::NAN),
                    Vec2::new(f32::INFINITY, 0.5),
                ]);
                for uv in uvs {
                    let got = env.lookup_level_clamped(level, uv);
                    let want = generic_lookup(&env, level, uv);
                    assert_eq!(
                        got.to_array().map(f32::to_bits),
                        want.to_array().map(f32::to_bits),
                        "{w}x{h} level {level} uv {uv}: {got} vs {want}"
                    );
                    if level == 0 {
                        // The texel-record copy of the finest level reads the same values.
                        let finest = env.bilinear_finest(uv);
                        assert_eq!(
                            finest.to_array().map(f32::to_bits),
                            want.to_array().map(f32::to_bits),
                            "{w}x{h} finest uv {uv}: {finest} vs {want}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn floor_frac_is_floor() {
        let mut rng = Rng::new(27);
        let mut ts: Vec<f32> = (0..10_000).map(|_| 4000.0 * rng.f32() - 2000.0).collect();
        ts.extend([
            -1.0, -0.5, -1e-30, -0.0, 0.0, 1e-30, 0.5, 1.0, 511.5, 4095.999,
        ]);
        ts.extend([(-1.0f32).next_up(), 1.0f32.next_down(), 2.0f32.next_down()]);
        for t in ts {
            let (k, f) = floor_frac(t);
            assert_eq!(k as f32, t.floor(), "{t}");
            // `+ 0.0` equates -0 and +0 (t = -0 gives -0 here and +0 with floor; the lookup's
            // coordinates are never -0 anyway).
            assert_eq!((f + 0.0).to_bits(), (t - t.floor()).to_bits(), "{t}");
        }
    }

    #[test]
    fn eval_pdf_matches_eval_and_pdf() {
        let mut rng = Rng::new(28);
        for to_world in [Mat3::IDENTITY, rotation()] {
            let env = EnvMap::new(test_image(32, 16), 1.5, to_world);
            let mut dirs: Vec<Vec3> = (0..5000)
                .map(|_| formula_dir(rng.vec2()) * (0.5 + 2.0 * rng.f32()))
                .collect();
            dirs.extend([
                Vec3::Y,
                -Vec3::Y,
                Vec3::ZERO,
                Vec3::NAN,
                Vec3::new(0.0, 0.0, -1.0),
            ]);
            for d in dirs {
                for spread in [0.0, 0.02, 0.5] {
                    let (l, p) = env.eval_pdf(d, spread);
                    assert_eq!(l, env.eval(d, spread), "{d}");
                    assert_eq!(p.to_bits(), env.pdf(d).to_bits(), "{d}");
                }
            }
        }
    }

    /// The batched lookup gives `eval_pdf`'s bits at every SIMD level this CPU has, for batch
    /// lengths that fill, and do not fill, the lanes, and for zero, NaN, polar and -0 directions.
    #[test]
    fn eval_pdf_batch_matches_eval_pdf_bit_for_bit() {
        let mut rng = Rng::new(29);
        for to_world in [Mat3::IDENTITY, rotation()] {
            let env = EnvMap::new(test_image(32, 16), 1.5, to_world);
            let mut dirs: Vec<Vec3> = (0..997)
                .map(|_| formula_dir(rng.vec2()) * (0.5 + 2.0 * rng.f32()))
                .collect();
            dirs.extend([
                Vec3::Y,
                -Vec3::Y,
                Vec3::ZERO,
                Vec3::NAN,
                Vec3::new(-0.0, 0.0, -1.0),
                Vec3::new(0.0, -0.0, 1.0),
                Vec3::new(1e-30, 1.0, -1e-30),
            ]);
            let spreads: Vec<f32> = (0..dirs.len()).map(|k| [0.0, 0.02, 0.5][k % 3]).collect();
            // Every combination of spread and wanted density (period 6 against period 3).
            let want_pdf: Vec<bool> = (0..dirs.len()).map(|k| k % 6 < 3).collect();
            let mut out = Vec::new();
            for simd in [BatchSimd::Portable, BatchSimd::Avx2, BatchSimd::Avx512] {
                for len in [dirs.len(), 16, 5, 1] {
                    env.eval_pdf_batch(
                        &dirs[..len],
                        &spreads[..len],
                        &want_pdf[..len],
                        simd,
                        &mut out,
                    );
                    assert_eq!(out.len(), len);
                    for (k, &(l, p)) in out.iter().enumerate() {
                        let (el, ep) = env.eval_pdf(dirs[k], spreads[k]);
                        assert_eq!(
                            l.to_array().map(f32::to_bits),
                            el.to_array().map(f32::to_bits)
                        );
                        if want_pdf[k] {
                            assert_eq!(p.to_bits(), ep.to_bits(), "{simd:?} {}", dirs[k]);
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn uv_dir_round_trip() {
        let mut rng = Rng::new(20);
        for to_world in [Mat3::IDENTITY, rotation()] {
            let env = EnvMap::new(test_image(8, 4), 1.0, to_world);
            for _ in 0..1000 {
                let uv = Vec2::new(rng.f32(), 0.001 + 0.998 * rng.f32());
                let dir = env.uv_to_dir(uv);
                assert!((dir.length() - 1.0).abs() < 1e-5);
                let back = env.dir_to_uv(dir);
                let du = (back.x - uv.x).abs();
                let du = du.min(1.0 - du);
                assert!(du < 2e-4 && (back.y - uv.y).abs() < 2e-4, "{uv} -> {back}");
                assert!((0.0..1.0).contains(&back.x) && (0.0..=1.0).contains(&back.y));
            }
        }
    }

    /// Midpoint quadrature of the solid-angle pdf over world (theta, phi) with +z as the pole
    /// (deliberately not the map's own frame).
    fn integrate_over_sphere(f: impl Fn(Vec3) -> f64, nt: usize, np: usize) -> f64 {
        let mut acc = 0.0;
        for it in 0..nt {
            let theta = (it as f64 + 0.5) / nt as f64 * std::f64::consts::PI;
            let mut row = 0.0;
            for ip in 0..np {
                let phi = (ip as f64 + 0.5) / np as f64 * std::f64::consts::TAU;
                let d = glam::DVec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                );
                row += f(d.as_vec3());
            }
            acc += row * theta.sin();
        }
        acc * (std::f64::consts::PI / nt as f64) * (std::f64::consts::TAU / np as f64)
    }

    #[test]
    fn pdf_integrates_to_one() {
        for to_world in [Mat3::IDENTITY, rotation()] {
            let env = EnvMap::new(test_image(32, 16), 1.0, to_world);
            let total = integrate_over_sphere(|d| env.pdf(d) as f64, 800, 1600);
            assert!((total - 1.0).abs() < 3e-3, "pdf integrates to {total}");
        }
    }

    #[test]
    fn sample_is_consistent_with_pdf_and_eval() {
        let env = EnvMap::new(test_image(32, 16), 1.5, rotation());
        let mut rng = Rng::new(21);
        for _ in 0..20_000 {
            let s = env.sample(rng.vec2()).expect("positive map always samples");
            assert!((s.direction.length() - 1.0).abs() < 1e-5);
            let pdf = env.pdf(s.direction);
            assert!((pdf - s.pdf).abs() <= 1e-3 * s.pdf, "{pdf} vs {}", s.pdf);
            let l = env.eval(s.direction, 0.0);
            assert!(
                (l - s.radiance).length() <= 1e-3 * l.length() + 1e-6,
                "{l} vs {}",
                s.radiance
            );
        }
    }

    #[test]
    fn sampled_directions_match_pdf() {
        let env = EnvMap::new(test_image(16, 8), 1.0, rotation());
        let (nt, np) = (12usize, 24usize);
        let samples = 100_000;
        let mut hist = vec![0.0f64; nt * np];
        let mut rng = Rng::new(22);
        for _ in 0..samples {
            let d = env.sample(rng.vec2()).unwrap().direction;
            let theta = d.z.clamp(-1.0, 1.0).acos();
            let phi = d.y.atan2(d.x).rem_euclid(2.0 * PI);
            let it = ((theta / PI * nt as f32) as usize).min(nt - 1);
            let ip = ((phi / (2.0 * PI) * np as f32) as usize).min(np - 1);
            hist[it * np + ip] += 1.0;
        }
        // Expected counts by quadrature of the pdf over each world bin (24 x 24 points per bin).
        let sub = 24;
        let mut expected = vec![0.0f64; nt * np];
        for it in 0..nt {
            for ip in 0..np {
                let mut acc = 0.0;
                for a in 0..sub {
                    let theta = (it as f64 + (a as f64 + 0.5) / sub as f64) / nt as f64
                        * std::f64::consts::PI;
                    for b in 0..sub {
                        let phi = (ip as f64 + (b as f64 + 0.5) / sub as f64) / np as f64
                            * std::f64::consts::TAU;
                        let d = glam::DVec3::new(
                            theta.sin() * phi.cos(),
                            theta.sin() * phi.sin(),
                            theta.cos(),
                        );
                        acc += env.pdf(d.as_vec3()) as f64 * theta.sin();
                    }
                }
                let dw = (std::f64::consts::PI / nt as f64) * (std::f64::consts::TAU / np as f64);
                expected[it * np + ip] = acc / (sub * sub) as f64 * dw * samples as f64;
            }
        }
        assert_chi_square("EnvMap::sample", &hist, &expected);
    }

    #[test]
    fn furnace_constant_map() {
        // ∫ L cos θ dω over the hemisphere around n = π L, estimated with env sampling only.
        let l = Vec3::new(0.5, 0.7, 0.9);
        let env = EnvMap::new(Image::filled(64, 32, l), 1.0, rotation());
        let n = Vec3::new(0.3, -0.8, 0.5).normalize();
        let count = 50_000;
        let mut rng = Rng::new(23);
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for _ in 0..count {
            let s = env.sample(rng.vec2()).unwrap();
            assert!((s.radiance - l).length() < 1e-5);
            let f = (s.radiance.y * s.direction.dot(n).max(0.0) / s.pdf) as f64;
            sum += f;
            sum2 += f * f;
        }
        let mean = sum / count as f64;
        let sigma = ((sum2 / count as f64 - mean * mean) / count as f64).sqrt();
        let expected = std::f64::consts::PI * l.y as f64;
        assert!(
            (mean - expected).abs() < 3.0 * sigma,
            "furnace: {mean} ± {sigma}, expected {expected}"
        );
        assert!(
            sigma < 0.01 * expected,
            "furnace estimator too noisy: sigma {sigma}"
        );
        // The filtered lookup of a constant map is the constant at any spread.
        for spread in [0.0, 0.01, 0.3, 3.0, 100.0] {
            let e = env.eval(Vec3::new(0.2, 0.9, -0.1), spread);
            assert!((e - l).length() < 1e-5, "spread {spread}: {e}");
        }
    }

    /// Env-only estimate of the power of a map with one bright texel, against quadrature of eval.
    fn single_texel_estimate() -> (f64, f64, f64) {
        let mut img = Image::filled(16, 8, Vec3::ZERO);
        img.pixels[3 * 16 + 6] = Vec3::splat(100.0);
        let env = EnvMap::new(img, 1.0, rotation());
        let reference = integrate_over_sphere(|d| env.eval(d, 0.0).y as f64, 800, 1600);
        let mut rng = Rng::new(25);
        let count = 40_000;
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for _ in 0..count {
            let s = env.sample(rng.vec2()).unwrap();
            let f = (s.radiance.y / s.pdf) as f64;
            sum += f;
            sum2 += f * f;
        }
        let mean = sum / count as f64;
        let sigma = ((sum2 / count as f64 - mean * mean) / count as f64).sqrt();
        (mean, sigma, reference)
    }

    #[test]
    fn bilinear_density_covers_eval() {
        // The piecewise-bilinear density covers the bright texel's whole bilinear footprint, and
        // is proportional to it (luminance x sin(theta) over 2 pi^2 sin(theta) per unit of
        // solid angle, with sin(theta) of the rows, not the direction): a tight estimate that
        // matches quadrature.
        let (mean, sigma, reference) = single_texel_estimate();
        assert!(
            (mean - reference).abs() < 3.0 * sigma + 2e-3 * reference,
            "{mean} ± {sigma} vs {reference}"
        );
        assert!(sigma < 0.05 * reference, "{mean} ± {sigma}");
    }

    #[test]
    fn black_and_bad_maps() {
        let env = EnvMap::new(Image::filled(8, 4, Vec3::ZERO), 1.0, Mat3::IDENTITY);
        assert!(env.sample(Vec2::new(0.3, 0.4)).is_none());
        assert_eq!(env.pdf(Vec3::Y), 0.0);
        assert_eq!(env.eval(Vec3::X, 0.0), Vec3::ZERO);
        // Negative and NaN texels read as 0; the rest of the map still samples.
        let mut img = Image::filled(4, 3, Vec3::ONE);
        img.pixels[4] = Vec3::new(-5.0, f32::NAN, f32::INFINITY);
        let env = EnvMap::new(img, 1.0, Mat3::IDENTITY);
        let d = env.uv_to_dir(Vec2::new(0.125, 0.5));
        assert_eq!(env.eval(d, 0.0), Vec3::ZERO);
        let mut rng = Rng::new(24);
        for _ in 0..1000 {
            let s = env.sample(rng.vec2()).unwrap();
            assert!(s.pdf.is_finite() && s.pdf > 0.0 && s.radiance.is_finite());
        }
        // Only patches with four black corners have zero density: texel (5, 1) lit, patch
        // (i, j) centred at u = (i + 1) / 8, v = (j + 0.5) / 3.
        let mut img = Image::filled(8, 4, Vec3::ZERO);
        img.pixels[8 + 5] = Vec3::ONE;
        let env = EnvMap::new(img, 1.0, Mat3::IDENTITY);
        let patch = |i: f32, j: f32| env.uv_to_dir(Vec2::new((i + 1.0) / 8.0, (j + 0.5) / 3.0));
        for (i, j) in [(4.0, 0.0), (5.0, 0.0), (4.0, 1.0), (5.0, 1.0)] {
            assert!(env.pdf(patch(i, j)) > 0.0, "patch ({i}, {j})");
        }
        for (i, j) in [(3.0, 1.0), (6.0, 1.0), (4.0, 2.0), (5.0, 2.0), (1.0, 0.0)] {
            assert_eq!(env.pdf(patch(i, j)), 0.0, "patch ({i}, {j})");
        }
        // Empty image, NaN scale, degenerate rotation: no panic, no NaN.
        let env = EnvMap::new(
            Image {
                width: 0,
                height: 0,
                pixels: vec![],
            },
            f32::NAN,
            Mat3::ZERO,
        );
        assert!(env.sample(Vec2::new(0.5, 0.5)).is_none());
        assert_eq!(env.eval(Vec3::Z, 0.1), Vec3::ZERO);
        assert_eq!(env.pdf(Vec3::Z), 0.0);
        assert_eq!(env.to_world(), Mat3::IDENTITY);
        let env = EnvMap::new(Image::filled(4, 2, Vec3::ONE), 1.0, Mat3::IDENTITY);
        assert!(env.pdf(Vec3::ZERO).is_finite());
        assert!(env.eval(Vec3::NAN, f32::NAN).is_finite());
    }

    #[test]
    fn spread_selects_mip_level_and_poles_do_not_wrap() {
        // One-texel checkerboard of 0 and 1: unfiltered lookups see the texel, a cone two texels
        // wide sees about the average.
        let (w, h) = (64u32, 32u32);
        let px = (0..w * h)
            .map(|k| Vec3::splat(((k % w + k / w) % 2) as f32))
            .collect();
        let env = EnvMap::new(Image::new(w, h, px), 1.0, Mat3::IDENTITY);
        let uv = Vec2::new((10.0 + 0.5) / w as f32, 16.0 / (h - 1) as f32);
        let d = env.uv_to_dir(uv);
        assert!((env.eval(d, 0.0).x - 0.0).abs() < 1e-5);
        let texel_angle = PI / h as f32;
        let e = env.eval(d, 2.0 * texel_angle).x;
        assert!((e - 0.5).abs() < 0.05, "2-texel cone gave {e}");
        // Top row bright, bottom row black: the zenith must not blend with the nadir.
        let mut img = Image::filled(8, 4, Vec3::splat(0.5));
        for i in 0..8 {
            img.pixels[i] = Vec3::ONE;
            img.pixels[3 * 8 + i] = Vec3::ZERO;
        }
        let env = EnvMap::new(img, 1.0, Mat3::IDENTITY);
        assert!((env.eval(Vec3::Y, 0.0) - Vec3::ONE).length() < 1e-5);
        assert!(env.eval(-Vec3::Y, 0.0).length() < 1e-5);
    }
}
