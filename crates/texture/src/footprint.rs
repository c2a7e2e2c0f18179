//! Anisotropic texture footprints: the ellipse in texture space that one camera sample's filter
//! covers, and how it shrinks as a pixel takes more samples.

use glam::{Mat2, Vec2};

/// An ellipse in texture space, given by two conjugate semi-axes (uv units), centred `shift` away
/// from the lookup point. Any pair of conjugate semi-axes describes the same ellipse (they need
/// not be perpendicular); lookups only use the quadratic form they define and their lengths.
///
/// A zero footprint ([`Footprint::POINT`]) means "no filtering": the finest level, bilinear.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Footprint {
    /// First semi-axis (uv).
    pub a: Vec2,
    /// Second semi-axis (uv).
    pub b: Vec2,
    /// Where the filter is centred, relative to the lookup point (uv); see
    /// [`crate::RayCone::toward_pixel_centre`]. Zero unless set.
    pub shift: Vec2,
    /// Filter as the circle of the same area (one trilinear probe) instead of along the ellipse:
    /// set by [`Footprint::isotropic`] for lookups after a rough bounce.
    pub isotropic: bool,
}

impl Footprint {
    /// No filtering beyond bilinear reconstruction.
    pub const POINT: Footprint = Footprint {
        a: Vec2::ZERO,
        b: Vec2::ZERO,
        shift: Vec2::ZERO,
        isotropic: false,
    };

    /// The ellipse with semi-axes `a` and `b`; non-finite axes make it a point (never NaN).
    #[inline]
    pub fn new(a: Vec2, b: Vec2) -> Self {
        if a.is_finite() && b.is_finite() {
            Self {
                a,
                b,
                shift: Vec2::ZERO,
                isotropic: false,
            }
        } else {
            Self::POINT
        }
    }

    /// A circle of radius `r` (uv units); a negative or non-finite radius gives a point.
    pub fn circle(r: f32) -> Self {
        let r = if r.is_finite() { r.max(0.0) } else { 0.0 };
        Self {
            a: Vec2::new(r, 0.0),
            b: Vec2::new(0.0, r),
            shift: Vec2::ZERO,
            isotropic: false,
        }
    }

    /// The same footprint filtered as the circle of its area: one trilinear probe at the level of
    /// its geometric-mean radius (`MipMap::lookup_aniso`). After a rough bounce the cone is wide
    /// and blurred by the lobe anyway, and how its ellipse is stretched no longer shows; the
    /// probes along the major axis (up to 33) were 7% of staircase's render instructions.
    #[inline]
    pub fn isotropic(self) -> Self {
        Self {
            isotropic: true,
            ..self
        }
    }

    /// The same ellipse centred `shift` (uv) away from the lookup point; a non-finite shift is
    /// dropped.
    #[inline]
    pub fn with_shift(self, shift: Vec2) -> Self {
        Self {
            shift: if shift.is_finite() { shift } else { Vec2::ZERO },
            ..self
        }
    }

    /// Both axes (not the shift) multiplied by `s`; a non-finite or negative `s` gives a point.
    #[inline]
    pub fn scaled(self, s: f32) -> Self {
        if s.is_finite() && s >= 0.0 {
            Self {
                isotropic: self.isotropic,
                ..Self::new(self.a * s, self.b * s).with_shift(self.shift)
            }
        } else {
            Self::POINT
        }
    }

    /// The footprint after the linear map `m` (e.g. a texture's uv transform, or uv to texels).
    #[inline]
    pub fn transformed(self, m: Mat2) -> Self {
        Self {
            isotropic: self.isotropic,
            ..Self::new(m * self.a, m * self.b).with_shift(m * self.shift)
        }
    }

