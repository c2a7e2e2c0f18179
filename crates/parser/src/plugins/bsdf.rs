//! BSDF plugins: `diffuse`, `mirror`, `plastic`, `phong`, `blinn`/`blinnphong`,
//! `blinn_microfacet`/`blinnphong_microfacet`, and the wrappers `twosided` and `normalmap`.

use crate::context::{plugin_type, unknown_type, Ctx, IdTarget};
use crate::error::Result;
use crate::plugins::texture::parse_texture;
use crate::props::Props;
use crate::scene::{Bsdf, BsdfId, BsdfKind, ColorParam, TextureId, TextureKind};
use crate::xml::Element;
use glam::Vec3;

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
    "twosided",
    "normalmap",
    "roughdiffuse",
];

/// Named indices of refraction Mitsuba accepts in place of a number.
const IOR_TABLE: &[(&str, f32)] = &[
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.333),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.575),
    ("diamond", 2.419),
];

/// A colour parameter that may be a constant (`rgb`, `srgb`, `spectrum`, `float`), an inline
/// `<texture>` or a `<ref>` to a texture.
pub(crate) fn color_param(
    ctx: &mut Ctx,
    props: &mut Props,
    names: &[&str],
    default: Vec3,
) -> Result<ColorParam> {
    let Some(e) = props.take_any(names) else {
        return Ok(ColorParam::Constant(default));
    };
    match e.tag.as_str() {
        "texture" => Ok(ColorParam::Texture(parse_texture(ctx, e)?)),
        "ref" => texture_ref(ctx, e).map(ColorParam::Texture),
        _ => {
            let c = props.color_of(ctx, e)?;
            if c.max_element() > 1.0 {
                // Renderable, but a surface reflecting more than it receives adds energy.
                let pos = e.attr("value").map_or(e.pos, |a| a.value_pos);
                ctx.warn_once(
                    "reflectance above 1",
                    pos,
                    format!(
                        "reflectance {} {} {} of {} is above 1: the surface reflects more light than it receives",
                        c.x, c.y, c.z, props.owner
                    ),
                );
            }
            Ok(ColorParam::Constant(c))
        }
    }
}

fn texture_ref(ctx: &Ctx, e: &Element) -> Result<TextureId> {
    match ctx.lookup(e)? {
        IdTarget::Texture(t) => Ok(t),
        _ => Err(ctx.err(
            e.pos,
            format!(
                "<ref id=\"{}\"> must name a texture here",
                e.attr_value("id").unwrap_or("")
            ),
        )),
    }
}

/// A normal map parameter: a bitmap texture (inline or by ref), always read raw.
fn normal_map_param(ctx: &mut Ctx, props: &mut Props, names: &[&str]) -> Result<Option<TextureId>> {
    let Some(e) = props.take_any(names) else {
        return Ok(None);
    };
    let (index, shared) = match e.tag.as_str() {
        "texture" => (parse_texture(ctx, e)?, false),
        "ref" => (texture_ref(ctx, e)?, true),
        _ => {
            return Err(ctx.err(
                e.pos,
                format!(
                    "the normal map of {} must be a bitmap <texture>, found <{}>",
                    props.owner, e.tag
                ),
            ))
        }
    };
    let TextureKind::Bitmap(b) = &ctx.textures[index].kind else {
        return Err(ctx.err(e.pos, "a normal map must be a bitmap texture"));
    };
    if b.raw {
        return Ok(Some(index));
    }
    if shared {
        // The referenced texture may also be used as a colour: keep it and add a raw copy.
        let mut copy = ctx.textures[index].clone();
        copy.id = None;
        if let TextureKind::Bitmap(b) = &mut copy.kind {
            b.raw = true;
        }
        ctx.textures.push(copy);
        return Ok(Some(ctx.textures.len() - 1));
    }
    if let TextureKind::Bitmap(b) = &mut ctx.textures[index].kind {
        b.raw = true;
    }
    Ok(Some(index))
}

/// The bsdf inside `twosided`/`normalmap`: a nested `<bsdf>` or a `<ref>` to one.
fn nested_bsdf(ctx: &mut Ctx, props: &mut Props, elem: &Element) -> Result<Bsdf> {
    let mut nested: Vec<&Element> = props.take_tag("bsdf");
    nested.extend(props.take_tag("ref"));
    nested.sort_by_key(|e| (e.pos.line, e.pos.column));
    let Some(first) = nested.first() else {
        return Err(ctx.err(elem.pos, format!("{} needs a nested <bsdf>", props.owner)));
    };
    for extra in &nested[1..] {
        ctx.warn(
            extra.pos,
            format!(
                "{} uses only its first nested bsdf; this one is ignored",
                props.owner
            ),
        );
    }
    if first.tag == "ref" {
        match ctx.lookup(first)? {
            IdTarget::Bsdf(b) => Ok(ctx.bsdfs[b].clone()),
            _ => Err(ctx.err(
                first.pos,
                format!(
                    "<ref id=\"{}\"> must name a bsdf here",
                    first.attr_value("id").unwrap_or("")
                ),
            )),
        }
    } else {
        parse_bsdf_value(ctx, first)
    }
}

