//! Textures, and the colours that may be textured.

use super::{SourceLocation, TextureId};
use glam::{Affine2, Vec3};
use std::path::PathBuf;

/// A colour that may be a constant or come from a texture.
#[derive(Clone, Debug, PartialEq)]
pub enum ColorParam {
    Constant(Vec3),
    Texture(TextureId),
}

#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    pub id: Option<String>,
    pub kind: TextureKind,
}

#[derive(Clone, Debug, PartialEq)]
pub enum TextureKind {
    Bitmap(Bitmap),
    /// Mitsuba's checkerboard: color0 where floor(u') + floor(v') is even, else color1.
    Checkerboard {
        color0: Vec3,
        color1: Vec3,
        to_uv: Affine2,
    },
    /// Mitsuba's `mesh_attribute`: the attribute `name` (`vertex_...`, interpolated with the
    /// hit's barycentrics, or `face_...`, constant per face) of the mesh it is evaluated on,
    /// times `scale`. One channel is read as grey.
    MeshAttribute {
        name: String,
        scale: f32,
        location: SourceLocation,
    },
    /// Mitsuba's `rawconstant`: `value` returned as it is, without colour conversion or range
    /// checks (negative values too); one channel (`<float>`) is read as grey, three
    /// (`<vector>`) cannot be read as a float parameter. Where a bsdf or an emitter reads it,
    /// the parser puts the value in place as a [`ColorParam::Constant`].
    RawConstant {
        value: Vec3,
        channels: u8,
    },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Bitmap {
    /// Absolute (resolved) path of the image.
    pub filename: PathBuf,
    /// Texture-coordinate transform: uv' = to_uv(uv). torrey's uscale/vscale/uoffset/voffset
    /// give `Affine2::from_scale_angle_translation((uscale, vscale), 0, (uoffset, voffset))`;
    /// Mitsuba 3's `to_uv` transform maps directly.
    pub to_uv: Affine2,
    /// Do not sRGB-decode 8-bit images (normal maps are always raw).
    pub raw: bool,
    pub filter: FilterType,
    pub wrap: WrapMode,
    /// Where the `filename` parameter was given, so that an image that fails to decode at render
    /// time is reported at its place in the scene file.
    pub location: SourceLocation,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilterType {
    Bilinear,
    Nearest,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WrapMode {
    Repeat,
    Mirror,
    Clamp,
}
