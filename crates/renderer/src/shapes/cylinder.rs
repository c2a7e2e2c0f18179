//! Mitsuba 3's `cylinder`, analytic: the open tube x² + y² = 1, 0 <= z <= 1 (no caps) placed by
//! `to_world` × translate(`p0`) × frame(`p1` − `p0`) × scale(`radius`, `radius`, |`p1` − `p0`|).
//! Ray intersection (both walls, from outside and inside), Mitsuba's uv (u = angle / 2π,
//! v = height), and uniform area sampling with Mitsuba's pdf for cylinders that emit.

use super::object_rows::ObjectRows;
use super::PrimGeom;
use super::{PrimInfo, SurfaceHit};
use crate::ray::ClosestHit;
use crate::ray::Ray;
use crate::sampling::Frame;
use glam::{Affine3A, Mat3, Mat4, Vec2, Vec3, Vec3A};
use std::f32::consts::{FRAC_1_PI, PI};
use torrey_fastmath::{atan2, sin_cos_2pi};

/// A cylinder in world space.
#[derive(Clone, Copy, Debug)]
pub struct Cylinder {
    /// Object (unit cylinder) to world, including `p0`, the axis frame, `radius` and length.
    pub to_world: Affine3A,
    pub to_object: ObjectRows,
    /// 2π × radius × length, both measured through `to_world` (Mitsuba's surface area, exact
    /// when x and y are scaled alike, which Mitsuba asks for).
    pub area: f32,
}

impl Cylinder {
    /// Mitsuba's cylinder from `p0`, `p1`, `radius` and `to_world`; None when the result is
    /// singular or not finite (p0 = p1, a zero radius or scale).
    pub fn new(p0: Vec3, p1: Vec3, radius: f32, to_world: Mat4) -> Option<Self> {
        let axis = p1 - p0;
        let length = axis.length();
        if !(length > 0.0 && length.is_finite()) {
            return None;
        }
        let f = Frame::from_normal((axis / length).into());
        let frame = Mat4::from_mat3(Mat3::from_cols(f.s.into(), f.t.into(), f.n.into()));
        let full = to_world
            * Mat4::from_translation(p0)
            * frame
            * Mat4::from_scale(Vec3::new(radius, radius, length));
        let full = Affine3A::from_mat4(full);
        let det = full.matrix3.determinant();
        if !(det.is_finite() && det != 0.0 && full.translation.is_finite()) {
            return None;
        }
        let area = 2.0 * PI * full.matrix3.x_axis.length() * full.matrix3.z_axis.length();
        Some(Self {
            to_world: full,
            to_object: ObjectRows::from_affine(full.inverse()),
            area,
        })
    }

    /// The cylinder as a BVH primitive.
    pub fn prim_geom(&self) -> PrimGeom {
        PrimGeom::Cylinder {
            to_object: self.to_object,
        }
    }

    /// The world-space unit normal at object-space wall point (x, y): the inverse transpose
    /// of `to_world` (the transpose of `to_object`'s linear part) applied to (x, y, 0).
    #[inline]
    fn normal_at(&self, x: f32, y: f32) -> Vec3A {
        let r = &self.to_object.0;
        (x * Vec3A::from(r[0].truncate()) + y * Vec3A::from(r[1].truncate())).normalize_or(Vec3A::Z)
    }

