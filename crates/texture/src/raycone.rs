//! Ray cones (Akenine-Möller et al., "Texture level of detail strategies for real-time ray
//! tracing", Ray Tracing Gems, 2019): a cheap texture-filter width for any hit along a path.

use glam::{Vec2, Vec3, Vec3A};

use crate::footprint::Footprint;

/// Smallest |cos| between ray and surface normal used when projecting the cone onto a surface;
/// caps the grazing-angle stretch at 1/0.01 = 100x so the footprint stays finite.
pub const MIN_COS: f32 = 0.01;

/// Semi-axis of a surface footprint per unit of cone width (one pixel for a camera cone): the
/// footprint ellipse's minor semi-axis is `RADIUS_PER_WIDTH * width`, its major one that over
/// |cos|. The lookup's kernel has a standard deviation of about 0.4 semi-axes, so 0.75 gives
/// 0.3 pixel, that of the pixel's own box filter (1/sqrt(12)): what `centre_weight` assumes. It is
/// also the measured best (0.7 to 0.85) for the 1-spp texture error on scenes/checker_sky.xml.
pub const RADIUS_PER_WIDTH: f32 = 0.75;

/// Ray cone (Akenine-Möller et al., "Texture level of detail strategies for real-time ray tracing"):
/// width and spread angle carried along a path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayCone {
    /// Cone width (world units) at the current ray origin.
    pub width: f32,
    /// Spread angle (radians); width grows by `spread * t` along the ray.
    pub spread: f32,
    /// The pixel centre the first hit's lookups move towards, if any.
    centre: Centre,
    /// A rough bounce has widened the cone ([`RayCone::widened`]): its footprints are
    /// [`Footprint::isotropic`].
    rough: bool,
}

/// [`RayCone::toward_pixel_centre`]'s state: set on the camera ray, active at its first hit (with
/// the distance travelled to it), gone after the next segment.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Centre {
    None,
    Pending { dir: Vec3, weight: f32 },
    Active { dir: Vec3, weight: f32, t: f32 },
}

impl RayCone {
    /// A camera ray's cone: zero width at the pinhole, spread = the angle one pixel subtends
    /// (e.g. 2 tan(fov_y / 2) / height for a perspective camera).
    pub fn from_pixel(pixel_spread_angle: f32) -> Self {
        Self {
            width: 0.0,
            spread: pixel_spread_angle,
            centre: Centre::None,
            rough: false,
        }
    }

    /// The cone leaving a rough bounce: its spread grows by `extra` (the lobe's width), and its
    /// footprints from now on are filtered as circles ([`Footprint::isotropic`]).
    pub fn widened(self, extra: f32) -> Self {
        Self {
            spread: self.spread + extra,
            rough: true,
            ..self
        }
    }

    /// The camera ray's cone, with the first hit's texture lookups moved by `weight` (see
    /// [`crate::centre_weight`]) of the way towards where the ray through the pixel centre, in
    /// direction `centre_dir` from the same origin, meets the hit's tangent plane. Only the first
    /// hit moves; a zero weight or an unusable direction leaves the cone as it was.
    pub fn toward_pixel_centre(self, centre_dir: Vec3, weight: f32) -> Self {
        let centre = match centre_dir.try_normalize() {
            Some(dir) if weight > 0.0 && weight.is_finite() => Centre::Pending { dir, weight },
            _ => Centre::None,
        };
        Self { centre, ..self }
    }

