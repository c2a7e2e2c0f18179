//! BSDF plugins: `diffuse`, `mirror`, `plastic`, `phong`, `blinn`/`blinnphong`,
//! `blinn_microfacet`/`blinnphong_microfacet`; Mitsuba 3's `dielectric`, `thindielectric`,
//! `roughdielectric`, `conductor`, `roughconductor`, `roughplastic`; and the wrappers
//! `twosided`, `blendbsdf`, `mask`, `normalmap` and `bumpmap`, and `null`; Mitsuba 3's `principled`
//! and `principledthin`.

mod ior;
mod microfacet;
mod nested;
mod params;
mod principled;

use crate::context::{plugin_type, unknown_type, Ctx, IdTarget};
use crate::error::Result;
use crate::plugins::texture::parse_texture;
use crate::props::Props;
use crate::scene::{Bsdf, BsdfId, BsdfKind, BumpMap, ColorParam, Dialect, TextureId};
use crate::xml::Element;
use glam::Vec3;

use ior::{conductor_ior, eta_param};
use microfacet::roughness;
use nested::{nested_bsdf, nested_bsdf_value, nested_bsdfs, normal_map_param, perturb_options};
pub(crate) use params::{color_param, color_param_within, texture_ref, Bound};
use params::{float_param, glossy};
use principled::{principled, principled_thin};

/// The types this parser reads (see `torrey_parser::accepted_plugins`).
pub(crate) const KNOWN: &[&str] = &[
    "diffuse",
    "mirror",
    "plastic",
    "phong",
    "blinn",
    "blinnphong",
    "blinn_microfacet",
    "blinnphong_microfacet",
    "dielectric",
    "thindielectric",
    "roughdielectric",
    "conductor",
    "roughconductor",
    "roughplastic",
    "blendbsdf",
    "mask",
    "null",
    "twosided",
    "normalmap",
    "roughdiffuse",
    "principled",
    "principledthin",
    "bumpmap",
];

