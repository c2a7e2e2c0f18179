//! The camera and the textures of a scene from their descriptions (bitmaps loaded and
//! mip-mapped), and the texture of a textured area emitter.

use super::build::BuildError;
use crate::cameras::{Camera, OrthographicCamera, PerspectiveCamera, ThinLensCamera};
use crate::lights::{EmissionTexture, TexelDistribution, UvMap};
use crate::shapes::{PrimInfo, ShapeKind};
use crate::textures::Texture;
use glam::Mat3;
use torrey_parser as desc;
use torrey_texture::{BitmapTexture, MipMap};

/// The camera of the scene for a `width` x `height` film. Its transform must be finite and
/// invertible: a degenerate one (a zero scale, say) maps every pixel to the same non-finite ray.
pub(super) fn build_camera(
    c: &desc::Camera,
    width: u32,
    height: u32,
) -> Result<Camera, BuildError> {
    let linear = Mat3::from_mat4(c.to_world);
    let det = linear.determinant();
    if !(c.to_world.is_finite() && det.is_finite() && det != 0.0) {
        return Err(BuildError::Other(
            "error: the camera's transform is degenerate (zero scale, or non-finite)".into(),
        ));
    }
    if !(c.fov_degrees.is_finite() && c.fov_degrees > 0.0 && c.fov_degrees < 180.0) {
        return Err(BuildError::Other(format!(
            "error: the camera's field of view must be in (0, 180) degrees, found {}",
            c.fov_degrees
        )));
    }
    let pinhole = PerspectiveCamera::new(c.to_world, c.fov_degrees, c.fov_axis, width, height)
        .with_clip(c.near_clip, c.far_clip);
    Ok(match c.kind {
        desc::CameraKind::ThinLens {
            aperture_radius,
            focus_distance,
        } => Camera::ThinLens(ThinLensCamera::new(
            pinhole,
            aperture_radius,
            focus_distance,
        )),
        desc::CameraKind::Orthographic => Camera::Orthographic(
            OrthographicCamera::new(c.to_world, c.near_clip, width, height)
                .with_far_clip(c.far_clip),
        ),
        // Mitsuba's thinlens has no principal point offset; its perspective camera does.
        desc::CameraKind::Perspective => {
            Camera::Perspective(pinhole.with_principal_point(c.principal_point_offset))
        }
    })
}

/// A bitmap's image, with its 8-bit codes when the file stores them (a pyramid keeps its finest
/// level as those).
pub(super) fn load_bitmap_image(
    bitmap: &desc::Bitmap,
    warnings: &mut Vec<String>,
) -> Result<(torrey_texture::Image, Option<torrey_texture::Codes8>), BuildError> {
    let loaded = torrey_texture::load_image(&bitmap.filename, bitmap.raw).map_err(|e| {
        BuildError::Texture {
            location: bitmap.location.to_string(),
            message: e.to_string(),
        }
    })?;
    warnings.extend(loaded.warnings);
    Ok((loaded.image, loaded.codes))
}

/// A texture of the scene from its description, its bitmap loaded and mip-mapped.
/// A textured area emitter's radiance: texture `index`, sampled by its luminance where Mitsuba
/// inverts the shape's uv map (a bitmap without a uv transform on a rectangle or a sphere).
pub(super) fn emission_texture(
    index: u32,
    textures: &[Texture],
    shape: &desc::Shape,
    kind: &ShapeKind,
    prims: &[PrimInfo],
) -> EmissionTexture {
    let map = match (&shape.geometry, kind) {
        (desc::Geometry::Rectangle, _) => prims.first().map(|prim| UvMap::Rectangle {
            origin: shape.to_world.transform_point3(glam::Vec3::ZERO).into(),
            ax: shape.to_world.transform_vector3(glam::Vec3::X).into(),
            ay: shape.to_world.transform_vector3(glam::Vec3::Y).into(),
            normal: prim.ng,
        }),
        (_, ShapeKind::Sphere(sphere)) => Some(UvMap::Sphere {
            center: sphere.center,
            radius: sphere.radius,
            to_world: sphere.to_object.transpose(),
        }),
        (_, ShapeKind::Disk(disk)) => Some(UvMap::Disk(Box::new(*disk))),
        (_, ShapeKind::Cylinder(cylinder)) => Some(UvMap::Cylinder(Box::new(*cylinder))),
        _ => None,
    };
    let sampling = match (&textures[index as usize], map) {
        (Texture::Bitmap(b), Some(map)) if b.to_uv() == glam::Affine2::IDENTITY => {
            TexelDistribution::new(&b.mip().level(0)).map(|d| (d, map))
        }
        _ => None,
    };
    EmissionTexture {
        texture: index,
        sampling,
    }
}

/// Every texture of a scene, in its order, built in parallel (decoding a JPEG and building its
/// mip-map take tens of milliseconds each); their warnings in that order too.
pub(super) fn build_textures(
    textures: &[desc::Texture],
    warnings: &mut Vec<String>,
) -> Result<Vec<Texture>, BuildError> {
    use rayon::prelude::*;
    let built: Vec<_> = textures
        .par_iter()
        .map(|t| {
            let mut own = Vec::new();
            (build_texture(t, &mut own), own)
        })
        .collect();
    let mut out = Vec::with_capacity(built.len());
    for (texture, own) in built {
        warnings.extend(own);
        out.push(texture?);
    }
    Ok(out)
}

pub(super) fn build_texture(
    t: &desc::Texture,
    warnings: &mut Vec<String>,
) -> Result<Texture, BuildError> {
    Ok(match &t.kind {
        desc::TextureKind::Bitmap(bitmap) => {
            let (image, codes) = load_bitmap_image(bitmap, warnings)?;
            let wrap = match bitmap.wrap {
                desc::WrapMode::Repeat => torrey_texture::WrapMode::Repeat,
                desc::WrapMode::Mirror => torrey_texture::WrapMode::Mirror,
                desc::WrapMode::Clamp => torrey_texture::WrapMode::Clamp,
            };
            let filter = match bitmap.filter {
                desc::FilterType::Bilinear => torrey_texture::FilterType::Bilinear,
                desc::FilterType::Nearest => torrey_texture::FilterType::Nearest,
            };
            Texture::Bitmap(BitmapTexture::with_codes(
                MipMap::new(image, wrap, filter),
                bitmap.to_uv,
                codes,
            ))
        }
        desc::TextureKind::Checkerboard {
            color0,
            color1,
            to_uv,
        } => Texture::Checkerboard {
            color0: (*color0).into(),
            color1: (*color1).into(),
            to_uv: *to_uv,
        },
        // Its table of shapes is filled once the shapes are built.
        desc::TextureKind::MeshAttribute { scale, .. } => Texture::MeshAttribute {
            by_shape: Vec::new(),
            scale: *scale,
        },
        // Where a bsdf or an emitter reads a rawconstant, the parser put its value in place;
        // as a texture of its own (a bump map's heights, say) it is a constant: a checkerboard
        // of one colour (no gradient, as Mitsuba's constant).
        desc::TextureKind::RawConstant { value, .. } => Texture::Checkerboard {
            color0: (*value).into(),
            color1: (*value).into(),
            to_uv: glam::Affine2::IDENTITY,
        },
    })
}
