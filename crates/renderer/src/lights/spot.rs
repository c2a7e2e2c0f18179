//! A spot light (Mitsuba's `spot`): a point light whose intensity is full within `beam_width` of
//! its axis and falls linearly in angle to zero at `cutoff_angle`, as Mitsuba's `spot.cpp`,
//! optionally times a texture projected through the cone.

use super::light_bounds::{luminance, DirectionCone, LightBounds};
use super::LightSample;
use crate::textures::Texture;
use glam::{Mat3A, Vec2, Vec3A};
use torrey_fastmath::acos;
use torrey_texture::Footprint;

/// A spot light: position, world-to-light frame, axis intensity and falloff angles.
pub struct SpotLight {
    pub position: Vec3A,
    /// World to light-local directions (the inverse of `to_world`'s linear part): the axis is +z.
    pub world_to_local: Mat3A,
    pub intensity: Vec3A,
    /// Cosines of the angles where the falloff starts and where it reaches zero.
    pub cos_beam: f32,
    pub cos_cutoff: f32,
    pub cutoff: f32,
    /// 1 / (cutoff − beam width) in radians (infinite when they are equal: no ramp).
    pub inv_transition: f32,
    /// Mitsuba's `texture`, multiplying the intensity, looked up at [`SpotLight::texture_uv`].
    pub texture: Option<Box<Texture>>,
    /// tan(cutoff): the cone's edge reaches uv 0 and 1 along the light's x and y axes.
    pub uv_factor: f32,
}

impl SpotLight {
    /// Its bounds for the light tree: a point emitting into the cone of its cutoff angle (its
    /// power overestimated as a point light's, which only shifts the choice).
    pub fn bounds(&self) -> LightBounds {
        let axis = self.world_to_local.inverse() * Vec3A::Z;
        LightBounds::point(
            self.position,
            4.0 * std::f32::consts::PI * luminance(self.intensity),
            DirectionCone {
                w: axis.normalize(),
                cos_theta: self.cos_cutoff,
            },
            0.0,
        )
    }

    /// A spot at `to_world`'s origin shining along its +z; angles in radians.
    pub fn new(
        to_world: glam::Mat4,
        intensity: Vec3A,
        cutoff: f32,
        beam_width: f32,
        texture: Option<Box<Texture>>,
    ) -> Self {
        let linear = Mat3A::from_mat4(to_world);
        Self {
            position: to_world.w_axis.truncate().into(),
            world_to_local: linear.inverse(),
            intensity,
            cos_beam: beam_width.cos(),
            cos_cutoff: cutoff.cos(),
            cutoff,
            inv_transition: 1.0 / (cutoff - beam_width),
            texture,
            uv_factor: cutoff.tan(),
        }
    }

    /// The texture coordinates of a light-local direction (Mitsuba's `direction_to_uv`): the
    /// plane z = 1 mapped so that the cone's edge on the x and y axes lands at 0 and 1.
    #[inline]
    pub fn texture_uv(&self, local: Vec3A) -> Vec2 {
        let scale = 0.5 / (local.z * self.uv_factor);
        Vec2::new(0.5 + local.x * scale, 0.5 + local.y * scale)
    }

    /// The falloff in [0, 1] along a world direction `d` leaving the light.
    #[inline]
    pub fn falloff(&self, d: Vec3A) -> f32 {
        let cos_theta = (self.world_to_local * d).normalize_or_zero().z;
        if cos_theta <= self.cos_cutoff {
            0.0
        } else if cos_theta >= self.cos_beam {
            1.0
        } else {
            ((self.cutoff - acos(cos_theta.clamp(-1.0, 1.0))) * self.inv_transition).clamp(0.0, 1.0)
        }
    }

    /// The connection from `p`: a delta sample, so no MIS; None outside the cone.
    #[inline(always)]
    pub fn sample(&self, p: Vec3A) -> Option<LightSample> {
        let d = self.position - p;
        let dist2 = d.length_squared();
        if dist2 == 0.0 {
            return None;
        }
        let dist = dist2.sqrt();
        let wi = d / dist;
        let falloff = self.falloff(-wi);
        if falloff <= 0.0 {
            return None;
        }
        let mut intensity = self.intensity;
        if let Some(texture) = &self.texture {
            let uv = self.texture_uv(self.world_to_local * -wi);
            intensity *= texture.eval(uv, Footprint::POINT);
        }
        Some(LightSample {
            wi,
            dist,
            radiance: intensity * (falloff / dist2),
            pdf: 1.0,
            is_delta: true,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Mat4, Vec3, Vec4};

    /// Full on the axis and inside the beam, half way down the ramp at the middle angle, dark
    /// beyond the cutoff; the axis follows `to_world`.
    #[test]
    fn falloff_follows_mitsubas_linear_ramp() {
        // Turned half a turn about y (its +z along world -z), at (1, 2, 3).
        let to_world = Mat4::from_cols(
            Vec4::new(-1.0, 0.0, 0.0, 0.0),
            Vec4::Y,
            Vec4::new(0.0, 0.0, -1.0, 0.0),
            Vec4::new(1.0, 2.0, 3.0, 1.0),
        );
        let (cutoff, beam) = (20f32.to_radians(), 10f32.to_radians());
        let spot = SpotLight::new(to_world, Vec3A::ONE, cutoff, beam, None);
        let axis = Vec3A::from(to_world.transform_vector3(Vec3::Z));
        assert!((axis - Vec3A::new(0.0, 0.0, -1.0)).length() < 1e-6);
        let at = |deg: f32| {
            let a = deg.to_radians();
            spot.falloff(Vec3A::new(a.sin(), 0.0, -a.cos()))
        };
        assert_eq!(at(0.0), 1.0);
        assert_eq!(at(9.0), 1.0);
        assert!((at(15.0) - 0.5).abs() < 1e-4, "{}", at(15.0));
        assert!((at(17.5) - 0.25).abs() < 1e-4, "{}", at(17.5));
        assert_eq!(at(21.0), 0.0);
        assert_eq!(at(90.0), 0.0);
        // From a point on the axis 2 units away: intensity / 4.
        let ls = spot.sample(Vec3A::new(1.0, 2.0, 1.0)).expect("in the beam");
        assert!((ls.radiance - Vec3A::splat(0.25)).length() < 1e-6);
        assert!(spot.sample(Vec3A::new(1.0, 2.0, 5.0)).is_none());
    }
}
