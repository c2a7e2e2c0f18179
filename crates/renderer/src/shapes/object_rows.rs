//! A world-to-object affine transform stored as three rows of four floats: 48 bytes, so that the
//! analytic shapes that need one ([`super::PrimGeom::Disk`], `Cylinder`) keep
//! `PrimGeom` as small as a triangle (an `Affine3A` is 64 bytes).

use glam::{Affine3A, Vec3A, Vec4};

/// The rows of a 3x4 affine matrix.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectRows(pub [Vec4; 3]);

impl ObjectRows {
    pub fn from_affine(a: Affine3A) -> Self {
        let m = a.matrix3;
        let t = a.translation;
        Self([
            Vec4::new(m.x_axis.x, m.y_axis.x, m.z_axis.x, t.x),
            Vec4::new(m.x_axis.y, m.y_axis.y, m.z_axis.y, t.y),
            Vec4::new(m.x_axis.z, m.y_axis.z, m.z_axis.z, t.z),
        ])
    }

    /// The transformed point.
    #[inline(always)]
    pub fn point(&self, p: Vec3A) -> Vec3A {
        let p = p.extend(1.0);
        Vec3A::new(self.0[0].dot(p), self.0[1].dot(p), self.0[2].dot(p))
    }

    /// The transformed direction (no translation).
    #[inline(always)]
    pub fn vector(&self, v: Vec3A) -> Vec3A {
        let v = v.extend(0.0);
        Vec3A::new(self.0[0].dot(v), self.0[1].dot(v), self.0[2].dot(v))
    }

    pub fn is_finite(&self) -> bool {
        self.0.iter().all(|r| r.is_finite())
    }

    /// The inverse transform as an affine map (object to world).
    pub fn inverse_affine(&self) -> Affine3A {
        let r = &self.0;
        let m = glam::Mat3A::from_cols(
            Vec3A::new(r[0].x, r[1].x, r[2].x),
            Vec3A::new(r[0].y, r[1].y, r[2].y),
            Vec3A::new(r[0].z, r[1].z, r[2].z),
        );
        Affine3A::from_mat3_translation(m.into(), Vec3A::new(r[0].w, r[1].w, r[2].w).into())
            .inverse()
    }
}
