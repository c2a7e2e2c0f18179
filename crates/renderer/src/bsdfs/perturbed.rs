//! What Mitsuba 3's `normalmap` and `bumpmap` adapters add to the BSDF they wrap, once the
//! shading frame is tilted (crates/renderer/src/scene/perturb.rs builds the frame): a direction
//! must lie on the same side of the tilted and the unperturbed normal, else the BSDF is 0 there
//! (and a sample in it is dropped); and f is scaled by Estevez et al.'s microfacet shadowing
//! term ("A Microfacet-Based Shadowing Function to Solve the Bump Terminator Problem", Ray
//! Tracing Gems 2019), which softens the terminator. The pdf is the nested BSDF's (zero on the
//! wrong side), as in Mitsuba.

use glam::Vec3A;

/// The adapter at a hit, in the local coordinates of the tilted frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Perturbation {
    /// The unperturbed shading normal, in the tilted frame's local coordinates.
    pub n0: Vec3A,
    /// α² = min(tan²θ_p / 8, 1) of the tilt θ_p; 0 without the shadowing term (which is then 1).
    pub alpha2: f32,
}

impl Perturbation {
    /// The shadowing term's α² for a tilted normal `n` given relative to the unperturbed frame.
    pub fn alpha2_of(n: Vec3A) -> f32 {
        let c2 = n.z * n.z;
        let tan2 = (1.0 - c2).max(0.0) / c2;
        if tan2.is_nan() {
            1.0
        } else {
            (0.125 * tan2).min(1.0)
        }
    }

    /// Whether `w` (local, unit) lies on the same side of both normals.
    #[inline]
    pub fn same_side(&self, w: Vec3A) -> bool {
        self.n0.dot(w) * w.z > 0.0
    }

    /// The factor on f towards `w` (local, unit): 0 on the wrong side, else the shadowing term
    /// 2 / (1 + √(1 + α² tan²θ0)) with θ0 the angle to the unperturbed normal.
    #[inline]
    pub fn factor(&self, w: Vec3A) -> f32 {
        let c = self.n0.dot(w);
        if !(c * w.z > 0.0) {
            return 0.0;
        }
        if self.alpha2 == 0.0 {
            return 1.0;
        }
        let c2 = c * c;
        let tan2 = (1.0 - c2).max(0.0) / c2;
        2.0 / (1.0 + (1.0 + self.alpha2 * tan2).sqrt())
    }
}
