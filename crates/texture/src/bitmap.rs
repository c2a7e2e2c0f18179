//! The scene's `bitmap` texture: a mip pyramid plus the uv transform from the scene file.

use glam::{Affine2, Vec2, Vec3};

use crate::footprint::Footprint;
use crate::mipmap::MipMap;

/// A bitmap texture as the scene uses it: a pyramid plus the uv transform
/// (uv' = to_uv(uv); torrey's uscale/vscale/uoffset/voffset, Mitsuba's `to_uv`).
#[derive(Clone, Debug)]
pub struct BitmapTexture {
    mip: MipMap,
    to_uv: Affine2,
    /// How much to_uv stretches uv distances (larger of the two axis scales), so footprints
    /// measured on the surface become footprints in texture space.
    uv_scale: f32,
}

impl BitmapTexture {
    /// Wraps a pyramid with its uv transform. The footprint scale is the larger of the lengths
    /// of to_uv's two linear columns (= max(|uscale|, |vscale|) for a scale-and-offset).
    pub fn new(mip: MipMap, to_uv: Affine2) -> Self {
        let s = to_uv
            .matrix2
            .x_axis
            .length()
            .max(to_uv.matrix2.y_axis.length());
        let uv_scale = if s.is_finite() { s } else { 1.0 };
        Self {
            mip,
            to_uv,
            uv_scale,
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
    pub fn eval_footprint(&self, uv: Vec2, fp: Footprint) -> Vec3 {
        let st = self.to_uv.transform_point2(uv);
        self.mip
            .lookup_aniso(st, fp.transformed(self.to_uv.matrix2))
    }

    /// `footprint` in the surface's own uv units (before to_uv); the uv scale is applied here:
    /// level = log2(footprint * max(w, h) * max(uscale, vscale)) with the scales taken from to_uv.
    pub fn eval(&self, uv: Vec2, footprint: f32) -> Vec3 {
        let st = self.to_uv.transform_point2(uv);
        self.mip.lookup(st, footprint * self.uv_scale)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::Image;
    use crate::mipmap::{FilterType, WrapMode};

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
        let v = tex.eval(Vec2::ZERO, 0.0);
        assert!((v.x - 0.9).abs() < 1e-5, "{v}");
        // Period 1/4 in uv after scaling by 4: uv and uv + 0.25 agree.
        let a = tex.eval(Vec2::new(0.03, 0.1), 0.0);
        let b = tex.eval(Vec2::new(0.28, 0.1), 0.0);
        assert!(a.abs_diff_eq(b, 1e-5));
    }

    #[test]
    fn footprint_follows_the_uv_transform() {
        // Stripes vary along x; with uscale 4 a footprint of 1/32 uv along u covers one texel
        // (8 texels per 1/4 uv), so it is bilinear, while 1/8 uv covers 4 texels (filtered).
        let tex = BitmapTexture::new(stripes(), Affine2::from_scale(Vec2::new(4.0, 1.0)));
        let uv = Vec2::new(0.0625 / 4.0, 0.5); // centre of texel 0 (value 0)
        let fp = |len: f32| Footprint::new(Vec2::new(len, 0.0), Vec2::ZERO);
        assert_eq!(tex.eval_footprint(uv, fp(1.0 / 32.0)).x, 0.0);
        assert!(tex.eval_footprint(uv, fp(1.0 / 8.0)).x > 0.3);
        // Along v the stripes are constant: any footprint there leaves the value alone.
        let along_v = Footprint::new(Vec2::new(0.0, 0.5), Vec2::ZERO);
        assert!(tex.eval_footprint(uv, along_v).x.abs() < 1e-6);
    }

    #[test]
    fn footprint_is_scaled_by_uv_scale() {
        let plain = BitmapTexture::new(stripes(), Affine2::IDENTITY);
        let scaled = BitmapTexture::new(stripes(), Affine2::from_scale(Vec2::new(1.0, 4.0)));
        let uv = Vec2::new(0.0625, 0.5); // centre of texel 0 (value 0)
                                         // Footprint 1/32 uv: 0.25 texels → level 0 for the plain texture.
        assert!(plain.eval(uv, 1.0 / 32.0).x.abs() < 1e-6);
        // With vscale 4 the same footprint covers 1 texel of the (8 texel) image per 1/8 →
        // level log2(1/32 * 8 * 4) = 0 ... and 1/16 gives level 1 where stripes average to 0.5.
        assert!(scaled.eval(uv, 1.0 / 32.0).x.abs() < 1e-6);
        assert!((scaled.eval(uv, 1.0 / 16.0).x - 0.5).abs() < 1e-6);
        // Plain texture at 1/16: level log2(0.5) → clamped to 0.
        assert!(plain.eval(uv, 1.0 / 16.0).x.abs() < 1e-6);
        // Halfway between: level 0.5 blends 0 and 0.5.
        let half = scaled.eval(uv, 1.0 / 16.0 / 2f32.sqrt()).x;
        assert!((half - 0.25).abs() < 1e-5, "{half}");
    }
}
