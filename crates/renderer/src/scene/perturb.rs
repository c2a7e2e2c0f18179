//! Mitsuba 3's `normalmap` and `bumpmap` (3.9.1): the tilted shading frame at a hit. The tilted
//! normal n is given relative to the unperturbed shading frame (normal ns, tangent dp/du made
//! orthogonal to it, bitangent ns × tangent):
//! - `normalmap`: n = 2 rgb − 1 of the raw bitmap;
//! - `bumpmap`: the height h's uv gradient (the gradient of the bilinear interpolant, scaled by
//!   `scale`) moves the surface along ns: dp/du' = dp/du + ns (∂h/∂u − ns·dp/du), the same for v,
//!   and n = dp/du' × dp/dv', turned to the geometric normal's side.
//!
//! With `flip_invalid_normals` (default), a tilted normal that the viewer sees from the other
//! side than the unperturbed one (wi.z · wi·n ≤ 0) is mirrored about ns (n.x, n.y negated;
//! Schüssler et al. 2017). The frame's tangent is the x axis made orthogonal to n. A two-sided
//! material seen from the back works in the mirrored frame (ns → −ns), as Mitsuba's `twosided`
//! mirrors the directions before its nested adapter sees them. The BSDF side of the adapter
//! (same-side test and shadowing term) is [`Perturbation`].

use crate::bsdfs::Perturbation;
use crate::sampling::Frame;
use crate::shapes::SurfaceHit;
use crate::textures::Texture;
use glam::Vec3A;
use torrey_parser as desc;
use torrey_texture::Footprint;

/// Where the tilted normal comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PerturbSource {
    /// `normalmap`: texture index of the raw RGB map.
    NormalMap(u32),
    /// `bumpmap`: texture index of the height field and the gradient's scale.
    BumpMap { texture: u32, scale: f32 },
}

/// A material's Mitsuba-style normal perturbation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MitsubaPerturb {
    pub source: PerturbSource,
    pub flip_invalid_normals: bool,
    pub use_shadowing_function: bool,
}

impl MitsubaPerturb {
    pub fn new(source: PerturbSource, options: desc::PerturbOptions) -> Self {
        Self {
            source,
            flip_invalid_normals: options.flip_invalid_normals,
            use_shadowing_function: options.use_shadowing_function,
        }
    }

    /// The tilted frame at `hit` seen from `wo`, and what the BSDF must add in it.
    /// `two_sided`: the material shades its back as its front, mirrored.
    pub fn frame(
        &self,
        textures: &[Texture],
        hit: &SurfaceHit,
        wo: Vec3A,
        footprint: Footprint,
        two_sided: bool,
    ) -> (Frame, Perturbation) {
        let mut base = Frame::from_normal_tangent(hit.ns, hit.dpdu);
        let mut n = match self.source {
            PerturbSource::NormalMap(t) => {
                textures[t as usize].eval(hit.uv, footprint) * 2.0 - Vec3A::ONE
            }
            PerturbSource::BumpMap { texture, scale } => {
                let g = textures[texture as usize].eval_1_grad(hit.uv) * scale;
                let ns = hit.ns;
                let dpdu = hit.dpdu + ns * (g.x - ns.dot(hit.dpdu));
                let dpdv = hit.dpdv + ns * (g.y - ns.dot(hit.dpdv));
                let c = dpdu.cross(dpdv);
                let c = if hit.ng.dot(c) < 0.0 { -c } else { c };
                base.to_local(c.normalize_or(ns))
            }
        };
        let mut wi = base.to_local(wo);
        if two_sided && wi.z < 0.0 {
            wi.z = -wi.z;
            base.n = -base.n;
        }
        if self.flip_invalid_normals && wi.z * wi.dot(n) <= 0.0 {
            n.x = -n.x;
            n.y = -n.y;
        }
        let n = n.normalize_or(Vec3A::Z);
        let s = (Vec3A::X - n * n.x).normalize_or(Vec3A::Y);
        let t = n.cross(s);
        let frame = Frame {
            s: base.to_world(s),
            t: base.to_world(t),
            n: base.to_world(n),
        };
        let perturbation = Perturbation {
            // The unperturbed normal (local z) in the tilted frame's coordinates.
            n0: Vec3A::new(s.z, t.z, n.z),
            alpha2: if self.use_shadowing_function {
                Perturbation::alpha2_of(n)
            } else {
                0.0
            },
        };
        (frame, perturbation)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Affine2, Vec2, Vec3};
    use torrey_texture::{BitmapTexture, Image, MipMap};

    fn constant_map(rgb: Vec3) -> Texture {
        let mip = MipMap::new(
            Image::filled(2, 2, rgb),
            torrey_texture::WrapMode::Repeat,
            torrey_texture::FilterType::Bilinear,
        );
        Texture::Bitmap(BitmapTexture::new(mip, Affine2::IDENTITY))
    }

    fn hit() -> SurfaceHit {
        SurfaceHit {
            t: 1.0,
            p: Vec3A::ZERO,
            ng: Vec3A::Z,
            ns: Vec3A::Z,
            uv: Vec2::new(0.3, 0.6),
            dpdu: Vec3A::X * 2.0,
            dpdv: Vec3A::Y * 3.0,
            bary: Vec2::ZERO,
            shape: 0,
            prim: 0,
        }
    }

