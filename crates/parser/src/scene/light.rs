//! Lights.

use super::{Bitmap, ColorParam, FovAxis, TextureId};
use glam::{Mat4, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// Radiant intensity in W/sr.
    Point { position: Vec3, intensity: Vec3 },
    /// Constant radiance from every direction (torrey's `<background>`, Mitsuba's `constant`).
    Constant { radiance: Vec3 },
    /// A light at infinity (Mitsuba's `directional`): `irradiance` (W/m²) on a surface facing
    /// it, arriving along the unit `direction` the light travels.
    Directional { direction: Vec3, irradiance: Vec3 },
    /// Mitsuba's `spot`: a point light at the origin of `to_world` shining along its +z with
    /// radiant `intensity` (W/sr) on the axis, full out to `beam_width` and falling linearly in
    /// angle to zero at `cutoff_angle` (both radians).
    Spot {
        to_world: Mat4,
        intensity: Vec3,
        cutoff_angle: f32,
        beam_width: f32,
        /// Mitsuba's `texture`: projected through the cone, multiplying the intensity; uv
        /// (0.5 + x / (2 z tan(cutoff)), 0.5 + y / (2 z tan(cutoff))) of the light-local direction.
        texture: Option<TextureId>,
    },
    /// Lat-long environment map in Mitsuba 3's orientation, rotated by `to_world`.
    Envmap {
        bitmap: Bitmap,
        scale: f32,
        to_world: Mat4,
    },
    /// Mitsuba's `projector`: a pinhole at `to_world`'s origin projecting `irradiance` along its
    /// +z, the field of view given as a perspective camera's (`fov_degrees` along `fov_axis` of
    /// the irradiance texture's image), times `scale`.
    Projector {
        to_world: Mat4,
        irradiance: ColorParam,
        scale: f32,
        fov_degrees: f32,
        fov_axis: FovAxis,
    },
}
