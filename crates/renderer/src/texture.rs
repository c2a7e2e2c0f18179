//! Colour sources as the renderer evaluates them at a hit: constants, bitmaps (filtered over the
//! ray cone's anisotropic footprint) and Mitsuba's procedural checkerboard.

use glam::{Affine2, Vec2, Vec3A};
use torrey_texture::{BitmapTexture, Footprint};

pub enum Texture {
    Bitmap(BitmapTexture),
    Checkerboard {
        color0: Vec3A,
        color1: Vec3A,
        to_uv: Affine2,
    },
}

impl Texture {
    /// Value at `uv` filtered over `footprint`, an ellipse in the surface's uv units.
    #[inline]
    pub fn eval(&self, uv: Vec2, footprint: Footprint) -> Vec3A {
        match self {
            Texture::Bitmap(b) => b.eval(uv, footprint).into(),
            Texture::Checkerboard {
                color0,
                color1,
                to_uv,
            } => {
                let p = to_uv.transform_point2(uv);
                // Mitsuba's checkerboard: each unit uv square holds 2x2 checks; colour 0 where
                // both fractional parts lie on the same side of one half.
                let fx = p.x - p.x.floor() > 0.5;
                let fy = p.y - p.y.floor() > 0.5;
                if fx == fy {
                    *color0
                } else {
                    *color1
                }
            }
        }
    }
}

/// A colour parameter resolved for rendering: a constant or an index into the scene's textures.
#[derive(Clone, Copy, Debug)]
pub enum ColorSource {
    Constant(Vec3A),
    Texture(u32),
}

impl ColorSource {
    #[inline]
    pub fn eval(&self, textures: &[Texture], uv: Vec2, footprint: Footprint) -> Vec3A {
        match *self {
            ColorSource::Constant(c) => c,
            ColorSource::Texture(i) => textures[i as usize].eval(uv, footprint),
        }
    }
}