/// A Mitsuba index of refraction: a number or a material name from [`IOR_TABLE`].
fn ior(ctx: &Ctx, props: &mut Props, name: &str, default: f32) -> Result<f32> {
    if let Some(a) = props.clone_string_if(name) {
        let key = a.value.to_ascii_lowercase();
        return IOR_TABLE
            .iter()
            .find(|(n, _)| *n == key)
            .map(|(_, v)| *v)
            .ok_or_else(|| {
                ctx.err(
                    a.value_pos,
                    format!("unknown index of refraction '{}'", a.value),
                )
            });
    }
    props.float_where(ctx, &[name], default, "positive", |v| v > 0.0)
}

fn glossy(ctx: &mut Ctx, props: &mut Props) -> Result<(ColorParam, f32)> {
    let reflectance = color_param(ctx, props, &["reflectance"], Vec3::splat(0.5))?;
    let exponent =
        props.float_where(ctx, &["exponent", "alpha"], 5.0, "at least 0", |v| v >= 0.0)?;
    Ok((reflectance, exponent))
}

/// Parses a `<bsdf>` without adding it to the scene.
///
/// | type | name | type | default |
/// | --- | --- | --- | --- |
/// | `diffuse` | `reflectance` | colour or texture | 0.5 |
/// | `mirror` | `reflectance` | colour or texture | 1 |
/// | `plastic` | `reflectance` (Mitsuba: `diffuse_reflectance`) | colour or texture | 0.5 |
/// | `plastic` | `eta` (or `ior`) | float | 1.5 |
/// | `plastic` | `int_ior`, `ext_ior` (Mitsuba) | float or material name | 1.49, 1.000277; eta = int/ext |
/// | `phong`, `blinn`, `blinnphong`, `blinn_microfacet` | `reflectance` | colour or texture | 0.5 |
/// | same | `exponent` (or `alpha`) | float | 5 |
/// | any but wrappers | `normal_map` (or `normalmap`) | bitmap texture | none; read raw |
/// | `twosided` | nested `<bsdf>` or `<ref>` | bsdf | required |
/// | `normalmap` | `normalmap` texture + nested bsdf | bitmap, bsdf | required |
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
    };
    let mut bsdf = match ty {
        "twosided" => {
            let mut inner = nested_bsdf(ctx, &mut props, elem)?;
            inner.two_sided = true;
            inner
        }
        "normalmap" => {
            let Some(map) = normal_map_param(ctx, &mut props, &["normalmap", "normal_map"])? else {
                return Err(ctx.err(
                    elem.pos,
                    "bsdf 'normalmap' needs a bitmap <texture name=\"normalmap\">",
                ));
            };
            let mut inner = nested_bsdf(ctx, &mut props, elem)?;
            inner.normal_map = Some(map);
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
            let mitsuba = props.has(&["diffuse_reflectance", "int_ior", "ext_ior"]);
            let reflectance = color_param(
                ctx,
                &mut props,
                &["reflectance", "diffuse_reflectance"],
                Vec3::splat(0.5),
            )?;
            let eta = match props.opt_float_pos(ctx, &["eta", "ior"])? {
                Some((eta, pos)) if eta <= 0.0 => {
                    return Err(ctx.err(
                        pos,
                        format!("parameter 'eta' of bsdf 'plastic' must be positive, found {eta}"),
                    ))
                }
                Some((eta, _)) => eta,
                None if mitsuba => {
                    ior(ctx, &mut props, "int_ior", 1.49)?
                        / ior(ctx, &mut props, "ext_ior", 1.000277)?
                }
                None => 1.5,
            };
            if mitsuba {
                ctx.warn(
                    elem.pos,
                    "torrey's plastic (a Schlick-Fresnel-weighted mirror over a diffuse base) differs from Mitsuba 3's plastic; diffuse_reflectance is used as reflectance and eta = int_ior / ext_ior",
                );
            }
            plain(BsdfKind::Plastic { reflectance, eta })
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
    if ty != "twosided" && ty != "normalmap" {
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
    let bsdf = parse_bsdf_value(ctx, elem)?;
    ctx.bsdfs.push(bsdf);
    let index = ctx.bsdfs.len() - 1;
    ctx.register_id(elem, IdTarget::Bsdf(index))?;
    Ok(index)
}
