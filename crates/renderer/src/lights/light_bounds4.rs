//! Four [`LightBounds`] side by side (a node of the light tree's four children), whose
//! importance at a shading point is estimated for all four at once in SIMD lanes: the tree's walk
//! evaluates one node per level instead of two binary children per level, over half as many
//! levels.
//!
//! The estimate is pbrt-v4's `LightBounds::Importance` (Conty Estevez and Kulla 2018): power over
//! squared distance (kept from getting small inside the bounds), times the cosine of the
//! smallest angle between the cone of emitter normals and the direction to the point (less the
//! angle the bounds subtend and the emission's spread), times the cosine at the receiving surface.
//! It is zero only where nothing inside the bounds can reach the point (a one-sided emitter
//! facing away from it).

use super::light_bounds::LightBounds;
use glam::{BVec4A, Vec3A, Vec4};

/// Four light bounds as lanes, with what the importance needs of each precomputed. An empty
/// lane (a node with fewer than four children) has no power and is never important.
#[derive(Clone, Copy, Debug)]
pub struct LightBounds4 {
    centre: [Vec4; 3],
    /// The squared radius of each box's bounding sphere, and the radius.
    radius2: Vec4,
    radius: Vec4,
    phi: Vec4,
    /// The axis of the cone of emitter normals, its cosine and sine.
    axis: [Vec4; 3],
    cos_o: Vec4,
    sin_o: Vec4,
    cos_theta_e: Vec4,
    two_sided: BVec4A,
}

impl LightBounds4 {
    /// The lanes of `bounds` (None: an empty lane).
    pub fn new(bounds: [Option<LightBounds>; 4]) -> Self {
        let lane = |f: &dyn Fn(&LightBounds) -> f32, empty: f32| {
            Vec4::from_array(bounds.map(|b| b.as_ref().map_or(empty, f)))
        };
        let radius2 = lane(&|b| 0.25 * (b.max - b.min).length_squared(), 0.0);
        let cos_o = lane(&|b| b.normals.cos_theta, 1.0);
        LightBounds4 {
            centre: [0, 1, 2].map(|i| lane(&|b| b.centroid()[i], 0.0)),
            radius2,
            radius: radius2.sqrt(),
            phi: lane(&|b| b.phi, 0.0),
            axis: [0, 1, 2].map(|i| lane(&|b| b.normals.w[i], 0.0)),
            cos_o,
            sin_o: (Vec4::ONE - cos_o * cos_o).max(Vec4::ZERO).sqrt(),
            // Above any cosine: an empty lane is cut off everywhere.
            cos_theta_e: lane(&|b| b.cos_theta_e, 2.0),
            two_sided: BVec4A::from_array(bounds.map(|b| b.is_some_and(|b| b.two_sided))),
        }
    }

    /// The estimate of the light each lane's bounds send to point `p`, whose surface normal is
    /// `n` (zero: a point in space, no cosine there): non-negative and finite, zero only where
    /// no emitter inside can reach `p` (and in empty lanes).
    #[inline]
    pub fn importance(&self, p: Vec3A, n: Vec3A) -> Vec4 {
        let to_p = [0, 1, 2].map(|i| Vec4::splat(p[i]) - self.centre[i]);
        let len2 = to_p[0] * to_p[0] + to_p[1] * to_p[1] + to_p[2] * to_p[2];
        // Squared distance, kept from getting small inside the bounds (pbrt's clamp).
        let d2 = len2.max(self.radius);
        let away = len2.cmpgt(Vec4::ZERO);
        let inv_len = Vec4::select(away, len2.sqrt().recip(), Vec4::ZERO);
        let wi = [
            Vec4::select(away, to_p[0] * inv_len, Vec4::ZERO),
            Vec4::select(away, to_p[1] * inv_len, Vec4::ZERO),
            Vec4::select(away, to_p[2] * inv_len, Vec4::ONE),
        ];
        // The angle the bounds' sphere subtends from p: inside it, every direction.
        let outside = len2.cmpgt(self.radius2);
        let sin2_b = self.radius2 * inv_len * inv_len;
        let sin_b = Vec4::select(outside, sin2_b.sqrt(), Vec4::ZERO);
        let cos_b = Vec4::select(
            outside,
            (Vec4::ONE - sin2_b).max(Vec4::ZERO).sqrt(),
            Vec4::NEG_ONE,
        );
        // The angle between the cone's axis and the direction to p, less the cone's and the
        // bounds' angles: no emitter normal inside faces p more directly than that.
        let cos_w = self.axis[0] * wi[0] + self.axis[1] * wi[1] + self.axis[2] * wi[2];
        let cos_w = Vec4::select(self.two_sided, cos_w.abs(), cos_w);
        let sin_w = (Vec4::ONE - cos_w * cos_w).max(Vec4::ZERO).sqrt();
        let (cos_x, sin_x) = cos_sub_clamped(sin_w, cos_w, self.sin_o, self.cos_o);
        let (cos_p, _) = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
        // A margin below the emission's edge keeps rounding from zeroing a light that reaches
        // p (a zero must be exact: that light is then never chosen there).
        let reaches = cos_p.cmpgt(self.cos_theta_e - Vec4::splat(1e-4));
        let mut importance = self.phi * cos_p.max(Vec4::splat(1e-4)) / d2;
        if n != Vec3A::ZERO {
            // The cosine at the receiver, either side (transmission counts), less the bounds'
            // angle; never zero (a shading normal need not be the geometric one).
            let cos_i = (wi[0] * n.x + wi[1] * n.y + wi[2] * n.z).abs();
            let sin_i = (Vec4::ONE - cos_i * cos_i).max(Vec4::ZERO).sqrt();
            importance *= cos_sub_clamped(sin_i, cos_i, sin_b, cos_b)
                .0
                .max(Vec4::splat(1e-2));
        }
        // NaN and infinities (a point on a point light) fail the comparison: zero.
        let usable = reaches & importance.abs().cmplt(Vec4::INFINITY);
        Vec4::select(usable, importance.max(Vec4::ZERO), Vec4::ZERO)
    }
}

