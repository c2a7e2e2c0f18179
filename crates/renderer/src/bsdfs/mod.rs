//! BSDFs in the local shading frame (z = shading normal), one file per model.
//!
//! The contract:
//! - A material holds each model's parameters, textured or not (`*Params`); at a hit it resolves
//!   them through a [`TextureQuery`] into a plain per-hit BSDF ([`BsdfParams::resolve`]), as
//!   pbrt-v4's `GetBxDF` does.
//! - Directions `wo` (towards the viewer) and `wi` (sampled or towards a light) both point away
//!   from the surface, in the frame of the shading normal *as the shape gives it*: `wo.z < 0`
//!   means the viewer is on the back. Each model decides what its back side does (the course's
//!   reflection-only models are black there; a dielectric refracts). [`SurfaceBsdf`] adds
//!   two-sidedness (Mitsuba's `twosided`, every material of a torrey-dialect scene).
//! - `eval` returns f(wo, wi)·|cos θi| for the non-delta lobes, `pdf` the solid-angle density of
//!   `sample` producing `wi`, and `sample` a [`BsdfSample`] with its weight f·|cos θi|/pdf, the
//!   relative index of refraction along the sampled direction and the sampled lobe's flags.
//!
//! These are torrey's own materials as the UCSD CSE 168 course defines them (handouts
//! homework3.tex: Schlick Fresnel, `mirror`, `plastic`; homework4.tex: `phong`, `blinnphong`,
//! `blinn_microfacet`). The course's ρ already includes the cosine of the light direction, so
//! `eval` returns exactly that ρ.
//!
//! A new BSDF is a file (parameters, `resolve`, `eval`/`pdf`/`sample`, its tests), a variant in
//! [`Bsdf`] and [`BsdfParams`] with one-line arms, the parser mapping and the docs.

// Comparisons are written `!(x > 0.0)` on purpose: they also reject NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod blinn;
mod blinn_microfacet;
mod diffuse;
mod flags;
pub mod fresnel;
mod mirror;
mod phong;
mod plastic;
#[cfg(test)]
mod tests;

pub use blinn::{Blinn, BlinnParams};
pub use blinn_microfacet::{BlinnMicrofacet, BlinnMicrofacetParams};
pub use diffuse::{Diffuse, DiffuseParams};
pub use flags::BsdfFlags;
pub use mirror::{Mirror, MirrorParams};
pub use phong::{Phong, PhongParams};
pub use plastic::{Plastic, PlasticParams};

use crate::textures::{ColorSource, FloatSource, TextureQuery};
use glam::{Vec2, Vec3A};
use torrey_parser::scene::{BsdfKind, ColorParam};

/// One sampled scattering direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// The sampled direction (local frame).
    pub wi: Vec3A,
    /// f·|cos θi| / pdf, including the probability of the lobe choice: the path throughput
    /// multiplier. For delta lobes it is the lobe's reflectance divided by its selection
    /// probability.
    pub weight: Vec3A,
    /// Solid-angle density of `wi` (non-delta lobes, times their selection probability, exactly
    /// what `pdf` returns); `f32::INFINITY` for a delta lobe, so that
    /// [`crate::sampling::power_heuristic`] gives such samples MIS weight 1.
    pub pdf: f32,
    /// Relative index of refraction along `wi`: η_i/η_t for a refraction (what Mitsuba's
    /// Russian roulette divides the throughput's η² by), 1 for a reflection.
    pub eta: f32,
    /// The lobe that was sampled: exactly one of reflection/transmission and one of
    /// diffuse/glossy/delta.
    pub lobe: BsdfFlags,
}

impl BsdfSample {
    /// A reflection sample (eta 1) from lobe `lobe`.
    #[inline(always)]
    pub fn reflection(wi: Vec3A, weight: Vec3A, pdf: f32, lobe: BsdfFlags) -> Self {
        Self {
            wi,
            weight,
            pdf,
            eta: 1.0,
            lobe,
        }
    }

    /// The sample came from a delta lobe: skip light-sampling MIS, emission is taken unweighted.
    #[inline(always)]
    pub fn is_delta(&self) -> bool {
        self.lobe.contains(BsdfFlags::DELTA)
    }
}

/// Mirror reflection of a local direction about the shading normal (+z).
#[inline(always)]
fn reflect_z(w: Vec3A) -> Vec3A {
    Vec3A::new(-w.x, -w.y, w.z)
}

/// A BSDF at a hit, with plain (resolved) parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bsdf {
    Diffuse(Diffuse),
    Mirror(Mirror),
    Plastic(Plastic),
    Phong(Phong),
    Blinn(Blinn),
    BlinnMicrofacet(BlinnMicrofacet),
}

