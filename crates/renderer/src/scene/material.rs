//! Materials as the integrator sees them: a BSDF's (possibly textured) parameters, the
//! material's sidedness, and an optional normal map (torrey's) or normal perturbation
//! (Mitsuba's `normalmap` / `bumpmap`, see [`MitsubaPerturb`]).

use super::perturb::{MitsubaPerturb, PerturbSource};
#[cfg(test)]
use crate::bsdfs::{BackSide, SurfaceBsdf};
use crate::bsdfs::{BsdfParams, Perturbation, SidedBsdf};
use crate::sampling::Frame;
use crate::shapes::SurfaceHit;
use crate::textures::{Texture, TextureQuery};
use glam::Vec3A;
use torrey_parser as desc;
use torrey_texture::Footprint;

/// A material ready to shade.
#[derive(Clone, Debug)]
pub struct Material {
    pub bsdf: BsdfParams,
    /// A different BSDF for the back (Mitsuba's `twosided` with two nested bsdfs).
    pub back: Option<BsdfParams>,
    /// Shades both sides (torrey-dialect scenes, or Mitsuba's `twosided`).
    pub two_sided: bool,
    /// torrey's normal map (torrey-dialect scenes: the course's rule).
    pub normal_map: Option<u32>,
    /// Mitsuba's `normalmap` or `bumpmap` (Mitsuba-dialect scenes; `bumpmap` in both).
    pub perturb: Option<MitsubaPerturb>,
    /// The BSDF depends on the tangent's direction (anisotropic roughness).
    pub anisotropic: bool,
    /// Shading reads a texture (the normal map, a textured parameter of either side): kept, not
    /// recomputed, because every hit asks (walking a blend's parameters cost 2% of cbox).
    textured: bool,
}

impl Material {
    /// The material of a parsed bsdf; every material of a torrey-dialect scene is two-sided.
    pub fn from_desc(b: &desc::Bsdf, torrey_dialect: bool) -> Self {
        let bsdf = BsdfParams::from_desc(&b.kind, torrey_dialect);
        let (back, mapped) = match &b.kind {
            desc::BsdfKind::TwoSided { front, back } => (
                Some(BsdfParams::from_desc(&back.kind, torrey_dialect)),
                &**front,
            ),
            desc::BsdfKind::Mask { nested, .. } => (None, &**nested),
            _ => (None, b),
        };
        let source = match (mapped.normal_map, mapped.bump_map) {
            (_, Some(bump)) => Some(PerturbSource::BumpMap {
                texture: bump.texture as u32,
                scale: bump.scale,
            }),
            (Some(t), None) if !torrey_dialect => Some(PerturbSource::NormalMap(t as u32)),
            _ => None,
        };
        let perturb = source.map(|s| MitsubaPerturb::new(s, mapped.perturb));
        let normal_map = if perturb.is_some() {
            None
        } else {
            mapped.normal_map
        };
        // A mask is as two-sided as what it masks (mirroring its null part changes nothing).
        let two_sided = match &b.kind {
            desc::BsdfKind::Mask { nested, .. } => b.two_sided || nested.two_sided,
            _ => b.two_sided,
        };
        let anisotropic = bsdf.anisotropic() || back.as_ref().is_some_and(|b| b.anisotropic());
        // A transmitting BSDF handles its back side itself (it refracts out of it).
        let two_sided = (two_sided || torrey_dialect) && !bsdf.transmits();
        let mut m = Material::new(
            bsdf,
            back,
            two_sided,
            normal_map.map(|t| t as u32),
            anisotropic,
        );
        if perturb.is_some() {
            m.perturb = perturb;
            m.textured = true;
        }
        m
    }

    /// A material from its parts.
    pub fn new(
        bsdf: BsdfParams,
        back: Option<BsdfParams>,
        two_sided: bool,
        normal_map: Option<u32>,
        anisotropic: bool,
    ) -> Self {
        let textured = normal_map.is_some()
            || bsdf.is_textured()
            || back.as_ref().is_some_and(|b| b.is_textured());
        Material {
            bsdf,
            back,
            two_sided,
            normal_map,
            perturb: None,
            anisotropic,
            textured,
        }
    }

    /// A `null` surface on both sides: every BSDF sample there is a pass-through
    /// (`BsdfSample::is_null`). The path loops ask at a path's last vertex, where they draw no
    /// sample (a `mask` counts as scattering there).
    #[inline(always)]
    pub fn passes_through(&self) -> bool {
        matches!(self.bsdf, BsdfParams::Null) && matches!(self.back, None | Some(BsdfParams::Null))
    }

