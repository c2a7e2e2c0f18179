//! Rays, and where a ray leaving a surface starts.

use glam::Vec3A;

/// A ray with its valid parameter interval.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub origin: Vec3A,
    pub dir: Vec3A,
    pub tmax: f32,
}

/// The closest hit along a ray: distance, primitive index, triangle barycentrics.
#[derive(Clone, Copy, Debug)]
pub struct ClosestHit {
    pub t: f32,
    pub prim: u32,
    pub b1: f32,
    pub b2: f32,
}

/// Moves a ray origin off a surface along the geometric normal, towards the side `dir` leaves
/// by, with an offset proportional to the point's magnitude (pbrt's error-bound idea, simplified
/// to a conservative relative epsilon), so that the new ray cannot re-hit its own surface.
#[inline]
pub fn offset_origin(p: Vec3A, ng: Vec3A, dir: Vec3A) -> Vec3A {
    let scale = (p.abs().max_element() + 1.0) * 2e-5;
    let n = if ng.dot(dir) < 0.0 { -ng } else { ng };
    p + n * scale
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_moves_to_the_side_of_the_direction() {
        let p = Vec3A::new(100.0, 0.0, 0.0);
        let o = offset_origin(p, Vec3A::Z, Vec3A::new(0.0, 1.0, 1.0));
        assert!(o.z > 0.0);
        let o = offset_origin(p, Vec3A::Z, Vec3A::new(0.0, 1.0, -1.0));
        assert!(o.z < 0.0);
    }
}