    /// The surface at `hit` along `ray`: the hit re-projected onto the wall, its outward normal,
    /// and when `needs_uv` Mitsuba's uv, dp/du = 2π (−y, x, 0) and dp/dv = (0, 0, 1) (object
    /// space, through `to_world`).
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
        let l = o + hit.t * d;
        let r = (l.x * l.x + l.y * l.y).sqrt();
        let (x, y) = if r > 0.0 {
            (l.x / r, l.y / r)
        } else {
            (1.0, 0.0)
        };
        let z = l.z.clamp(0.0, 1.0);
        let p = self.to_world.transform_point3a(Vec3A::new(x, y, z));
        let n = self.normal_at(x, y);
        let (uv, dpdu, dpdv) = if needs_uv {
            let mut u = atan2(y, x) * (0.5 * FRAC_1_PI);
            if u < 0.0 {
                u += 1.0;
            }
            (
                Vec2::new(u, z),
                self.to_world
                    .transform_vector3a(2.0 * PI * Vec3A::new(-y, x, 0.0)),
                self.to_world.transform_vector3a(Vec3A::Z),
            )
        } else {
            (Vec2::ZERO, Vec3A::ZERO, Vec3A::ZERO)
        };
        SurfaceHit {
            t: hit.t,
            p,
            ng: n,
            ns: n,
            uv,
            dpdu,
            dpdv,
            bary: Vec2::ZERO,
            shape: prim.shape,
            prim: hit.prim,
        }
    }

    /// A point uniform over the wall (uniform in height and angle) and the outward normal there
    /// (before `flip_normals`); the area density is 1 / [`Cylinder::area`], as in Mitsuba.
    #[inline]
    pub fn sample_point(&self, u: Vec2) -> (Vec3A, Vec3A) {
        let (s, c) = sin_cos_2pi(u.y);
        let p = self.to_world.transform_point3a(Vec3A::new(c, s, u.x));
        (p, self.normal_at(c, s))
    }

    /// The point at Mitsuba's uv (u = φ / 2π, v = height), the outward normal (before
    /// `flip_normals`) and |dp/du × dp/dv| there: Mitsuba's `eval_parameterization`, for
    /// sampling a textured emitter by its texture.
    #[inline]
    pub fn point_at_uv(&self, uv: Vec2) -> (Vec3A, Vec3A, f32) {
        let (s, c) = sin_cos_2pi(uv.x);
        (
            self.to_world.transform_point3a(Vec3A::new(c, s, uv.y)),
            self.normal_at(c, s),
            self.uv_jacobian(uv),
        )
    }

    /// |dp/du × dp/dv| at `uv` (see [`Cylinder::point_at_uv`]).
    #[inline]
    pub fn uv_jacobian(&self, uv: Vec2) -> f32 {
        let (s, c) = sin_cos_2pi(uv.x);
        let dpdu = self
            .to_world
            .transform_vector3a(2.0 * PI * Vec3A::new(-s, c, 0.0));
        dpdu.cross(self.to_world.transform_vector3a(Vec3A::Z))
            .length()
    }

    /// [`Cylinder::sample_point`] with Mitsuba's uv there (u = angle / 2π, v = height): the
    /// sample's own coordinates.
    #[inline]
    pub fn sample_point_uv(&self, u: Vec2) -> (Vec3A, Vec3A, Vec2) {
        let (p, n) = self.sample_point(u);
        (p, n, Vec2::new(u.y, u.x))
    }
}

