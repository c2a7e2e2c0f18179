//! An instance of a shape group (Mitsuba's `instance` of a `shapegroup`): the group's geometry is
//! stored once, in the group's own space with its own BVH, and each instance places it in the
//! world by a transform. A ray is carried into the group's space (its direction not renormalised,
//! so that the distance t along it is the world ray's t), and the surface found there is carried
//! back: positions and tangents by `to_world`, normals by its inverse transpose.

use super::SurfaceHit;
use crate::ray::Ray;
use glam::{Affine3A, Mat3A, Mat4, Vec3A};

/// One placement of a shape group.
#[derive(Clone, Copy, Debug)]
pub struct Instance {
    pub to_world: Affine3A,
    pub to_local: Affine3A,
    /// The inverse transpose of `to_world`'s linear part: what normals transform with.
    pub normal_to_world: Mat3A,
    /// Index of the group's BVH in [`crate::accel::instances::Instances`].
    pub group: u32,
}

impl Instance {
    /// The instance of group `group` placed by `to_world`, which must be invertible (the parser
    /// checks it) and affine (its last row is ignored, as Mitsuba's instances do for
    /// directions).
    pub fn new(to_world: Mat4, group: u32) -> Self {
        let to_world = Affine3A::from_mat4(to_world);
        let to_local = to_world.inverse();
        Self {
            to_world,
            to_local,
            normal_to_world: to_local.matrix3.transpose(),
            group,
        }
    }

    /// `ray` in the group's space. The direction keeps the length the transform gives it, so t
    /// (and `tmax`) mean the same distance along both rays.
    #[inline(always)]
    pub fn local_ray(&self, ray: &Ray) -> Ray {
        Ray {
            origin: self.to_local.transform_point3a(ray.origin),
            dir: self.to_local.transform_vector3a(ray.dir),
            tmax: ray.tmax,
        }
    }

    /// The surface `local`, found in the group's space, in world space: position and dp/du,
    /// dp/dv by `to_world`, the geometric and shading normals by its inverse transpose
    /// (renormalised); t, uv, shape and primitive stay.
    #[inline]
    pub fn surface_to_world(&self, local: SurfaceHit) -> SurfaceHit {
        let normal = |n: Vec3A| (self.normal_to_world * n).normalize_or(n);
        SurfaceHit {
            p: self.to_world.transform_point3a(local.p),
            ng: normal(local.ng),
            ns: normal(local.ns),
            dpdu: self.to_world.transform_vector3a(local.dpdu),
            dpdv: self.to_world.transform_vector3a(local.dpdv),
            ..local
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Quat, Vec2, Vec3};

    /// A non-uniform scale with a rotation: positions and tangents follow the transform,
    /// normals stay perpendicular to the transformed tangents, and the local ray's t reaches
    /// the same point as the world ray's.
    #[test]
    fn surfaces_and_rays_transform_consistently() {
        let to_world = Mat4::from_scale_rotation_translation(
            Vec3::new(2.0, 0.5, 1.5),
            Quat::from_axis_angle(Vec3::new(1.0, 2.0, 0.5).normalize(), 0.7),
            Vec3::new(1.0, -2.0, 3.0),
        );
        let inst = Instance::new(to_world, 0);
        let ray = Ray {
            origin: Vec3A::new(0.3, 0.2, -4.0),
            dir: Vec3A::new(0.1, -0.2, 1.0).normalize(),
            tmax: 7.0,
        };
        let local = inst.local_ray(&ray);
        assert_eq!(local.tmax, ray.tmax);
        let t = 3.25;
        let back = inst
            .to_world
            .transform_point3a(local.origin + t * local.dir);
        assert!((back - (ray.origin + t * ray.dir)).length() < 1e-5);

        let (dpdu, dpdv) = (Vec3A::new(1.0, 0.2, 0.0), Vec3A::new(0.0, 1.0, -0.3));
        let n = dpdu.cross(dpdv).normalize();
        let sh = SurfaceHit {
            t,
            p: Vec3A::new(0.5, 0.5, 0.5),
            ng: n,
            ns: n,
            uv: Vec2::new(0.25, 0.75),
            dpdu,
            dpdv,
            bary: Vec2::ZERO,
            shape: 3,
            prim: 7,
        };
        let w = inst.surface_to_world(sh);
        assert!((w.p - Vec3A::from(to_world.transform_point3(Vec3::splat(0.5)))).length() < 1e-5);
        assert!((w.ng.length() - 1.0).abs() < 1e-6);
        assert!(w.ng.dot(w.dpdu).abs() < 1e-5 && w.ng.dot(w.dpdv).abs() < 1e-5);
        // Same side as the transformed tangents' cross product (positive determinant).
        assert!(w.ng.dot(w.dpdu.cross(w.dpdv)) > 0.0);
        assert_eq!((w.uv, w.shape, w.prim, w.t), (sh.uv, 3, 7, t));
    }
}
