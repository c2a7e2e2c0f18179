//! Emitter plugins outside shapes: `point`, `envmap`, `constant` (and torrey's `<background>`).

use crate::context::{plugin_type, unknown_type, Ctx, IdTarget};
use crate::error::Result;
use crate::plugins::texture::{bitmap_element, parse_bitmap};
use crate::props::Props;
use crate::scene::Light;
use crate::transform::frame_problem;
use crate::xml::Element;
use glam::{Mat4, Vec3};

/// The types this parser reads (see `torrey_parser::accepted_plugins`).
pub(crate) const KNOWN: &[&str] = &["point", "envmap", "constant", "area"];

/// Mitsuba 3 emitters the renderer cannot draw yet: a clear error at their place.
const NOT_YET: &[&str] = &[
    "spot",
    "directional",
    "projector",
    "directionalarea",
    "sunsky",
];

/// Parses a top-level `<emitter>`.
///
/// | type | name | type | default |
/// | --- | --- | --- | --- |
/// | `point` | `intensity` | colour | 1 (W/sr) |
/// | `point` | `position` | point | 0, then moved by `to_world` |
/// | `point` | `to_world` | transform | identity |
/// | `envmap` | `filename` + bitmap parameters | string | required unless a nested bitmap `<texture>` is given |
/// | `envmap` | nested `<texture type="bitmap">` (seed dialect, e.g. `name="reflectance"`) | texture | |
/// | `envmap` | `scale`, `intensity_scale` | float | 1 (both multiply) |
/// | `envmap` | `to_world` | transform | identity (affine, invertible, axis scales 1e-6 to 1e6) |
/// | `constant` | `radiance` | colour | 1 |
pub(crate) fn parse_emitter(ctx: &mut Ctx, elem: &Element) -> Result<Light> {
    let ty = plugin_type(ctx, elem)?;
    if NOT_YET.contains(&ty) {
        let pos = elem.attr("type").map_or(elem.pos, |a| a.value_pos);
        return Err(ctx.err(
            pos,
            format!(
                "emitter '{ty}' is not supported yet (supported: {}; area inside a shape)",
                KNOWN[..3].join(", ")
            ),
        ));
    }
    if !KNOWN.contains(&ty) {
        return Err(unknown_type(ctx, elem, "emitter", &KNOWN[..3]));
    }
    if ty == "area" {
        return Err(ctx.err(elem.pos, "an area emitter must be nested inside a <shape>"));
    }
    let mut props = Props::new(ctx, elem, format!("emitter '{ty}'"))?;
    ctx.register_id(elem, IdTarget::Other)?;
    let light = match ty {
        "point" => {
            let intensity = props.color(ctx, &["intensity"], Vec3::ONE)?;
            let position = props.point(ctx, &["position"])?.unwrap_or(Vec3::ZERO);
            let to_world = props
                .transform(ctx, &["to_world"], false)?
                .unwrap_or(Mat4::IDENTITY);
            let position = to_world.transform_point3(position);
            let reach = position.abs().max_element() as f64;
            if reach.is_nan() || reach > crate::plugins::shape::WORLD_EXTENT {
                return Err(ctx.err(
                    elem.pos,
                    format!(
                        "the point light's position, moved by its to_world, reaches {reach:.3e}, beyond the {:e} torrey supports",
                        crate::plugins::shape::WORLD_EXTENT
                    ),
                ));
            }
            Light::Point {
                position,
                intensity,
            }
        }
        "constant" => Light::Constant {
            radiance: props.color(ctx, &["radiance"], Vec3::ONE)?,
        },
        _ => {
            let bitmap = if props.has(&["filename"]) {
                parse_bitmap(ctx, &mut props, elem)?
            } else {
                let textures = props.take_tag("texture");
                let Some(t) = textures.first() else {
                    return Err(ctx.err(
                        elem.pos,
                        "emitter 'envmap' needs a 'filename' or a nested bitmap <texture>",
                    ));
                };
                bitmap_element(ctx, t)?
            };
            let mut scale = 1.0;
            for name in ["scale", "intensity_scale"] {
                if let Some((v, pos)) = props.opt_float_pos(ctx, &[name])? {
                    if v < 0.0 {
                        return Err(ctx.err(
                            pos,
                            format!("parameter '{name}' of emitter 'envmap' must not be negative, found {v}"),
                        ));
                    }
                    if v == 0.0 {
                        ctx.warn(pos, format!("parameter '{name}' of emitter 'envmap' is 0: the environment is black"));
                    }
                    scale *= v;
                }
            }
            if !scale.is_finite() {
                return Err(ctx.err(
                    elem.pos,
                    "emitter 'envmap': scale times intensity_scale is too large for a 32-bit float",
                ));
            }
            let to_world = match props.transform_pos(ctx, &["to_world"], false)? {
                None => Mat4::IDENTITY,
                Some((m, pos)) => {
                    if let Some(problem) = frame_problem(m) {
                        return Err(ctx.err(
                            pos,
                            format!(
                                "the envmap's to_world cannot orient an environment: {problem}"
                            ),
                        ));
                    }
                    m
                }
            };
            Light::Envmap {
                bitmap,
                scale,
                to_world,
            }
        }
    };
    props.finish(ctx);
    Ok(light)
}

/// torrey's `<background>`: `radiance` colour, default 0.5 → a constant environment.
pub(crate) fn parse_background(ctx: &mut Ctx, elem: &Element) -> Result<Light> {
    let mut props = Props::new(ctx, elem, "<background>".into())?;
    let radiance = props.color(ctx, &["radiance"], Vec3::splat(0.5))?;
    props.finish(ctx);
    Ok(Light::Constant { radiance })
}
