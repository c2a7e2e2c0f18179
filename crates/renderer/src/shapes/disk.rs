//! Mitsuba 3's `disk`, analytic: the unit disk in the object's xy plane (normal +z) placed by
//! `to_world`, which may scale x and y differently or shear them (an ellipse). Ray
//! intersection, Mitsuba's polar uv (u = radius, v = angle / 2π), and uniform area sampling with
//! its pdf for disks that emit.

use super::object_rows::ObjectRows;
use super::PrimGeom;
use super::{PrimInfo, SurfaceHit};
use crate::ray::ClosestHit;
use crate::ray::Ray;
use glam::{Affine3A, Mat4, Vec2, Vec3A};
use std::f32::consts::{FRAC_1_PI, PI};
use torrey_fastmath::{atan2, sin_cos_2pi};

/// A disk in world space.
#[derive(Clone, Copy, Debug)]
pub struct Disk {
    pub to_world: Affine3A,
    pub to_object: ObjectRows,
    /// The unit normal in world space (the inverse transpose of `to_world` applied to +z),
    /// before `flip_normals`.
    pub normal: Vec3A,
    /// π |dp/dx × dp/dy|: the area of the (possibly elliptic) disk, as Mitsuba 3.9.1 gives it
    /// (π for a shear of 0.5, where the product of the axes' lengths would say 1.118 π).
    pub area: f32,
}

impl Disk {
    /// The disk placed by `to_world`; None when the transform is singular or not finite.
    pub fn new(to_world: Mat4) -> Option<Self> {
        let to_world = Affine3A::from_mat4(to_world);
        let det = to_world.matrix3.determinant();
        if !(det.is_finite() && det != 0.0 && to_world.translation.is_finite()) {
            return None;
        }
        let to_object = ObjectRows::from_affine(to_world.inverse());
        let normal = (to_world.matrix3.inverse().transpose() * Vec3A::Z).normalize();
        let area = PI
            * to_world
                .matrix3
                .x_axis
                .cross(to_world.matrix3.y_axis)
                .length();
        Some(Self {
            to_world,
            to_object,
            normal,
            area,
        })
    }

    /// The disk as a BVH primitive.
    pub fn prim_geom(&self) -> PrimGeom {
        PrimGeom::Disk {
            to_object: self.to_object,
        }
    }

    /// The surface at `hit` along `ray`: the hit re-projected onto the disk's plane, and when
    /// `needs_uv` Mitsuba's uv, dp/du (radial) and dp/dv (2π times the tangential direction).
    #[inline]
    pub fn surface(
        &self,
        ray: &Ray,
        prim: &PrimInfo,
        hit: &ClosestHit,
        needs_uv: bool,
    ) -> SurfaceHit {
        let o = self.to_object.point(ray.origin);
        let d = self.to_object.vector(ray.dir);
        let local = Vec3A::new(o.x + hit.t * d.x, o.y + hit.t * d.y, 0.0);
        let p = self.to_world.transform_point3a(local);
        let (uv, dpdu, dpdv) = if needs_uv {
            let (uv, dpdu_l, dpdv_l) = disk_uv(local);
            (
                uv,
                self.to_world.transform_vector3a(dpdu_l),
                self.to_world.transform_vector3a(dpdv_l),
            )
        } else {
            (Vec2::ZERO, Vec3A::ZERO, Vec3A::ZERO)
        };
        SurfaceHit {
            t: hit.t,
            p,
            ng: self.normal,
            ns: self.normal,
            uv,
            dpdu,
            dpdv,
            bary: Vec2::ZERO,
            shape: prim.shape,
            prim: hit.prim,
        }
    }

    /// A point uniform over the disk's area (concentric mapping) and the normal there (before
    /// `flip_normals`); the area density is 1 / [`Disk::area`].
    #[inline]
    pub fn sample_point(&self, u: Vec2) -> (Vec3A, Vec3A) {
        let p = square_to_disk_concentric(u);
        (
            self.to_world.transform_point3a(Vec3A::new(p.x, p.y, 0.0)),
            self.normal,
        )
    }

    /// The point at Mitsuba's uv (u = r, v = φ / 2π), the normal (before `flip_normals`) and
    /// |dp/du × dp/dv| there (2π r times the area scale of `to_world`): Mitsuba's
    /// `eval_parameterization`, for sampling a textured emitter by its texture.
    #[inline]
    pub fn point_at_uv(&self, uv: Vec2) -> (Vec3A, Vec3A, f32) {
        let (sin_phi, cos_phi) = sin_cos_2pi(uv.y);
        let local = Vec3A::new(uv.x * cos_phi, uv.x * sin_phi, 0.0);
        (
            self.to_world.transform_point3a(local),
            self.normal,
            self.uv_jacobian(uv),
        )
    }

