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
//!   two-sidedness (Mitsuba's `twosided`, every material of a torrey-dialect scene);
//!   [`SidedBsdf`] is the one side of it that a given `wo` sees, which the path loop shades with.
//! - `eval` returns f(wo, wi)·|cos θi| for the non-delta lobes, `pdf` the solid-angle density of
//!   `sample` producing `wi`, and `sample` a [`BsdfSample`] with its weight f·|cos θi|/pdf, the
//!   relative index of refraction along the sampled direction and the sampled lobe's flags.
//!
//! Two families of models: torrey's own materials as the UCSD CSE 168 course defines them
//! (handouts homework3.tex: Schlick Fresnel, `mirror`, `plastic`; homework4.tex: `phong`,
//! `blinnphong`, `blinn_microfacet`; the course's ρ already includes the cosine of the light
//! direction, so `eval` returns exactly that ρ), and Mitsuba 3's (`dielectric`,
//! `thindielectric`, `roughdielectric`, `conductor`, `roughconductor`, Mitsuba's `plastic` and
//! `roughplastic`, `principled` and `principledthin`) with its parameters, defaults and conventions (exact Fresnel, microfacet
//! models in [`microfacet`]).
//!
//! A new BSDF is a file (parameters, `resolve`, `eval`/`pdf`/`sample`, its tests), a variant in
//! [`Bsdf`] and [`BsdfParams`] with one-line arms, the parser mapping and the docs.

// Comparisons are written `!(x > 0.0)` on purpose: they also reject NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod blend;
mod blinn;
mod blinn_microfacet;
mod conductor;
mod dielectric;
mod diffuse;
mod flags;
pub mod fresnel;
pub mod microfacet;
mod mirror;
mod null;
mod params;
mod perturbed;
mod phong;
mod plastic;
mod principled;
mod principled_lobes;
mod principled_thin;
mod rough_conductor;
mod rough_dielectric;
mod rough_plastic;
mod sample;
mod sided;
mod smooth_plastic;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_mitsuba;
#[cfg(test)]
mod tests_mitsuba_values;
#[cfg(test)]
mod tests_principled;

pub use blend::{Blend, BlendParams};
pub use blinn::{Blinn, BlinnParams};
pub use blinn_microfacet::{BlinnMicrofacet, BlinnMicrofacetParams};
pub use conductor::{Conductor, ConductorParams};
pub use dielectric::{Dielectric, DielectricParams, ThinDielectric, ThinDielectricParams};
pub use diffuse::{Diffuse, DiffuseParams};
pub use flags::BsdfFlags;
pub use microfacet::MicrofacetKind;
pub use mirror::{Mirror, MirrorParams};
pub use null::Null;
pub use params::BsdfParams;
pub use perturbed::Perturbation;
pub use phong::{Phong, PhongParams};
pub use plastic::{Plastic, PlasticParams};
pub use principled::{Principled, PrincipledParams};
pub use principled_thin::{PrincipledThin, PrincipledThinParams};
pub use rough_conductor::{RoughConductor, RoughConductorParams};
pub use rough_dielectric::{RoughDielectric, RoughDielectricParams};
pub use rough_plastic::{RoughPlastic, RoughPlasticParams};
pub use sample::BsdfSample;
pub use sided::SidedBsdf;
#[cfg(test)]
pub use sided::{BackSide, SurfaceBsdf};
pub use smooth_plastic::{specular_sampling_weight, SmoothPlastic, SmoothPlasticParams};

use glam::{Vec2, Vec3A};

/// Mirror reflection of a local direction about the shading normal (+z).
#[inline(always)]
fn reflect_z(w: Vec3A) -> Vec3A {
    Vec3A::new(-w.x, -w.y, w.z)
}

