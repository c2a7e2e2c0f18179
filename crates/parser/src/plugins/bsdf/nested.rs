//! The wrappers' parts (`twosided`, `blendbsdf`, `mask`, `normalmap`, `bumpmap`): their nested
//! bsdfs, normal maps and perturbation options.

use super::{parse_bsdf, parse_bsdf_value, texture_ref};
use crate::context::{Ctx, IdTarget};
use crate::error::Result;
use crate::plugins::texture::parse_texture;
use crate::props::Props;
use crate::scene::{Bsdf, BsdfId, PerturbOptions, TextureId, TextureKind};
use crate::xml::Element;

/// `flip_invalid_normals` and `use_shadowing_function` of Mitsuba's `normalmap` and `bumpmap`.
pub(super) fn perturb_options(ctx: &Ctx, props: &mut Props) -> Result<PerturbOptions> {
    Ok(PerturbOptions {
        flip_invalid_normals: props.boolean(ctx, &["flip_invalid_normals"], true)?,
        use_shadowing_function: props.boolean(ctx, &["use_shadowing_function"], true)?,
    })
}

/// A normal map parameter: a bitmap texture (inline or by ref), always read raw.
pub(super) fn normal_map_param(
    ctx: &mut Ctx,
    props: &mut Props,
    names: &[&str],
) -> Result<Option<TextureId>> {
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
pub(super) fn nested_bsdfs(
    ctx: &mut Ctx,
    props: &mut Props,
    elem: &Element,
    max: usize,
) -> Result<Vec<Bsdf>> {
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
pub(super) fn nested_bsdf_value(ctx: &mut Ctx, first: &Element) -> Result<Bsdf> {
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
pub(super) fn nested_bsdf(ctx: &mut Ctx, props: &mut Props, elem: &Element) -> Result<Bsdf> {
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
