//! A material's BSDF parameters, from the parser's description to the per-hit BSDF.

use super::{
    specular_sampling_weight, BlendParams, BlinnMicrofacetParams, BlinnParams, Bsdf,
    ConductorParams, DielectricParams, DiffuseParams, MicrofacetKind, MirrorParams, Null,
    PhongParams, PlasticParams, PrincipledParams, PrincipledThinParams, RoughConductorParams,
    RoughDielectricParams, RoughPlasticParams, SmoothPlasticParams, ThinDielectricParams,
};
use crate::textures::{ColorSource, FloatSource, TextureQuery};
use torrey_parser::scene::{BsdfKind, ColorParam, MicrofacetType};

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
