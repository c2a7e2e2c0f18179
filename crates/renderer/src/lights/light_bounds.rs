//! Bounds of a light for choosing lights by their contribution (the light tree of
//! [`super::selection`]): where the light is (a box), how much it emits (its power, as luminance),
//! and in which directions (a cone of surface normals, widened by how far from the normal the
//! emission reaches), as in pbrt-v4's `LightBounds` (Conty Estevez and Kulla 2018).
//!
//! [`super::light_bounds4::LightBounds4::importance`] estimates what a light (or a cluster of
//! lights) sends to a point from these bounds, four at a time.

use glam::Vec3A;
use std::f32::consts::PI;

/// A cone of directions: axis `w` and the cosine of its half-angle (-1: every direction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionCone {
    pub w: Vec3A,
    pub cos_theta: f32,
}

impl DirectionCone {
    /// Every direction.
    pub const SPHERE: DirectionCone = DirectionCone {
        w: Vec3A::Z,
        cos_theta: -1.0,
    };

    /// The smallest cone (of this construction) holding both `self` and `other`.
    pub fn union(self, other: DirectionCone) -> DirectionCone {
        let theta_a = self.cos_theta.clamp(-1.0, 1.0).acos();
        let theta_b = other.cos_theta.clamp(-1.0, 1.0).acos();
        let theta_d = self.w.dot(other.w).clamp(-1.0, 1.0).acos();
        if (theta_d + theta_b).min(PI) <= theta_a {
            return self;
        }
        if (theta_d + theta_a).min(PI) <= theta_b {
            return other;
        }
        // The merged cone spans from a's far edge to b's far edge.
        let theta_o = 0.5 * (theta_a + theta_d + theta_b);
        if theta_o >= PI {
            return DirectionCone::SPHERE;
        }
        let axis = self.w.cross(other.w);
        let len = axis.length();
        if len.partial_cmp(&1e-12) != Some(std::cmp::Ordering::Greater) {
            return DirectionCone::SPHERE;
        }
        // Rotate a's axis towards b's by theta_o - theta_a (Rodrigues' formula).
        let (k, angle) = (axis / len, theta_o - theta_a);
        let (sin, cos) = angle.sin_cos();
        let w = self.w * cos + k.cross(self.w) * sin + k * k.dot(self.w) * (1.0 - cos);
        DirectionCone {
            w: w.normalize(),
            cos_theta: theta_o.cos(),
        }
    }
}

/// Where a light is, what it emits and towards where.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBounds {
    pub min: Vec3A,
    pub max: Vec3A,
    /// Emitted power (luminance; its scale only matters relative to other lights').
    pub phi: f32,
    /// The cone of the emitters' normals.
    pub normals: DirectionCone,
    /// The cosine of how far beyond its normal an emitter sends light: 0 (90 degrees) for a
    /// diffuse emitter.
    pub cos_theta_e: f32,
    /// Emits on both sides of its surface (the cone is then read in both directions).
    pub two_sided: bool,
}

impl LightBounds {
    /// Bounds of a point emitting in the directions of `cone` (spread `cos_theta_e` further).
    pub fn point(p: Vec3A, phi: f32, normals: DirectionCone, cos_theta_e: f32) -> Self {
        LightBounds {
            min: p,
            max: p,
            phi,
            normals,
            cos_theta_e,
            two_sided: false,
        }
    }

    pub fn centroid(&self) -> Vec3A {
        0.5 * (self.min + self.max)
    }

    /// Whether every number is finite (a light whose bounds are not is chosen independently of
    /// the shading point).
    pub fn is_finite(&self) -> bool {
        self.min.is_finite()
            && self.max.is_finite()
            && self.phi.is_finite()
            && self.normals.w.is_finite()
            && self.normals.cos_theta.is_finite()
    }

    /// Bounds of both.
    pub fn union(&self, other: &LightBounds) -> LightBounds {
        LightBounds {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
            phi: self.phi + other.phi,
            normals: self.normals.union(other.normals),
            cos_theta_e: self.cos_theta_e.min(other.cos_theta_e),
            two_sided: self.two_sided || other.two_sided,
        }
    }
}

/// The luminance of linear sRGB `c` (Rec. 709 weights), the power measure of the light tree.
#[inline]
pub fn luminance(c: Vec3A) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

#[cfg(test)]
mod tests {
    use super::*;
    use torrey_testkit::Rng;

    fn random_dir(rng: &mut Rng) -> Vec3A {
        loop {
            let v = Vec3A::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - Vec3A::ONE;
            if v.length_squared() > 1e-3 && v.length_squared() <= 1.0 {
                return v.normalize();
            }
        }
    }

    /// A union holds every direction of both cones (directions sampled inside each).
    #[test]
    fn cone_union_holds_both_cones() {
        let mut rng = Rng::new(3);
        for _ in 0..2000 {
            let a = DirectionCone {
                w: random_dir(&mut rng),
                cos_theta: rng.f32() * 2.0 - 1.0,
            };
            let b = DirectionCone {
                w: random_dir(&mut rng),
                cos_theta: rng.f32() * 2.0 - 1.0,
            };
            let u = a.union(b);
            for cone in [a, b] {
                for _ in 0..20 {
                    let d = random_dir(&mut rng);
                    if d.dot(cone.w) >= cone.cos_theta {
                        assert!(
                            d.dot(u.w) >= u.cos_theta - 1e-4,
                            "{a:?} {b:?} -> {u:?}: {d}"
                        );
                    }
                }
            }
        }
    }
}
