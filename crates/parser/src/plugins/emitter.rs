//! Emitter plugins outside shapes: `point`, `spot`, `directional`, `envmap`, `constant`,
//! `projector` (and torrey's `<background>`).

use crate::context::{plugin_type, unknown_type, Ctx, IdTarget};
use crate::error::Result;
use crate::plugins::bsdf::{color_param, texture_ref};
use crate::plugins::sensor::{checked_fov, focal_length_fov, focal_length_param, fov_axis_param};
use crate::plugins::texture::{bitmap_element, parse_bitmap, parse_texture};
use crate::props::Props;
use crate::scene::{ColorParam, FovAxis, Light};
use crate::transform::frame_problem;
use crate::xml::Element;
use glam::{Mat4, Vec3};

/// The types this parser reads (see `torrey_parser::accepted_plugins`).
pub(crate) const KNOWN: &[&str] = &[
    "point",
    "spot",
    "directional",
    "envmap",
    "constant",
    "projector",
    "area",
];

/// The emitters that may stand at the top level (all of [`KNOWN`] but `area`).
const TOP_LEVEL: usize = 6;

/// Mitsuba 3 emitters the renderer cannot draw yet: a clear error at their place.
const NOT_YET: &[&str] = &["directionalarea", "sunsky"];

/// Parses a top-level `<emitter>`.
///
/// | type | name | type | default |
/// | --- | --- | --- | --- |
/// | `point` | `intensity` | colour | 1 (W/sr) |
/// | `point` | `position` | point | 0, then moved by `to_world` |
/// | `point` | `to_world` | transform | identity |
/// | `spot` | `intensity` | colour | 1 (W/sr, on the axis) |
/// | `spot` | `cutoff_angle` | float | 20 (degrees, 0 < angle <= 180: dark beyond) |
/// | `spot` | `beam_width` | float | cutoff_angle * 3/4 (degrees, at most cutoff_angle: full inside) |
/// | `spot` | `to_world` | transform | identity (the light sits at its origin and shines along its +z) |
/// | `spot` | `texture` | texture (bitmap, checkerboard; inline or ref) | none; multiplies `intensity`, projected through the cone: uv = 0.5 + (x, y) / (2 z tan(cutoff_angle)) of the light-local direction |
/// | `directional` | `irradiance` | colour | 1 (W/m²) |
/// | `directional` | `direction` | vector | (0, 0, 1): where the light travels |
/// | `directional` | `to_world` | transform | identity; the light travels along its +z (exclusive with `direction`) |
/// | `envmap` | `filename` + bitmap parameters | string | required unless a nested bitmap `<texture>` is given |
/// | `envmap` | nested `<texture type="bitmap">` (seed dialect, e.g. `name="reflectance"`) | texture | |
/// | `envmap` | `scale`, `intensity_scale` | float | 1 (both multiply) |
/// | `envmap` | `to_world` | transform | identity (affine, invertible, axis scales 1e-6 to 1e6) |
/// | `constant` | `radiance` | colour | 1 |
/// | `projector` | `irradiance` | colour or texture (`<texture>`, `<ref>`) | required: irradiance on the image plane at z = 1 |
/// | `projector` | `scale` | float | 1 |
/// | `projector` | `fov` | float | from `focal_length` (degrees, 0 < fov < 180) |
/// | `projector` | `focal_length` | string like `50mm` | `50mm`: fov along the diagonal of 36 x 24 mm film |
/// | `projector` | `fov_axis` | string: x, y, diagonal, smaller, larger | x (with `fov`), of the irradiance texture's image (1 x 1 for a colour) |
/// | `projector` | `to_world` | transform | identity (a pinhole at its origin projecting along its +z, +x to the image's left, as the perspective camera) |
pub(crate) fn parse_emitter(ctx: &mut Ctx, elem: &Element) -> Result<Light> {
    let ty = plugin_type(ctx, elem)?;
    if NOT_YET.contains(&ty) {
        let pos = elem.attr("type").map_or(elem.pos, |a| a.value_pos);
        return Err(ctx.err(
            pos,
            format!(
                "emitter '{ty}' is not supported yet (supported: {}; area inside a shape)",
                KNOWN[..TOP_LEVEL].join(", ")
            ),
        ));
    }
    if !KNOWN.contains(&ty) {
        return Err(unknown_type(ctx, elem, "emitter", &KNOWN[..TOP_LEVEL]));
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
        "spot" => parse_spot(ctx, &mut props, elem)?,
        "directional" => parse_directional(ctx, &mut props, elem)?,
        "projector" => parse_projector(ctx, &mut props, elem)?,
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

/// Mitsuba's `spot` (see [`parse_emitter`]'s table).
fn parse_spot(ctx: &mut Ctx, props: &mut Props, elem: &Element) -> Result<Light> {
    // Mitsuba requires a spatially varying texture here (a constant belongs in `intensity`).
    let texture = match props.take_any(&["texture"]) {
        None => None,
        Some(e) => match e.tag.as_str() {
            "texture" => Some(parse_texture(ctx, e)?),
            "ref" => Some(texture_ref(ctx, e)?),
            _ => {
                return Err(ctx.err(
                    e.pos,
                    format!(
                        "a spot light's texture must be a spatially varying <texture> (bitmap, checkerboard), found <{}>; a constant belongs in its intensity",
                        e.tag
                    ),
                ))
            }
        },
    };
    if let Some(t) = texture {
        if matches!(
            ctx.textures[t].kind,
            crate::scene::TextureKind::RawConstant { .. }
        ) {
            return Err(ctx.err(
                elem.pos,
                "a spot light's texture must be spatially varying (bitmap, checkerboard), not a rawconstant; a constant belongs in its intensity",
            ));
        }
    }
    let intensity = props.color(ctx, &["intensity"], Vec3::ONE)?;
    let (cutoff, cutoff_pos) = props
        .opt_float_pos(ctx, &["cutoff_angle"])?
        .unwrap_or((20.0, elem.pos));
    if !(cutoff > 0.0 && cutoff <= 180.0) {
        return Err(ctx.err(
            cutoff_pos,
            format!("the spot light's cutoff_angle must be in (0, 180] degrees, found {cutoff}"),
        ));
    }
    let (beam, beam_pos) = props
        .opt_float_pos(ctx, &["beam_width"])?
        .unwrap_or((cutoff * 0.75, elem.pos));
    if !(0.0..=cutoff).contains(&beam) {
        return Err(ctx.err(
            beam_pos,
            format!(
                "the spot light's beam_width must be in [0, cutoff_angle = {cutoff}] degrees, found {beam}"
            ),
        ));
    }
    let to_world = match props.transform_pos(ctx, &["to_world"], false)? {
        None => Mat4::IDENTITY,
        Some((m, pos)) => {
            if let Some(problem) = frame_problem(m) {
                return Err(ctx.err(
                    pos,
                    format!("the spot light's to_world cannot place a light: {problem}"),
                ));
            }
            m
        }
    };
    Ok(Light::Spot {
        to_world,
        intensity,
        cutoff_angle: cutoff.to_radians(),
        beam_width: beam.to_radians(),
        texture,
    })
}

/// Mitsuba's `projector` (see [`parse_emitter`]'s table).
fn parse_projector(ctx: &mut Ctx, props: &mut Props, elem: &Element) -> Result<Light> {
    let textured = elem.children.iter().any(|c| {
        c.attr_value("name") == Some("irradiance") && (c.tag == "texture" || c.tag == "ref")
    });
    let irradiance = if textured {
        color_param(ctx, props, &["irradiance"], Vec3::ONE)?
    } else if props.has(&["irradiance"]) {
        ColorParam::Constant(props.color(ctx, &["irradiance"], Vec3::ONE)?)
    } else {
        return Err(ctx.err(
            elem.pos,
            "emitter 'projector' needs an 'irradiance' (a colour or a texture)",
        ));
    };
    let (scale, scale_pos) = props
        .opt_float_pos(ctx, &["scale"])?
        .unwrap_or((1.0, elem.pos));
    if !(scale >= 0.0 && scale.is_finite()) {
        return Err(ctx.err(
            scale_pos,
            format!("the projector's scale must be a finite non-negative number, found {scale}"),
        ));
    }
    let fov = props.opt_float_pos(ctx, &["fov"])?;
    let focal = props.string(ctx, &["focal_length"])?;
    let axis = props.string(ctx, &["fov_axis"])?;
    let (fov_degrees, mut fov_axis) = match (fov, focal) {
        (Some(_), Some(f)) => {
            return Err(ctx.err(
                f.value_pos,
                "a projector takes 'fov' or 'focal_length', not both",
            ))
        }
        (Some((f, pos)), None) => (checked_fov(ctx, f, pos)?, FovAxis::X),
        (None, Some(a)) => (focal_length_param(ctx, a)?, FovAxis::Diagonal),
        (None, None) => (focal_length_fov(50.0), FovAxis::Diagonal),
    };
    if let Some(a) = axis {
        if fov.is_none() {
            ctx.warn(
                a.value_pos,
                "fov_axis without fov is ignored: Mitsuba measures focal_length along the diagonal",
            );
        } else {
            fov_axis = fov_axis_param(ctx, a)?;
        }
    }
    let to_world = match props.transform_pos(ctx, &["to_world"], false)? {
        None => Mat4::IDENTITY,
        Some((m, pos)) => {
            if let Some(problem) = frame_problem(m) {
                return Err(ctx.err(
                    pos,
                    format!("the projector's to_world cannot place a light: {problem}"),
                ));
            }
            m
        }
    };
    Ok(Light::Projector {
        to_world,
        irradiance,
        scale,
        fov_degrees,
        fov_axis,
    })
}

/// Mitsuba's `directional` (see [`parse_emitter`]'s table).
fn parse_directional(ctx: &mut Ctx, props: &mut Props, elem: &Element) -> Result<Light> {
    let irradiance = props.color(ctx, &["irradiance"], Vec3::ONE)?;
    let given = props.has(&["direction"]);
    let direction = props.point(ctx, &["direction"])?;
    let to_world = props.transform_pos(ctx, &["to_world"], false)?;
    let direction = match (direction, to_world) {
        (Some(_), Some((_, pos))) => {
            return Err(ctx.err(
                pos,
                "a directional emitter takes 'direction' or 'to_world', not both",
            ))
        }
        (Some(d), None) => d,
        (None, Some((m, _))) => m.transform_vector3(Vec3::Z),
        (None, None) => Vec3::Z,
    };
    let length = direction.length();
    if !(length.is_finite() && length > 1e-30) {
        let what = if given { "direction" } else { "to_world's +z" };
        return Err(ctx.err(
            elem.pos,
            format!("the directional emitter's {what} is {direction}, which gives no direction"),
        ));
    }
    Ok(Light::Directional {
        direction: direction / length,
        irradiance,
    })
}

/// torrey's `<background>`: `radiance` colour, default 0.5 → a constant environment.
pub(crate) fn parse_background(ctx: &mut Ctx, elem: &Element) -> Result<Light> {
    let mut props = Props::new(ctx, elem, "<background>".into())?;
    let radiance = props.color(ctx, &["radiance"], Vec3::splat(0.5))?;
    props.finish(ctx);
    Ok(Light::Constant { radiance })
}
