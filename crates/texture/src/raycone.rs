//! Ray cones (Akenine-Möller et al., "Texture level of detail strategies for real-time ray
//! tracing", Ray Tracing Gems, 2019): a cheap texture-filter width for any hit along a path.

use glam::{Vec2, Vec3};

use crate::footprint::Footprint;

/// Smallest |cos| between ray and surface normal used when projecting the cone onto a surface;
/// caps the grazing-angle stretch at 1/0.01 = 100x so the footprint stays finite.
pub const MIN_COS: f32 = 0.01;

/// Semi-axis of a surface footprint per unit of cone width: the footprint ellipse's minor
/// semi-axis is `RADIUS_PER_WIDTH * width` (its major one that over |cos|). With 1 the
/// ellipse spans two pixel widths, as pbrt's EWA ellipse spans two pixel differentials, and the
/// lookup's kernel (standard deviation about 0.35 of a semi-axis) is about a third of a pixel
/// wide: the best 1-spp texture error on the grazing checkerboard (see docs/conventions.md).
pub const RADIUS_PER_WIDTH: f32 = 1.0;

/// Ray cone (Akenine-Möller et al., "Texture level of detail strategies for real-time ray tracing"):
/// width and spread angle carried along a path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayCone {
    /// Cone width (world units) at the current ray origin.
    pub width: f32,
    /// Spread angle (radians); width grows by `spread * t` along the ray.
    pub spread: f32,
}

impl RayCone {
    /// A camera ray's cone: zero width at the pinhole, spread = the angle one pixel subtends
    /// (e.g. 2 tan(fov_y / 2) / height for a perspective camera).
    pub fn from_pixel(pixel_spread_angle: f32) -> Self {
        Self {
            width: 0.0,
            spread: pixel_spread_angle,
        }
    }

    /// The cone after travelling distance `t`: width += spread * t.
    pub fn at_distance(self, t: f32) -> Self {
        Self {
            width: self.width + self.spread * t,
            spread: self.spread,
        }
    }

    /// The anisotropic footprint at a hit: the cone's circular cross-section projected along the
    /// ray onto the surface, then mapped to uv by the inverse of the surface's Jacobian.
    ///
    /// On the surface the ellipse has its minor semi-axis `r = RADIUS_PER_WIDTH * width` across
    /// the plane of incidence (along normal x ray) and its major semi-axis r / |cos| along the ray
    /// direction projected onto the surface, cos between the ray and the geometric normal clamped
    /// to [`MIN_COS`]. A world tangent vector w maps to the uv vector (du, dv) solving
    /// dpdu du + dpdv dv = w in the least-squares sense (exact for w in the tangent plane).
    /// Where dpdu and dpdv are (nearly) parallel or zero (sphere poles) the footprint falls back
    /// to a circle of radius |major| / max(|dpdu|, |dpdv|); with no usable derivatives it is a
    /// point. Never NaN.
    pub fn footprint(&self, ray_dir: Vec3, normal: Vec3, dpdu: Vec3, dpdv: Vec3) -> Footprint {
        let r = self.width.abs() * RADIUS_PER_WIDTH;
        let (Some(d), Some(n)) = (ray_dir.try_normalize(), normal.try_normalize()) else {
            return Footprint::POINT;
        };
        if !(r.is_finite() && r > 0.0) {
            return Footprint::POINT;
        }
        let cos = d.dot(n);
        // Across the plane of incidence, and the ray's direction within the surface.
        let (across, along) = match n.cross(d).try_normalize() {
            Some(across) => (across, n.cross(across)),
            None => n.any_orthonormal_pair(),
        };
        let major = along * (r / cos.abs().max(MIN_COS));
        let minor = across * r;
        let (uu, uv, vv) = (dpdu.dot(dpdu), dpdu.dot(dpdv), dpdv.dot(dpdv));
        let det = uu * vv - uv * uv;
        if det > 1e-6 * uu * vv && det.is_finite() && det > 0.0 {
            let to_uv = |w: Vec3| {
                let (pu, pv) = (dpdu.dot(w), dpdv.dot(w));
                Vec2::new(vv * pu - uv * pv, uu * pv - uv * pu) / det
            };
            return Footprint::new(to_uv(major), to_uv(minor));
        }
        let scale = uu.max(vv).sqrt();
        if scale > 0.0 && scale.is_finite() {
            Footprint::circle(major.length() / scale)
        } else {
            Footprint::POINT
        }
    }

