//! Bsdfs: the models, their parameters and the normal and bump maps.

use super::{ColorParam, TextureId};

#[derive(Clone, Debug, PartialEq)]
pub struct Bsdf {
    pub id: Option<String>,
    pub kind: BsdfKind,
    /// Wrapped in `twosided`. In torrey-dialect scenes every bsdf is two-sided anyway.
    pub two_sided: bool,
    /// Tangent-space normal map (a raw bitmap texture), from the seed dialect's
    /// `<texture name="normal_map">` or Mitsuba 3's `normalmap` wrapper.
    pub normal_map: Option<TextureId>,
    /// Mitsuba 3's `bumpmap` wrapper.
    pub bump_map: Option<BumpMap>,
    /// The options of Mitsuba 3's `normalmap` and `bumpmap` wrappers.
    pub perturb: PerturbOptions,
}

/// Mitsuba 3's `bumpmap`: a height texture whose uv gradient, times `scale`, tilts the
/// shading normal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BumpMap {
    pub texture: TextureId,
    pub scale: f32,
}

/// What Mitsuba 3's `normalmap` and `bumpmap` do besides tilting the normal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PerturbOptions {
    /// `flip_invalid_normals` (default true): a tilted normal that the incident direction sees
    /// from the other side is mirrored about the unperturbed normal.
    pub flip_invalid_normals: bool,
    /// `use_shadowing_function` (default true): Estevez et al.'s microfacet shadowing term.
    pub use_shadowing_function: bool,
}

impl Default for PerturbOptions {
    fn default() -> Self {
        Self {
            flip_invalid_normals: true,
            use_shadowing_function: true,
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum BsdfKind {
    Diffuse {
        reflectance: ColorParam,
    },
    /// torrey's mirror: perfect reflection weighted by Schlick Fresnel with F0 = reflectance.
    Mirror {
        reflectance: ColorParam,
    },
    /// `plastic`: in torrey-dialect scenes the course's Schlick-Fresnel (F0 from `eta`)
    /// weighted mirror over a diffuse base; in Mitsuba-dialect scenes Mitsuba's smooth plastic
    /// (`reflectance` is its diffuse_reflectance, `eta` = int_ior / ext_ior).
    Plastic {
        reflectance: ColorParam,
        eta: f32,
        /// Mitsuba's specular_reflectance (1 by default).
        specular_reflectance: ColorParam,
        /// Mitsuba's `nonlinear`.
        nonlinear: bool,
    },
    /// Normalised Phong lobe around the mirror direction: reflectance (a+1)/(2pi) cos^a.
    Phong {
        reflectance: ColorParam,
        exponent: f32,
    },
    /// Normalised Blinn-Phong: reflectance (a+2)/(4pi(2-2^(-a/2))) (n.h)^a.
    Blinn {
        reflectance: ColorParam,
        exponent: f32,
    },
    /// Microfacet with a Blinn distribution, Schlick Fresnel (F0 = reflectance) and Walter et
    /// al.'s rational Smith shadowing fit.
    BlinnMicrofacet {
        reflectance: ColorParam,
        exponent: f32,
    },
    /// Mitsuba's `dielectric` (`thin`: `thindielectric`); `eta` = int_ior / ext_ior.
    Dielectric {
        eta: f32,
        thin: bool,
        specular_reflectance: ColorParam,
        specular_transmittance: ColorParam,
    },
    /// Mitsuba's `roughdielectric`. Float parameters that may be textured are `ColorParam`s
    /// whose first channel is read.
    RoughDielectric {
        distribution: MicrofacetType,
        alpha_u: ColorParam,
        alpha_v: ColorParam,
        /// Mitsuba's `sample_visible`: sample the visible normals (true) or D(m) cos θm.
        sample_visible: bool,
        eta: f32,
        specular_reflectance: ColorParam,
        specular_transmittance: ColorParam,
    },
    /// Mitsuba's `conductor`: complex IOR eta + i k relative to the outside.
    Conductor {
        eta: ColorParam,
        k: ColorParam,
        specular_reflectance: ColorParam,
    },
    /// Mitsuba's `roughconductor`.
    RoughConductor {
        distribution: MicrofacetType,
        alpha_u: ColorParam,
        alpha_v: ColorParam,
        /// Mitsuba's `sample_visible`: sample the visible normals (true) or D(m) cos θm.
        sample_visible: bool,
        eta: ColorParam,
        k: ColorParam,
        specular_reflectance: ColorParam,
    },
    /// Mitsuba's `twosided` with two nested bsdfs: `front` seen from the normal's side,
    /// `back` from the other (evaluated with directions mirrored to its front).
    TwoSided {
        front: Box<Bsdf>,
        back: Box<Bsdf>,
    },
    /// Mitsuba's `blendbsdf`: (1 − weight) · first + weight · second.
    Blend {
        weight: ColorParam,
        first: Box<Bsdf>,
        second: Box<Bsdf>,
    },
    /// Mitsuba's `null`: an invisible surface; rays pass straight through (a bounce).
    Null,
    /// Mitsuba's `mask`: `nested` with probability `opacity`, else passed through as `null`.
    Mask {
        opacity: ColorParam,
        nested: Box<Bsdf>,
    },
    /// Mitsuba's `roughplastic` (isotropic).
    RoughPlastic {
        distribution: MicrofacetType,
        alpha: f32,
        /// Mitsuba's `sample_visible`.
        sample_visible: bool,
        diffuse_reflectance: ColorParam,
        specular_reflectance: ColorParam,
        eta: f32,
        nonlinear: bool,
    },
    /// Mitsuba's `principled` (the Disney BSDF).
    Principled(Box<PrincipledDesc>),
    /// Mitsuba's `principledthin` (the thin-sheet Disney BSDF).
    PrincipledThin(Box<PrincipledThinDesc>),
}

/// Mitsuba's `principled` parameters; the float ones may be textures (first channel).
#[derive(Clone, Debug, PartialEq)]
pub struct PrincipledDesc {
    pub base_color: ColorParam,
    pub roughness: ColorParam,
    pub anisotropic: ColorParam,
    pub metallic: ColorParam,
    pub spec_trans: ColorParam,
    pub spec_tint: ColorParam,
    pub sheen: ColorParam,
    pub sheen_tint: ColorParam,
    pub flatness: ColorParam,
    pub clearcoat: ColorParam,
    pub clearcoat_gloss: ColorParam,
    /// Interior/exterior IOR, given or derived from `specular`.
    pub eta: f32,
    pub main_specular_sampling_rate: f32,
    pub clearcoat_sampling_rate: f32,
    pub diffuse_reflectance_sampling_rate: f32,
}

/// Mitsuba's `principledthin` parameters; the float ones may be textures (first channel).
#[derive(Clone, Debug, PartialEq)]
pub struct PrincipledThinDesc {
    pub base_color: ColorParam,
    pub roughness: ColorParam,
    pub anisotropic: ColorParam,
    pub spec_trans: ColorParam,
    pub spec_tint: ColorParam,
    pub sheen: ColorParam,
    pub sheen_tint: ColorParam,
    pub flatness: ColorParam,
    pub diff_trans: ColorParam,
    pub eta: ColorParam,
    pub specular_reflectance_sampling_rate: f32,
    pub specular_transmittance_sampling_rate: f32,
    pub diffuse_reflectance_sampling_rate: f32,
    pub diffuse_transmittance_sampling_rate: f32,
}

/// Mitsuba's microfacet `distribution`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MicrofacetType {
    Beckmann,
    Ggx,
}