/// Parses a `<bsdf>` without adding it to the scene.
///
/// | type | name | type | default |
/// | --- | --- | --- | --- |
/// | `diffuse` | `reflectance` | colour or texture | 0.5 |
/// | `mirror` | `reflectance` | colour or texture | 1 |
/// | `plastic` | `reflectance` (Mitsuba: `diffuse_reflectance`) | colour or texture | 0.5 |
/// | `plastic` | `eta` (or `ior`) | float | 1.5 |
/// | `plastic` | `int_ior`, `ext_ior` (Mitsuba) | float or material name | 1.49, 1.000277; eta = int/ext |
/// | `plastic` (Mitsuba dialect) | `specular_reflectance` | colour or texture | 1 |
/// | `plastic` (Mitsuba dialect) | `nonlinear` | boolean | false |
/// | `dielectric`, `thindielectric`, `roughdielectric` | `int_ior`, `ext_ior` | float or name | bk7 (1.5046), air (1.000277) |
/// | same | `specular_reflectance`, `specular_transmittance` | colour or texture | 1 |
/// | `roughdielectric`, `roughconductor`, `roughplastic` | `distribution` | string | beckmann (or ggx) |
/// | same | `alpha` | float or texture (roughplastic: float) | 0.1 |
/// | `roughdielectric`, `roughconductor` | `alpha_u`, `alpha_v` | float or texture | both or neither |
/// | `roughdielectric`, `roughconductor`, `roughplastic` | `sample_visible` | boolean | true: sample the visible normals; false: D(m) cos θm |
/// | `conductor`, `roughconductor` | `material` | string (table below) | none: η 0, k 1 |
/// | same | `eta`, `k` | colour or texture | 0, 1 |
/// | same | `specular_reflectance` | colour or texture | 1 |
/// | `roughplastic` | `diffuse_reflectance` | colour or texture | 0.5 |
/// | `roughplastic` | `specular_reflectance` | colour or texture | 1 |
/// | `roughplastic` | `int_ior`, `ext_ior` | float or name | polypropylene (1.49), air |
/// | `roughplastic` | `nonlinear` | boolean | false |
/// | `phong`, `blinn`, `blinnphong`, `blinn_microfacet` | `reflectance` | colour or texture | 0.5 |
/// | same | `exponent` (or `alpha`) | float | 5 |
/// | any but wrappers | `normal_map` (or `normalmap`) | bitmap texture | none; read raw |
/// | `twosided` | nested `<bsdf>` or `<ref>` | bsdf | required; a second one is the back's |
/// | `blendbsdf` | `weight`; two nested bsdfs | float or texture; bsdfs | required: (1 − weight) first + weight second |
/// | `mask` | `opacity`; one nested bsdf | float or texture; bsdf | 0.5; required |
/// | `null` | none | | |
/// | `normalmap` | `normalmap` texture + nested bsdf | bitmap, bsdf | required |
/// | `principled`, `principledthin` | `base_color` | colour or texture | 0.5 |
/// | same | `roughness` | float or texture | 0.5 |
/// | same | `anisotropic`, `spec_trans`, `spec_tint`, `sheen`, `sheen_tint`, `flatness` | float or texture | 0 |
/// | `principled` | `metallic`, `clearcoat`, `clearcoat_gloss` | float or texture | 0 |
/// | `principled` | `eta` or `specular` (not both) | float | specular 0.5 (η = 2 / (1 − √(0.08 s)) − 1 ≈ 1.5) |
/// | `principled` | `main_specular_sampling_rate`, `clearcoat_sampling_rate`, `diffuse_reflectance_sampling_rate` | float | 1 |
/// | `principledthin` | `diff_trans` | float or texture, 0 to 2 | 0 |
/// | `principledthin` | `eta` | float or texture | 1.5 |
/// | `principledthin` | `specular_reflectance_sampling_rate`, `specular_transmittance_sampling_rate`, `diffuse_reflectance_sampling_rate`, `diffuse_transmittance_sampling_rate` | float | 1 |
/// | `bumpmap` | one nested texture (any name) + nested bsdf | float texture (bitmap: luminance), bsdf | required |
/// | `bumpmap` | `scale` | float | 1 (multiplies the height gradient) |
/// | `normalmap`, `bumpmap` | `flip_invalid_normals` | boolean | true (Mitsuba-dialect scenes) |
/// | `normalmap`, `bumpmap` | `use_shadowing_function` | boolean | true (Mitsuba-dialect scenes) |
pub(crate) fn parse_bsdf_value(ctx: &mut Ctx, elem: &Element) -> Result<Bsdf> {
    let ty = plugin_type(ctx, elem)?;
    if !KNOWN.contains(&ty) {
        return Err(unknown_type(ctx, elem, "bsdf", KNOWN));
    }
    let mut props = Props::new(ctx, elem, format!("bsdf '{ty}'"))?;
    let plain = |kind| Bsdf {
        id: None,
        kind,
        two_sided: false,
        normal_map: None,
        bump_map: None,
        perturb: Default::default(),
    };
    let mut bsdf = match ty {
        "twosided" => {
            let mut nested = nested_bsdfs(ctx, &mut props, elem, 2)?;
            if nested.len() == 2 {
                // Mitsuba's twosided with a different bsdf on the back.
                let back = nested.pop().unwrap();
                let front = nested.pop().unwrap();
                Bsdf {
                    id: None,
                    kind: BsdfKind::TwoSided {
                        front: Box::new(front),
                        back: Box::new(back),
                    },
                    two_sided: true,
                    normal_map: None,
                    bump_map: None,
                    perturb: Default::default(),
                }
            } else {
                let mut inner = nested.pop().unwrap();
                inner.two_sided = true;
                inner
            }
        }
        "normalmap" => {
            let Some(map) = normal_map_param(ctx, &mut props, &["normalmap", "normal_map"])? else {
                return Err(ctx.err(
                    elem.pos,
                    "bsdf 'normalmap' needs a bitmap <texture name=\"normalmap\">",
                ));
            };
            let mut inner = nested_bsdf(ctx, &mut props, elem)?;
            if inner.normal_map.is_some() || inner.bump_map.is_some() {
                return Err(ctx.err(
                    elem.pos,
                    "bsdf 'normalmap' around a bsdf that is already normal- or bump-mapped is not supported",
                ));
            }
            inner.normal_map = Some(map);
            inner.perturb = perturb_options(ctx, &mut props)?;
            inner
        }
        "bumpmap" => {
            let scale = props.float(ctx, &["scale"], 1.0)?;
            let perturb = perturb_options(ctx, &mut props)?;
            // The height field: the one nested <texture> (any name) or a <ref> to a texture.
            let mut heights: Vec<TextureId> = Vec::new();
            for e in props.take_tag("texture") {
                heights.push(parse_texture(ctx, e)?);
            }
            let mut bsdf_refs = Vec::new();
            for e in props.take_tag("ref") {
                match ctx.lookup(e)? {
                    IdTarget::Texture(t) => heights.push(t),
                    _ => bsdf_refs.push(e),
                }
            }
            if heights.len() != 1 {
                return Err(ctx.err(
                    elem.pos,
                    format!(
                        "bsdf 'bumpmap' needs exactly one nested height <texture>, found {}",
                        heights.len()
                    ),
                ));
            }
            let mut nested: Vec<&Element> = props.take_tag("bsdf");
            nested.extend(bsdf_refs);
            if nested.len() != 1 {
                return Err(ctx.err(
                    elem.pos,
                    format!(
                        "bsdf 'bumpmap' needs exactly one nested bsdf, found {}",
                        nested.len()
                    ),
                ));
            }
            let mut inner = nested_bsdf_value(ctx, nested[0])?;
            if inner.normal_map.is_some() || inner.bump_map.is_some() {
                return Err(ctx.err(
                    elem.pos,
                    "bsdf 'bumpmap' around a bsdf that is already normal- or bump-mapped is not supported",
                ));
            }
            inner.bump_map = Some(BumpMap {
                texture: heights[0],
                scale,
            });
            inner.perturb = perturb;
            inner
        }
        "diffuse" => plain(BsdfKind::Diffuse {
            reflectance: color_param(ctx, &mut props, &["reflectance"], Vec3::splat(0.5))?,
        }),
        "roughdiffuse" => {
            // Mitsuba 0.6's Oren-Nayar: read as Lambertian (alpha ignored), said once per bsdf.
            ctx.warn(
                elem.pos,
                "bsdf 'roughdiffuse' is read as 'diffuse' (its roughness is ignored)",
            );
            props.ignore(&["alpha", "use_fast_approx", "distribution"]);
            plain(BsdfKind::Diffuse {
                reflectance: color_param(ctx, &mut props, &["reflectance"], Vec3::splat(0.5))?,
            })
        }
        "mirror" => plain(BsdfKind::Mirror {
            reflectance: color_param(ctx, &mut props, &["reflectance"], Vec3::ONE)?,
        }),
        "plastic" => {
            let torrey = ctx.dialect == Dialect::Torrey;
            let mitsuba_params = props.has(&["diffuse_reflectance", "int_ior", "ext_ior"]);
            let reflectance = color_param(
                ctx,
                &mut props,
                &["reflectance", "diffuse_reflectance"],
                Vec3::splat(0.5),
            )?;
            let eta = match props.opt_float_pos(ctx, &["eta", "ior"])? {
                Some((eta, pos)) if eta.is_nan() || eta <= 0.0 => {
                    return Err(ctx.err(
                        pos,
                        format!("parameter 'eta' of bsdf 'plastic' must be positive, found {eta}"),
                    ))
                }
                Some((eta, _)) => eta,
                None if mitsuba_params || !torrey => eta_param(ctx, &mut props, elem, 1.49)?,
                None => 1.5,
            };
            let specular_reflectance =
                color_param(ctx, &mut props, &["specular_reflectance"], Vec3::ONE)?;
            let nonlinear = props.boolean(ctx, &["nonlinear"], false)?;
            if mitsuba_params && torrey {
                ctx.warn(
                    elem.pos,
                    "in a torrey-dialect scene plastic is the course's model (a Schlick-Fresnel-weighted mirror over a diffuse base), not Mitsuba 3's; diffuse_reflectance is used as reflectance and eta = int_ior / ext_ior",
                );
            }
            plain(BsdfKind::Plastic {
                reflectance,
                eta,
                specular_reflectance,
                nonlinear,
            })
        }
        "blendbsdf" => {
            if !props.has(&["weight"]) {
                return Err(ctx.err(
                    elem.pos,
                    "bsdf 'blendbsdf' needs a weight (float or texture)",
                ));
            }
            let weight = float_param(ctx, &mut props, &["weight"], 0.5, Bound::Fraction)?;
            let mut nested = nested_bsdfs(ctx, &mut props, elem, 2)?;
            if nested.len() != 2 {
                return Err(ctx.err(elem.pos, "bsdf 'blendbsdf' needs two nested bsdfs"));
            }
            let second = nested.pop().unwrap();
            let first = nested.pop().unwrap();
            plain(BsdfKind::Blend {
                weight,
                first: Box::new(first),
                second: Box::new(second),
            })
        }
        "null" => plain(BsdfKind::Null),
        "principled" => plain(BsdfKind::Principled(Box::new(principled(
            ctx, &mut props, elem,
        )?))),
        "principledthin" => plain(BsdfKind::PrincipledThin(Box::new(principled_thin(
            ctx, &mut props,
        )?))),
        "mask" => {
            let opacity = float_param(ctx, &mut props, &["opacity"], 0.5, Bound::Fraction)?;
            let mut nested = nested_bsdfs(ctx, &mut props, elem, 1)?;
            plain(BsdfKind::Mask {
                opacity,
                nested: Box::new(nested.pop().unwrap()),
            })
        }
        "dielectric" | "thindielectric" => plain(BsdfKind::Dielectric {
            eta: eta_param(ctx, &mut props, elem, 1.5046)?,
            thin: ty == "thindielectric",
            specular_reflectance: color_param(
                ctx,
                &mut props,
                &["specular_reflectance"],
                Vec3::ONE,
            )?,
            specular_transmittance: color_param(
                ctx,
                &mut props,
                &["specular_transmittance"],
                Vec3::ONE,
            )?,
        }),
        "roughdielectric" => {
            let (distribution, alpha_u, alpha_v, sample_visible) =
                roughness(ctx, &mut props, elem, true)?;
            plain(BsdfKind::RoughDielectric {
                distribution,
                alpha_u,
                alpha_v,
                sample_visible,
                eta: eta_param(ctx, &mut props, elem, 1.5046)?,
                specular_reflectance: color_param(
                    ctx,
                    &mut props,
                    &["specular_reflectance"],
                    Vec3::ONE,
                )?,
                specular_transmittance: color_param(
                    ctx,
                    &mut props,
                    &["specular_transmittance"],
                    Vec3::ONE,
                )?,
            })
        }
        "conductor" => {
            let (eta, k) = conductor_ior(ctx, &mut props)?;
            plain(BsdfKind::Conductor {
                eta,
                k,
                specular_reflectance: color_param(
                    ctx,
                    &mut props,
                    &["specular_reflectance"],
                    Vec3::ONE,
                )?,
            })
        }
        "roughconductor" => {
            let (distribution, alpha_u, alpha_v, sample_visible) =
                roughness(ctx, &mut props, elem, true)?;
            let (eta, k) = conductor_ior(ctx, &mut props)?;
            plain(BsdfKind::RoughConductor {
                distribution,
                alpha_u,
                alpha_v,
                sample_visible,
                eta,
                k,
                specular_reflectance: color_param(
                    ctx,
                    &mut props,
                    &["specular_reflectance"],
                    Vec3::ONE,
                )?,
            })
        }
        "roughplastic" => {
            let (distribution, alpha, _, sample_visible) = roughness(ctx, &mut props, elem, false)?;
            let ColorParam::Constant(alpha) = alpha else {
                return Err(ctx.err(
                    elem.pos,
                    "bsdf 'roughplastic': alpha must be a number (Mitsuba does not texture it)",
                ));
            };
            plain(BsdfKind::RoughPlastic {
                distribution,
                alpha: alpha.x,
                sample_visible,
                diffuse_reflectance: color_param(
                    ctx,
                    &mut props,
                    &["diffuse_reflectance", "reflectance"],
                    Vec3::splat(0.5),
                )?,
                specular_reflectance: color_param(
                    ctx,
                    &mut props,
                    &["specular_reflectance"],
                    Vec3::ONE,
                )?,
                eta: eta_param(ctx, &mut props, elem, 1.49)?,
                nonlinear: props.boolean(ctx, &["nonlinear"], false)?,
            })
        }
        "phong" => {
            let (reflectance, exponent) = glossy(ctx, &mut props)?;
            plain(BsdfKind::Phong {
                reflectance,
                exponent,
            })
        }
        "blinn" | "blinnphong" => {
            let (reflectance, exponent) = glossy(ctx, &mut props)?;
            plain(BsdfKind::Blinn {
                reflectance,
                exponent,
            })
        }
        _ => {
            let (reflectance, exponent) = glossy(ctx, &mut props)?;
            plain(BsdfKind::BlinnMicrofacet {
                reflectance,
                exponent,
            })
        }
    };
    if ty != "twosided" && ty != "normalmap" && ty != "bumpmap" {
        if let Some(map) = normal_map_param(ctx, &mut props, &["normal_map", "normalmap"])? {
            bsdf.normal_map = Some(map);
        }
    }
    bsdf.id = elem.attr_value("id").map(String::from);
    props.finish(ctx);
    Ok(bsdf)
}

/// Parses a `<bsdf>`, adds it to the scene and registers its id.
pub(crate) fn parse_bsdf(ctx: &mut Ctx, elem: &Element) -> Result<BsdfId> {
    if let Some(IdTarget::Bsdf(b)) = ctx.already(elem) {
        // A `<ref>` made us parse it before its place in the document.
        return Ok(b);
    }
    ctx.texture_uses.push(Vec::new());
    let bsdf = parse_bsdf_value(ctx, elem);
    let uses = ctx.texture_uses.pop().unwrap_or_default();
    let bsdf = bsdf?;
    ctx.bsdfs.push(bsdf);
    let index = ctx.bsdfs.len() - 1;
    ctx.bsdf_textures.insert(index, uses);
    ctx.register_id(elem, IdTarget::Bsdf(index))?;
    Ok(index)
}