    /// uv footprint at a hit: the cone width projected onto the surface, then converted to uv.
    ///
    /// Projection: world width = |width| / max(|cos|, [`MIN_COS`]) with cos between the ray
    /// direction and the geometric normal (neither needs to be normalised).
    /// Conversion: divide by sqrt(|dpdu x dpdv|), the geometric mean of the two uv axis lengths
    /// (world length per unit uv). This is the isotropic choice that matches the cone's texel
    /// density ratio in the paper; for anisotropic parametrisations it sits between the blurrier
    /// "shorter axis" and the sharper "longer axis" choices. Where dpdu x dpdv degenerates
    /// (sphere poles) it falls back to the longer of |dpdu|, |dpdv|; with no usable derivatives
    /// the footprint is 0 (finest level). Never NaN.
    pub fn uv_footprint(&self, ray_dir: Vec3, normal: Vec3, dpdu: Vec3, dpdv: Vec3) -> f32 {
        // `normalize_or_zero` step for step (same reciprocals, same products, so the same bits),
        // but testing the reciprocals instead of comparing the normalised vectors with zero:
        // a valid reciprocal never normalises a vector to zero.
        let rd = ray_dir.length_recip();
        let rn = normal.length_recip();
        let cos = if rd.is_finite() && rd > 0.0 && rn.is_finite() && rn > 0.0 {
            (ray_dir * rd).dot(normal * rn).abs().max(MIN_COS)
        } else {
            1.0
        };
        footprint_from_cos(self.width, cos, dpdu, dpdv)
    }
}

