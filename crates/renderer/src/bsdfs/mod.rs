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
mod perturbed;
mod phong;
mod plastic;
mod principled;
mod principled_lobes;
mod principled_thin;
mod rough_conductor;
mod rough_dielectric;
mod rough_plastic;
mod smooth_plastic;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_mitsuba;
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
pub use perturbed::Perturbation;
pub use phong::{Phong, PhongParams};
pub use plastic::{Plastic, PlasticParams};
pub use principled::{Principled, PrincipledParams};
pub use principled_thin::{PrincipledThin, PrincipledThinParams};
pub use rough_conductor::{RoughConductor, RoughConductorParams};
pub use rough_dielectric::{RoughDielectric, RoughDielectricParams};
pub use rough_plastic::{RoughPlastic, RoughPlasticParams};
pub use smooth_plastic::{specular_sampling_weight, SmoothPlastic, SmoothPlasticParams};

use crate::textures::{ColorSource, FloatSource, TextureQuery};
use glam::{Vec2, Vec3A};
use torrey_parser::scene::{BsdfKind, ColorParam, MicrofacetType};

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
    /// Relative index of refraction crossed along `wi`, Mitsuba's `BSDFSample::eta`: η_t/η_i
    /// (the side `wi` enters over the side `wo` is on; 1.5 entering glass from air) for a
    /// refraction, 1 for a reflection. The integrator multiplies them up and Russian roulette
    /// uses throughput·η², as Mitsuba does (radiance is scaled by 1/η² crossing into glass).
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

    /// A crossing of a `null` surface (Mitsuba's `BSDFFlags::Null`), not a scattering.
    #[inline(always)]
    pub fn is_null(&self) -> bool {
        self.lobe.contains(BsdfFlags::NULL)
    }
}

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

/// A material's BSDF parameters, possibly textured: what [`BsdfParams::resolve`] turns into a
/// [`Bsdf`] at a hit. (`RoughPlastic` carries its 64-entry coating table inline: a scene has
/// few materials, and the per-hit BSDF only borrows it.)
#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant)]
pub enum BsdfParams {
    Diffuse(DiffuseParams),
    Mirror(MirrorParams),
    Plastic(PlasticParams),
    Phong(PhongParams),
    Blinn(BlinnParams),
    BlinnMicrofacet(BlinnMicrofacetParams),
    Dielectric(DielectricParams),
    ThinDielectric(ThinDielectricParams),
    RoughDielectric(RoughDielectricParams),
    Conductor(ConductorParams),
    RoughConductor(RoughConductorParams),
    SmoothPlastic(SmoothPlasticParams),
    RoughPlastic(RoughPlasticParams),
    Blend(BlendParams),
    Null,
    Principled(PrincipledParams),
    PrincipledThin(PrincipledThinParams),
}

