//! Area emitters, inside shapes or declared with an id.

use crate::context::{plugin_type, Ctx, IdTarget};
use crate::error::Result;
use crate::plugins::bsdf::color_param;
use crate::props::Props;
use crate::scene::ColorParam;
use crate::xml::Element;
use glam::Vec3;

/// An `<emitter type="area">` (inside a shape, or with an id outside one): its radiance, 1 with a
/// texture, and the texture.
pub(crate) fn parse_area_emitter(
    ctx: &mut Ctx,
    e: &Element,
) -> Result<(Vec3, Option<crate::scene::TextureId>)> {
    let ety = plugin_type(ctx, e)?;
    if ety != "area" {
        return Err(ctx.err(
            e.pos,
            format!("only area emitters can be attached to a shape, found '{ety}'"),
        ));
    }
    let mut ep = Props::new(ctx, e, "emitter 'area'".into())?;
    let textured = e.children.iter().any(|c| {
        c.attr_value("name") == Some("radiance") && (c.tag == "texture" || c.tag == "ref")
    });
    let emission = if textured {
        match color_param(ctx, &mut ep, &["radiance"], Vec3::ONE)? {
            ColorParam::Texture(t) => (Vec3::ONE, Some(t)),
            ColorParam::Constant(c) => (c, None),
        }
    } else {
        (ep.color(ctx, &["radiance"], Vec3::ONE)?, None)
    };
    ep.finish(ctx);
    Ok(emission)
}

/// An `area` emitter declared with an id outside shapes (attached to the shapes that `<ref>` it,
/// as Mitsuba allows): added to [`Ctx::area_emitters`] once, where it stands or when a `<ref>`
/// first names it.
pub(crate) fn define_area_emitter(ctx: &mut Ctx, elem: &Element) -> Result<IdTarget> {
    if let Some(t) = ctx.already(elem) {
        return Ok(t);
    }
    let emission = parse_area_emitter(ctx, elem)?;
    ctx.area_emitters.push(emission);
    let target = IdTarget::AreaEmitter(ctx.area_emitters.len() - 1);
    ctx.register_id(elem, target)?;
    Ok(target)
}
