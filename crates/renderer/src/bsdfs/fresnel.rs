//! Fresnel reflectance. The torrey course's models use Schlick's approximation throughout.

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
}