    /// The ellipse's principal semi-axes (major, minor) as perpendicular vectors: the singular
    /// vectors of the 2x2 matrix [a b] scaled by its singular values, so exact also when `a` and
    /// `b` are not perpendicular. A circle returns the x and y axes.
    pub fn principal_axes(&self) -> (Vec2, Vec2) {
        // M M^T = a a^T + b b^T = [[p, r], [r, q]]; its eigenvalues are the squared lengths.
        // Scaled to a unit largest component so the squares neither overflow nor underflow.
        let scale = self.a.abs().max_element().max(self.b.abs().max_element());
        if !(scale > 0.0 && scale.is_finite()) {
            return (Vec2::ZERO, Vec2::ZERO);
        }
        let (a, b) = (self.a / scale, self.b / scale);
        let p = a.x * a.x + b.x * b.x;
        let q = a.y * a.y + b.y * b.y;
        let r = a.x * a.y + b.x * b.y;
        let half_diff = 0.5 * (p - q);
        let root = (half_diff * half_diff + r * r).sqrt();
        let l1 = 0.5 * (p + q) + root;
        // det^2 / l1 is the small eigenvalue without the cancellation of (p + q)/2 - root.
        let det = a.perp_dot(b);
        let l2 = if l1 > 0.0 {
            (det * det / l1).min(l1)
        } else {
            0.0
        };
        // The eigenvector of l1: (l1 - q, r) or (r, l1 - p), whichever is longer (both are
        // non-negative sums here, so neither cancels); a circle takes the x axis.
        let v = if half_diff >= 0.0 {
            Vec2::new(half_diff + root, r)
        } else {
            Vec2::new(r, root - half_diff)
        };
        let dir = v.try_normalize().unwrap_or(Vec2::X);
        let (major, minor) = (dir * (l1.sqrt() * scale), dir.perp() * (l2.sqrt() * scale));
        if major.is_finite() && minor.is_finite() {
            (major, minor)
        } else {
            (Vec2::ZERO, Vec2::ZERO)
        }
    }

    /// The two semi-axis lengths of the ellipse, (major, minor).
    pub fn axis_lengths(&self) -> (f32, f32) {
        let (major, minor) = self.principal_axes();
        (major.length(), minor.length())
    }

    /// True when both axes are zero (a plain bilinear lookup).
    #[inline]
    pub fn is_point(&self) -> bool {
        self.a == Vec2::ZERO && self.b == Vec2::ZERO
    }
}

/// How far a first-hit texture lookup moves from the sample towards the pixel centre when a
/// pixel takes `spp` samples: 1 - sqrt(1 - 1/spp) (1 at one sample, about 1/(2 spp) for many).
///
/// With the footprint scaled by [`spp_scale`], the lookup positions of the pixel's samples spread
/// over sqrt(1 - 1/spp) of the pixel and each filters 1/sqrt(spp) of it, so their variances add
/// up to the pixel's own: in expectation every sample count filters the texture over one pixel,
/// the exact answer. At one sample the lookup is the pixel's filtered texture at its centre (what
/// a rasteriser computes), with no noise from where in the pixel the sample fell.
pub fn centre_weight(spp: u32) -> f32 {
    let n = spp.max(1) as f32;
    1.0 - (1.0 - 1.0 / n).sqrt()
}