    /// The cone after travelling distance `t`: width += spread * t.
    pub fn at_distance(self, t: f32) -> Self {
        let centre = match self.centre {
            Centre::Pending { dir, weight } => Centre::Active { dir, weight, t },
            _ => Centre::None,
        };
        Self {
            width: self.width + self.spread * t,
            centre,
            ..self
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
    /// point. Never NaN. After a rough bounce ([`RayCone::widened`]) it is
    /// [`Footprint::isotropic`].
    ///
    /// In `Vec3A`s (whole-vector multiplies; glam's SSE dot and cross add in the scalar
    /// order, so the result is the same to the bit as with `Vec3`, as long as the build does not
    /// enable the `fma` target feature, with which glam fuses the cross product).
    pub fn footprint(&self, ray_dir: Vec3A, normal: Vec3A, dpdu: Vec3A, dpdv: Vec3A) -> Footprint {
        let fp = self.ellipse(ray_dir, normal, dpdu, dpdv);
        if self.rough {
            fp.isotropic()
        } else {
            fp
        }
    }

    /// [`RayCone::footprint`]'s ellipse.
    #[inline(always)]
    fn ellipse(&self, ray_dir: Vec3A, normal: Vec3A, dpdu: Vec3A, dpdv: Vec3A) -> Footprint {
        let r = self.width.abs() * RADIUS_PER_WIDTH;
        if !(r.is_finite() && r > 0.0) {
            return Footprint::POINT;
        }
        let (Some(d), Some(n)) = (ray_dir.try_normalize(), normal.try_normalize()) else {
            return Footprint::POINT;
        };
        let cos = d.dot(n);
        // Across the plane of incidence, and the ray's direction within the surface.
        let (across, along) = match n.cross(d).try_normalize() {
            Some(across) => (across, n.cross(across)),
            None => {
                let (a, b) = Vec3::from(n).any_orthonormal_pair();
                (a.into(), b.into())
            }
        };
        let major = along * (r / cos.abs().max(MIN_COS));
        let minor = across * r;
        let (uu, uv, vv) = (dpdu.dot(dpdu), dpdu.dot(dpdv), dpdv.dot(dpdv));
        let det = uu * vv - uv * uv;
        if det > 1e-6 * uu * vv && det.is_finite() && det > 0.0 {
            let inv_det = 1.0 / det;
            let to_uv = |w: Vec3A| {
                let (pu, pv) = (dpdu.dot(w), dpdv.dot(w));
                Vec2::new(vv * pu - uv * pv, uu * pv - uv * pu) * inv_det
            };
            let fp = Footprint::new(to_uv(major), to_uv(minor));
            return match self.centre_offset(ray_dir, n, major, minor) {
                Some(w) => fp.with_shift(to_uv(w)),
                None => fp,
            };
        }
        let scale = uu.max(vv).sqrt();
        if scale > 0.0 && scale.is_finite() {
            Footprint::circle(major.length() / scale)
        } else {
            Footprint::POINT
        }
    }

    /// The world offset, within the tangent plane, from the hit to where the first hit's lookup
    /// is centred ([`RayCone::toward_pixel_centre`]): `weight` times the way to the pixel-centre
    /// ray's intersection with the tangent plane, kept within two semi-axes of the footprint
    /// ellipse (`major`, `minor`, perpendicular) so that a centre ray nearly parallel to the
    /// plane cannot throw the lookup far away. None when inactive or unusable.
    fn centre_offset(&self, ray_dir: Vec3A, n: Vec3A, major: Vec3A, minor: Vec3A) -> Option<Vec3A> {
        let Centre::Active { dir, weight, t } = self.centre else {
            return None;
        };
        let dir = Vec3A::from(dir);
        // Hit p = o + t ray_dir; the centre ray o + s dir meets the plane n.(x - p) = 0 at
        // s = t (n.ray_dir) / (n.dir).
        let (dn, cn) = (ray_dir.dot(n), dir.dot(n));
        let s = t * dn / cn;
        if !(s > 0.0 && s.is_finite()) {
            return None;
        }
        let w = (dir * s - ray_dir * t) * weight;
        // Its size in units of the ellipse's semi-axes.
        let (ma, mi) = (major.length_squared(), minor.length_squared());
        if !(ma > 0.0 && mi > 0.0) {
            return None;
        }
        let norm = ((w.dot(major)).powi(2) / (ma * ma) + (w.dot(minor)).powi(2) / (mi * mi)).sqrt();
        let w = if norm > 2.0 { w * (2.0 / norm) } else { w };
        w.is_finite().then_some(w)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

    #[test]
    fn ellipse_footprint_analytic_values() {
        // Width 0.01 at the hit, so r = 0.01 * RADIUS_PER_WIDTH world units.
        let c = RayCone::from_pixel(0.001).at_distance(10.0);
        let r = 0.01 * RADIUS_PER_WIDTH;
        let (du, dv) = (Vec3A::X * 2.0, Vec3A::Y * 2.0);
        // Head-on on a plane of side 2: a circle of radius r / 2 in uv.
        let (ma, mi) = c.footprint(-Vec3A::Z, Vec3A::Z, du, dv).axis_lengths();
        assert!(
            (ma - r / 2.0).abs() < 1e-7 && (mi - r / 2.0).abs() < 1e-7,
            "{ma} {mi}"
        );
        // 60 degrees from the normal in the y-z plane: stretched by 1 / cos 60 = 2 along v only.
        let a = 60f32.to_radians();
        let dir = Vec3A::new(0.0, a.sin(), -a.cos());
        let fp = c.footprint(dir, Vec3A::Z, du, dv);
        let (major, minor) = fp.principal_axes();
        assert!((major.length() - r).abs() < 1e-6, "{fp:?}");
        assert!(major.x.abs() < 1e-7, "major along v: {major}");
        assert!((minor.length() - r / 2.0).abs() < 1e-6, "{fp:?}");
        // The back side gives the same ellipse.
        let back = c.footprint(dir, -Vec3A::Z, du, dv).axis_lengths();
        assert!((back.0 - r).abs() < 1e-6 && (back.1 - r / 2.0).abs() < 1e-6);
        // Anisotropic parametrisation: |dpdu| = 1, |dpdv| = 4: head-on the ellipse is r along u
        // and r / 4 along v.
        let (major, minor) = c
            .footprint(-Vec3A::Z, Vec3A::Z, Vec3A::X, Vec3A::Y * 4.0)
            .principal_axes();
        assert!((major.length() - r).abs() < 1e-6 && major.y.abs() < 1e-7);
        assert!((minor.length() - r / 4.0).abs() < 1e-6 && minor.x.abs() < 1e-7);
        // Sheared parametrisation (dpdv not perpendicular to dpdu): axes map back exactly.
        let (du, dv) = (Vec3A::X, Vec3A::new(1.0, 1.0, 0.0));
        let fp = c.footprint(-Vec3A::Z, Vec3A::Z, du, dv);
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
            .footprint(Vec3A::X, Vec3A::Z, Vec3A::X, Vec3A::Y)
            .axis_lengths();
        assert!(
            (ma - r / MIN_COS).abs() < 1e-5 && (mi - r).abs() < 1e-7,
            "{ma} {mi}"
        );
        // Sphere pole: dpdu = 0 falls back to a circle of |major| / |dpdv|.
        let pi = std::f32::consts::PI;
        let (ma, mi) = c
            .footprint(-Vec3A::Z, Vec3A::Z, Vec3A::ZERO, Vec3A::X * pi)
            .axis_lengths();
        assert!((ma - r / pi).abs() < 1e-7 && (mi - r / pi).abs() < 1e-7);
        // No derivatives, no direction, NaN: a point or finite.
        assert!(c
            .footprint(-Vec3A::Z, Vec3A::Z, Vec3A::ZERO, Vec3A::ZERO)
            .is_point());
        assert!(c
            .footprint(Vec3A::ZERO, Vec3A::Z, Vec3A::X, Vec3A::Y)
            .is_point());
        let nan = c.footprint(Vec3A::splat(f32::NAN), Vec3A::Z, Vec3A::X, Vec3A::Y);
        assert!(nan.a.is_finite() && nan.b.is_finite());
        let zero = RayCone::from_pixel(0.001).footprint(-Vec3A::Z, Vec3A::Z, Vec3A::X, Vec3A::Y);
        assert!(zero.is_point());
    }

    #[test]
    fn first_hit_lookups_move_toward_the_pixel_centre() {
        // Camera at the origin looking down -z at the plane z = -2 (normal +z, uv = (x, y)).
        let (du, dv) = (Vec3A::X, Vec3A::Y);
        let sample_dir = Vec3A::new(0.01, 0.0, -1.0);
        let centre_dir = Vec3::new(0.0, 0.0, -1.0);
        let t = 2.0 * sample_dir.length();
        let d = sample_dir.normalize();
        for weight in [1.0, 0.25] {
            let cone = RayCone::from_pixel(0.01)
                .toward_pixel_centre(centre_dir, weight)
                .at_distance(t);
            let fp = cone.footprint(d, Vec3A::Z, du, dv);
            // The sample hits x = 0.02, the centre ray x = 0: the shift is -0.02 * weight in u.
            assert!((fp.shift.x + 0.02 * weight).abs() < 1e-6, "{fp:?}");
            assert!(fp.shift.y.abs() < 1e-7);
            // Only the first hit moves.
            let next = cone.at_distance(1.0).footprint(d, Vec3A::Z, du, dv);
            assert_eq!(next.shift, Vec2::ZERO);
        }
        // A centre ray that misses the plane (parallel or behind) leaves the lookup in place, and
        // a far intersection is kept within two semi-axes.
        let cone = RayCone::from_pixel(0.01)
            .toward_pixel_centre(Vec3::X, 1.0)
            .at_distance(t);
        assert_eq!(cone.footprint(d, Vec3A::Z, du, dv).shift, Vec2::ZERO);
        let grazing = Vec3::new(1.0, 0.0, -1e-4);
        let cone = RayCone::from_pixel(0.01)
            .toward_pixel_centre(grazing, 1.0)
            .at_distance(t);
        let fp = cone.footprint(d, Vec3A::Z, du, dv);
        let (ma, _) = fp.axis_lengths();
        assert!(fp.shift.length() <= 2.0 * ma * 1.0001, "{fp:?}");
        // Without a centre nothing moves.
        let plain = RayCone::from_pixel(0.01)
            .at_distance(t)
            .footprint(d, Vec3A::Z, du, dv);
        assert_eq!(plain.shift, Vec2::ZERO);
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

    /// A rough bounce widens the cone by the lobe's width and makes every later footprint
    /// isotropic (the same ellipse, filtered as a circle); before it, footprints are anisotropic.
    #[test]
    fn a_rough_bounce_makes_footprints_isotropic() {
        let (d, du, dv) = (Vec3A::new(0.6, 0.0, -0.8), Vec3A::X, Vec3A::Y);
        let camera = RayCone::from_pixel(0.002).at_distance(4.0);
        let before = camera.footprint(d, Vec3A::Z, du, dv);
        assert!(!before.isotropic && !before.is_point());
        let rough = camera.widened(0.25);
        assert_eq!(rough.spread, 0.002 + 0.25);
        assert_eq!(rough.width, camera.width);
        let after = rough.footprint(d, Vec3A::Z, du, dv);
        assert!(after.isotropic);
        assert_eq!((after.a, after.b), (before.a, before.b));
        let later = rough.at_distance(2.0).footprint(d, Vec3A::Z, du, dv);
        assert!(later.isotropic && later.a.length() > after.a.length());
    }
}