/// A BSDF at a hit, with plain (resolved) parameters; it may borrow tables from its material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bsdf<'a> {
    Diffuse(Diffuse),
    Mirror(Mirror),
    Plastic(Plastic),
    Phong(Phong),
    Blinn(Blinn),
    BlinnMicrofacet(BlinnMicrofacet),
    Dielectric(Dielectric),
    ThinDielectric(ThinDielectric),
    RoughDielectric(RoughDielectric),
    Conductor(Conductor),
    RoughConductor(RoughConductor),
    SmoothPlastic(SmoothPlastic),
    RoughPlastic(RoughPlastic<'a>),
    Blend(Blend<'a>),
    Null(Null),
    Principled(Principled<'a>),
    PrincipledThin(PrincipledThin<'a>),
}

impl Bsdf<'_> {
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
            Bsdf::Dielectric(b) => b.eval(wo, wi),
            Bsdf::ThinDielectric(b) => b.eval(wo, wi),
            Bsdf::RoughDielectric(b) => b.eval(wo, wi),
            Bsdf::Conductor(b) => b.eval(wo, wi),
            Bsdf::RoughConductor(b) => b.eval(wo, wi),
            Bsdf::SmoothPlastic(b) => b.eval(wo, wi),
            Bsdf::RoughPlastic(b) => b.eval(wo, wi),
            Bsdf::Blend(b) => b.eval(wo, wi),
            Bsdf::Null(b) => b.eval(wo, wi),
            Bsdf::Principled(b) => b.eval(wo, wi),
            Bsdf::PrincipledThin(b) => b.eval(wo, wi),
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
            Bsdf::Dielectric(b) => b.pdf(wo, wi),
            Bsdf::ThinDielectric(b) => b.pdf(wo, wi),
            Bsdf::RoughDielectric(b) => b.pdf(wo, wi),
            Bsdf::Conductor(b) => b.pdf(wo, wi),
            Bsdf::RoughConductor(b) => b.pdf(wo, wi),
            Bsdf::SmoothPlastic(b) => b.pdf(wo, wi),
            Bsdf::RoughPlastic(b) => b.pdf(wo, wi),
            Bsdf::Blend(b) => b.pdf(wo, wi),
            Bsdf::Null(b) => b.pdf(wo, wi),
            Bsdf::Principled(b) => b.pdf(wo, wi),
            Bsdf::PrincipledThin(b) => b.pdf(wo, wi),
        }
    }

    /// [`Bsdf::eval`] and [`Bsdf::pdf`] together (the same bits): the microfacet models share
    /// their half vector, D and F between the two, which next-event estimation needs both of.
    #[inline(always)]
    pub fn eval_pdf(&self, wo: Vec3A, wi: Vec3A) -> (Vec3A, f32) {
        match self {
            Bsdf::RoughDielectric(b) => b.eval_pdf(wo, wi),
            Bsdf::RoughConductor(b) => b.eval_pdf(wo, wi),
            Bsdf::RoughPlastic(b) => b.eval_pdf(wo, wi),
            _ => (self.eval(wo, wi), self.pdf(wo, wi)),
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
            Bsdf::Dielectric(b) => b.sample(wo, u_lobe),
            Bsdf::ThinDielectric(b) => b.sample(wo, u_lobe),
            Bsdf::RoughDielectric(b) => b.sample(wo, u, u_lobe),
            Bsdf::Conductor(b) => b.sample(wo),
            Bsdf::RoughConductor(b) => b.sample(wo, u),
            Bsdf::SmoothPlastic(b) => b.sample(wo, u, u_lobe),
            Bsdf::RoughPlastic(b) => b.sample(wo, u, u_lobe),
            Bsdf::Blend(b) => b.sample(wo, u, u_lobe),
            Bsdf::Null(b) => b.sample(wo),
            Bsdf::Principled(b) => b.sample(wo, u, u_lobe),
            Bsdf::PrincipledThin(b) => b.sample(wo, u, u_lobe),
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
            Bsdf::Dielectric(_) => Dielectric::FLAGS,
            Bsdf::ThinDielectric(_) => ThinDielectric::FLAGS,
            Bsdf::RoughDielectric(_) => RoughDielectric::FLAGS,
            Bsdf::Conductor(_) => Conductor::FLAGS,
            Bsdf::RoughConductor(_) => RoughConductor::FLAGS,
            Bsdf::SmoothPlastic(_) => SmoothPlastic::FLAGS,
            Bsdf::RoughPlastic(_) => RoughPlastic::FLAGS,
            Bsdf::Blend(b) => b.flags(),
            Bsdf::Null(_) => Null::FLAGS,
            Bsdf::Principled(b) => b.flags(),
            Bsdf::PrincipledThin(_) => PrincipledThin::FLAGS,
        }
    }

    /// A rough measure of the angular width (radians, at most 1) of the widest non-delta lobe,
    /// for growing ray-cone spread: 0 for a mirror, 1 for diffuse and plastic's diffuse base,
    /// about the lobe's standard deviation for the glossy ones. Callers use 0 after a sample
    /// from a delta lobe.
    pub fn roughness(&self) -> f32 {
        match self {
            Bsdf::Diffuse(_) | Bsdf::Plastic(_) | Bsdf::SmoothPlastic(_) => 1.0,
            Bsdf::Mirror(_)
            | Bsdf::Dielectric(_)
            | Bsdf::ThinDielectric(_)
            | Bsdf::Conductor(_)
            | Bsdf::Null(_) => 0.0,
            Bsdf::RoughDielectric(b) => b.roughness(),
            Bsdf::RoughConductor(b) => b.roughness(),
            Bsdf::RoughPlastic(b) => b.roughness(),
            Bsdf::Blend(b) => b.roughness(),
            Bsdf::Phong(b) => b.roughness(),
            Bsdf::Blinn(b) => b.roughness(),
            Bsdf::BlinnMicrofacet(b) => b.roughness(),
            Bsdf::Principled(b) => b.roughness(),
            Bsdf::PrincipledThin(b) => b.roughness(),
        }
    }
}
