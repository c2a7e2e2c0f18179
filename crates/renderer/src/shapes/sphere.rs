//! Mitsuba's sphere, analytic (never tessellated): ray intersection, uv and its derivatives,
//! the surface at a hit, and sampling by the solid angle it subtends (with the matching pdf) for
//! spheres that emit.

use super::PrimGeom;
use super::{PrimInfo, SurfaceHit};
use crate::ray::ClosestHit;
use crate::ray::Ray;
use crate::sampling::Frame;
use glam::{Mat3, Mat4, Vec2, Vec3, Vec3A};
use std::f32::consts::PI;
use torrey_fastmath::{acos, atan2, sin_cos_2pi};

/// A sphere in world space, and the world-to-object rotation that fixes its uv poles.
#[derive(Clone, Copy, Debug)]
pub struct Sphere {
    pub center: Vec3A,
    pub radius: f32,
    pub to_object: Mat3,
}

impl Sphere {
    /// Mitsuba's sphere: `to_world` × translate(`center`) × scale(`radius`); the scale of
    /// `to_world` must be uniform.
    pub fn new(center: Vec3, radius: f32, to_world: Mat4) -> Self {
        let c = to_world.transform_point3(center);
        let linear = Mat3::from_mat4(to_world);
        let scale = linear.x_axis.length();
        let r = radius * scale;
        let rot = if scale > 0.0 {
            linear * (1.0 / scale)
        } else {
            Mat3::IDENTITY
        };
        Self {
            center: c.into(),
            radius: r,
            to_object: rot.transpose(),
        }
    }

    /// Mitsuba's uv of the point with outward unit normal `n`.
    #[inline]
    pub fn uv_of_normal(&self, n: Vec3A) -> Vec2 {
        sphere_uv(self.to_object * n).0
    }

    /// The sphere as a BVH primitive.
    pub fn prim_geom(&self) -> PrimGeom {
        PrimGeom::Sphere {
            center: self.center,
            radius: self.radius,
        }
    }