/// Ray/cylinder intersection in the cylinder's object space (the unit tube, 0 <= z <= 1): the
/// nearest t in (0, tmax) on the wall, from outside or inside. Solved in f64 (as Mitsuba's
/// scalar variants do): rays leaving the wall start a hair away from it, and the root near zero
/// must keep its sign.
#[inline]
pub fn intersect_cylinder(ray: &Ray, to_object: &ObjectRows, tmax: f32) -> Option<f32> {
    let rows = to_object.0.map(|r| r.as_dvec4());
    let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3());
    let point = |i: usize| rows[i].truncate().dot(o) + rows[i].w;
    let vector = |i: usize| rows[i].truncate().dot(d);
    let (ox, oy, oz) = (point(0), point(1), point(2));
    let (dx, dy, dz) = (vector(0), vector(1), vector(2));
    let a = dx * dx + dy * dy;
    let b = 2.0 * (ox * dx + oy * dy);
    let c = ox * ox + oy * oy - 1.0;
    if a == 0.0 {
        return None;
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return None;
    }
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    let (mut t0, mut t1) = (q / a, if q != 0.0 { c / q } else { -b / (2.0 * a) });
    if t0 > t1 {
        std::mem::swap(&mut t0, &mut t1);
    }
    for t in [t0, t1] {
        let z = oz + t * dz;
        if t > 0.0 && t < tmax as f64 && (0.0..=1.0).contains(&z) {
            return Some(t as f32);
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `point_at_uv` is the point whose Mitsuba uv is the uv asked for, on the wall (normal
    /// outward), with |dp/du × dp/dv| by finite differences.
    #[test]
    fn point_at_uv_inverts_the_uv_and_gives_its_jacobian() {
        let cyl = Cylinder::new(
            glam::Vec3::new(1.0, 0.1, 0.2),
            glam::Vec3::new(1.3, 1.1, 0.0),
            0.3,
            glam::Mat4::IDENTITY,
        )
        .unwrap();
        for uv in [
            Vec2::new(0.3, 0.1),
            Vec2::new(0.8, 0.55),
            Vec2::new(0.05, 0.9),
        ] {
            let (p, n, jac) = cyl.point_at_uv(uv);
            let l = cyl.to_object.point(p);
            let mut u = l.y.atan2(l.x) * (0.5 * FRAC_1_PI);
            if u < 0.0 {
                u += 1.0;
            }
            assert!((Vec2::new(u, l.z) - uv).length() < 1e-4, "{uv}");
            assert!((n.length() - 1.0).abs() < 1e-5);
            let h = 1e-3;
            let du = (cyl.point_at_uv(uv + Vec2::new(h, 0.0)).0 - p) / h;
            let dv = (cyl.point_at_uv(uv + Vec2::new(0.0, h)).0 - p) / h;
            let fd = du.cross(dv).length();
            assert!((fd - jac).abs() < 2e-2 * jac, "{fd} vs {jac}");
            // Outward: away from the axis.
            assert!(n.dot(p - cyl.to_world.transform_point3a(Vec3A::new(0.0, 0.0, uv.y))) > 0.0);
        }
    }

    fn ray(o: Vec3A, d: Vec3A) -> Ray {
        Ray {
            origin: o,
            dir: d,
            tmax: f32::INFINITY,
        }
    }

    fn hit(c: &Cylinder, r: &Ray) -> Option<SurfaceHit> {
        let t = intersect_cylinder(r, &c.to_object, r.tmax)?;
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
        Some(c.surface(r, &prim, &h, true))
    }

    fn close(a: Vec3A, b: [f32; 3]) -> bool {
        (a - Vec3A::from(b)).length() < 2e-4
    }

    /// Values printed by Mitsuba 3.9.1 (`ray_intersect` on cylinders) for the same rays.
    #[test]
    fn uv_normal_and_derivatives_match_mitsuba() {
        let unit = Cylinder::new(Vec3::ZERO, Vec3::Z, 1.0, Mat4::IDENTITY).unwrap();
        let s = hit(&unit, &ray(Vec3A::new(5.0, 0.3, 0.4), -Vec3A::X)).unwrap();
        assert!((s.t - 4.04606).abs() < 1e-4);
        assert!(
            (s.uv - Vec2::new(0.0484933, 0.4)).length() < 1e-5,
            "{}",
            s.uv
        );
        assert!(close(s.ng, [0.953939, 0.3, 0.0]));
        assert!(close(s.dpdu, [-1.88496, 5.99378, 0.0]));
        assert!(close(s.dpdv, [0.0, 0.0, 1.0]));
        // From inside: the far wall, normal still outward.
        let s = hit(&unit, &ray(Vec3A::new(0.0, 0.2, 0.4), Vec3A::X)).unwrap();
        assert!((s.t - 0.979796).abs() < 1e-5);
        assert!(close(s.ng, [0.979796, 0.2, 0.0]));
        // Open ends: along the axis nothing is hit.
        assert!(hit(&unit, &ray(Vec3A::new(0.0, 0.0, 5.0), -Vec3A::Z)).is_none());
        assert!((unit.area - 2.0 * PI).abs() < 1e-5);

        let c = Cylinder::new(
            Vec3::new(0.0, 0.0, 0.1),
            Vec3::new(0.0, 0.0, 0.6),
            0.5,
            Mat4::IDENTITY,
        )
        .unwrap();
        let s = hit(&c, &ray(Vec3A::new(5.0, 0.3, 0.4), -Vec3A::X)).unwrap();
        assert!((s.uv - Vec2::new(0.102416, 0.6)).length() < 1e-5);
        assert!(close(s.dpdv, [0.0, 0.0, 0.5]));
        assert!(hit(&c, &ray(Vec3A::new(0.3, 5.0, 0.7), -Vec3A::Y)).is_none());

        // A tilted axis under a to_world: the axis frame is Mitsuba's.
        let to_world = Mat4::from_translation(Vec3::new(0.0, 0.0, 1.0))
            * Mat4::from_rotation_x(30f32.to_radians());
        let c = Cylinder::new(
            Vec3::new(0.5, 0.0, 0.0),
            Vec3::new(0.5, 2.0, 0.3),
            0.5,
            to_world,
        )
        .unwrap();
        let s = hit(&c, &ray(Vec3A::new(5.0, 0.6, 1.3), -Vec3A::X)).unwrap();
        assert!((s.t - 4.019732).abs() < 1e-4);
        assert!(
            (s.uv - Vec2::new(0.0448619, 0.324492)).length() < 1e-4,
            "{}",
            s.uv
        );
        assert!(close(s.ng, [0.960535, 0.173274, -0.217595]), "{}", s.ng);
        assert!(
            close(s.dpdu, [-0.873858, 1.879776, -2.360599]),
            "{}",
            s.dpdu
        );
        assert!(close(s.dpdv, [0.0, 1.582051, 1.259808]), "{}", s.dpdv);
        let s = hit(&c, &ray(Vec3A::new(0.5, 0.5, 5.0), -Vec3A::Z)).unwrap();
        assert!(
            (s.uv - Vec2::new(0.75, 0.512921)).length() < 1e-4,
            "{}",
            s.uv
        );
        assert!((c.area - 6.353478).abs() < 1e-4);

        // Non-uniform x/y scale: an elliptic tube with the ellipse's normal (Mitsuba warns).
        let c = Cylinder::new(
            Vec3::ZERO,
            Vec3::Z,
            1.0,
            Mat4::from_scale(Vec3::new(2.0, 0.5, 1.5)),
        )
        .unwrap();
        let s = hit(&c, &ray(Vec3A::new(0.3, 5.0, 0.7), -Vec3A::Y)).unwrap();
        assert!((s.t - 4.505657).abs() < 1e-4);
        assert!(close(s.ng, [0.0379019, 0.999282, 0.0]));
        assert!((c.area - 18.849556).abs() < 1e-3);
    }

    /// Area samples lie on the wall, uniformly in height and angle.
    #[test]
    fn area_samples_cover_the_wall_uniformly() {
        let c = Cylinder::new(
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 3.0, 1.0),
            0.7,
            Mat4::IDENTITY,
        )
        .unwrap();
        let mut rng = torrey_testkit::Rng::new(3);
        let n = 100_000;
        let (mut z_sum, mut x_pos) = (0.0f64, 0usize);
        for _ in 0..n {
            let (p, nrm) = c.sample_point(Vec2::new(rng.f32(), rng.f32()));
            let l = c.to_object.point(p);
            assert!(
                (l.x * l.x + l.y * l.y - 1.0).abs() < 1e-4 && (-1e-5..=1.0 + 1e-5).contains(&l.z)
            );
            assert!((nrm - c.normal_at(l.x, l.y)).length() < 1e-4);
            z_sum += l.z as f64;
            x_pos += (l.x > 0.0) as usize;
        }
        assert!((z_sum / n as f64 - 0.5).abs() < 0.005);
        assert!((x_pos as f64 / n as f64 - 0.5).abs() < 0.01);
    }
}
