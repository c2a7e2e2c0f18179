//! Textures as the renderer evaluates them at a hit: bitmaps (filtered over the ray cone's
//! anisotropic footprint) and Mitsuba's procedural checkerboard; and the textured parameters of
//! materials ([`ColorSource`], [`FloatSource`]), resolved at a hit through a [`TextureQuery`].

use glam::{Affine2, Vec2, Vec3A};
use torrey_texture::{BitmapTexture, Footprint};

/// A texture of the scene.
pub enum Texture {
    Bitmap(BitmapTexture),
    Checkerboard {
        color0: Vec3A,
        color1: Vec3A,
        to_uv: Affine2,
    },
}

impl Texture {
    /// Value at `uv` filtered over `footprint`, an ellipse in the surface's uv units. Out of
    /// line: a lookup is dozens of operations anyway, and inlined into every textured parameter
    /// of every BSDF it bloated the path loop (cbox, which has no textures, ran 9% more
    /// instructions).
    #[inline(never)]
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

impl Texture {
    /// The value of a float parameter at `uv`: a bitmap's first channel; for the checkerboard,
    /// the colours swapped, as Mitsuba 3's `eval_1` selects them (its `eval` puts color0 where
    /// both fractional parts lie on the same side of one half, its `eval_1` where they do not).
    #[inline]
    pub fn eval_1(&self, uv: Vec2, footprint: Footprint) -> f32 {
        match self {
            Texture::Checkerboard {
                color0,
                color1,
                to_uv,
            } => {
                let p = to_uv.transform_point2(uv);
                let fx = p.x - p.x.floor() > 0.5;
                let fy = p.y - p.y.floor() > 0.5;
                if fx != fy {
                    color0.x
                } else {
                    color1.x
                }
            }
            _ => self.eval(uv, footprint).x,
        }
    }
}

impl Texture {
    /// The uv gradient of the float value (Mitsuba's `eval_1_grad`, which `bumpmap` reads): a
    /// bitmap's luminance, bilinearly interpolated at full resolution; zero for the
    /// checkerboard, which is piecewise constant.
    pub fn eval_1_grad(&self, uv: Vec2) -> Vec2 {
        match self {
            Texture::Bitmap(b) => b.eval_1_grad(uv),
            Texture::Checkerboard { .. } => Vec2::ZERO,
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

/// A float parameter resolved for rendering: a constant or an index into the scene's textures
/// (read by [`Texture::eval_1`]).
#[derive(Clone, Copy, Debug)]
pub enum FloatSource {
    Constant(f32),
    Texture(u32),
}

impl FloatSource {
    #[inline]
    pub fn eval(&self, textures: &[Texture], uv: Vec2, footprint: Footprint) -> f32 {
        match *self {
            FloatSource::Constant(c) => c,
            FloatSource::Texture(i) => textures[i as usize].eval_1(uv, footprint),
        }
    }

    /// Whether evaluating it reads a texture.
    pub fn is_textured(&self) -> bool {
        matches!(self, FloatSource::Texture(_))
    }
}

impl ColorSource {
    /// Whether evaluating it reads a texture.
    pub fn is_textured(&self) -> bool {
        matches!(self, ColorSource::Texture(_))
    }
}

/// Where and how wide textures are looked up at a hit: what a material needs to resolve its
/// textured parameters into a per-hit BSDF.
#[derive(Clone, Copy)]
pub struct TextureQuery<'a> {
    pub textures: &'a [Texture],
    pub uv: Vec2,
    /// The filter's footprint, an ellipse in the surface's uv units ([`Footprint::POINT`]: the
    /// finest level, bilinear).
    pub footprint: Footprint,
}

impl TextureQuery<'_> {
    #[inline(always)]
    pub fn color(&self, c: ColorSource) -> Vec3A {
        c.eval(self.textures, self.uv, self.footprint)
    }

    #[inline(always)]
    pub fn float(&self, f: FloatSource) -> f32 {
        f.eval(self.textures, self.uv, self.footprint)
    }
}
