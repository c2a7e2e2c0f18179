//! Lat-long environment map with luminance importance sampling, in Mitsuba 3's orientation.
//!
//! Local frame (before `to_world`): theta = pi v, phi = 2 pi u and
//! `d = (sin phi sin theta, cos theta, -cos phi sin theta)`, so +y is up, v = 0 (image row 0) is the
//! zenith and u = 0 looks down -z. Inverse: u = atan2(d.x, -d.z) / 2pi wrapped to [0, 1),
//! v = acos(d.y) / pi.
//!
//! Sampling weight of texel (i, j) = Rec.709 luminance x sin(theta_j), with the cell-centred
//! theta_j = pi (j + 0.5) / H. Mitsuba instead treats row j as a point sample at pi j / (H - 1)
//! with bilinear interpolation; the two differ by under one texel. The density over solid angle is
//! p(u, v) / (2 pi^2 sin theta), with theta the direction's own polar angle (exact Jacobian of the
//! lat-long map), so sample/pdf stay consistent everywhere.

use crate::distribution::{Distribution2D, ONE_MINUS_EPSILON};
use glam::{Mat3, Vec2, Vec3};
use std::f32::consts::PI;
use torrey_texture::Image;

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
    /// Sanitised texels (non-negative, finite), row 0 = top = zenith.
    image: Image,
    width: usize,
    height: usize,
    scale: f32,
    to_world: Mat3,
    to_local: Mat3,
    distribution: Distribution2D,
    /// False for an all-black map: nothing to sample, pdf is 0 everywhere.
    samplable: bool,
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
            Image::filled(1, 1, Vec3::ZERO)
        } else {
            let mut image = image;
            for p in &mut image.pixels {
                *p = Vec3::select(p.cmpgt(Vec3::ZERO) & p.is_finite_mask(), *p, Vec3::ZERO);
            }
            image
        };
        let scale = if scale.is_finite() && scale > 0.0 {
            scale
        } else {
            0.0
        };
        let (width, height) = (image.width as usize, image.height as usize);
        let mut weights = Vec::with_capacity(width * height);
        for j in 0..height {
            let sin_theta = (PI * (j as f32 + 0.5) / height as f32).sin();
            for i in 0..width {
                weights.push(luminance(image.pixels[j * width + i]) * sin_theta);
            }
        }
        let distribution = Distribution2D::new(&weights, width, height);
        let samplable = distribution.integral() > 0.0 && scale > 0.0;
        let to_world = orthonormalize(to_world);
        Self {
            image,
            width,
            height,
            scale,
            to_world,
            to_local: to_world.transpose(),
            distribution,
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

    /// Local lat-long uv of a local direction (need not be normalised).
    #[inline]
    fn local_dir_to_uv(d: Vec3) -> Vec2 {
        let d = d.normalize_or(Vec3::Y);
        let mut u = d.x.atan2(-d.z) * (0.5 / PI);
        if u < 0.0 {
            u += 1.0;
        }
        if !(u < 1.0) {
            u = 0.0;
        }
        let v = (d.y.clamp(-1.0, 1.0).acos() / PI).clamp(0.0, 1.0);
        Vec2::new(u, v)
    }

    /// Local direction of a lat-long uv.
    #[inline]
    fn uv_to_local_dir(uv: Vec2) -> Vec3 {
        let (sin_theta, cos_theta) = (PI * uv.y).sin_cos();
        let (sin_phi, cos_phi) = (2.0 * PI * uv.x).sin_cos();
        Vec3::new(sin_phi * sin_theta, cos_theta, -cos_phi * sin_theta)
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

    /// Bilinear lookup with Mitsuba's texel centres; u repeats, v clamps at the poles.
    #[inline]
    fn lookup(&self, uv: Vec2, _footprint: f32) -> Vec3 {
        let (w, h) = (self.width as f32, self.height as f32);
        let x = uv.x * w - 0.5;
        let y = (uv.y * h - 0.5).clamp(0.0, h - 1.0);
        let (x0f, y0f) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0f, y - y0f);
        let wrap = |i: i64| i.rem_euclid(self.width as i64) as usize;
        let x0 = wrap(x0f as i64);
        let x1 = wrap(x0f as i64 + 1);
        let y0 = (y0f as usize).min(self.height - 1);
        let y1 = (y0 + 1).min(self.height - 1);
        let p = |i: usize, j: usize| self.image.pixels[j * self.width + i];
        let top = p(x0, y0) * (1.0 - fx) + p(x1, y0) * fx;
        let bottom = p(x0, y1) * (1.0 - fx) + p(x1, y1) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// Filter width in uv units for a ray cone of angle `spread`: the cone covers about spread/pi
    /// of v; we use that isotropically (along u near the poles this under-filters a little rather
    /// than blurring the zenith).
    #[inline]
    fn footprint(spread: f32) -> f32 {
        if spread.is_finite() && spread > 0.0 {
            spread / PI
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
        self.lookup(uv, Self::footprint(spread)) * self.scale
    }

    /// Importance-samples a direction by luminance x sin(theta). `None` for a black map or a
    /// sample that lands exactly on a pole.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<EnvSample> {
        if !self.samplable {
            return None;
        }
        let (uv, p) = self.distribution.sample(u);
        if !(p > 0.0) {
            return None;
        }
        let uv = uv.min(Vec2::splat(ONE_MINUS_EPSILON));
        let local = Self::uv_to_local_dir(uv);
        let sin_theta = (local.x * local.x + local.z * local.z).sqrt();
        if !(sin_theta > 0.0) {
            return None;
        }
        let pdf = p / (2.0 * PI * PI * sin_theta);
        Some(EnvSample {
            direction: self.to_world * local,
            radiance: self.lookup(uv, 0.0) * self.scale,
            pdf,
        })
    }

    /// Density over solid angle of [`Self::sample`] producing world direction `dir`.
    #[inline]
    pub fn pdf(&self, dir: Vec3) -> f32 {
        if !self.samplable {
            return 0.0;
        }
        let local = (self.to_local * dir).normalize_or_zero();
        let sin_theta = (local.x * local.x + local.z * local.z).sqrt();
        if !(sin_theta > 0.0) {
            return 0.0;
        }
        let uv = Self::local_dir_to_uv(local);
        self.distribution.pdf(uv) / (2.0 * PI * PI * sin_theta)
    }
}