/// How much a footprint shrinks when a pixel takes `spp` samples: 1 / sqrt(spp).
///
/// One sample per pixel is filtered over the pixel's whole footprint, which removes most of its
/// texture aliasing. With `spp` samples the pixel integral itself averages the texture, and the
/// filter only needs to cover the region one sample stands for, 1/spp of the pixel's area, i.e.
/// 1/sqrt(spp) of its width. The filter's bias (a blur no sample count removes) then falls as the
/// noise does, so high sample counts converge to the unfiltered (bilinear) image, which is what
/// Mitsuba converges to. Below a texel the lookup is bilinear anyway (see `MipMap::lookup_aniso`).
pub fn spp_scale(spp: u32) -> f32 {
    1.0 / (spp.max(1) as f32).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_lengths_of_axis_aligned_rotated_and_sheared_ellipses() {
        let e = Footprint::new(Vec2::new(3.0, 0.0), Vec2::new(0.0, 0.5));
        let (m, n) = e.axis_lengths();
        assert!((m - 3.0).abs() < 1e-6 && (n - 0.5).abs() < 1e-6, "{m} {n}");
        // Rotation keeps the lengths.
        let r = Mat2::from_angle(0.7);
        let (m, n) = e.transformed(r).axis_lengths();
        assert!((m - 3.0).abs() < 1e-5 && (n - 0.5).abs() < 1e-5, "{m} {n}");
        // Conjugate semi-axes of the same ellipse: a shear of the parameter circle.
        // a' = a cos t + b sin t, b' = -a sin t + b cos t describe the same ellipse.
        let t = 0.4f32;
        let (a, b) = (e.a, e.b);
        let c = Footprint::new(a * t.cos() + b * t.sin(), -a * t.sin() + b * t.cos());
        let (m, n) = c.axis_lengths();
        assert!((m - 3.0).abs() < 1e-5 && (n - 0.5).abs() < 1e-5, "{m} {n}");
        // Degenerate: a segment and a point.
        let (m, n) = Footprint::new(Vec2::new(1.0, 1.0), Vec2::new(2.0, 2.0)).axis_lengths();
        assert!((m - 10f32.sqrt()).abs() < 1e-5 && n.abs() < 1e-6, "{m} {n}");
        assert_eq!(Footprint::POINT.axis_lengths(), (0.0, 0.0));
    }

    #[test]
    fn principal_axes_are_perpendicular_and_span_the_same_ellipse() {
        let mut rng = torrey_testkit::Rng::new(7);
        for _ in 0..1000 {
            let e = Footprint::new(
                Vec2::new(rng.range(-3.0, 3.0), rng.range(-3.0, 3.0)),
                Vec2::new(rng.range(-3.0, 3.0), rng.range(-3.0, 3.0)),
            );
            let (ma, mi) = e.principal_axes();
            assert!(
                ma.dot(mi).abs() < 1e-3 * (1.0 + ma.length_squared()),
                "{e:?}"
            );
            assert!(ma.length() >= mi.length());
            // Same quadratic form: a a^T + b b^T = ma ma^T + mi mi^T.
            let form = |x: Vec2, y: Vec2| {
                [
                    x.x * x.x + y.x * y.x,
                    x.x * x.y + y.x * y.y,
                    x.y * x.y + y.y * y.y,
                ]
            };
            let (f, g) = (form(e.a, e.b), form(ma, mi));
            for k in 0..3 {
                assert!(
                    (f[k] - g[k]).abs() < 1e-3 * (1.0 + f[0] + f[2]),
                    "{e:?} {f:?} {g:?}"
                );
            }
        }
    }

    #[test]
    fn non_finite_inputs_give_a_point() {
        assert!(Footprint::new(Vec2::NAN, Vec2::X).is_point());
        assert!(Footprint::circle(f32::INFINITY).is_point());
        assert!(Footprint::circle(-1.0).is_point());
        assert!(Footprint::circle(1.0).scaled(f32::NAN).is_point());
        assert!(Footprint::circle(1e30)
            .transformed(Mat2::from_diagonal(Vec2::splat(1e30)))
            .is_point());
    }

    #[test]
    fn centre_weight_and_scale_keep_a_pixel_of_variance() {
        assert_eq!(centre_weight(1), 1.0);
        assert_eq!(centre_weight(0), 1.0);
        for spp in [2, 3, 4, 16, 256, 4096] {
            let (f, s) = (centre_weight(spp), spp_scale(spp));
            // Lookup positions spread over (1 - f) of the pixel, each filtering s of it.
            assert!(((1.0 - f) * (1.0 - f) + s * s - 1.0).abs() < 1e-5, "{spp}");
        }
        assert!((centre_weight(256) - 1.0 / 512.0).abs() < 1e-5);
    }

    #[test]
    fn shift_follows_linear_maps() {
        let fp = Footprint::circle(0.1).with_shift(Vec2::new(0.2, -0.1));
        let m = Mat2::from_cols(Vec2::new(2.0, 0.0), Vec2::new(1.0, 3.0));
        assert_eq!(fp.transformed(m).shift, m * fp.shift);
        assert_eq!(fp.scaled(0.5).shift, fp.shift);
        assert_eq!(fp.with_shift(Vec2::NAN).shift, Vec2::ZERO);
    }

    #[test]
    fn spp_scale_is_inverse_square_root() {
        assert_eq!(spp_scale(0), 1.0);
        assert_eq!(spp_scale(1), 1.0);
        assert_eq!(spp_scale(4), 0.5);
        assert_eq!(spp_scale(256), 1.0 / 16.0);
    }
}