    /// |dp/du × dp/dv| at `uv` (see [`Disk::point_at_uv`]).
    #[inline]
    pub fn uv_jacobian(&self, uv: Vec2) -> f32 {
        let scale = self
            .to_world
            .transform_vector3a(Vec3A::X)
            .cross(self.to_world.transform_vector3a(Vec3A::Y))
            .length();
        2.0 * std::f32::consts::PI * uv.x * scale
    }

    /// [`Disk::sample_point`] with Mitsuba's uv there (for a textured emitter's radiance).
    #[inline]
    pub fn sample_point_uv(&self, u: Vec2) -> (Vec3A, Vec3A, Vec2) {
        let p = square_to_disk_concentric(u);
        let local = Vec3A::new(p.x, p.y, 0.0);
        (
            self.to_world.transform_point3a(local),
            self.normal,
            disk_uv(local).0,
        )
    }
}

/// Mitsuba's disk uv at object-space point `local` (z = 0): u = r, v = atan2(y, x) / 2π in
/// [0, 1); dp/du = (cos φ, sin φ, 0), dp/dv = 2π (−y, x, 0), in object space.
pub fn disk_uv(local: Vec3A) -> (Vec2, Vec3A, Vec3A) {
    let r = (local.x * local.x + local.y * local.y).sqrt();
    let mut v = atan2(local.y, local.x) * (0.5 * FRAC_1_PI);
    if v < 0.0 {
        v += 1.0;
    }
    let (cos_phi, sin_phi) = if r != 0.0 {
        (local.x / r, local.y / r)
    } else {
        (1.0, 0.0)
    };
    (
        Vec2::new(r, v),
        Vec3A::new(cos_phi, sin_phi, 0.0),
        2.0 * PI * Vec3A::new(-local.y, local.x, 0.0),
    )
}

/// Shirley and Chiu's concentric map from the unit square to the unit disk (the sampling
/// module's, whose sines and cosines are branch-free polynomials).
fn square_to_disk_concentric(u: Vec2) -> Vec2 {
    crate::sampling::square_to_concentric_disk(u)
}

