//! The scene's lights from their descriptions (area lights are made with their shapes, in
//! [`super::build_shapes`]).

use super::build::BuildError;
use super::build_textures::{build_texture, load_bitmap_image};
use crate::cameras::PerspectiveCamera;
use crate::lights::{
    ConstantLight, DirectionalLight, EnvLight, Light, PointLight, ProjectorLight, SpotLight,
};
use crate::textures::{ColorSource, Texture};
use glam::{Mat3, Mat4, Vec3A};
use torrey_light::EnvMap;
use torrey_parser as desc;

/// The light of `light` (a light of `scene`, whose textures are built as `textures`); None for
/// one that emits nothing (a black background would only waste light samples).
pub(super) fn build_light(
    light: &desc::Light,
    scene: &desc::Scene,
    textures: &[Texture],
    warnings: &mut Vec<String>,
) -> Result<Option<Light>, BuildError> {
    Ok(Some(match light {
        desc::Light::Point {
            position,
            intensity,
        } => Light::Point(PointLight {
            position: (*position).into(),
            intensity: (*intensity).into(),
        }),
        desc::Light::Spot {
            to_world,
            intensity,
            cutoff_angle,
            beam_width,
            texture,
        } => {
            // The light keeps its own copy: lights are sampled without the scene's
            // texture list at hand.
            let texture = texture
                .map(|t| build_texture(&scene.textures[t], warnings).map(Box::new))
                .transpose()?;
            Light::Spot(SpotLight::new(
                *to_world,
                (*intensity).into(),
                *cutoff_angle,
                *beam_width,
                texture,
            ))
        }
        desc::Light::Directional {
            direction,
            irradiance,
        } => Light::Directional(DirectionalLight {
            to_light: -Vec3A::from(*direction),
            irradiance: (*irradiance).into(),
        }),
        // A black background emits nothing: keeping it would only waste light samples.
        desc::Light::Constant { radiance } if radiance.max_element() <= 0.0 => return Ok(None),
        desc::Light::Constant { radiance } => Light::Constant(ConstantLight {
            radiance: (*radiance).into(),
        }),
        desc::Light::Projector {
            to_world,
            irradiance,
            scale,
            fov_degrees,
            fov_axis,
        } => {
            let (irradiance, (w, h)) = match irradiance {
                desc::ColorParam::Constant(c) => (ColorSource::Constant((*c).into()), (1, 1)),
                desc::ColorParam::Texture(t) => (
                    ColorSource::Texture(*t as u32),
                    match &textures[*t] {
                        Texture::Bitmap(b) => (b.mip().width(), b.mip().height()),
                        _ => (1, 1),
                    },
                ),
            };
            // The field of view as a perspective camera of the texture's size has it.
            let camera = PerspectiveCamera::new(Mat4::IDENTITY, *fov_degrees, *fov_axis, w, h);
            Light::Projector(ProjectorLight::new(
                *to_world,
                irradiance,
                *scale,
                camera.tan_half_x(),
                w as f32 / h as f32,
            ))
        }
        desc::Light::Envmap {
            bitmap,
            scale,
            to_world,
        } => {
            let (image, _) = load_bitmap_image(bitmap, warnings)?;
            let rotation = Mat3::from_mat4(*to_world);
            Light::Env(Box::new(EnvLight {
                map: EnvMap::new(image, *scale, rotation),
            }))
        }
    }))
}
