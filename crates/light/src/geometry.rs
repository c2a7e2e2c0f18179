//! Sampling helpers for area lights: pure geometry, shared by the renderer's next-event estimation
//! and by its MIS weights (every sampler has a matching pdf).

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Below this sin^2 of the cone half-angle (about 1.5 degrees) the cone is sampled with a Taylor
/// expansion, because `1 - cos(theta_max)` loses all precision in f32 for tiny or distant spheres.
const SMALL_CONE_SIN2: f32 = 0.000_685_23;

/// Uniformly samples a triangle by area: returns barycentrics (b1, b2) of the second and third
/// vertex (b0 = 1 - b1 - b2). Uses Heitz's low-distortion square-to-triangle warp, which keeps
/// stratified samples well spread.
#[inline]
pub fn sample_triangle_uniform(u: Vec2) -> (f32, f32) {
    let (b0, b1);
    if u.x < u.y {
        b0 = u.x * 0.5;
        b1 = u.y - b0;
    } else {
        b1 = u.y * 0.5;
        b0 = u.x - b1;
    }
    let b2 = (1.0 - b0 - b1).max(0.0);
    (b1, b2)
}

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

/// Builds two unit vectors orthogonal to unit `n` (Duff et al.'s branchless basis).
#[inline]
fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
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
        let phi = 2.0 * PI * u.y;
        let normal = Vec3::new(r * phi.cos(), r * phi.sin(), z);
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
        return pdf.is_finite().then_some(SphereSample { point, normal, pdf });
    }

    let dist = dist2.sqrt();
    let w = to_center / dist;
    let sin2_max = radius * radius / dist2;
    let sin_max = sin2_max.sqrt();
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
    let cos_alpha = sin2_theta / sin_max
        + cos_theta * (1.0 - sin2_theta / sin2_max).max(0.0).sqrt();
    let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    let (t1, t2) = orthonormal_basis(w);
    let normal = (-w * cos_alpha + (t1 * phi.cos() + t2 * phi.sin()) * sin_alpha).normalize();
    let point = center + radius * normal;
    let pdf = 1.0 / (2.0 * PI * one_minus_cos_max);
    (pdf.is_finite() && normal.is_finite()).then_some(SphereSample { point, normal, pdf })
}

/// Density over solid angle at `reference` of [`sample_sphere_solid_angle`] producing `direction`
/// (need not be normalised). 0 when the direction misses the sphere.
pub fn sphere_solid_angle_pdf(center: Vec3, radius: f32, reference: Vec3, direction: Vec3) -> f32 {
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
    // Inside the cone iff 1 - cos(angle to axis) <= 1 - cos(theta_max); computed via the chord so
    // tiny cones keep their precision: 1 - cos = |d - w|^2 / 2.
    let w = to_center / dist2.sqrt();
    let one_minus_cos = 0.5 * (d - w).length_squared();
    if one_minus_cos > one_minus_cos_max * (1.0 + 1e-4) {
        return 0.0;
    }
    1.0 / (2.0 * PI * one_minus_cos_max)
}