/// Ray/disk intersection in the disk's object space (where it is the unit disk at z = 0): the
/// t in (0, tmax) where the ray crosses the plane inside the disk. t is the same in world and
/// object space (the map is affine).
#[inline]
pub fn intersect_disk(ray: &Ray, to_object: &ObjectRows, tmax: f32) -> Option<f32> {
    let o = to_object.point(ray.origin);
    let d = to_object.vector(ray.dir);
    let t = -o.z / d.z;
    if !(t > 0.0 && t < tmax) {
        return None;
    }
    let x = o.x + t * d.x;
    let y = o.y + t * d.y;
    (x * x + y * y <= 1.0).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// `point_at_uv` inverts Mitsuba's disk uv (the uv of its point is the uv asked for), and its
    /// Jacobian is |dp/du × dp/dv| by finite differences, through a non-uniform scale.
    #[test]
    fn point_at_uv_inverts_the_uv_and_gives_its_jacobian() {
        let disk = Disk::new(
            Mat4::from_translation(Vec3::new(0.5, 1.0, -2.0))
                * Mat4::from_scale(Vec3::new(2.0, 0.5, 3.0)),
        )
        .unwrap();
        for uv in [
            Vec2::new(0.3, 0.1),
            Vec2::new(0.8, 0.55),
            Vec2::new(0.5, 0.9),
        ] {
            let (p, n, jac) = disk.point_at_uv(uv);
            let back = disk_uv(disk.to_object.point(p)).0;
            assert!((back - uv).length() < 1e-4, "{uv} -> {back}");
            assert_eq!(n, disk.normal);
            let h = 1e-3;
            let du = (disk.point_at_uv(uv + Vec2::new(h, 0.0)).0 - p) / h;
            let dv = (disk.point_at_uv(uv + Vec2::new(0.0, h)).0 - p) / h;
            let fd = du.cross(dv).length();
            assert!((fd - jac).abs() < 2e-2 * jac, "{fd} vs {jac}");
        }
    }

    fn ray(o: Vec3A, d: Vec3A) -> Ray {
        Ray {
            origin: o,
            dir: d,
            tmax: f32::INFINITY,
        }
    }

    fn hit(disk: &Disk, r: &Ray) -> Option<SurfaceHit> {
        let t = intersect_disk(r, &disk.to_object, r.tmax)?;
        let prim = PrimInfo {
            ng: Vec3A::ZERO,
            indices: [0; 3],
            shape: 0,
        };
        let h = ClosestHit {
            t,
            prim: 0,
            b1: 0.0,
            b2: 0.0,
        };
        Some(disk.surface(r, &prim, &h, true))
    }

    fn close(a: Vec3A, b: [f32; 3]) -> bool {
        (a - Vec3A::from(b)).length() < 1e-4
    }

    /// Values printed by Mitsuba 3.9.1 (`ray_intersect` on a disk) for the same rays.
    #[test]
    fn uv_normal_and_derivatives_match_mitsuba() {
        let disk = Disk::new(Mat4::IDENTITY).unwrap();
        for dz in [-1.0, 1.0] {
            let s = hit(&disk, &ray(Vec3A::new(0.3, 0.4, -5.0 * dz), Vec3A::Z * dz)).unwrap();
            assert!((s.t - 5.0).abs() < 1e-5);
            assert!(
                (s.uv - Vec2::new(0.5, 0.147584)).length() < 1e-5,
                "{}",
                s.uv
            );
            assert!(close(s.ng, [0.0, 0.0, 1.0]));
            assert!(close(s.dpdu, [0.6, 0.8, 0.0]));
            assert!(close(s.dpdv, [-2.51327, 1.88496, 0.0]));
        }
        let s = hit(&disk, &ray(Vec3A::new(-0.5, -0.2, 5.0), -Vec3A::Z)).unwrap();
        assert!((s.uv - Vec2::new(0.538517, 0.560559)).length() < 1e-5);
        // A non-uniform scale: uv from the object-space point, derivatives through to_world.
        let disk = Disk::new(Mat4::from_scale(Vec3::new(2.0, 0.5, 3.0))).unwrap();
        let s = hit(&disk, &ray(Vec3A::new(0.3, 0.4, 5.0), -Vec3A::Z)).unwrap();
        assert!((s.uv - Vec2::new(0.813941, 0.220501)).length() < 1e-5);
        assert!(close(s.dpdu, [0.368577, 0.491436, 0.0]));
        assert!(close(s.dpdv, [-10.0531, 0.471239, 0.0]));
        assert!((disk.area - PI).abs() < 1e-5);
        assert!(hit(&disk, &ray(Vec3A::new(2.1, 0.0, 5.0), -Vec3A::Z)).is_none());
        assert!(hit(&disk, &ray(Vec3A::new(1.9, 0.0, 5.0), -Vec3A::Z)).is_some());
        assert!(hit(&disk, &ray(Vec3A::new(0.0, 0.6, 5.0), -Vec3A::Z)).is_none());
        // A shear: uv from the object-space point, area π |det| (Mitsuba 3.9.1: π).
        let shear = Mat4::from_cols_array_2d(&[
            [1.0, 0.0, 0.0, 0.0],
            [0.5, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ]);
        let disk = Disk::new(shear).unwrap();
        let s = hit(&disk, &ray(Vec3A::new(0.6, 0.3, 5.0), -Vec3A::Z)).unwrap();
        assert!(
            (s.uv - Vec2::new(0.540833, 0.0935835)).length() < 1e-5,
            "{}",
            s.uv
        );
        assert!((disk.area - PI).abs() < 1e-5);
    }

    /// Area sampling covers the disk uniformly: the sample mean of x² + y² (object space) of
    /// a uniform disk is 1/2, and every sample lies on it.
    #[test]
    fn area_samples_are_uniform_on_the_disk() {
        let disk = Disk::new(
            Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0))
                * Mat4::from_rotation_x(0.7)
                * Mat4::from_scale(Vec3::new(2.0, 1.5, 1.0)),
        )
        .unwrap();
        let mut rng = torrey_testkit::Rng::new(7);
        let n = 200_000;
        let mut sum = 0.0f64;
        let mut quadrant = [0usize; 4];
        for _ in 0..n {
            let (p, nrm) = disk.sample_point(Vec2::new(rng.f32(), rng.f32()));
            assert_eq!(nrm, disk.normal);
            let l = disk.to_object.point(p);
            assert!(l.z.abs() < 1e-5 && l.x * l.x + l.y * l.y <= 1.0 + 1e-5);
            sum += (l.x * l.x + l.y * l.y) as f64;
            quadrant[(l.x > 0.0) as usize * 2 + (l.y > 0.0) as usize] += 1;
        }
        assert!((sum / n as f64 - 0.5).abs() < 0.005, "{}", sum / n as f64);
        for q in quadrant {
            assert!((q as f64 / n as f64 - 0.25).abs() < 0.01, "{quadrant:?}");
        }
    }
}
