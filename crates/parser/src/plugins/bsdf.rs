//! BSDF plugins: `diffuse`, `mirror`, `plastic`, `phong`, `blinn`/`blinnphong`,
//! `blinn_microfacet`/`blinnphong_microfacet`; Mitsuba 3's `dielectric`, `thindielectric`,
//! `roughdielectric`, `conductor`, `roughconductor`, `roughplastic`; and the wrappers
//! `twosided`, `blendbsdf`, `mask`, `normalmap` and `bumpmap`, and `null`; Mitsuba 3's `principled`
//! and `principledthin`.

use crate::context::{plugin_type, unknown_type, Ctx, IdTarget};
use crate::error::Result;
use crate::plugins::texture::parse_texture;
use crate::props::Props;
use crate::scene::{
    Bsdf, BsdfId, BsdfKind, BumpMap, ColorParam, Dialect, MicrofacetType, PerturbOptions,
    PrincipledDesc, PrincipledThinDesc, TextureId, TextureKind,
};
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

/// Mitsuba 3's named conductors (`material`), as its RGB variants see them: the tabulated
/// spectra of η and k (data/ior/<name>.{eta,k}.spd) integrated against the CIE 1931 colour
/// matching functions and converted to linear sRGB (`spectrum_list_to_srgb`, unbounded;
/// negative components clamped to 0 as Mitsuba's `srgb` texture does). Values read from
/// Mitsuba 3.9.1's `scalar_rgb` variant (`mi.traverse` of a conductor with each `material`).
/// Entries: name, η (r, g, b), k (r, g, b).
#[rustfmt::skip]
const CONDUCTOR_TABLE: &[(&str, [f32; 3], [f32; 3])] = &[
    ("a-C", [2.94405, 2.22714, 1.96816], [0.887465, 0.799299, 0.81529]),
    ("Ag", [0.155276, 0.116728, 0.138388], [4.82835, 3.12222, 2.1469]),
    ("Al", [1.6575, 0.880405, 0.521244], [9.22381, 6.2695, 4.837]),
    ("AlAs", [3.6053, 3.23294, 2.21632], [0.000679437, 0.0, 0.00751271]),
    ("AlAs_palik", [3.6053, 3.23294, 2.21632], [0.000679437, 0.0, 0.00751271]),
    ("AlSb", [0.0, 4.13937, 4.66925], [0.0, 0.0940091, 1.30057]),
    ("AlSb_palik", [0.0, 4.13937, 4.66925], [0.0, 0.0940091, 1.30057]),
    ("Au", [0.143036, 0.375307, 1.44205], [3.983, 2.38556, 1.60336]),
    ("Be", [4.18501, 3.18503, 2.78406], [3.83547, 3.01012, 2.86899]),
    ("Cr", [4.36967, 2.91651, 1.6549], [5.20655, 4.23131, 3.7547]),
    ("CsI", [2.1449, 1.70232, 1.66243], [0.0, 0.0, 0.0]),
    ("Cu", [0.201005, 0.92375, 1.10222], [3.91326, 2.45305, 2.14209]),
    ("Cu_palik", [0.213229, 0.919715, 1.10241], [3.92187, 2.45733, 2.13658]),
    ("Cu2O", [3.55177, 2.94987, 2.75188], [0.114207, 0.193897, 0.606134]),
    ("CuO", [3.24754, 2.44781, 2.21022], [0.52109, 0.570031, 0.722179]),
    ("d-C", [2.70872, 2.31883, 2.2289], [0.0, 0.0, 0.0]),
    ("Hg", [2.39894, 1.44003, 0.90957], [6.32759, 4.37192, 3.42176]),
    ("HgTe", [4.77904, 3.2312, 2.6599], [1.63161, 1.58081, 1.72929]),
    ("Ir", [3.0863, 2.08219, 1.61791], [5.59215, 4.06709, 3.26731]),
    ("K", [0.0640432, 0.0464098, 0.0381849], [2.1042, 1.34894, 0.913126]),
    ("Li", [0.265791, 0.195618, 0.220949], [3.54015, 2.31112, 1.66861]),
    ("MgO", [2.08958, 1.65072, 1.59488], [4.3327e-12, 0.0, 2.49865e-11]),
    ("Mo", [4.48397, 3.52513, 2.77631], [4.11144, 3.42083, 3.15061]),
    ("Na_palik", [0.0602694, 0.0561409, 0.0619884], [3.17927, 2.11249, 1.57904]),
    ("Nb", [3.42007, 2.79009, 2.39563], [3.44139, 2.73767, 2.57975]),
    ("Ni_palik", [2.3673, 1.66337, 1.46708], [4.49881, 3.05015, 2.34544]),
    ("Rh", [2.58579, 1.86022, 1.55426], [6.78226, 4.70299, 3.97607]),
    ("Se", [4.05831, 2.84294, 2.82085], [0.75405, 0.638444, 0.521808]),
    ("SiC", [3.17234, 2.52597, 2.47937], [7.53766e-07, 0.0, 1.01925e-05]),
    ("SnTe", [4.52425, 1.98164, 1.28159], [0.0, 0.0, 0.0]),
    ("Ta", [2.06272, 2.39294, 2.62793], [2.40836, 1.74149, 1.94703]),
    ("Te", [7.39023, 4.4821, 2.63711], [3.25602, 3.52706, 3.29205]),
    ("ThF4", [1.83071, 1.44223, 1.38765], [0.0, 0.0, 0.0]),
    ("TiC", [3.70053, 2.83742, 2.58229], [3.26564, 2.35159, 2.17279]),
    ("TiN", [1.64845, 1.15052, 1.37982], [3.36833, 1.9435, 1.10207]),
    ("TiO2", [3.45661, 2.80174, 2.90517], [0.000105265, 0.0, 0.000652887]),
    ("VC", [3.65757, 2.75274, 2.53267], [3.0683, 2.19869, 1.96319]),
    ("V_palik", [4.27758, 3.51295, 2.76107], [3.4913, 2.88945, 3.11152]),
    ("VN", [2.8656, 2.11919, 1.94009], [3.03224, 2.05612, 1.61631]),
    ("W", [4.37082, 3.30025, 2.99841], [3.50064, 2.60487, 2.27323]),
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

/// What a constant parameter's value may be beyond "not negative" (which every colour must be).
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Bound {
    /// A reflectance or transmittance (an albedo): above 1 the surface scatters more light than
    /// it receives, which renders but adds energy, so it is warned about.
    Albedo,
    /// A float in [0, 1] that Mitsuba clamps (blendbsdf's `weight`, mask's `opacity`): above 1
    /// is warned about and read as 1.
    Fraction,
    /// No upper bound (a conductor's `eta` and `k`, roughness `alpha`).
    None,
}

/// A colour parameter that may be a constant (`rgb`, `srgb`, `spectrum`, `float`), an inline
/// `<texture>` or a `<ref>` to a texture; a reflectance or transmittance (see [`Bound::Albedo`]).
pub(crate) fn color_param(
    ctx: &mut Ctx,
    props: &mut Props,
    names: &[&str],
    default: Vec3,
) -> Result<ColorParam> {
    color_param_within(ctx, props, names, default, Bound::Albedo)
}

/// As [`color_param`], with the given bound on a constant value; warnings name the parameter as
/// the file spells it.
pub(crate) fn color_param_within(
    ctx: &mut Ctx,
    props: &mut Props,
    names: &[&str],
    default: Vec3,
    bound: Bound,
) -> Result<ColorParam> {
    texture_param(ctx, props, names, default, bound, false)
}

/// A `rawconstant` texture `t` named by `e`, read as a parameter: its value, put in place (no
/// colour conversion and no range check, as Mitsuba's); a float parameter (`float`) needs one
/// channel (Mitsuba: "eval_1() is not defined for 3D-valued textures"). None for other
/// textures.
fn raw_constant(
    ctx: &Ctx,
    t: TextureId,
    e: &Element,
    float: bool,
    owner: &str,
) -> Result<Option<Vec3>> {
    match ctx.textures[t].kind {
        TextureKind::RawConstant { channels: 3, .. } if float => Err(ctx.err(
            e.pos,
            format!(
                "{} of {owner} is a float parameter, but this rawconstant texture has three channels (Mitsuba: eval_1() is not defined for 3D-valued textures)",
                e.attr_value("name").map_or("the parameter".to_string(), |n| format!("'{n}'"))
            ),
        )),
        TextureKind::RawConstant { value, .. } => Ok(Some(value)),
        _ => Ok(None),
    }
}

/// [`color_param_within`], or a float parameter (`float`: a rawconstant texture must have one
/// channel).
fn texture_param(
    ctx: &mut Ctx,
    props: &mut Props,
    names: &[&str],
    default: Vec3,
    bound: Bound,
    float: bool,
) -> Result<ColorParam> {
    let Some(e) = props.take_any(names) else {
        return Ok(ColorParam::Constant(default));
    };
    let texture = match e.tag.as_str() {
        "texture" => Some(parse_texture(ctx, e)?),
        "ref" => Some(texture_ref(ctx, e)?),
        _ => None,
    };
    if let Some(t) = texture {
        if let Some(value) = raw_constant(ctx, t, e, float, &props.owner)? {
            return Ok(ColorParam::Constant(value));
        }
        if let Some(uses) = ctx.texture_uses.last_mut() {
            uses.push((t, false));
        }
        return Ok(ColorParam::Texture(t));
    }
    let c = props.color_of(ctx, e)?;
    let name = e.attr_value("name").unwrap_or(names[0]);
    let pos = e.attr("value").map_or(e.pos, |a| a.value_pos);
    match bound {
        // Renderable, but a surface scattering more than it receives adds energy.
        Bound::Albedo if c.max_element() > 1.0 => ctx.warn_once(
            "albedo above 1",
            pos,
            format!(
                "parameter '{name}' of {} is {} {} {}, above 1: the surface scatters more light than it receives",
                props.owner, c.x, c.y, c.z
            ),
        ),
        // Float parameters read the first channel (Mitsuba's float textures).
        Bound::Fraction if c.x > 1.0 => ctx.warn(
            pos,
            format!(
                "parameter '{name}' of {} is {}, above 1: read as 1 (Mitsuba clamps it to [0, 1])",
                props.owner, c.x
            ),
        ),
        _ => {}
    }
    Ok(ColorParam::Constant(c))
}

pub(crate) fn texture_ref(ctx: &mut Ctx, e: &Element) -> Result<TextureId> {
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

/// `flip_invalid_normals` and `use_shadowing_function` of Mitsuba's `normalmap` and `bumpmap`.
fn perturb_options(ctx: &Ctx, props: &mut Props) -> Result<PerturbOptions> {
    Ok(PerturbOptions {
        flip_invalid_normals: props.boolean(ctx, &["flip_invalid_normals"], true)?,
        use_shadowing_function: props.boolean(ctx, &["use_shadowing_function"], true)?,
    })
}

/// A normal map parameter: a bitmap texture (inline or by ref), always read raw.
fn normal_map_param(ctx: &mut Ctx, props: &mut Props, names: &[&str]) -> Result<Option<TextureId>> {
    let Some(e) = props.take_any(names) else {
        return Ok(None);
    };
    // An inline texture with an id may be used elsewhere too (by a `<ref>`): shared.
    let (index, shared) = match e.tag.as_str() {
        "texture" => (parse_texture(ctx, e)?, e.attr("id").is_some()),
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

/// The bsdfs inside `twosided`/`normalmap`: nested `<bsdf>`s or `<ref>`s to them, at most `max`
/// (extra ones are warned about and ignored), at least one.
fn nested_bsdfs(ctx: &mut Ctx, props: &mut Props, elem: &Element, max: usize) -> Result<Vec<Bsdf>> {
    let mut nested: Vec<&Element> = props.take_tag("bsdf");
    nested.extend(props.take_tag("ref"));
    nested.sort_by_key(|e| (e.pos.line, e.pos.column));
    if nested.is_empty() {
        return Err(ctx.err(elem.pos, format!("{} needs a nested <bsdf>", props.owner)));
    }
    for extra in nested.iter().skip(max) {
        ctx.warn(
            extra.pos,
            format!(
                "{} uses only its first {max} nested bsdf(s); this one is ignored",
                props.owner
            ),
        );
    }
    nested
        .iter()
        .take(max)
        .map(|e| nested_bsdf_value(ctx, e))
        .collect()
}

/// A copy of the scene's bsdf `index` to nest in another; the textures it uses count as the
/// outer bsdf's (for the `mesh_attribute` checks).
fn nested_copy(ctx: &mut Ctx, index: BsdfId) -> Bsdf {
    if let Some(uses) = ctx.bsdf_textures.get(&index).cloned() {
        if let Some(outer) = ctx.texture_uses.last_mut() {
            outer.extend(uses);
        }
    }
    ctx.bsdfs[index].clone()
}

/// One nested `<bsdf>` or `<ref>` to a bsdf. A nested bsdf with an id is added to the scene's
/// table and registered (Mitsuba registers ids at any depth: shapes may `<ref>` it).
fn nested_bsdf_value(ctx: &mut Ctx, first: &Element) -> Result<Bsdf> {
    if first.tag != "ref" && first.attr("id").is_some() {
        let index = parse_bsdf(ctx, first)?;
        return Ok(nested_copy(ctx, index));
    }
    if first.tag == "ref" {
        match ctx.lookup(first)? {
            IdTarget::Bsdf(b) => Ok(nested_copy(ctx, b)),
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

/// The bsdf inside `normalmap`: a nested `<bsdf>` or a `<ref>` to one.
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
    nested_bsdf_value(ctx, first)
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

/// A float parameter that may be textured (Mitsuba's float textures: the first channel is
/// read), as a [`ColorParam`]; `bound` says what a constant may be.
fn float_param(
    ctx: &mut Ctx,
    props: &mut Props,
    names: &[&str],
    default: f32,
    bound: Bound,
) -> Result<ColorParam> {
    let p = texture_param(ctx, props, names, Vec3::splat(default), bound, true)?;
    if let (ColorParam::Texture(t), Some(uses)) = (&p, ctx.texture_uses.last_mut()) {
        if let Some(last) = uses.iter_mut().rev().find(|(u, _)| u == t) {
            last.1 = true;
        }
    }
    Ok(p)
}

/// A float parameter that may be a texture, without [`color_param`]'s reflectance warning
/// (principled's `diff_trans` goes to 2, `eta` above 1).
fn float_texture(ctx: &mut Ctx, props: &mut Props, name: &str, default: f32) -> Result<ColorParam> {
    let Some(e) = props.take_any(&[name]) else {
        return Ok(ColorParam::Constant(Vec3::splat(default)));
    };
    let t = match e.tag.as_str() {
        "texture" => parse_texture(ctx, e)?,
        "ref" => texture_ref(ctx, e)?,
        _ => return Ok(ColorParam::Constant(props.color_of(ctx, e)?)),
    };
    Ok(match raw_constant(ctx, t, e, true, &props.owner)? {
        Some(value) => ColorParam::Constant(value),
        None => ColorParam::Texture(t),
    })
}

/// Whether a lobe parameter is switched on, as Mitsuba's `get_flag`: given, and not a constant 0.
fn lobe_on(p: &ColorParam) -> bool {
    !matches!(p, ColorParam::Constant(c) if *c == Vec3::ZERO)
}

/// Mitsuba's `principled` (src/bsdfs/principled.cpp): `eta` or `specular` (not both); with
/// transmission on, η = 1 becomes 1.001 and specular 0 becomes 0.001.
fn principled(ctx: &mut Ctx, props: &mut Props, elem: &Element) -> Result<PrincipledDesc> {
    let base_color = color_param(ctx, props, &["base_color"], Vec3::splat(0.5))?;
    let mut f = |name: &str, default: f32| float_texture(ctx, props, name, default);
    let roughness = f("roughness", 0.5)?;
    let anisotropic = f("anisotropic", 0.0)?;
    let metallic = f("metallic", 0.0)?;
    let spec_trans = f("spec_trans", 0.0)?;
    let spec_tint = f("spec_tint", 0.0)?;
    let sheen = f("sheen", 0.0)?;
    let sheen_tint = f("sheen_tint", 0.0)?;
    let flatness = f("flatness", 0.0)?;
    let clearcoat = f("clearcoat", 0.0)?;
    let clearcoat_gloss = f("clearcoat_gloss", 0.0)?;
    let transmits = lobe_on(&spec_trans);
    if props.has(&["eta"]) && props.has(&["specular"]) {
        return Err(ctx.err(
            elem.pos,
            "bsdf 'principled': give either eta or specular, not both",
        ));
    }
    let eta = if props.has(&["eta"]) {
        let eta = props.float_where(ctx, &["eta"], 1.5, "positive", |v| v > 0.0)?;
        if transmits && eta == 1.0 {
            1.001
        } else {
            eta
        }
    } else {
        let mut specular = props.float_where(ctx, &["specular"], 0.5, "in [0, 12.5)", |v| {
            (0.0..12.5).contains(&v)
        })?;
        if transmits && specular == 0.0 {
            specular = 1e-3;
        }
        2.0 / (1.0 - (0.08 * specular).sqrt()) - 1.0
    };
    let rate = |props: &mut Props, name: &str| {
        props.float_where(ctx, &[name], 1.0, "at least 0", |v| v >= 0.0)
    };
    Ok(PrincipledDesc {
        base_color,
        roughness,
        anisotropic,
        metallic,
        spec_trans,
        spec_tint,
        sheen,
        sheen_tint,
        flatness,
        clearcoat,
        clearcoat_gloss,
        eta,
        main_specular_sampling_rate: rate(props, "main_specular_sampling_rate")?,
        clearcoat_sampling_rate: rate(props, "clearcoat_sampling_rate")?,
        diffuse_reflectance_sampling_rate: rate(props, "diffuse_reflectance_sampling_rate")?,
    })
}

/// Mitsuba's `principledthin` (src/bsdfs/principledthin.cpp).
fn principled_thin(ctx: &mut Ctx, props: &mut Props) -> Result<PrincipledThinDesc> {
    let base_color = color_param(ctx, props, &["base_color"], Vec3::splat(0.5))?;
    let mut f = |name: &str, default: f32| float_texture(ctx, props, name, default);
    let roughness = f("roughness", 0.5)?;
    let anisotropic = f("anisotropic", 0.0)?;
    let spec_trans = f("spec_trans", 0.0)?;
    let spec_tint = f("spec_tint", 0.0)?;
    let sheen = f("sheen", 0.0)?;
    let sheen_tint = f("sheen_tint", 0.0)?;
    let flatness = f("flatness", 0.0)?;
    let diff_trans = f("diff_trans", 0.0)?;
    let eta = f("eta", 1.5)?;
    let rate = |props: &mut Props, name: &str| {
        props.float_where(ctx, &[name], 1.0, "at least 0", |v| v >= 0.0)
    };
    Ok(PrincipledThinDesc {
        base_color,
        roughness,
        anisotropic,
        spec_trans,
        spec_tint,
        sheen,
        sheen_tint,
        flatness,
        diff_trans,
        eta,
        specular_reflectance_sampling_rate: rate(props, "specular_reflectance_sampling_rate")?,
        specular_transmittance_sampling_rate: rate(props, "specular_transmittance_sampling_rate")?,
        diffuse_reflectance_sampling_rate: rate(props, "diffuse_reflectance_sampling_rate")?,
        diffuse_transmittance_sampling_rate: rate(props, "diffuse_transmittance_sampling_rate")?,
    })
}

/// Mitsuba's `int_ior` / `ext_ior` pair as their ratio.
fn eta_param(ctx: &Ctx, props: &mut Props, elem: &Element, int_default: f32) -> Result<f32> {
    let int_ior = ior(ctx, props, "int_ior", int_default)?;
    let ext_ior = ior(ctx, props, "ext_ior", 1.000277)?;
    if !(int_ior > 0.0 && ext_ior > 0.0) {
        return Err(ctx.err(
            elem.pos,
            format!("{}: int_ior and ext_ior must be positive", props.owner),
        ));
    }
    Ok(int_ior / ext_ior)
}

/// Mitsuba's microfacet `distribution` (default beckmann), roughness (`alpha` for both axes, or
/// `alpha_u` and `alpha_v` together; default 0.1) and `sample_visible` (default true).
fn roughness(
    ctx: &mut Ctx,
    props: &mut Props,
    elem: &Element,
    anisotropic: bool,
) -> Result<(MicrofacetType, ColorParam, ColorParam, bool)> {
    let distribution = match props.string(ctx, &["distribution"])? {
        None => MicrofacetType::Beckmann,
        Some(a) => match a.value.to_ascii_lowercase().as_str() {
            "beckmann" => MicrofacetType::Beckmann,
            "ggx" => MicrofacetType::Ggx,
            other => {
                return Err(ctx.err(
                    a.value_pos,
                    format!(
                    "unknown microfacet distribution '{other}' in {} (expected beckmann or ggx)",
                    props.owner
                ),
                ))
            }
        },
    };
    let sample_visible = props.boolean(ctx, &["sample_visible"], true)?;
    if anisotropic && props.has(&["alpha_u", "alpha_v"]) {
        if props.has(&["alpha"]) || !(props.has(&["alpha_u"]) && props.has(&["alpha_v"])) {
            return Err(ctx.err(
                elem.pos,
                format!(
                    "{}: give either alpha or both alpha_u and alpha_v",
                    props.owner
                ),
            ));
        }
        let u = float_param(ctx, props, &["alpha_u"], 0.1, Bound::None)?;
        let v = float_param(ctx, props, &["alpha_v"], 0.1, Bound::None)?;
        return Ok((distribution, u, v, sample_visible));
    }
    let a = float_param(ctx, props, &["alpha"], 0.1, Bound::None)?;
    Ok((distribution, a.clone(), a, sample_visible))
}

/// Mitsuba's conductor parameters: `eta` and `k` (colours or textures), or a named
/// `material` from [`CONDUCTOR_TABLE`]; neither means `none`, a perfect mirror (η 0, k 1).
fn conductor_ior(ctx: &mut Ctx, props: &mut Props) -> Result<(ColorParam, ColorParam)> {
    let material = props.string(ctx, &["material"])?;
    if let Some(a) = material {
        if a.value != "none" {
            if props.has(&["eta", "k"]) {
                return Err(ctx.err(
                    a.value_pos,
                    format!(
                        "{}: give either eta and k or material, not both",
                        props.owner
                    ),
                ));
            }
            let Some((_, eta, k)) = CONDUCTOR_TABLE.iter().find(|(n, _, _)| *n == a.value) else {
                let names: Vec<&str> = CONDUCTOR_TABLE.iter().map(|(n, _, _)| *n).collect();
                return Err(ctx.err(
                    a.value_pos,
                    format!(
                        "unknown conductor material '{}' (known: {}, none)",
                        a.value,
                        names.join(", ")
                    ),
                ));
            };
            return Ok((
                ColorParam::Constant(Vec3::from(*eta)),
                ColorParam::Constant(Vec3::from(*k)),
            ));
        }
    }
    // Indices of refraction, not reflectances: no upper bound.
    let eta = color_param_within(ctx, props, &["eta"], Vec3::ZERO, Bound::None)?;
    let k = color_param_within(ctx, props, &["k"], Vec3::ONE, Bound::None)?;
    Ok((eta, k))
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
