//! Fresnel reflectance. The torrey course's models use Schlick's approximation throughout;
//! Mitsuba's models use the exact equations for unpolarised light (dielectric and conductor)
//! and the fitted diffuse Fresnel reflectance.

use glam::Vec3A;

/// Schlick's approximation of Fresnel reflectance, F0 + (1 − F0)(1 − cos θ)^5, the course's
/// choice for every model (cos θ clamped to [0, 1]).
pub fn schlick_fresnel(f0: Vec3A, cos_theta: f32) -> Vec3A {
    f0 + (Vec3A::ONE - f0) * schlick_weight(cos_theta)
}

/// (1 − cos θ)^5, the angular part of [`schlick_fresnel`], shared with the scalar (plastic) form.
pub fn schlick_weight(cos_theta: f32) -> f32 {
    let m = (1.0 - cos_theta).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// Schlick's F0 of a dielectric interface with relative index of refraction `eta`:
/// ((η − 1) / (η + 1))².
pub fn schlick_f0(eta: f32) -> f32 {
    let r = (eta - 1.0) / (eta + 1.0);
    r * r
}

/// Exact Fresnel reflectance of a dielectric interface for unpolarised light, as Mitsuba's
/// `fresnel`: `eta` = η_int / η_ext and `cos_i` the cosine of the incident direction with the
/// normal (negative: arriving from inside). Returns (R, cos θt, η_it, η_ti): cos θt carries the
/// sign of the side the refracted ray leaves to (opposite to `cos_i`), R = 1 under total
/// internal reflection, η_it = η_t/η_i the relative IOR across the interface and η_ti its
/// inverse.
#[inline]
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> (f32, f32, f32, f32) {
    let outside = cos_i >= 0.0;
    let (eta_it, eta_ti) = if outside {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    let cos_t_sqr = 1.0 - eta_ti * eta_ti * (1.0 - cos_i * cos_i);
    let ci = cos_i.abs();
    let ct = cos_t_sqr.max(0.0).sqrt();
    let r = if eta == 1.0 {
        0.0
    } else if ci == 0.0 || cos_t_sqr <= 0.0 {
        1.0
    } else {
        let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
        let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
        0.5 * (a_s * a_s + a_p * a_p)
    };
    let cos_t = if outside { -ct } else { ct };
    (r, cos_t, eta_it, eta_ti)
}

/// Refraction of `w` (pointing away from the surface) through a surface with normal `m`, given
/// the cos θt and η_ti that [`fresnel_dielectric`] returned for `w·m` (Mitsuba's `refract`).
#[inline]
pub fn refract(w: Vec3A, m: Vec3A, cos_t: f32, eta_ti: f32) -> Vec3A {
    m * (w.dot(m) * eta_ti + cos_t) - w * eta_ti
}

/// Exact Fresnel reflectance of a conductor (complex IOR η + ik, relative to the outside) for
/// unpolarised light, one channel.
#[inline]
fn fresnel_conductor1(cos_i: f32, eta: f32, k: f32) -> f32 {
    let c2 = cos_i * cos_i;
    let s2 = 1.0 - c2;
    let s4 = s2 * s2;
    let t1 = eta * eta - k * k - s2;
    let a2pb2 = (t1 * t1 + 4.0 * k * k * eta * eta).max(0.0).sqrt();
    let a = (0.5 * (a2pb2 + t1)).max(0.0).sqrt();
    let term1 = a2pb2 + c2;
    let term2 = 2.0 * cos_i * a;
    let rs = (term1 - term2) / (term1 + term2);
    let term3 = a2pb2 * c2 + s4;
    let term4 = term2 * s2;
    let rp = rs * (term3 - term4) / (term3 + term4);
    let r = 0.5 * (rs + rp);
    if r.is_finite() {
        r
    } else {
        1.0
    }
}

/// [`fresnel_conductor1`] per colour channel (`cos_i` in [0, 1]).
#[inline]
pub fn fresnel_conductor(cos_i: f32, eta: Vec3A, k: Vec3A) -> Vec3A {
    let c = cos_i.clamp(0.0, 1.0);
    Vec3A::new(
        fresnel_conductor1(c, eta.x, k.x),
        fresnel_conductor1(c, eta.y, k.y),
        fresnel_conductor1(c, eta.z, k.z),
    )
}

/// The fraction of diffuse (cosine-distributed) light reflected by a dielectric interface of
/// relative IOR `eta`, Mitsuba's `fresnel_diffuse_reflectance`: Egan and Hilgeman's fit for
/// η < 1, d'Eon and Irving's polynomial in 1/η otherwise.
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    let inv = 1.0 / eta;
    if eta < 1.0 {
        0.0636 * inv + eta * (eta * -1.4399 + 0.7099) + 0.6681
    } else {
        let c = [0.919317, -3.4793, 6.75335, -7.80989, 4.98554, -1.36881f32];
        c.iter().rev().fold(0.0, |acc, &ci| acc * inv + ci)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn schlick_values() {
        let f0 = Vec3A::splat(0.04);
        assert_eq!(schlick_fresnel(f0, 1.0), f0);
        assert!((schlick_fresnel(f0, 0.0) - Vec3A::ONE).abs().max_element() < 1e-7);
        assert!((schlick_f0(1.5) - 0.04).abs() < 1e-7);
        // Clamped outside [0, 1].
        assert_eq!(schlick_weight(-0.5), 1.0);
        assert_eq!(schlick_weight(1.5), 0.0);
    }

    #[test]
    fn exact_dielectric_and_conductor() {
        // Normal incidence: ((η−1)/(η+1))², from either side; grazing: 1.
        let (r, ct, eta_it, eta_ti) = fresnel_dielectric(1.0, 1.5);
        assert!((r - 0.04).abs() < 1e-6 && (ct + 1.0).abs() < 1e-6);
        assert_eq!((eta_it, eta_ti), (1.5, 1.0 / 1.5));
        let (r, ct, eta_it, _) = fresnel_dielectric(-1.0, 1.5);
        assert!((r - 0.04).abs() < 1e-6 && (ct - 1.0).abs() < 1e-6 && eta_it == 1.0 / 1.5);
        // Total internal reflection beyond the critical angle (sin θc = 1/1.5).
        assert_eq!(fresnel_dielectric(-0.5, 1.5).0, 1.0);
        assert!(fresnel_dielectric(-0.9, 1.5).0 < 1.0);
        // Brewster's angle: tan θ = η, R = Rs/2.
        let cb = (1.0f32 / (1.0 + 1.5 * 1.5)).sqrt();
        let (r, ..) = fresnel_dielectric(cb, 1.5);
        assert!((r - 0.5 * 0.1479).abs() < 1e-3, "{r}");
        // Snell: refracted direction has sin θt = sin θi / η.
        let w = Vec3A::new(0.6, 0.0, 0.8);
        let (_, ct, _, eta_ti) = fresnel_dielectric(w.z, 1.5);
        let t = refract(w, Vec3A::Z, ct, eta_ti);
        assert!((t.length() - 1.0).abs() < 1e-5 && (t.x + 0.4).abs() < 1e-6 && t.z < 0.0);
        // A conductor with k = 0 is a dielectric; η = 0, k = 1 is a perfect mirror.
        let f = fresnel_conductor(0.7, Vec3A::splat(1.5), Vec3A::ZERO);
        assert!((f.x - fresnel_dielectric(0.7, 1.5).0).abs() < 1e-5, "{f}");
        let f = fresnel_conductor(0.3, Vec3A::ZERO, Vec3A::ONE);
        assert!((f - Vec3A::ONE).abs().max_element() < 1e-5, "{f}");
        // Diffuse Fresnel reflectance of η = 1.5: about 0.092 outside, 0.596 inside.
        assert!((fresnel_diffuse_reflectance(1.5) - 0.0918).abs() < 2e-3);
        assert!((fresnel_diffuse_reflectance(1.0 / 1.5) - 0.596).abs() < 5e-3);
    }
}