    fn normal_map(n: Vec3, flip: bool, shadowing: bool) -> (Vec<Texture>, MitsubaPerturb) {
        let p = MitsubaPerturb::new(
            PerturbSource::NormalMap(0),
            desc::PerturbOptions {
                flip_invalid_normals: flip,
                use_shadowing_function: shadowing,
            },
        );
        (vec![constant_map((n.normalize() + Vec3::ONE) * 0.5)], p)
    }

    fn dir(theta_deg: f32, phi_deg: f32) -> Vec3A {
        let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
        Vec3A::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
    }

    #[test]
    fn flat_map_leaves_the_frame_and_the_bsdf_alone() {
        let (tex, p) = normal_map(Vec3::Z, true, true);
        let (f, pert) = p.frame(&tex, &hit(), dir(30.0, 10.0), Footprint::POINT, false);
        assert!(f.n.abs_diff_eq(Vec3A::Z, 1e-6), "{:?}", f.n);
        assert!(pert.n0.abs_diff_eq(Vec3A::Z, 1e-6));
        assert_eq!(pert.alpha2, 0.0);
        assert_eq!(pert.factor(dir(70.0, 0.0)), 1.0);
        // Below both normals is consistent too: the nested BSDF decides there.
        assert_eq!(pert.factor(dir(110.0, 0.0)), 1.0);
    }

    #[test]
    fn tilted_map_flips_for_a_viewer_behind_it_and_shadows() {
        // n tilted 45° towards +x; a viewer at 80° towards −x sees it from behind.
        let n = Vec3::new(1.0, 0.0, 1.0);
        let wo = dir(80.0, 180.0);
        let (tex, p) = normal_map(n, true, true);
        let (f, pert) = p.frame(&tex, &hit(), wo, Footprint::POINT, false);
        let tilt = Vec3A::new(-1.0, 0.0, 1.0).normalize();
        assert!(f.n.abs_diff_eq(tilt, 2e-2), "flipped: {:?}", f.n);
        assert!(f.n.dot(wo) > 0.0);
        // The same without flipping keeps the map's normal.
        let (tex, p) = normal_map(n, false, true);
        let (g, _) = p.frame(&tex, &hit(), wo, Footprint::POINT, false);
        assert!(g.n.abs_diff_eq(Vec3A::new(1.0, 0.0, 1.0).normalize(), 2e-2));
        // Shadowing: tan²θn ≈ 1 → α² ≈ 1/8; towards 60° from ns, tan² = 3.
        assert!((pert.alpha2 - 0.125).abs() < 1e-2, "{}", pert.alpha2);
        let w = f.to_local(dir(60.0, 90.0));
        let expected = 2.0 / (1.0 + (1.0 + pert.alpha2 * 3.0).sqrt());
        assert!((pert.factor(w) - expected).abs() < 1e-4);
        // Below ns but above the tilted normal: 0, and the pdf side test agrees.
        let below = f.to_local(dir(95.0, 180.0));
        assert!(below.z > 0.0);
        assert_eq!(pert.factor(below), 0.0);
        assert!(!pert.same_side(below));
    }

    #[test]
    fn two_sided_back_works_in_the_mirrored_frame() {
        let (tex, p) = normal_map(Vec3::new(0.3, 0.2, 1.0), true, true);
        let wo = dir(140.0, 30.0);
        let (front_view, _) = p.frame(&tex, &hit(), -wo, Footprint::POINT, true);
        let (back, pert) = p.frame(&tex, &hit(), wo, Footprint::POINT, true);
        assert!(back.n.z < 0.0 && back.n.dot(wo) > 0.0);
        // The unperturbed normal, as the tilted frame sees it, is −ns: mirrored.
        assert!(back.to_world(pert.n0).abs_diff_eq(-Vec3A::Z, 1e-5));
        // One-sided, the viewer stays behind the tilted normal.
        let (one, _) = p.frame(&tex, &hit(), wo, Footprint::POINT, false);
        assert!(one.n.dot(wo) < 0.0);
        assert!(front_view.n.z > 0.0);
    }

    #[test]
    fn bump_gradient_tilts_against_the_slope() {
        // Height rising along u (0 → 1 over the texture's width): the normal leans to −u.
        let px = (0..8).map(|k| Vec3::splat((k % 4) as f32 / 3.0)).collect();
        let mip = MipMap::new(
            Image::new(4, 2, px),
            torrey_texture::WrapMode::Clamp,
            torrey_texture::FilterType::Bilinear,
        );
        let tex = vec![Texture::Bitmap(BitmapTexture::new(mip, Affine2::IDENTITY))];
        let p = MitsubaPerturb::new(
            PerturbSource::BumpMap {
                texture: 0,
                scale: 0.5,
            },
            desc::PerturbOptions::default(),
        );
        let mut h = hit();
        h.uv = Vec2::new(0.5, 0.5);
        let (f, _) = p.frame(&tex, &h, Vec3A::Z, Footprint::POINT, false);
        // ∂h/∂u = 4/3 per uv; scaled 2/3; dp/du = 2x: n ∝ (−(2/3)·3, 0, 2·3) / |…|.
        let expected = Vec3A::new(-1.0 / 3.0, 0.0, 1.0).normalize();
        assert!(f.n.abs_diff_eq(expected, 1e-4), "{:?} vs {expected:?}", f.n);
    }
}
