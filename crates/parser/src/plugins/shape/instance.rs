//! `shapegroup` and `instance`.

use super::{parse_shape, world_problem};
use crate::context::{Ctx, IdTarget};
use crate::error::Result;
use crate::props::Props;
use crate::scene::{Instance, Shape, ShapeGroup, Warning};
use crate::xml::Element;
use glam::{Mat3, Mat4};

/// `shapegroup` (with an `id`): its nested shapes are stored once, in the group's own space, and
/// drawn only where `instance`s place them. As in Mitsuba, a group holds no emitters, no groups
/// and no instances. Returns no shapes of its own.
///
/// | name | type | default |
/// | --- | --- | --- |
/// | nested `<shape>`s | shape | none |
pub(super) fn parse_shapegroup(ctx: &mut Ctx, elem: &Element) -> Result<Vec<Shape>> {
    if ctx.already(elem).is_some() {
        // A `<ref>` further up made us parse it already.
        return Ok(Vec::new());
    }
    let Some(id) = elem.attr("id").map(|a| a.value.clone()) else {
        return Err(ctx.err(elem.pos, "a shapegroup needs an 'id' to be instanced"));
    };
    let mut props = Props::new(ctx, elem, "shape 'shapegroup'".into())?;
    let mut shapes = Vec::new();
    for child in props.take_tag("shape") {
        let ty = child.attr_value("type").unwrap_or("");
        if ty == "shapegroup" || ty == "instance" {
            return Err(ctx.err(
                child.pos,
                format!("a shapegroup cannot contain a '{ty}' (Mitsuba allows one level)"),
            ));
        }
        for s in parse_shape(ctx, child)? {
            if s.emitter.is_some() {
                return Err(ctx.err(
                    child.pos,
                    "shapes in a shapegroup cannot be emitters (as in Mitsuba)",
                ));
            }
            shapes.push(s);
        }
    }
    props.finish(ctx);
    ctx.shape_groups.push(ShapeGroup {
        id,
        shapes,
        location: ctx.location(elem.pos),
    });
    let index = ctx.shape_groups.len() - 1;
    ctx.register_id(elem, IdTarget::ShapeGroup(index))?;
    Ok(Vec::new())
}

/// `instance`: a `<ref>` to a shapegroup placed by `to_world`, which must be invertible. The
/// group's geometry is shared, not copied (the renderer's two-level BVH). Returns no shapes: the
/// instance goes to [`crate::Scene::instances`].
///
/// | name | type | default |
/// | --- | --- | --- |
/// | `to_world` (`toWorld`) | transform | identity |
/// | nested `<ref id>` | shapegroup | required |
pub(super) fn parse_instance(ctx: &mut Ctx, elem: &Element) -> Result<Vec<Shape>> {
    let mut props = Props::new(ctx, elem, "shape 'instance'".into())?;
    ctx.register_id(elem, IdTarget::Other)?;
    let to_world = props
        .transform(ctx, &["to_world"], false)?
        .unwrap_or(Mat4::IDENTITY);
    let refs = props.take_tag("ref");
    let Some(r) = refs.first() else {
        return Err(ctx.err(
            elem.pos,
            "shape 'instance' needs a <ref id=\"...\"/> to a shapegroup",
        ));
    };
    if let Some(second) = refs.get(1) {
        return Err(ctx.err(
            second.pos,
            "shape 'instance' takes a single shapegroup (as in Mitsuba)",
        ));
    }
    let IdTarget::ShapeGroup(g) = ctx.lookup(r)? else {
        return Err(ctx.err(
            r.pos,
            format!(
                "<ref id=\"{}\"> in an instance must name a shapegroup",
                r.attr_value("id").unwrap_or("")
            ),
        ));
    };
    let det = Mat3::from_mat4(to_world).determinant();
    if !(to_world.is_finite() && det.is_finite() && det != 0.0) {
        return Err(ctx.err(
            elem.pos,
            "the to_world of shape 'instance' is degenerate (zero scale, or non-finite)",
        ));
    }
    for s in &ctx.shape_groups[g].shapes {
        if let Some(problem) = world_problem(&s.geometry, to_world * s.to_world) {
            return Err(ctx.err(elem.pos, format!("shape 'instance': {problem}")));
        }
    }
    props.finish(ctx);
    ctx.instances.push(Instance {
        group: g,
        to_world,
        location: ctx.location(elem.pos),
    });
    Ok(Vec::new())
}

/// A warning for every shapegroup that no instance places (Mitsuba draws nothing of it either).
pub(crate) fn warn_unused_groups(ctx: &mut Ctx) {
    let mut used = vec![false; ctx.shape_groups.len()];
    for i in &ctx.instances {
        used[i.group] = true;
    }
    for (g, used) in ctx.shape_groups.iter().zip(used) {
        if !used {
            ctx.warnings.push(Warning {
                location: g.location.clone(),
                message: format!(
                    "shapegroup '{}' is not instanced; nothing of it is drawn",
                    g.id
                ),
            });
        }
    }
}