/// The footprint for a cone of `width` meeting the surface at `cos`: the projected world width
/// over sqrt(|dpdu x dpdv|) (or the longer axis where that degenerates); 0 when not finite.
#[inline]
fn footprint_from_cos(width: f32, cos: f32, dpdu: Vec3, dpdv: Vec3) -> f32 {
    let world = width.abs() / cos;
    let area = dpdu.cross(dpdv).length();
    let scale = if area > 1e-20 && area.is_finite() {
        area.sqrt()
    } else {
        dpdu.length().max(dpdv.length())
    };
    let fp = if scale > 0.0 && scale.is_finite() {
        world / scale
    } else {
        0.0
    };
    if fp.is_finite() {
        fp
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The previous `uv_footprint`'s cosine (normalize_or_zero and a comparison with zero), kept
    /// as the reference the current one must match bit for bit.
    fn uv_footprint_reference(c: &RayCone, ray_dir: Vec3, normal: Vec3, du: Vec3, dv: Vec3) -> f32 {
        let d = ray_dir.normalize_or_zero();
        let n = normal.normalize_or_zero();
        let cos = if d == Vec3::ZERO || n == Vec3::ZERO {
            1.0
        } else {
            d.dot(n).abs().max(MIN_COS)
        };
        // The projection onto uv is unchanged; only the cosine's zero test was rewritten.
        footprint_from_cos(c.width, cos, du, dv)
    }

    #[test]
    fn footprint_matches_reference_bit_for_bit() {
        let mut rng = torrey_testkit::Rng::new(0x1234_5678_9ABC_DEF0);
        let mut next = move || rng.next_u64();
        // Mostly ordinary values at very different scales, sometimes special ones.
        let mut value = move || -> f32 {
            let r = next();
            match r % 16 {
                0 => [
                    0.0,
                    -0.0,
                    f32::NAN,
                    f32::INFINITY,
                    -f32::INFINITY,
                    1e-30,
                    -1e-25,
                ][(r >> 8) as usize % 7],
                1 => [1e-20, 3e-23, 1e19, -2e20, f32::MIN_POSITIVE, 1e-40][(r >> 8) as usize % 6],
                _ => {
                    let m = ((r >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0;
                    m * [1.0, 1e-3, 1e3, 1e-12, 1e12][(r >> 8) as usize % 5]
                }
            }
        };
        let mut v3 = || Vec3::new(value(), value(), value());
        for _ in 0..200_000 {
            let cone = RayCone {
                width: v3().x,
                spread: 0.0,
            };
            let (d, n, du, dv) = (v3(), v3(), v3(), v3());
            let got = cone.uv_footprint(d, n, du, dv);
            let want = uv_footprint_reference(&cone, d, n, du, dv);
            assert_eq!(got.to_bits(), want.to_bits(), "{cone:?} {d} {n} {du} {dv}");
        }
    }

    #[test]
    fn ellipse_footprint_analytic_values() {
        // Width 0.01 at the hit, so r = 0.01 * RADIUS_PER_WIDTH world units.
        let c = RayCone::from_pixel(0.001).at_distance(10.0);
        let r = 0.01 * RADIUS_PER_WIDTH;
        let (du, dv) = (Vec3::X * 2.0, Vec3::Y * 2.0);
        // Head-on on a plane of side 2: a circle of radius r / 2 in uv.
        let (ma, mi) = c.footprint(-Vec3::Z, Vec3::Z, du, dv).axis_lengths();
        assert!(
            (ma - r / 2.0).abs() < 1e-7 && (mi - r / 2.0).abs() < 1e-7,
            "{ma} {mi}"
        );
        // 60 degrees from the normal in the y-z plane: stretched by 1 / cos 60 = 2 along v only.
        let a = 60f32.to_radians();
        let dir = Vec3::new(0.0, a.sin(), -a.cos());
        let fp = c.footprint(dir, Vec3::Z, du, dv);
        let (major, minor) = fp.principal_axes();
        assert!((major.length() - r).abs() < 1e-6, "{fp:?}");
        assert!(major.x.abs() < 1e-7, "major along v: {major}");
        assert!((minor.length() - r / 2.0).abs() < 1e-6, "{fp:?}");
        // The back side gives the same ellipse.
        let back = c.footprint(dir, -Vec3::Z, du, dv).axis_lengths();
        assert!((back.0 - r).abs() < 1e-6 && (back.1 - r / 2.0).abs() < 1e-6);
        // Anisotropic parametrisation: |dpdu| = 1, |dpdv| = 4: head-on the ellipse is r along u
        // and r / 4 along v.
        let (major, minor) = c
            .footprint(-Vec3::Z, Vec3::Z, Vec3::X, Vec3::Y * 4.0)
            .principal_axes();
        assert!((major.length() - r).abs() < 1e-6 && major.y.abs() < 1e-7);
        assert!((minor.length() - r / 4.0).abs() < 1e-6 && minor.x.abs() < 1e-7);
        // Sheared parametrisation (dpdv not perpendicular to dpdu): axes map back exactly.
        let (du, dv) = (Vec3::X, Vec3::new(1.0, 1.0, 0.0));
        let fp = c.footprint(-Vec3::Z, Vec3::Z, du, dv);
        for w in [fp.a, fp.b] {
            let world = du * w.x + dv * w.y;
            assert!((world.length() - r).abs() < 1e-6, "{w}");
        }
        assert!(
            (du * fp.a.x + dv * fp.a.y)
                .dot(du * fp.b.x + dv * fp.b.y)
                .abs()
                < 1e-9
        );
    }

    #[test]
    fn ellipse_footprint_grazing_and_degenerate_cases() {
        let c = RayCone::from_pixel(0.001).at_distance(3.0);
        let r = 0.003 * RADIUS_PER_WIDTH;
        // Exactly grazing: the stretch is capped at 1 / MIN_COS.
        let (ma, mi) = c
            .footprint(Vec3::X, Vec3::Z, Vec3::X, Vec3::Y)
            .axis_lengths();
        assert!(
            (ma - r / MIN_COS).abs() < 1e-5 && (mi - r).abs() < 1e-7,
            "{ma} {mi}"
        );
        // Sphere pole: dpdu = 0 falls back to a circle of |major| / |dpdv|.
        let pi = std::f32::consts::PI;
        let (ma, mi) = c
            .footprint(-Vec3::Z, Vec3::Z, Vec3::ZERO, Vec3::X * pi)
            .axis_lengths();
        assert!((ma - r / pi).abs() < 1e-7 && (mi - r / pi).abs() < 1e-7);
        // No derivatives, no direction, NaN: a point or finite.
        assert!(c
            .footprint(-Vec3::Z, Vec3::Z, Vec3::ZERO, Vec3::ZERO)
            .is_point());
        assert!(c
            .footprint(Vec3::ZERO, Vec3::Z, Vec3::X, Vec3::Y)
            .is_point());
        let nan = c.footprint(Vec3::splat(f32::NAN), Vec3::Z, Vec3::X, Vec3::Y);
        assert!(nan.a.is_finite() && nan.b.is_finite());
        let zero = RayCone::from_pixel(0.001).footprint(-Vec3::Z, Vec3::Z, Vec3::X, Vec3::Y);
        assert!(zero.is_point());
    }

    #[test]
    fn width_grows_linearly_with_distance() {
        let c = RayCone::from_pixel(0.002);
        assert_eq!(c.width, 0.0);
        let c5 = c.at_distance(5.0);
        assert!((c5.width - 0.01).abs() < 1e-7);
        let c8 = c5.at_distance(3.0);
        assert!((c8.width - 0.016).abs() < 1e-7);
        assert_eq!(c8.spread, 0.002);
    }

    #[test]
    fn footprint_analytic_values() {
        // Rectangle of side 2 (dpdu = dpdv = 2 x/y): head-on, width 0.01 → 0.005 uv.
        let c = RayCone::from_pixel(0.001).at_distance(10.0);
        let (du, dv) = (Vec3::X * 2.0, Vec3::Y * 2.0);
        let head_on = c.uv_footprint(-Vec3::Z, Vec3::Z, du, dv);
        assert!((head_on - 0.005).abs() < 1e-7, "{head_on}");
        // 60 degrees from the normal: stretched by 1 / cos 60 = 2.
        let dir = Vec3::new(0.0, (60f32).to_radians().sin(), -(60f32).to_radians().cos());
        let oblique = c.uv_footprint(dir, Vec3::Z, du, dv);
        assert!((oblique - 0.01).abs() < 1e-6, "{oblique}");
        // Back-facing normal gives the same value.
        assert!((c.uv_footprint(dir, -Vec3::Z, du, dv) - oblique).abs() < 1e-7);
        // Anisotropic: |du| = 1, |dv| = 4 → geometric mean 2.
        let aniso = c.uv_footprint(-Vec3::Z, Vec3::Z, Vec3::X, Vec3::Y * 4.0);
        assert!((aniso - 0.005).abs() < 1e-7);
    }

    #[test]
    fn footprint_grows_with_distance_and_grazing_angle() {
        let c = RayCone::from_pixel(0.001);
        let (du, dv) = (Vec3::X, Vec3::Y);
        let mut prev = -1.0;
        for k in 0..50 {
            let f = c
                .at_distance(k as f32)
                .uv_footprint(-Vec3::Z, Vec3::Z, du, dv);
            assert!(f > prev);
            prev = f;
        }
        let c = c.at_distance(3.0);
        let mut prev = -1.0;
        for k in 0..=90 {
            let a = (k as f32).to_radians();
            let dir = Vec3::new(a.sin(), 0.0, -a.cos());
            let f = c.uv_footprint(dir, Vec3::Z, du, dv);
            assert!(f.is_finite() && f >= prev, "angle {k}");
            prev = f;
        }
        // Exactly grazing is capped at 1/MIN_COS times head-on.
        assert!((prev - 0.003 / MIN_COS).abs() < 1e-5);
    }

    #[test]
    fn degenerate_inputs_stay_finite() {
        let c = RayCone::from_pixel(0.001).at_distance(2.0);
        // Sphere pole: dpdu = 0, falls back to |dpdv| = pi.
        let pole = c.uv_footprint(
            -Vec3::Z,
            Vec3::Z,
            Vec3::ZERO,
            Vec3::X * std::f32::consts::PI,
        );
        assert!((pole - 0.002 / std::f32::consts::PI).abs() < 1e-7);
        assert_eq!(
            c.uv_footprint(Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO),
            0.0
        );
        let nan = c.uv_footprint(Vec3::splat(f32::NAN), Vec3::Z, Vec3::X, Vec3::Y);
        assert!(nan.is_finite());
    }
}
