//! Materials as the integrator sees them: a BSDF's (possibly textured) parameters, the
//! material's sidedness, and an optional normal map.

use crate::bsdfs::{BackSide, BsdfParams, SurfaceBsdf};
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
    pub normal_map: Option<u32>,
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
        let (back, normal_map) = match &b.kind {
            desc::BsdfKind::TwoSided { front, back } => (
                Some(BsdfParams::from_desc(&back.kind, torrey_dialect)),
                front.normal_map,
            ),
            desc::BsdfKind::Mask { nested, .. } => (None, nested.normal_map),
            _ => (None, b.normal_map),
        };
        // A mask is as two-sided as what it masks (mirroring its null part changes nothing).
        let two_sided = match &b.kind {
            desc::BsdfKind::Mask { nested, .. } => b.two_sided || nested.two_sided,
            _ => b.two_sided,
        };
        let anisotropic = bsdf.anisotropic() || back.as_ref().is_some_and(|b| b.anisotropic());
        // A transmitting BSDF handles its back side itself (it refracts out of it).
        let two_sided = (two_sided || torrey_dialect) && !bsdf.transmits();
        Material::new(
            bsdf,
            back,
            two_sided,
            normal_map.map(|t| t as u32),
            anisotropic,
        )
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
            anisotropic,
            textured,
        }
    }

    /// Whether shading reads any texture, i.e. needs uv and a ray-cone footprint.
    #[inline(always)]
    pub fn is_textured(&self) -> bool {
        self.textured
    }

    /// The BSDF at a hit, its textured parameters looked up through `q`.
    #[inline(always)]
    pub fn bsdf<'a>(&'a self, q: &TextureQuery<'a>) -> SurfaceBsdf<'a> {
        SurfaceBsdf {
            front: self.bsdf.resolve(q),
            back: match &self.back {
                Some(b) => BackSide::Other(b.resolve(q)),
                None if self.two_sided => BackSide::Mirrored,
                None => BackSide::Front,
            },
        }
    }

    /// The local shading frame at a hit: the shading normal as the shape gives it (the BSDF
    /// decides what its back side does, see [`SurfaceBsdf`]), or the normal map's.
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
    ) -> Frame {
        let Some(tex) = self.normal_map else {
            // The common case, inline in the path loop; normal maps take the call below.
            // Anisotropic BSDFs are oriented by the surface's tangent dp/du, as Mitsuba's
            // shading frame is; for the others the tangent's direction does not matter.
            if self.anisotropic {
                return Frame::from_normal_tangent(hit.ns, hit.dpdu);
            }
            return Frame::from_normal(hit.ns);
        };
        self.normal_mapped_frame(textures, hit, wo, tex, footprint)
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
