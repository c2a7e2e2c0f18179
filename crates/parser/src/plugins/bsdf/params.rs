//! The bsdf parameters that may be constants or textures (colours and floats), shared by the
//! bsdf plugins and the emitters.

use crate::context::{Ctx, IdTarget};
use crate::error::Result;
use crate::plugins::texture::parse_texture;
use crate::props::Props;
use crate::scene::{ColorParam, TextureId, TextureKind};
use crate::xml::Element;
use glam::Vec3;

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

pub(super) fn glossy(ctx: &mut Ctx, props: &mut Props) -> Result<(ColorParam, f32)> {
    let reflectance = color_param(ctx, props, &["reflectance"], Vec3::splat(0.5))?;
    let exponent =
        props.float_where(ctx, &["exponent", "alpha"], 5.0, "at least 0", |v| v >= 0.0)?;
    Ok((reflectance, exponent))
}

/// A float parameter that may be textured (Mitsuba's float textures: the first channel is
/// read), as a [`ColorParam`]; `bound` says what a constant may be.
pub(super) fn float_param(
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
pub(super) fn float_texture(
    ctx: &mut Ctx,
    props: &mut Props,
    name: &str,
    default: f32,
) -> Result<ColorParam> {
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
