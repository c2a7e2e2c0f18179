//! The scene's `bitmap` texture: a mip pyramid plus the uv transform from the scene file.

use glam::{Affine2, Vec2, Vec3A};

use crate::footprint::Footprint;
use crate::mipmap::MipMap;

/// A bitmap texture as the scene uses it: a pyramid plus the uv transform
/// (uv' = to_uv(uv); torrey's uscale/vscale/uoffset/voffset, Mitsuba's `to_uv`).
#[derive(Clone, Debug)]
pub struct BitmapTexture {
    mip: MipMap,
    to_uv: Affine2,
}

impl BitmapTexture {
    /// Wraps a pyramid with its uv transform; lookups read a packed copy of its texels
    /// ([`MipMap::with_packed_texels`]).
    pub fn new(mip: MipMap, to_uv: Affine2) -> Self {
        Self::with_codes(mip, to_uv, None)
    }

    /// [`BitmapTexture::new`] with the 8-bit `codes` the pyramid's finest level was decoded
    /// from, kept instead of its floats ([`MipMap::with_packed_texels_from`]).
    pub fn with_codes(mip: MipMap, to_uv: Affine2, codes: Option<crate::Codes8>) -> Self {
        Self {
            mip: mip.with_packed_texels_from(codes),
            to_uv,
        }
    }

    /// The pyramid, e.g. for a renderer that wants the mean colour (the 1x1 level).
    pub fn mip(&self) -> &MipMap {
        &self.mip
    }

    /// The uv transform applied before lookups.
    pub fn to_uv(&self) -> Affine2 {
        self.to_uv
    }

    /// The texture filtered over `fp`, an ellipse in the surface's own uv units (before to_uv):
    /// its axes go through to_uv's linear part, so scales, rotations and shears of the uv
    /// transform stretch the footprint exactly as they stretch the texture.
    pub fn eval(&self, uv: Vec2, fp: Footprint) -> Vec3A {
        let st = self.to_uv.transform_point2(uv);
        self.mip
            .lookup_aniso(st, fp.transformed(self.to_uv.matrix2))
    }
}