    /// Whether shading reads any texture, i.e. needs uv and a ray-cone footprint.
    #[inline(always)]
    pub fn is_textured(&self) -> bool {
        self.textured
    }

    /// The BSDF at a hit, its textured parameters looked up through `q`.
    /// `perturbation` is what [`Material::shading_frame`] returned with the frame. The loops
    /// shade with [`Material::bsdf_facing`]; this is the tests' reference.
    #[cfg(test)]
    #[inline(always)]
    pub fn bsdf<'a>(
        &'a self,
        q: &TextureQuery<'a>,
        perturbation: Option<Perturbation>,
    ) -> SurfaceBsdf<'a> {
        SurfaceBsdf {
            front: self.bsdf.resolve(q),
            back: match &self.back {
                Some(b) => BackSide::Other(b.resolve(q)),
                None if self.two_sided => BackSide::Mirrored,
                None => BackSide::Front,
            },
            perturbation,
        }
    }

    /// [`Material::bsdf`]'s side that `wo` (local, in the shading frame) sees, the other side's
    /// parameters left unresolved: what the path loop shades with.
    #[inline(always)]
    pub fn bsdf_facing<'a>(
        &'a self,
        q: &TextureQuery<'a>,
        perturbation: Option<Perturbation>,
        wo: Vec3A,
    ) -> SidedBsdf<'a> {
        // As `SurfaceBsdf::side`: the back is whatever a viewer with wo.z < 0 sees.
        let (params, mirrored) = match &self.back {
            Some(b) if wo.z < 0.0 => (b, true),
            None if wo.z < 0.0 && self.two_sided => (&self.bsdf, true),
            _ => (&self.bsdf, false),
        };
        SidedBsdf {
            bsdf: params.resolve(q),
            mirrored,
            perturbation,
        }
    }

    /// The local shading frame at a hit: the shading normal as the shape gives it (the BSDF
    /// decides what its back side does, see [`SurfaceBsdf`]), or the normal map's; with
    /// Mitsuba's `normalmap` / `bumpmap`, also the adapter the BSDF applies in that frame.
    ///
    /// With a normal map, the side is decided by the geometric normal, the map perturbs the
    /// normal on that side (n = 2 rgb - 1 in the frame t = dp/du made orthogonal to ns,
    /// b = ns x t), and for a two-sided material a perturbed normal that would face away from
    /// `wo` is bent back until it is just visible, so normal-mapped surfaces never turn black or
    /// leak light at grazing angles.
    #[inline(always)]
    pub fn shading_frame(
        &self,
        textures: &[Texture],
        hit: &SurfaceHit,
        wo: Vec3A,
        footprint: Footprint,
    ) -> (Frame, Option<Perturbation>) {
        let Some(tex) = self.normal_map else {
            if let Some(p) = &self.perturb {
                return self.perturbed_frame(p, textures, hit, wo, footprint);
            }
            // The common case, inline in the path loop; normal maps take the calls aside.
            // Anisotropic BSDFs are oriented by the surface's tangent dp/du, as Mitsuba's
            // shading frame is; for the others the tangent's direction does not matter.
            if self.anisotropic {
                return (Frame::from_normal_tangent(hit.ns, hit.dpdu), None);
            }
            return (Frame::from_normal(hit.ns), None);
        };
        (
            self.normal_mapped_frame(textures, hit, wo, tex, footprint),
            None,
        )
    }

    /// [`Material::shading_frame`] for Mitsuba's `normalmap` / `bumpmap`.
    #[inline(never)]
    fn perturbed_frame(
        &self,
        p: &MitsubaPerturb,
        textures: &[Texture],
        hit: &SurfaceHit,
        wo: Vec3A,
        footprint: Footprint,
    ) -> (Frame, Option<Perturbation>) {
        if self.back.is_some() && hit.ns.dot(wo) < 0.0 {
            // Mitsuba's twosided with a second bsdf: the back's has no normal or bump map.
            return (Frame::from_normal_tangent(hit.ns, hit.dpdu), None);
        }
        let (frame, perturbation) = p.frame(textures, hit, wo, footprint, self.two_sided);
        (frame, Some(perturbation))
    }

    /// [`Material::shading_frame`] for a material with normal map `tex`.
    #[inline(never)]
    fn normal_mapped_frame(
        &self,
        textures: &[Texture],
        hit: &SurfaceHit,
        wo: Vec3A,
        tex: u32,
        footprint: Footprint,
    ) -> Frame {
        let front = hit.ng.dot(wo) >= 0.0;
        let rgb = textures[tex as usize].eval(hit.uv, footprint);
        let local = (rgb * 2.0 - Vec3A::ONE).normalize_or(Vec3A::Z);
        let ns = hit.ns;
        let t = (hit.dpdu - ns * ns.dot(hit.dpdu)).normalize_or(Frame::from_normal(ns).s);
        let b = ns.cross(t);
        let mut n = (t * local.x + b * local.y + ns * local.z).normalize_or(ns);
        if !front {
            if !self.two_sided {
                // The back of a one-sided material: its BSDF decides what the viewer sees.
                return Frame::from_normal(n);
            }
            n = -n;
        }
        const MIN_COS: f32 = 0.01;
        let cos = n.dot(wo);
        if cos < MIN_COS {
            n = (n + wo * (MIN_COS - cos)).normalize_or(n);
        }
        Frame::from_normal(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdfs::{DiffuseParams, PhongParams};
    use crate::textures::{ColorSource, FloatSource};
    use glam::Vec2;
    use torrey_testkit::Rng;

    /// The side [`Material::bsdf_facing`] resolves answers exactly as the whole
    /// [`SurfaceBsdf`] does for the same `wo`, from the front and the back, for a one-sided
    /// material, a two-sided one and one with a second BSDF behind (black, mirrored and other).
    #[test]
    fn the_facing_side_shades_as_the_whole_surface() {
        let diffuse = BsdfParams::Diffuse(DiffuseParams {
            reflectance: ColorSource::Constant(Vec3A::new(0.2, 0.5, 0.7)),
        });
        let phong = BsdfParams::Phong(PhongParams {
            reflectance: ColorSource::Constant(Vec3A::new(0.6, 0.3, 0.1)),
            exponent: FloatSource::Constant(20.0),
        });
        let materials = [
            Material::new(phong.clone(), None, false, None, false),
            Material::new(phong.clone(), None, true, None, false),
            Material::new(phong, Some(diffuse), true, None, false),
        ];
        let q = TextureQuery {
            textures: &[],
            at: None,
            uv: Vec2::ZERO,
            footprint: Footprint::POINT,
        };
        let mut rng = Rng::new(5);
        let mut nonzero_back = [0; 3];
        for (m, material) in materials.iter().enumerate() {
            let whole = material.bsdf(&q, None);
            for k in 0..400 {
                let (a, b) = (rng.vec2(), rng.vec2());
                let dir = |u: Vec2, sign: f32| {
                    let z = (0.05 + 0.9 * u.x) * sign;
                    let r = (1.0 - z * z).sqrt();
                    let phi = std::f32::consts::TAU * u.y;
                    Vec3A::new(r * phi.cos(), r * phi.sin(), z)
                };
                let wo = dir(a, if k % 2 == 0 { 1.0 } else { -1.0 });
                let wi = dir(b, if k % 4 < 2 { 1.0 } else { -1.0 });
                let sided = material.bsdf_facing(&q, None, wo);
                assert_eq!(sided.eval(wo, wi), whole.eval(wo, wi), "material {m}");
                let both = (whole.eval(wo, wi), whole.pdf(wo, wi));
                assert_eq!(sided.eval_pdf(wo, wi), both, "material {m}");
                assert_eq!(sided.flags(), whole.flags(wo), "material {m}");
                assert_eq!(sided.roughness(), whole.roughness(wo), "material {m}");
                let (u, u_lobe) = (rng.vec2(), rng.f32());
                let (s, w) = (sided.sample(wo, u, u_lobe), whole.sample(wo, u, u_lobe));
                assert_eq!(
                    s.map(|s| (s.wi, s.weight, s.pdf)),
                    w.map(|s| (s.wi, s.weight, s.pdf))
                );
                if wo.z < 0.0 && whole.eval(wo, wi) != Vec3A::ZERO {
                    nonzero_back[m] += 1;
                }
            }
        }
        // One-sided: black from behind; the others shade their back.
        assert_eq!(nonzero_back[0], 0);
        assert!(
            nonzero_back[1] > 50 && nonzero_back[2] > 50,
            "{nonzero_back:?}"
        );
    }
}
