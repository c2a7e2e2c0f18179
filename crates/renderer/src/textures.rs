//! Textures as the renderer evaluates them at a hit: bitmaps (filtered over the ray cone's
//! anisotropic footprint), Mitsuba's procedural checkerboard and mesh attributes; and the
//! textured parameters of materials ([`ColorSource`], [`FloatSource`]), resolved at a hit
//! through a [`TextureQuery`].

use crate::shapes::attributes::AttributePoint;

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
    /// Mitsuba's `mesh_attribute`: for each shape (by index), its attribute's index in
    /// [`crate::shapes::attributes::MeshAttributes`] (`u32::MAX`: the shape has none; the
    /// parser refuses scenes where such a shape uses the texture), times `scale`.
    MeshAttribute {
        by_shape: Vec<u32>,
        scale: f32,
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
            Texture::Bitmap(b) => b.eval(uv, footprint),
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
            // Needs the hit, not uv: evaluated by `TextureQuery` (BSDF parameters only).
            Texture::MeshAttribute { .. } => Vec3A::ZERO,
        }
    }

    /// A `mesh_attribute`'s value at `at`; None for other textures.
    #[inline(never)]
    fn eval_attribute(&self, at: &AttributePoint) -> Option<Vec3A> {
        let Texture::MeshAttribute { by_shape, scale } = self else {
            return None;
        };
        let slot = *by_shape.get(at.shape as usize)?;
        let data = at.attributes.list.get(slot as usize)?;
        Some(data.eval(at) * *scale)
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
            Texture::Checkerboard { .. } | Texture::MeshAttribute { .. } => Vec2::ZERO,
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
    /// The hit, for `mesh_attribute` textures (None where there is no mesh hit).
    /// A reference, not the point itself: the query is copied into every blend of every hit.
    pub at: Option<&'a AttributePoint<'a>>,
    pub uv: Vec2,
    /// The filter's footprint, an ellipse in the surface's uv units ([`Footprint::POINT`]: the
    /// finest level, bilinear).
    pub footprint: Footprint,
}

impl TextureQuery<'_> {
    #[inline(always)]
    pub fn color(&self, c: ColorSource) -> Vec3A {
        if let (ColorSource::Texture(i), Some(at)) = (c, &self.at) {
            if let Some(v) = self.textures[i as usize].eval_attribute(at) {
                return v;
            }
        }
        c.eval(self.textures, self.uv, self.footprint)
    }

    /// A float parameter (the parser lets only one-channel `mesh_attribute`s be read as one).
    #[inline(always)]
    pub fn float(&self, f: FloatSource) -> f32 {
        if let (FloatSource::Texture(i), Some(at)) = (f, &self.at) {
            if let Some(v) = self.textures[i as usize].eval_attribute(at) {
                return v.x;
            }
        }
        f.eval(self.textures, self.uv, self.footprint)
    }
}