impl BitmapTexture {
    /// The gradient with respect to (u, v) of the texture's luminance (Rec. 709 weights; a grey
    /// image's value), bilinearly interpolated at the finest level: Mitsuba 3's bitmap
    /// `eval_1_grad`, which `bumpmap` reads. Like Mitsuba, the texel-space partials go through
    /// the transpose of `to_uv`'s linear part and are then scaled by the resolution.
    pub fn eval_1_grad(&self, uv: Vec2) -> Vec2 {
        let st = self.to_uv.transform_point2(uv);
        let g = self
            .mip
            .bilinear_gradient(st, |c| 0.212671 * c.x + 0.715160 * c.y + 0.072169 * c.z);
        let m = self.to_uv.matrix2;
        let g = Vec2::new(m.x_axis.dot(g), m.y_axis.dot(g));
        g * Vec2::new(self.mip.width() as f32, self.mip.height() as f32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Image;
    use crate::mipmap::{FilterType, WrapMode};
    use glam::Vec3;

    fn stripes() -> MipMap {
        // 8x8 vertical stripes 0/1: level 0 alternates, level 1 and coarser are 0.5.
        let px = (0..64).map(|k| Vec3::splat(((k % 8) % 2) as f32)).collect();
        MipMap::new(Image::new(8, 8, px), WrapMode::Repeat, FilterType::Bilinear)
    }

    #[test]
    fn uv_transform_is_applied() {
        let tex = BitmapTexture::new(
            stripes(),
            Affine2::from_scale_angle_translation(Vec2::new(4.0, 4.0), 0.0, Vec2::new(0.2, 0.3)),
        );
        // uv = (0.0) maps to st = (0.2, 0.3): x texel coordinate 1.6 → centre of texel 1 is
        // at 1.5, so 0.9 * texel1 + 0.1 * texel2 = 0.9.
        let v = tex.eval(Vec2::ZERO, Footprint::POINT);
        assert!((v.x - 0.9).abs() < 1e-5, "{v}");
        // Period 1/4 in uv after scaling by 4: uv and uv + 0.25 agree.
        let a = tex.eval(Vec2::new(0.03, 0.1), Footprint::POINT);
        let b = tex.eval(Vec2::new(0.28, 0.1), Footprint::POINT);
        assert!(a.abs_diff_eq(b, 1e-5));
    }

    #[test]
    fn footprint_follows_the_uv_transform() {
        // Stripes vary along x; with uscale 4 a footprint of 1/32 uv along u covers one texel
        // (8 texels per 1/4 uv), so it is bilinear, while 1/8 uv covers 4 texels (filtered).
        let tex = BitmapTexture::new(stripes(), Affine2::from_scale(Vec2::new(4.0, 1.0)));
        let uv = Vec2::new(0.0625 / 4.0, 0.5); // centre of texel 0 (value 0)
        let fp = |len: f32| Footprint::new(Vec2::new(len, 0.0), Vec2::ZERO);
        assert_eq!(tex.eval(uv, fp(1.0 / 32.0)).x, 0.0);
        assert!(tex.eval(uv, fp(1.0 / 8.0)).x > 0.3);
        // Along v the stripes are constant: any footprint there leaves the value alone.
        let along_v = Footprint::new(Vec2::new(0.0, 0.5), Vec2::ZERO);
        assert!(tex.eval(uv, along_v).x.abs() < 1e-6);
    }

    /// The gradient is the bilinear interpolant's: central differences of the (point) lookups
    /// inside one texel cell, through a rotated, scaled uv transform, with wrapping; zero for
    /// nearest filtering.
    #[test]
    fn gradient_matches_finite_differences() {
        let (w, h) = (5u32, 3u32);
        let px = (0..w * h)
            .map(|k| {
                let (x, y) = ((k % w) as f32, (k / w) as f32);
                Vec3::new(0.3 * x + 0.1 * y * y, 0.5 * (x * y).sin(), 0.2 * y)
            })
            .collect::<Vec<_>>();
        let lum = |c: Vec3| 0.212671 * c.x + 0.715160 * c.y + 0.072169 * c.z;
        let to_uv =
            Affine2::from_scale_angle_translation(Vec2::new(1.3, 0.8), 0.4, Vec2::new(0.1, -0.2));
        let tex = BitmapTexture::new(
            MipMap::new(
                Image::new(w, h, px.clone()),
                WrapMode::Repeat,
                FilterType::Bilinear,
            ),
            to_uv,
        );
        let eps = 1e-3;
        for uv in [
            Vec2::new(0.31, 0.47),
            Vec2::new(-0.2, 0.9),
            Vec2::new(0.77, 0.13),
        ] {
            let f = |uv: Vec2| lum(tex.eval(uv, Footprint::POINT).into());
            let fd = Vec2::new(
                f(uv + Vec2::X * eps) - f(uv - Vec2::X * eps),
                f(uv + Vec2::Y * eps) - f(uv - Vec2::Y * eps),
            ) / (2.0 * eps);
            let g = tex.eval_1_grad(uv);
            // Mitsuba scales the transformed partials by the resolution per axis (exact for a
            // diagonal to_uv): compare against that convention.
            let st_grad = {
                let m = to_uv.matrix2;
                let inv = m.inverse();
                // fd = Mᵀ ∇st f; Mitsuba's result is res ⊙ (Mᵀ ∇xy f) with ∇st = res ⊙ ∇xy.
                let grad_st = inv.transpose() * fd;
                let grad_xy = grad_st / Vec2::new(w as f32, h as f32);
                (m.transpose() * grad_xy) * Vec2::new(w as f32, h as f32)
            };
            assert!(
                (g - st_grad).length() < 2e-2 * (1.0 + g.length()),
                "{uv}: {g} vs {st_grad}"
            );
        }
        let nearest = BitmapTexture::new(
            MipMap::new(Image::new(w, h, px), WrapMode::Repeat, FilterType::Nearest),
            Affine2::IDENTITY,
        );
        assert_eq!(nearest.eval_1_grad(Vec2::new(0.3, 0.4)), Vec2::ZERO);
    }
}