impl BsdfParams {
    /// The parser's description with its textures resolved to the scene's texture indices;
    /// `torrey_dialect` picks the course's `plastic` over Mitsuba's.
    pub fn from_desc(kind: &BsdfKind, torrey_dialect: bool) -> Self {
        let color = |c: &ColorParam| match c {
            ColorParam::Constant(v) => ColorSource::Constant((*v).into()),
            ColorParam::Texture(t) => ColorSource::Texture(*t as u32),
        };
        let float = FloatSource::Constant;
        // A float parameter that may be a texture (its first channel).
        let float_tex = |c: &ColorParam| match c {
            ColorParam::Constant(v) => FloatSource::Constant(v.x),
            ColorParam::Texture(t) => FloatSource::Texture(*t as u32),
        };
        let microfacet = |d: &MicrofacetType| match d {
            MicrofacetType::Beckmann => MicrofacetKind::Beckmann,
            MicrofacetType::Ggx => MicrofacetKind::Ggx,
        };
        match kind {
            // The material takes the back apart (`Material::from_desc`); this is the front.
            BsdfKind::TwoSided { front, .. } => Self::from_desc(&front.kind, torrey_dialect),
            BsdfKind::Null => BsdfParams::Null,
            // A mask is a blend of `null` (weight 1 − opacity) and the nested bsdf.
            BsdfKind::Mask { opacity, nested } => BsdfParams::Blend(BlendParams {
                weight: float_tex(opacity),
                children: Box::new([
                    BsdfParams::Null,
                    Self::from_desc(&nested.kind, torrey_dialect),
                ]),
            }),
            BsdfKind::Blend {
                weight,
                first,
                second,
            } => BsdfParams::Blend(BlendParams {
                weight: float_tex(weight),
                children: Box::new([
                    Self::from_desc(&first.kind, torrey_dialect),
                    Self::from_desc(&second.kind, torrey_dialect),
                ]),
            }),
            BsdfKind::Plastic {
                reflectance,
                eta,
                specular_reflectance,
                nonlinear,
            } if !torrey_dialect => {
                let (d, s) = (color(reflectance), color(specular_reflectance));
                BsdfParams::SmoothPlastic(SmoothPlasticParams {
                    diffuse_reflectance: d,
                    specular_reflectance: s,
                    eta: *eta,
                    nonlinear: *nonlinear,
                    specular_sampling_weight: specular_sampling_weight(d, s),
                })
            }
            BsdfKind::Dielectric {
                eta,
                thin,
                specular_reflectance,
                specular_transmittance,
            } => {
                let p = DielectricParams {
                    eta: *eta,
                    specular_reflectance: color(specular_reflectance),
                    specular_transmittance: color(specular_transmittance),
                };
                if *thin {
                    BsdfParams::ThinDielectric(ThinDielectricParams(p))
                } else {
                    BsdfParams::Dielectric(p)
                }
            }
            BsdfKind::RoughDielectric {
                distribution,
                alpha_u,
                alpha_v,
                sample_visible,
                eta,
                specular_reflectance,
                specular_transmittance,
            } => BsdfParams::RoughDielectric(RoughDielectricParams {
                kind: microfacet(distribution),
                alpha_u: float_tex(alpha_u),
                alpha_v: float_tex(alpha_v),
                sample_visible: *sample_visible,
                eta: *eta,
                specular_reflectance: color(specular_reflectance),
                specular_transmittance: color(specular_transmittance),
            }),
            BsdfKind::Conductor {
                eta,
                k,
                specular_reflectance,
            } => BsdfParams::Conductor(ConductorParams {
                eta: color(eta),
                k: color(k),
                specular_reflectance: color(specular_reflectance),
            }),
            BsdfKind::RoughConductor {
                distribution,
                alpha_u,
                alpha_v,
                sample_visible,
                eta,
                k,
                specular_reflectance,
            } => BsdfParams::RoughConductor(RoughConductorParams {
                kind: microfacet(distribution),
                alpha_u: float_tex(alpha_u),
                alpha_v: float_tex(alpha_v),
                sample_visible: *sample_visible,
                eta: color(eta),
                k: color(k),
                specular_reflectance: color(specular_reflectance),
            }),
            BsdfKind::RoughPlastic {
                distribution,
                alpha,
                sample_visible,
                diffuse_reflectance,
                specular_reflectance,
                eta,
                nonlinear,
            } => {
                let mut p = RoughPlasticParams::new(
                    color(diffuse_reflectance),
                    color(specular_reflectance),
                    microfacet(distribution),
                    *alpha,
                    *eta,
                    *nonlinear,
                );
                p.distr.visible = *sample_visible;
                BsdfParams::RoughPlastic(p)
            }
            BsdfKind::Principled(d) => BsdfParams::Principled(PrincipledParams {
                base_color: color(&d.base_color),
                roughness: float_tex(&d.roughness),
                anisotropic: float_tex(&d.anisotropic),
                metallic: float_tex(&d.metallic),
                spec_trans: float_tex(&d.spec_trans),
                spec_tint: float_tex(&d.spec_tint),
                sheen: float_tex(&d.sheen),
                sheen_tint: float_tex(&d.sheen_tint),
                flatness: float_tex(&d.flatness),
                clearcoat: float_tex(&d.clearcoat),
                clearcoat_gloss: float_tex(&d.clearcoat_gloss),
                eta: d.eta,
                main_specular_sampling_rate: d.main_specular_sampling_rate,
                clearcoat_sampling_rate: d.clearcoat_sampling_rate,
                diffuse_reflectance_sampling_rate: d.diffuse_reflectance_sampling_rate,
            }),
            BsdfKind::PrincipledThin(d) => BsdfParams::PrincipledThin(PrincipledThinParams {
                base_color: color(&d.base_color),
                roughness: float_tex(&d.roughness),
                anisotropic: float_tex(&d.anisotropic),
                spec_trans: float_tex(&d.spec_trans),
                spec_tint: float_tex(&d.spec_tint),
                sheen: float_tex(&d.sheen),
                sheen_tint: float_tex(&d.sheen_tint),
                flatness: float_tex(&d.flatness),
                diff_trans: float_tex(&d.diff_trans),
                eta: float_tex(&d.eta),
                specular_reflectance_sampling_rate: d.specular_reflectance_sampling_rate,
                specular_transmittance_sampling_rate: d.specular_transmittance_sampling_rate,
                diffuse_reflectance_sampling_rate: d.diffuse_reflectance_sampling_rate,
                diffuse_transmittance_sampling_rate: d.diffuse_transmittance_sampling_rate,
            }),
            BsdfKind::Diffuse { reflectance } => BsdfParams::Diffuse(DiffuseParams {
                reflectance: color(reflectance),
            }),
            BsdfKind::Mirror { reflectance } => BsdfParams::Mirror(MirrorParams {
                reflectance: color(reflectance),
            }),
            BsdfKind::Plastic {
                reflectance, eta, ..
            } => BsdfParams::Plastic(PlasticParams {
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
    pub fn resolve<'a>(&'a self, q: &TextureQuery<'a>) -> Bsdf<'a> {
        match self {
            BsdfParams::Diffuse(p) => Bsdf::Diffuse(p.resolve(q)),
            BsdfParams::Mirror(p) => Bsdf::Mirror(p.resolve(q)),
            BsdfParams::Plastic(p) => Bsdf::Plastic(p.resolve(q)),
            BsdfParams::Phong(p) => Bsdf::Phong(p.resolve(q)),
            BsdfParams::Blinn(p) => Bsdf::Blinn(p.resolve(q)),
            BsdfParams::BlinnMicrofacet(p) => Bsdf::BlinnMicrofacet(p.resolve(q)),
            BsdfParams::Dielectric(p) => Bsdf::Dielectric(p.resolve(q)),
            BsdfParams::ThinDielectric(p) => Bsdf::ThinDielectric(p.resolve(q)),
            BsdfParams::RoughDielectric(p) => Bsdf::RoughDielectric(p.resolve(q)),
            BsdfParams::Conductor(p) => Bsdf::Conductor(p.resolve(q)),
            BsdfParams::RoughConductor(p) => Bsdf::RoughConductor(p.resolve(q)),
            BsdfParams::SmoothPlastic(p) => Bsdf::SmoothPlastic(p.resolve(q)),
            BsdfParams::RoughPlastic(p) => Bsdf::RoughPlastic(p.resolve(q)),
            BsdfParams::Blend(p) => Bsdf::Blend(p.resolve(q)),
            BsdfParams::Null => Bsdf::Null(Null),
            BsdfParams::Principled(p) => Bsdf::Principled(p.resolve(q)),
            BsdfParams::PrincipledThin(p) => Bsdf::PrincipledThin(p.resolve(q)),
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
            BsdfParams::Dielectric(p) | BsdfParams::ThinDielectric(ThinDielectricParams(p)) => {
                p.specular_reflectance.is_textured() || p.specular_transmittance.is_textured()
            }
            BsdfParams::RoughDielectric(p) => p.is_textured(),
            BsdfParams::Conductor(p) => p.is_textured(),
            BsdfParams::RoughConductor(p) => p.is_textured(),
            BsdfParams::SmoothPlastic(p) => p.is_textured(),
            BsdfParams::RoughPlastic(p) => p.is_textured(),
            BsdfParams::Blend(p) => p.is_textured(),
            BsdfParams::Null => false,
            BsdfParams::Principled(p) => p.is_textured(),
            BsdfParams::PrincipledThin(p) => p.is_textured(),
        }
    }

    /// Whether the model's lobes depend on the tangent's direction (α_u ≠ α_v, or textured).
    pub fn anisotropic(&self) -> bool {
        let differ = |u: &FloatSource, v: &FloatSource| match (u, v) {
            (FloatSource::Constant(a), FloatSource::Constant(b)) => a != b,
            _ => true,
        };
        // Exhaustive: a new model must say whether it reads the tangent.
        match self {
            BsdfParams::RoughConductor(p) => differ(&p.alpha_u, &p.alpha_v),
            BsdfParams::RoughDielectric(p) => differ(&p.alpha_u, &p.alpha_v),
            BsdfParams::Blend(p) => p.children.iter().any(|c| c.anisotropic()),
            BsdfParams::Principled(p) => p.anisotropic(),
            BsdfParams::PrincipledThin(p) => p.anisotropic(),
            BsdfParams::Diffuse(_)
            | BsdfParams::Mirror(_)
            | BsdfParams::Plastic(_)
            | BsdfParams::Phong(_)
            | BsdfParams::Blinn(_)
            | BsdfParams::BlinnMicrofacet(_)
            | BsdfParams::Dielectric(_)
            | BsdfParams::ThinDielectric(_)
            | BsdfParams::Conductor(_)
            | BsdfParams::SmoothPlastic(_)
            | BsdfParams::RoughPlastic(_)
            | BsdfParams::Null => false,
        }
    }

    /// Whether the model transmits light: it then handles both sides itself and a two-sided
    /// material does not mirror its back (a torrey-dialect glass must refract on the way out).
    pub fn transmits(&self) -> bool {
        // Exhaustive: a new model must say whether it transmits. (`null` passes light straight
        // through as a delta lobe but needs no back of its own: mirroring it changes nothing.)
        match self {
            BsdfParams::Dielectric(_)
            | BsdfParams::ThinDielectric(_)
            | BsdfParams::RoughDielectric(_) => true,
            BsdfParams::Blend(p) => p.children.iter().any(|c| c.transmits()),
            BsdfParams::Principled(p) => p.transmits(),
            BsdfParams::PrincipledThin(_) => true,
            BsdfParams::Diffuse(_)
            | BsdfParams::Mirror(_)
            | BsdfParams::Plastic(_)
            | BsdfParams::Phong(_)
            | BsdfParams::Blinn(_)
            | BsdfParams::BlinnMicrofacet(_)
            | BsdfParams::Conductor(_)
            | BsdfParams::RoughConductor(_)
            | BsdfParams::SmoothPlastic(_)
            | BsdfParams::RoughPlastic(_)
            | BsdfParams::Null => false,
        }
    }
}

/// What a viewer behind a surface (wo.z < 0) sees.
#[cfg(test)]
#[derive(Clone, Copy, Debug)]
pub enum BackSide<'a> {
    /// The front BSDF itself decides (black for the reflection-only models; a dielectric
    /// refracts).
    Front,
    /// The front BSDF with both directions mirrored to the front (Mitsuba's `twosided` with one
    /// BSDF, every material of a torrey-dialect scene).
    Mirrored,
    /// Another BSDF, mirrored to the front (Mitsuba's `twosided` with two).
    Other(Bsdf<'a>),
}

/// A BSDF at a hit with its sidedness. Both loops shade with [`SidedBsdf`]; this whole
/// surface is compiled for the tests only, as the reference they check [`SidedBsdf`] against.
#[cfg(test)]
#[derive(Clone, Copy, Debug)]
pub struct SurfaceBsdf<'a> {
    pub front: Bsdf<'a>,
    pub back: BackSide<'a>,
    /// Mitsuba's `normalmap` / `bumpmap` adapter (None: no tilted frame, or torrey's normal map).
    pub perturbation: Option<Perturbation>,
}

/// `w` mirrored through the tangent plane.
#[inline(always)]
fn flip_z(w: Vec3A) -> Vec3A {
    Vec3A::new(w.x, w.y, -w.z)
}

#[cfg(test)]
impl<'a> SurfaceBsdf<'a> {
    /// The BSDF facing `wo`, and whether directions must be mirrored for it.
    #[inline(always)]
    fn side(&self, wo: Vec3A) -> (&Bsdf<'a>, bool) {
        if wo.z < 0.0 {
            match &self.back {
                BackSide::Front => {}
                BackSide::Mirrored => return (&self.front, true),
                BackSide::Other(back) => return (back, true),
            }
        }
        (&self.front, false)
    }

    #[inline(always)]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Vec3A {
        let f = match self.side(wo) {
            (b, false) => b.eval(wo, wi),
            (b, true) => b.eval(flip_z(wo), flip_z(wi)),
        };
        match &self.perturbation {
            None => f,
            Some(p) => f * p.factor(wi),
        }
    }

    #[inline(always)]
    pub fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        if let Some(p) = &self.perturbation {
            if !p.same_side(wi) {
                return 0.0;
            }
        }
        match self.side(wo) {
            (b, false) => b.pdf(wo, wi),
            (b, true) => b.pdf(flip_z(wo), flip_z(wi)),
        }
    }

    #[inline(always)]
    pub fn sample(&self, wo: Vec3A, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        let s = match self.side(wo) {
            (b, false) => b.sample(wo, u, u_lobe),
            (b, true) => b.sample(flip_z(wo), u, u_lobe).map(|s| BsdfSample {
                wi: flip_z(s.wi),
                ..s
            }),
        };
        match &self.perturbation {
            None => s,
            Some(p) => s.and_then(|s| {
                let k = p.factor(s.wi);
                (k > 0.0).then(|| BsdfSample {
                    weight: s.weight * k,
                    ..s
                })
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

/// The side of a [`SurfaceBsdf`] that one viewing direction `wo` sees, chosen once per hit: what
/// the path loop shades with. Only that side's parameters are resolved (textures of the other
/// side are not looked up), the side is not decided again at every call, and it is half the size
/// of a [`SurfaceBsdf`] with a second BSDF. Every method must be given that same `wo`; they
/// return exactly what [`SurfaceBsdf`]'s do for it.
#[derive(Clone, Copy, Debug)]
pub struct SidedBsdf<'a> {
    pub bsdf: Bsdf<'a>,
    /// `wo` is behind a two-sided material: both directions are mirrored to the front for `bsdf`.
    pub mirrored: bool,
    /// Mitsuba's `normalmap` / `bumpmap` adapter, as in [`SurfaceBsdf`].
    pub perturbation: Option<Perturbation>,
}

impl SidedBsdf<'_> {
    /// `w` as `bsdf` sees it.
    #[inline(always)]
    fn local(&self, w: Vec3A) -> Vec3A {
        if self.mirrored {
            flip_z(w)
        } else {
            w
        }
    }

    #[inline(always)]
    pub fn eval(&self, wo: Vec3A, wi: Vec3A) -> Vec3A {
        let f = self.bsdf.eval(self.local(wo), self.local(wi));
        match &self.perturbation {
            None => f,
            Some(p) => f * p.factor(wi),
        }
    }

    #[inline(always)]
    pub fn pdf(&self, wo: Vec3A, wi: Vec3A) -> f32 {
        if let Some(p) = &self.perturbation {
            if !p.same_side(wi) {
                return 0.0;
            }
        }
        self.bsdf.pdf(self.local(wo), self.local(wi))
    }

    #[inline(always)]
    pub fn sample(&self, wo: Vec3A, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        let s = if self.mirrored {
            self.bsdf.sample(flip_z(wo), u, u_lobe).map(|s| BsdfSample {
                wi: flip_z(s.wi),
                ..s
            })
        } else {
            self.bsdf.sample(wo, u, u_lobe)
        };
        match &self.perturbation {
            None => s,
            Some(p) => s.and_then(|s| {
                let k = p.factor(s.wi);
                (k > 0.0).then(|| BsdfSample {
                    weight: s.weight * k,
                    ..s
                })
            }),
        }
    }

    /// The lobes of the side seen.
    #[inline(always)]
    pub fn flags(&self) -> BsdfFlags {
        self.bsdf.flags()
    }

    /// [`Bsdf::roughness`] of the side seen.
    #[inline(always)]
    pub fn roughness(&self) -> f32 {
        self.bsdf.roughness()
    }

    /// [`Bsdf::null_transmission`] of the side `wo` sees.
    pub fn null_transmission(&self, wo: Vec3A) -> Vec3A {
        self.bsdf.null_transmission(self.local(wo))
    }
}