    /// The surface at `hit` along `ray`: the hit re-projected onto the sphere, its normal, and
    /// when `needs_uv` Mitsuba's uv and its derivatives.
    #[inline(always)]
    pub fn surface(
        &self,
        ray: &Ray,
        prim: &PrimInfo,
        hit: &ClosestHit,
        needs_uv: bool,
    ) -> SurfaceHit {
        let Sphere {
            center,
            radius,
            to_object,
        } = *self;
        let p_ray = ray.origin + hit.t * ray.dir;
        let n = (p_ray - center).normalize_or(Vec3A::Z);
        // Re-project onto the surface: the ray's point carries the cancellation error.
        let p = center + radius * n;
        let (uv, dpdu, dpdv) = if needs_uv {
            let (uv, dpdu_l, dpdv_l) = sphere_uv(to_object * n);
            let to_world = to_object.transpose();
            (uv, to_world * dpdu_l * radius, to_world * dpdv_l * radius)
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
}

/// Ray/sphere intersection with the numerically stable quadratic (the discriminant computed from
/// the ray's closest approach, as in Ray Tracing Gems ch. 7), returning the nearest t in (tmin, tmax).
#[inline]
pub fn intersect_sphere(
    ray: &Ray,
    center: Vec3A,
    radius: f32,
    tmin: f32,
    tmax: f32,
) -> Option<f32> {
    let f = ray.origin - center;
    let a = ray.dir.length_squared();
    let b = -f.dot(ray.dir);
    let c = f.length_squared() - radius * radius;
    // An origin outside the sphere (or on it) and a ray pointing away from its centre: below,
    // q = b - sqrt(..) is negative (or NaN), so c / q and q / a are never positive and no t
    // exceeds tmin >= 0. Deciding it here skips the divisions and the square root: rays leaving
    // a sphere (reflections, shadow rays) are a third of the tests in envmap_sky.
    if b < 0.0 && c >= 0.0 && tmin >= 0.0 {
        return None;
    }
    // Distance² from the centre to the line, computed without catastrophic cancellation.
    let l = f + (b / a) * ray.dir;
    let disc = radius * radius - l.length_squared();
    if disc < 0.0 {
        return None;
    }
    let q = b + b.signum() * (a * disc).sqrt();
    let (t0, t1) = if q == 0.0 {
        (0.0, 0.0)
    } else {
        let r0 = c / q;
        let r1 = q / a;
        if r0 < r1 {
            (r0, r1)
        } else {
            (r1, r0)
        }
    };
    if t0 > tmin && t0 < tmax {
        Some(t0)
    } else if t1 > tmin && t1 < tmax {
        Some(t1)
    } else {
        None
    }
}

/// Sphere texture coordinates and tangents in Mitsuba's convention, from the hit point in the
/// sphere's object frame scaled to the unit sphere (pole axis +z).
/// Returns (uv, dp/du, dp/dv) with the derivatives in the same (unit-sphere, object) frame.
pub fn sphere_uv(local: Vec3A) -> (Vec2, Vec3A, Vec3A) {
    let (x, y, z) = (local.x, local.y, local.z.clamp(-1.0, 1.0));
    let mut phi = atan2(y, x);
    if phi < 0.0 {
        phi += 2.0 * std::f32::consts::PI;
    }
    let theta = acos(z);
    let uv = Vec2::new(
        phi / (2.0 * std::f32::consts::PI),
        theta / std::f32::consts::PI,
    );
    let dpdu = 2.0 * std::f32::consts::PI * Vec3A::new(-y, x, 0.0);
    let (sin_phi, cos_phi) = sin_cos_2pi(uv.x);
    let rxy = (x * x + y * y).sqrt();
    let dpdv = std::f32::consts::PI * Vec3A::new(z * cos_phi, z * sin_phi, -rxy);
    (uv, dpdu, dpdv)
}

impl Sphere {
    /// A point on the sphere sampled by the solid angle it subtends from `reference`
    /// ([`sample_sphere_solid_angle`]).
    #[inline(always)]
    pub fn sample_solid_angle(&self, reference: Vec3A, u: Vec2) -> Option<SphereSample> {
        sample_sphere_solid_angle(self.center.into(), self.radius, reference.into(), u)
    }

    /// The density MIS needs for a ray from (near) `reference` along `direction` that hit the
    /// sphere ([`sphere_hit_pdf`]).
    #[inline(always)]
    pub fn hit_pdf(&self, reference: Vec3A, direction: Vec3A) -> f32 {
        sphere_hit_pdf(
            self.center.into(),
            self.radius,
            reference.into(),
            direction.into(),
        )
    }
}

/// Below this sin^2 of the cone half-angle (about 1.5 degrees) the cone is sampled with a Taylor
/// expansion, because `1 - cos(theta_max)` loses all precision in f32 for tiny or distant spheres.
const SMALL_CONE_SIN2: f32 = 0.000_685_23;

/// A point sampled on a sphere light, with the density needed for MIS.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereSample {
    /// Position on the sphere surface.
    pub point: Vec3,
    /// Outward unit normal at `point`.
    pub normal: Vec3,
    /// Density over solid angle as seen from the reference point.
    pub pdf: f32,
}

/// `1 - cos(theta_max)` of the cone subtended by a sphere, accurate for tiny cones.
#[inline]
fn cone_one_minus_cos(sin2_max: f32) -> f32 {
    if sin2_max < SMALL_CONE_SIN2 {
        // 1 - sqrt(1 - s) = s/2 + s^2/8 + ...
        0.5 * sin2_max + 0.125 * sin2_max * sin2_max
    } else {
        1.0 - (1.0 - sin2_max).max(0.0).sqrt()
    }
}

#[inline]
fn valid_sphere(center: Vec3, radius: f32, reference: Vec3) -> bool {
    center.is_finite() && reference.is_finite() && radius.is_finite() && radius > 0.0
}

/// Sphere sampled by the cone of directions it subtends from `reference` (pbrt-style); falls back
/// to uniform area sampling when `reference` is inside. Returns point on the sphere, its outward
/// normal, and the pdf over solid angle at `reference`. `None` for a degenerate sphere or sample.
pub fn sample_sphere_solid_angle(
    center: Vec3,
    radius: f32,
    reference: Vec3,
    u: Vec2,
) -> Option<SphereSample> {
    if !valid_sphere(center, radius, reference) {
        return None;
    }
    let to_center = center - reference;
    let dist2 = to_center.length_squared();
    if dist2 <= radius * radius {
        // Inside (or on) the sphere: uniform by area, converted to solid angle at `reference`.
        let z = 1.0 - 2.0 * u.x;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let (sin_phi, cos_phi) = sin_cos_2pi(u.y);
        let normal = Vec3::new(r * cos_phi, r * sin_phi, z);
        let point = center + radius * normal;
        let d = point - reference;
        let len2 = d.length_squared();
        if len2 <= 0.0 {
            return None;
        }
        let cos = (normal.dot(d) / len2.sqrt()).abs();
        if cos <= 0.0 {
            return None;
        }
        let pdf = len2 / (cos * 4.0 * PI * radius * radius);
        return pdf
            .is_finite()
            .then_some(SphereSample { point, normal, pdf });
    }

    // Two independent divisions, the rest multiplies: the chain of square roots and divisions
    // is this function's cost (a tenth of veach-direct's render).
    let dist = dist2.sqrt();
    let inv_dist = 1.0 / dist;
    let inv_sin_max = dist / radius;
    let w = Vec3A::from(to_center) * inv_dist;
    let sin_max = radius * inv_dist;
    let sin2_max = sin_max * sin_max;
    let one_minus_cos_max = cone_one_minus_cos(sin2_max);

    // Angle theta between the sampled direction and the axis, uniform in cos over the cone.
    let (sin2_theta, cos_theta) = if sin2_max < SMALL_CONE_SIN2 {
        let s2 = sin2_max * u.x;
        (s2, (1.0 - s2).sqrt())
    } else {
        let c = 1.0 - u.x * one_minus_cos_max;
        ((1.0 - c * c).max(0.0), c)
    };
    // Angle alpha at the sphere centre between -w and the hit point's normal (law of sines in the
    // triangle reference-centre-hit, taking the nearer intersection).
    let r = sin2_theta * inv_sin_max;
    let cos_alpha = r + cos_theta * (1.0 - r * inv_sin_max).max(0.0).sqrt();
    let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
    let (sin_phi, cos_phi) = sin_cos_2pi(u.y);
    let frame = Frame::from_normal(w);
    // Unit by construction (an orthonormal frame, cos² + sin² = 1): no normalisation.
    let normal = Vec3::from(-w * cos_alpha + (frame.s * cos_phi + frame.t * sin_phi) * sin_alpha);
    let point = center + radius * normal;
    let pdf = 1.0 / (2.0 * PI * one_minus_cos_max);
    (pdf.is_finite() && normal.is_finite()).then_some(SphereSample { point, normal, pdf })
}

/// Density over solid angle at `reference` of [`sample_sphere_solid_angle`] producing `direction`
/// (need not be normalised). 0 when the direction misses the sphere. (The renderer asks only for
/// directions whose rays hit the sphere, [`sphere_hit_pdf`]; the tests check the sampler against
/// this.)
#[cfg(test)]
pub fn sphere_solid_angle_pdf(center: Vec3, radius: f32, reference: Vec3, direction: Vec3) -> f32 {
    sphere_pdf(center, radius, reference, direction, true)
}

/// [`sphere_solid_angle_pdf`] for a direction whose ray is known to have hit the sphere: the
/// density of the cone seen from `reference` outside the sphere, without testing whether
/// `direction` lies in that cone, as Mitsuba's `Sphere::pdf_direction` computes it. A BSDF-sampled
/// ray leaves from the shading point moved off the surface ([`crate::ray::offset_origin`]), not
/// from the point itself, so a ray that hit a sphere near its silhouette can lie just outside
/// the cone seen from the point: there the cone test gave 0, multiple importance sampling then
/// gave the hit weight 1, and one such sample of a small, bright sphere made a firefly
/// (issue 34: a diffuse wall pixel at 6.0 where Mitsuba has 0.079).
pub fn sphere_hit_pdf(center: Vec3, radius: f32, reference: Vec3, direction: Vec3) -> f32 {
    sphere_pdf(center, radius, reference, direction, false)
}

#[inline]
fn sphere_pdf(center: Vec3, radius: f32, reference: Vec3, direction: Vec3, test_cone: bool) -> f32 {
    if !valid_sphere(center, radius, reference) {
        return 0.0;
    }
    let len = direction.length();
    if !(len > 0.0 && len.is_finite()) {
        return 0.0;
    }
    let d = direction / len;
    let to_center = center - reference;
    let dist2 = to_center.length_squared();
    if dist2 <= radius * radius {
        // Inside: the ray leaves through exactly one point; convert the area density there.
        let oc = reference - center;
        let b = oc.dot(d);
        let c = dist2 - radius * radius;
        let t = -b + (b * b - c).max(0.0).sqrt();
        if t <= 0.0 {
            return 0.0;
        }
        let point = reference + t * d;
        let normal = (point - center) / radius;
        let cos = normal.dot(d).abs();
        if cos <= 0.0 {
            return 0.0;
        }
        return t * t / (cos * 4.0 * PI * radius * radius);
    }
    let sin2_max = radius * radius / dist2;
    let one_minus_cos_max = cone_one_minus_cos(sin2_max);
    if test_cone {
        // Inside the cone iff 1 - cos(angle to axis) <= 1 - cos(theta_max); computed via the
        // chord so tiny cones keep their precision: 1 - cos = |d - w|^2 / 2.
        let w = to_center / dist2.sqrt();
        let one_minus_cos = 0.5 * (d - w).length_squared();
        if one_minus_cos > one_minus_cos_max * (1.0 + 1e-4) {
            return 0.0;
        }
    }
    1.0 / (2.0 * PI * one_minus_cos_max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use torrey_testkit::{assert_chi_square, Rng};

    fn ray(o: Vec3A, d: Vec3A) -> Ray {
        Ray {
            origin: o,
            dir: d,
            tmax: f32::INFINITY,
        }
    }

    #[test]
    fn sphere_hits_from_outside_and_inside() {
        let c = Vec3A::new(0.0, 0.0, -5.0);
        let t = intersect_sphere(&ray(Vec3A::ZERO, -Vec3A::Z), c, 1.0, 0.0, f32::INFINITY).unwrap();
        assert!((t - 4.0).abs() < 1e-5);
        let t = intersect_sphere(&ray(c, Vec3A::X), c, 2.0, 0.0, f32::INFINITY).unwrap();
        assert!((t - 2.0).abs() < 1e-5);
        assert!(
            intersect_sphere(&ray(Vec3A::ZERO, Vec3A::Z), c, 1.0, 0.0, f32::INFINITY).is_none()
        );
        // A far, small sphere is still hit accurately (stable discriminant).
        let far = Vec3A::new(0.0, 0.0, -1e4);
        let t =
            intersect_sphere(&ray(Vec3A::ZERO, -Vec3A::Z), far, 0.01, 0.0, f32::INFINITY).unwrap();
        assert!((t - (1e4 - 0.01)).abs() < 0.01);
    }

    /// `intersect_sphere` as it was before its early exit for rays leaving the sphere: the
    /// reference its answers must equal to the bit.
    fn intersect_sphere_reference(
        ray: &Ray,
        center: Vec3A,
        radius: f32,
        tmin: f32,
        tmax: f32,
    ) -> Option<f32> {
        let f = ray.origin - center;
        let a = ray.dir.length_squared();
        let b = -f.dot(ray.dir);
        let l = f + (b / a) * ray.dir;
        let disc = radius * radius - l.length_squared();
        if disc < 0.0 {
            return None;
        }
        let c = f.length_squared() - radius * radius;
        let q = b + b.signum() * (a * disc).sqrt();
        let (t0, t1) = if q == 0.0 {
            (0.0, 0.0)
        } else {
            let (r0, r1) = (c / q, q / a);
            if r0 < r1 {
                (r0, r1)
            } else {
                (r1, r0)
            }
        };
        if t0 > tmin && t0 < tmax {
            Some(t0)
        } else if t1 > tmin && t1 < tmax {
            Some(t1)
        } else {
            None
        }
    }

    /// The early exit changes no answer: origins on, just off, inside and outside the sphere,
    /// rays leaving, entering, grazing and passing through its centre, unnormalised, zero, NaN
    /// and infinite directions and origins, negative, zero and positive tmin, tmax cuts.
    #[test]
    fn intersect_sphere_matches_its_reference_bit_for_bit() {
        let mut rng = Rng::new(77);
        let center = Vec3A::new(0.3, -1.2, 2.0);
        let radius = 0.75;
        let origins = [
            center,
            center + Vec3A::new(0.0, 0.0, radius),
            center + Vec3A::new(radius, 0.0, 0.0) * (1.0 + f32::EPSILON),
            center + Vec3A::new(0.0, radius, 0.0) * (1.0 - f32::EPSILON),
            center + Vec3A::new(5.0, 1.0, -3.0),
            Vec3A::new(f32::NAN, 0.0, 0.0),
            Vec3A::new(f32::INFINITY, 1.0, 0.0),
            Vec3A::new(1e30, -1e30, 1e30),
        ];
        let dirs = [
            Vec3A::X,
            -Vec3A::X,
            Vec3A::Z,
            -Vec3A::Z,
            Vec3A::ZERO,
            Vec3A::new(f32::NAN, 1.0, 0.0),
            Vec3A::new(f32::INFINITY, 0.0, 0.0),
            Vec3A::new(1e-30, 0.0, 0.0),
            Vec3A::new(3.0, -4.0, 12.0),
        ];
        let mut cases: Vec<(Vec3A, Vec3A)> = origins
            .iter()
            .flat_map(|&o| dirs.iter().map(move |&d| (o, d)))
            .collect();
        let mut v = || {
            Vec3A::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            )
        };
        for _ in 0..2000 {
            // Rays from points on the sphere (leaving or re-entering it) and from just off it,
            // and rays from around it, unnormalised.
            let n = v().normalize_or(Vec3A::X);
            let d = v() * 2.0;
            cases.push((center + n * radius, d));
            cases.push((center + n * radius * (1.0 + 1e-4), d));
            cases.push((center + v() * 3.0, d));
        }
        // Rays aimed at the silhouette: grazing, hitting and missing by an ulp or so.
        for k in 0..64 {
            let o = center + Vec3A::new(0.0, 0.0, -4.0);
            let edge = center + Vec3A::new(radius * (1.0 + (k as f32 - 32.0) * 1e-7), 0.0, 0.0);
            cases.push((o, (edge - o).normalize()));
        }
        let (mut hits, mut checked) = (0, 0);
        for (o, d) in cases {
            let r = ray(o, d);
            for tmin in [0.0, -0.0, 1e-3, -1.0] {
                for tmax in [f32::INFINITY, 1.0, 1e-4, 0.0, f32::NAN] {
                    let got = intersect_sphere(&r, center, radius, tmin, tmax);
                    let want = intersect_sphere_reference(&r, center, radius, tmin, tmax);
                    assert_eq!(
                        got.map(f32::to_bits),
                        want.map(f32::to_bits),
                        "o {o} d {d} tmin {tmin} tmax {tmax}"
                    );
                    hits += want.is_some() as usize;
                    checked += 1;
                }
            }
        }
        // The cases cover hits and misses alike.
        assert!(
            hits > checked / 20 && hits < checked / 2,
            "{hits} hits of {checked}"
        );
    }

    #[test]
    fn sphere_uv_follows_mitsuba() {
        // +x on the equator: phi = 0, theta = pi/2.
        let (uv, dpdu, dpdv) = sphere_uv(Vec3A::X);
        assert!((uv - Vec2::new(0.0, 0.5)).length() < 1e-6);
        assert!((dpdu - Vec3A::new(0.0, 2.0 * std::f32::consts::PI, 0.0)).length() < 1e-5);
        assert!((dpdv - Vec3A::new(0.0, 0.0, -std::f32::consts::PI)).length() < 1e-5);
        // +y: phi = pi/2 → u = 0.25; north pole: v = 0.
        assert!((sphere_uv(Vec3A::Y).0.x - 0.25).abs() < 1e-6);
        assert!(sphere_uv(Vec3A::Z).0.y.abs() < 1e-6);
        // -y wraps to u = 0.75, not -0.25.
        assert!((sphere_uv(-Vec3A::Y).0.x - 0.75).abs() < 1e-6);
    }

    /// Nearest positive intersection of a ray with a sphere (in f64, as an independent check).
    fn intersect(center: Vec3, radius: f32, o: Vec3, d: Vec3) -> Option<Vec3> {
        let (c, o, d) = (center.as_dvec3(), o.as_dvec3(), d.as_dvec3().normalize());
        let oc = o - c;
        let b = oc.dot(d);
        let cc = oc.length_squared() - (radius as f64).powi(2);
        let disc = b * b - cc;
        // Grazing directions may miss by rounding; treat them as tangent.
        let s = disc.max(0.0).sqrt();
        let t = if -b - s > 0.0 { -b - s } else { -b + s };
        (t > 0.0).then(|| (o + t * d).as_vec3())
    }

    /// A basis around `w` built independently of the code under test.
    fn frame(w: Vec3) -> (Vec3, Vec3) {
        let a = if w.x.abs() < 0.9 { Vec3::X } else { Vec3::Y };
        let t1 = a.cross(w).normalize();
        (t1, w.cross(t1))
    }

    /// Samples the sphere from outside, checks geometry and pdf consistency, and runs a
    /// chi-square test on (1 - cos theta, phi) bins around the axis, extending past the cone.
    fn check_cone(center: Vec3, radius: f32, reference: Vec3, seed: u64) {
        let to_c = center - reference;
        let w = to_c.normalize();
        let sin2_max = radius * radius / to_c.length_squared();
        let omc_max = cone_one_minus_cos(sin2_max) as f64;
        let (t1, t2) = frame(w);
        let (nt, np) = (10usize, 8usize);
        let t_range = 1.25; // bins cover t = (1 - cos) / omc_max in [0, 1.25)
        let samples = 100_000;
        let mut hist = vec![0.0f64; nt * np];
        let mut rng = Rng::new(seed);
        for _ in 0..samples {
            let s = sample_sphere_solid_angle(center, radius, reference, rng.vec2()).unwrap();
            // On the sphere, normal outward, facing the reference point.
            assert!(((s.point - center).length() - radius).abs() < 1e-4 * radius.max(1.0));
            assert!((s.normal - (s.point - center) / radius).length() < 1e-3);
            let d = (s.point - reference).normalize();
            assert!(s.normal.dot(-d) >= -1e-3, "sampled the back side");
            // The ray towards the sample hits the sphere first at the sample.
            let hit = intersect(center, radius, reference, d).expect("sample direction misses");
            let tol = 2e-3 * radius + 1e-4 * (s.point - reference).length();
            assert!((hit - s.point).length() < tol, "{hit} vs {}", s.point);
            let pdf = sphere_solid_angle_pdf(center, radius, reference, d);
            assert!((pdf - s.pdf).abs() <= 1e-5 * s.pdf, "{pdf} vs {}", s.pdf);
            // 1 - cos via the chord, precise for tiny cones.
            let omc = 0.5 * (d - w).length_squared() as f64;
            let t = omc / omc_max;
            let phi = (d.dot(t2) as f64)
                .atan2(d.dot(t1) as f64)
                .rem_euclid(std::f64::consts::TAU);
            let it = ((t / t_range * nt as f64) as usize).min(nt - 1);
            let ip = ((phi / std::f64::consts::TAU * np as f64) as usize).min(np - 1);
            hist[it * np + ip] += 1.0;
        }
        // Expected counts: integrate the pdf over each bin (dω = omc_max dt dphi).
        let sub = 8;
        let mut expected = vec![0.0f64; nt * np];
        let mut total = 0.0;
        for it in 0..nt {
            for ip in 0..np {
                let mut acc = 0.0;
                for a in 0..sub {
                    for b in 0..sub {
                        let t = (it as f64 + (a as f64 + 0.5) / sub as f64) / nt as f64 * t_range;
                        let phi = (ip as f64 + (b as f64 + 0.5) / sub as f64) / np as f64
                            * std::f64::consts::TAU;
                        let omc = t * omc_max;
                        let cos = 1.0 - omc;
                        let sin = (omc * (2.0 - omc)).max(0.0).sqrt();
                        let d = w * cos as f32
                            + (t1 * phi.cos() as f32 + t2 * phi.sin() as f32) * sin as f32;
                        acc += sphere_solid_angle_pdf(center, radius, reference, d) as f64;
                    }
                }
                let dw = omc_max * t_range / nt as f64 * std::f64::consts::TAU / np as f64;
                let mass = acc / (sub * sub) as f64 * dw;
                total += mass;
                expected[it * np + ip] = mass * samples as f64;
            }
        }
        assert!((total - 1.0).abs() < 2e-3, "cone pdf integrates to {total}");
        // Bins straddling the cone edge have quadrature error; the pdf check above is exact.
        assert_chi_square("sample_sphere_solid_angle (cone)", &hist, &expected);
    }

    #[test]
    fn sphere_cone_sampling_matches_pdf() {
        check_cone(
            Vec3::new(0.3, -0.2, 2.0),
            0.9,
            Vec3::new(0.1, 0.1, -0.5),
            11,
        );
        check_cone(Vec3::new(1.0, 2.0, 3.0), 1.0, Vec3::new(1.0, 2.0, 4.2), 12);
        // Tiny / distant sphere: the Taylor branch.
        check_cone(
            Vec3::new(0.0, 100.0, 0.0),
            1.0,
            Vec3::new(0.5, 0.0, -0.3),
            13,
        );
    }

    #[test]
    fn sphere_inside_sampling_matches_pdf() {
        let center = Vec3::new(0.2, -0.1, 0.3);
        let radius = 1.5;
        let reference = Vec3::new(0.9, 0.2, 0.0);
        let (nt, np) = (8usize, 16usize);
        let samples = 100_000;
        let mut hist = vec![0.0f64; nt * np];
        let mut rng = Rng::new(14);
        for _ in 0..samples {
            let s = sample_sphere_solid_angle(center, radius, reference, rng.vec2()).unwrap();
            assert!(((s.point - center).length() - radius).abs() < 1e-4);
            let d = (s.point - reference).normalize();
            let pdf = sphere_solid_angle_pdf(center, radius, reference, d);
            assert!((pdf - s.pdf).abs() <= 1e-3 * s.pdf, "{pdf} vs {}", s.pdf);
            let theta = d.z.clamp(-1.0, 1.0).acos();
            let phi = d.y.atan2(d.x).rem_euclid(std::f32::consts::TAU);
            let it = ((theta / PI * nt as f32) as usize).min(nt - 1);
            let ip = ((phi / (2.0 * PI) * np as f32) as usize).min(np - 1);
            hist[it * np + ip] += 1.0;
        }
        let sub = 16;
        let mut expected = vec![0.0f64; nt * np];
        let mut total = 0.0;
        for it in 0..nt {
            for ip in 0..np {
                let mut acc = 0.0;
                for a in 0..sub {
                    for b in 0..sub {
                        let theta = (it as f64 + (a as f64 + 0.5) / sub as f64) / nt as f64
                            * std::f64::consts::PI;
                        let phi = (ip as f64 + (b as f64 + 0.5) / sub as f64) / np as f64
                            * std::f64::consts::TAU;
                        let d = Vec3::new(
                            (theta.sin() * phi.cos()) as f32,
                            (theta.sin() * phi.sin()) as f32,
                            theta.cos() as f32,
                        );
                        acc += sphere_solid_angle_pdf(center, radius, reference, d) as f64
                            * theta.sin();
                    }
                }
                let mass = acc / (sub * sub) as f64
                    * (std::f64::consts::PI / nt as f64)
                    * (std::f64::consts::TAU / np as f64);
                total += mass;
                expected[it * np + ip] = mass * samples as f64;
            }
        }
        assert!(
            (total - 1.0).abs() < 2e-3,
            "inside pdf integrates to {total}"
        );
        assert_chi_square("sample_sphere_solid_angle (inside)", &hist, &expected);
    }

    #[test]
    fn sphere_degenerate_input() {
        let u = Vec2::new(0.3, 0.7);
        assert!(sample_sphere_solid_angle(Vec3::ZERO, 0.0, Vec3::X * 3.0, u).is_none());
        assert!(sample_sphere_solid_angle(Vec3::ZERO, f32::NAN, Vec3::X * 3.0, u).is_none());
        assert!(sample_sphere_solid_angle(Vec3::NAN, 1.0, Vec3::X * 3.0, u).is_none());
        assert_eq!(
            sphere_solid_angle_pdf(Vec3::ZERO, -1.0, Vec3::X * 3.0, -Vec3::X),
            0.0
        );
        assert_eq!(
            sphere_solid_angle_pdf(Vec3::ZERO, 1.0, Vec3::X * 3.0, Vec3::ZERO),
            0.0
        );
        // Direction away from the sphere: zero.
        assert_eq!(
            sphere_solid_angle_pdf(Vec3::ZERO, 1.0, Vec3::X * 3.0, Vec3::X),
            0.0
        );
        // Analytic value: sphere of radius 1 at distance 2 subtends cos(theta_max) = sqrt(3)/2.
        let pdf = sphere_solid_angle_pdf(Vec3::ZERO, 1.0, Vec3::X * 2.0, -Vec3::X);
        let expected = 1.0 / (2.0 * PI * (1.0 - 3.0f32.sqrt() / 2.0));
        assert!((pdf - expected).abs() < 1e-4 * expected);
    }
}
