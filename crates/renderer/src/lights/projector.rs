//! A projector (Mitsuba's `projector`): a pinhole that projects an irradiance texture into the
//! scene, the reciprocal of the perspective camera (same fov conventions, image plane at z = 1
//! along its +z, +x of camera space to the image's left). As Mitsuba's `projector.cpp`, a point
//! whose projection (u, v) falls inside [0, 1]^2 receives pi x scale x irradiance(u, v) /
//! (z^2 cos), z its depth in the projector's frame and cos = the projector's (unnormalised)
//! +z axis dotted with the direction from the projector to the point: so a constant texture
//! projected onto the plane z = 1 gives it a constant irradiance. A delta-position light.

use super::light_bounds::{luminance, DirectionCone, LightBounds};
use super::LightSample;
use crate::textures::{ColorSource, Texture};
use glam::{Mat4, Vec2, Vec3A};
use std::f32::consts::PI;
use torrey_texture::Footprint;

/// A projector light.
pub struct ProjectorLight {
    position: Vec3A,
    /// World to projector space (the inverse of `to_world`).
    to_local: Mat4,
    /// `to_world` applied to +z (not normalised, as Mitsuba's).
    axis: Vec3A,
    irradiance: ColorSource,
    scale: f32,
    /// tan of half the field of view along x and along y.
    tan_half: Vec2,
}

impl ProjectorLight {
    /// Its bounds for the light tree: a point emitting into its half space (power from the
    /// irradiance's scale, a texture counted as 1).
    pub fn bounds(&self) -> LightBounds {
        let irradiance = match self.irradiance {
            ColorSource::Constant(c) => luminance(c),
            ColorSource::Texture(_) => 1.0,
        };
        LightBounds::point(
            self.position,
            4.0 * std::f32::consts::PI * self.scale * irradiance,
            DirectionCone {
                w: self.axis.normalize(),
                cos_theta: 0.0,
            },
            0.0,
        )
    }

    /// `tan_half_x`: tan of half the horizontal field of view; `aspect`: the irradiance texture's
    /// width / height (1 for a constant).
    pub fn new(
        to_world: Mat4,
        irradiance: ColorSource,
        scale: f32,
        tan_half_x: f32,
        aspect: f32,
    ) -> Self {
        Self {
            position: to_world.transform_point3(glam::Vec3::ZERO).into(),
            to_local: to_world.inverse(),
            axis: to_world.transform_vector3(glam::Vec3::Z).into(),
            irradiance,
            scale,
            tan_half: Vec2::new(tan_half_x, tan_half_x / aspect),
        }
    }

    /// The projector's image coordinates of world point `p`, if it lies in front of it and
    /// inside the image; with its depth z.
    #[inline]
    pub fn project(&self, p: Vec3A) -> Option<(Vec2, f32)> {
        let local = self.to_local.transform_point3(p.into());
        if local.z.is_nan() || local.z <= 0.0 {
            return None;
        }
        let uv = Vec2::new(
            0.5 - 0.5 * local.x / (local.z * self.tan_half.x),
            0.5 - 0.5 * local.y / (local.z * self.tan_half.y),
        );
        (uv.cmpge(Vec2::ZERO).all() && uv.cmple(Vec2::ONE).all()).then_some((uv, local.z))
    }

    /// The connection from `p`: a delta sample, so no MIS.
    #[inline]
    pub fn sample(&self, p: Vec3A, textures: &[Texture]) -> Option<LightSample> {
        let (uv, z) = self.project(p)?;
        let d = self.position - p;
        let dist = d.length();
        if dist.is_nan() || dist <= 0.0 {
            return None;
        }
        let wi = d / dist;
        let cos = -self.axis.dot(wi);
        if cos.is_nan() || cos <= 0.0 {
            return None;
        }
        let irradiance = self.irradiance.eval(textures, uv, Footprint::POINT);
        Some(LightSample {
            wi,
            dist,
            radiance: irradiance * (PI * self.scale / (z * z * cos)),
            pdf: 1.0,
            is_delta: true,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Vec3, Vec4};

    /// A constant projector gives the plane z = 1 in front of it the same irradiance everywhere
    /// (pi x scale x irradiance), only inside its field of view; the image's left is camera +x.
    #[test]
    fn constant_irradiance_is_constant_on_the_unit_plane() {
        // Turned half a turn about y (its +z along world -z), at (1, 2, 3).
        let to_world = Mat4::from_cols(
            Vec4::new(-1.0, 0.0, 0.0, 0.0),
            Vec4::Y,
            Vec4::new(0.0, 0.0, -1.0, 0.0),
            Vec4::new(1.0, 2.0, 3.0, 1.0),
        );
        let tan_x = (30f32.to_radians()).tan();
        let proj =
            ProjectorLight::new(to_world, ColorSource::Constant(Vec3A::ONE), 2.0, tan_x, 2.0);
        for (x, y) in [(0.0, 0.0), (0.4, 0.1), (-0.5, -0.25)] {
            let p = Vec3A::from(to_world.transform_point3(Vec3::new(x, y, 1.0)));
            let ls = proj.sample(p, &[]).expect("inside the image");
            // Irradiance on the plane (normal along the projector's axis): radiance x cos.
            let cos = (1.0 + x * x + y * y).sqrt().recip();
            let e = ls.radiance.x * cos;
            assert!((e - 2.0 * PI).abs() < 1e-4 * e, "({x}, {y}): {e}");
        }
        // Outside the field of view (tan 30 deg = 0.577 along x, half that along y), behind.
        let at =
            |x: f32, y: f32, z: f32| Vec3A::from(to_world.transform_point3(Vec3::new(x, y, z)));
        assert!(proj.sample(at(0.6, 0.0, 1.0), &[]).is_none());
        assert!(proj.sample(at(0.0, 0.3, 1.0), &[]).is_none());
        assert!(proj.sample(at(0.0, 0.0, -1.0), &[]).is_none());
        // Camera +x is the image's left: u below one half.
        let (uv, _) = proj.project(at(0.3, 0.1, 1.0)).unwrap();
        assert!(uv.x < 0.5 && uv.y < 0.5, "{uv}");
    }
}