impl Bsdf {
    /// f(wo, wi)·|cos θi| of the non-delta lobes.
    #[inline(always)]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Vec3A {
        match self {
            Bsdf::Diffuse(b) => b.eval(wo, wi),
            Bsdf::Mirror(b) => b.eval(wo, wi),
            Bsdf::Plastic(b) => b.eval(wo, wi),
            Bsdf::Phong(b) => b.eval(wo, wi),
            Bsdf::Blinn(b) => b.eval(wo, wi),
            Bsdf::BlinnMicrofacet(b) => b.eval(wo, wi),
        }
    }

    /// Solid-angle pdf of [`Bsdf::sample`] producing `wi` (non-delta lobes, times their
    /// selection probability).
    #[inline(always)]
    pub fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        match self {
            Bsdf::Diffuse(b) => b.pdf(wo, wi),
            Bsdf::Mirror(b) => b.pdf(wo, wi),
            Bsdf::Plastic(b) => b.pdf(wo, wi),
            Bsdf::Phong(b) => b.pdf(wo, wi),
            Bsdf::Blinn(b) => b.pdf(wo, wi),
            Bsdf::BlinnMicrofacet(b) => b.pdf(wo, wi),
        }
    }

    /// Samples a direction: `u` picks the direction, `u_lobe` the lobe of multi-lobe models.
    /// None when nothing is scattered (the back of a one-sided model, or a proposal below the
    /// surface). The diffuse case, the common one in most scenes, is inline; the others take a
    /// call (their size keeps them out of the path loop).
    #[inline(always)]
    pub fn sample(&self, wo: Vec3A, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        match self {
            Bsdf::Diffuse(b) => b.sample(wo, u),
            _ => self.sample_other(wo, u, u_lobe),
        }
    }

    #[inline(never)]
    fn sample_other(&self, wo: Vec3A, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        match self {
            Bsdf::Diffuse(b) => b.sample(wo, u),
            Bsdf::Mirror(b) => b.sample(wo),
            Bsdf::Plastic(b) => b.sample(wo, u, u_lobe),
            Bsdf::Phong(b) => b.sample(wo, u),
            Bsdf::Blinn(b) => b.sample(wo, u),
            Bsdf::BlinnMicrofacet(b) => b.sample(wo, u),
        }
    }

    /// The lobes this BSDF has.
    pub fn flags(&self) -> BsdfFlags {
        match self {
            Bsdf::Diffuse(_) => Diffuse::FLAGS,
            Bsdf::Mirror(_) => Mirror::FLAGS,
            Bsdf::Plastic(_) => Plastic::FLAGS,
            Bsdf::Phong(_) => Phong::FLAGS,
            Bsdf::Blinn(_) => Blinn::FLAGS,
            Bsdf::BlinnMicrofacet(_) => BlinnMicrofacet::FLAGS,
        }
    }

    /// A rough measure of the angular width (radians, at most 1) of the widest non-delta lobe,
    /// for growing ray-cone spread: 0 for a mirror, 1 for diffuse and plastic's diffuse base,
    /// about the lobe's standard deviation for the glossy ones. Callers use 0 after a sample
    /// from a delta lobe.
    pub fn roughness(&self) -> f32 {
        match self {
            Bsdf::Diffuse(_) | Bsdf::Plastic(_) => 1.0,
            Bsdf::Mirror(_) => 0.0,
            Bsdf::Phong(b) => b.roughness(),
            Bsdf::Blinn(b) => b.roughness(),
            Bsdf::BlinnMicrofacet(b) => b.roughness(),
        }
    }
}

/// A material's BSDF parameters, possibly textured: what [`BsdfParams::resolve`] turns into a
/// [`Bsdf`] at a hit.
#[derive(Clone, Copy, Debug)]
pub enum BsdfParams {
    Diffuse(DiffuseParams),
    Mirror(MirrorParams),
    Plastic(PlasticParams),
    Phong(PhongParams),
    Blinn(BlinnParams),
    BlinnMicrofacet(BlinnMicrofacetParams),
}