/// cos and sin of max(0, a − b) for angles given by their sines and cosines, lane by lane.
#[inline(always)]
fn cos_sub_clamped(sin_a: Vec4, cos_a: Vec4, sin_b: Vec4, cos_b: Vec4) -> (Vec4, Vec4) {
    let within = cos_a.cmpgt(cos_b);
    (
        Vec4::select(within, Vec4::ONE, cos_a * cos_b + sin_a * sin_b),
        Vec4::select(
            within,
            Vec4::ZERO,
            (sin_a * cos_b - cos_a * sin_b).max(Vec4::ZERO),
        ),
    )
}

#[cfg(test)]
mod tests {
    use super::super::light_bounds::DirectionCone;
    use super::*;
    use torrey_testkit::Rng;

    fn facing_z(two_sided: bool) -> LightBounds {
        LightBounds {
            min: Vec3A::new(-0.5, -0.5, 0.0),
            max: Vec3A::new(0.5, 0.5, 0.0),
            phi: 1.0,
            normals: DirectionCone {
                w: Vec3A::Z,
                cos_theta: 1.0,
            },
            cos_theta_e: 0.0,
            two_sided,
        }
    }

    /// A one-sided emitter facing away has no importance behind it; facing the point it has;
    /// two-sided it has on both sides. Empty lanes have none.
    #[test]
    fn importance_is_zero_only_behind_one_sided_emitters() {
        let b = LightBounds4::new([Some(facing_z(false)), Some(facing_z(true)), None, None]);
        let at = |p: Vec3A, n: Vec3A| b.importance(p, n).to_array();
        let front = at(Vec3A::new(0.0, 0.0, 2.0), Vec3A::ZERO);
        assert!(front[0] > 0.0 && front[1] > 0.0, "{front:?}");
        assert_eq!(&front[2..], &[0.0, 0.0]);
        assert!(at(Vec3A::new(3.0, 0.0, 0.01), -Vec3A::X)[0] > 0.0);
        let behind = at(Vec3A::new(0.0, 0.0, -2.0), Vec3A::ZERO);
        assert_eq!(behind[0], 0.0);
        assert!(behind[1] > 0.0, "{behind:?}");
    }

    /// Far from a small emitter facing the point, the importance is its power over the squared
    /// distance times the receiver's cosine; a lane's value does not depend on the others.
    #[test]
    fn importance_of_a_distant_emitter_is_power_over_distance_squared() {
        let mut rng = Rng::new(5);
        let small = LightBounds {
            min: Vec3A::splat(-1e-3),
            max: Vec3A::splat(1e-3),
            phi: 3.0,
            normals: DirectionCone::SPHERE,
            cos_theta_e: 0.0,
            two_sided: false,
        };
        for _ in 0..100 {
            let p = Vec3A::new(rng.f32(), rng.f32(), rng.f32()) * 20.0 - Vec3A::splat(10.0);
            if p.length() < 2.0 {
                continue;
            }
            // A receiver turned at most about 30 degrees away from the emitter.
            let jitter = Vec3A::new(rng.f32(), rng.f32(), rng.f32()) - Vec3A::splat(0.5);
            let n = (p.normalize() + jitter).normalize();
            let cos = p.normalize().dot(n).abs();
            let expected = 3.0 / p.length_squared() * cos;
            let other = LightBounds {
                phi: 100.0 * rng.f32(),
                ..facing_z(false)
            };
            let got = LightBounds4::new([Some(other), Some(small), None, Some(other)])
                .importance(p, n)
                .y;
            // The bounds' angle (under 1e-3) moves the receiver's cosine a little.
            assert!(
                (got - expected).abs() <= 5e-3 * expected,
                "{p} {n}: {got} against {expected}"
            );
        }
    }
}
