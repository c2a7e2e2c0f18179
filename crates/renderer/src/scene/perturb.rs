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