impl BsdfParams {
    /// The parser's description with its textures resolved to the scene's texture indices.
    pub fn from_desc(kind: &BsdfKind) -> Self {
        let color = |c: &ColorParam| match c {
            ColorParam::Constant(v) => ColorSource::Constant((*v).into()),
            ColorParam::Texture(t) => ColorSource::Texture(*t as u32),
        };
        let float = FloatSource::Constant;
        match kind {
            BsdfKind::Diffuse { reflectance } => BsdfParams::Diffuse(DiffuseParams {
                reflectance: color(reflectance),
            }),
            BsdfKind::Mirror { reflectance } => BsdfParams::Mirror(MirrorParams {
                reflectance: color(reflectance),
            }),
            BsdfKind::Plastic { reflectance, eta } => BsdfParams::Plastic(PlasticParams {
                reflectance: color(reflectance),
                eta: *eta,
            }),
            BsdfKind::Phong {
                reflectance,
                exponent,
            } => BsdfParams::Phong(PhongParams {
                reflectance: color(reflectance),
                exponent: float(*exponent),
            }),
            BsdfKind::Blinn {
                reflectance,
                exponent,
            } => BsdfParams::Blinn(BlinnParams {
                reflectance: color(reflectance),
                exponent: float(*exponent),
            }),
            BsdfKind::BlinnMicrofacet {
                reflectance,
                exponent,
            } => BsdfParams::BlinnMicrofacet(BlinnMicrofacetParams {
                reflectance: color(reflectance),
                exponent: float(*exponent),
            }),
        }
    }

    /// The BSDF at a hit whose textures `q` looks up.
    #[inline(always)]
    pub fn resolve(&self, q: &TextureQuery) -> Bsdf {
        match self {
            BsdfParams::Diffuse(p) => Bsdf::Diffuse(p.resolve(q)),
            BsdfParams::Mirror(p) => Bsdf::Mirror(p.resolve(q)),
            BsdfParams::Plastic(p) => Bsdf::Plastic(p.resolve(q)),
            BsdfParams::Phong(p) => Bsdf::Phong(p.resolve(q)),
            BsdfParams::Blinn(p) => Bsdf::Blinn(p.resolve(q)),
            BsdfParams::BlinnMicrofacet(p) => Bsdf::BlinnMicrofacet(p.resolve(q)),
        }
    }

    /// Whether resolving reads any texture (then the hit needs uv and a footprint).
    pub fn is_textured(&self) -> bool {
        match self {
            BsdfParams::Diffuse(p) => p.reflectance.is_textured(),
            BsdfParams::Mirror(p) => p.reflectance.is_textured(),
            BsdfParams::Plastic(p) => p.reflectance.is_textured(),
            BsdfParams::Phong(p) => p.reflectance.is_textured() || p.exponent.is_textured(),
            BsdfParams::Blinn(p) => p.reflectance.is_textured() || p.exponent.is_textured(),
            BsdfParams::BlinnMicrofacet(p) => {
                p.reflectance.is_textured() || p.exponent.is_textured()
            }
        }
    }
}

/// What a viewer behind a surface (wo.z < 0) sees.
#[derive(Clone, Copy, Debug)]
pub enum BackSide {
    /// The front BSDF itself decides (black for the reflection-only models; a dielectric
    /// refracts).
    Front,
    /// The front BSDF with both directions mirrored to the front (Mitsuba's `twosided` with one
    /// BSDF, every material of a torrey-dialect scene).
    Mirrored,
}

/// A BSDF at a hit with its sidedness.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceBsdf {
    pub front: Bsdf,
    pub back: BackSide,
}

/// `w` mirrored through the tangent plane.
#[inline(always)]
fn flip_z(w: Vec3A) -> Vec3A {
    Vec3A::new(w.x, w.y, -w.z)
}

impl SurfaceBsdf {
    /// The BSDF facing `wo`, and whether directions must be mirrored for it.
    #[inline(always)]
    fn side(&self, wo: Vec3A) -> (&Bsdf, bool) {
        if wo.z < 0.0 {
            match &self.back {
                BackSide::Front => {}
                BackSide::Mirrored => return (&self.front, true),
            }
        }
        (&self.front, false)
    }

    #[inline(always)]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Vec3A {
        match self.side(wo) {
            (b, false) => b.eval(wo, wi),
            (b, true) => b.eval(flip_z(wo), flip_z(wi)),
        }
    }

    #[inline(always)]
    pub fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        match self.side(wo) {
            (b, false) => b.pdf(wo, wi),
            (b, true) => b.pdf(flip_z(wo), flip_z(wi)),
        }
    }

    #[inline(always)]
    pub fn sample(&self, wo: Vec3A, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        match self.side(wo) {
            (b, false) => b.sample(wo, u, u_lobe),
            (b, true) => b.sample(flip_z(wo), u, u_lobe).map(|s| BsdfSample {
                wi: flip_z(s.wi),
                ..s
            }),
        }
    }

    /// The lobes seen from `wo`'s side.
    #[inline(always)]
    pub fn flags(&self, wo: Vec3A) -> BsdfFlags {
        self.side(wo).0.flags()
    }

    /// [`Bsdf::roughness`] of the side `wo` sees.
    #[inline(always)]
    pub fn roughness(&self, wo: Vec3A) -> f32 {
        self.side(wo).0.roughness()
    }
}
