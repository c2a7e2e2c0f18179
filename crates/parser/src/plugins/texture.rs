//! Texture plugins: `bitmap`, `checkerboard`, `mesh_attribute` and `rawconstant`.

use crate::context::{plugin_type, unknown_type, Ctx, IdTarget};
use crate::error::Result;
use crate::files::input_file;
use crate::props::Props;
use crate::scene::{Bitmap, FilterType, Texture, TextureId, TextureKind, WrapMode};
use crate::transform::to_affine2;
use crate::xml::Element;
use glam::{Affine2, Vec2, Vec3};

/// The texture-coordinate transform shared by the texture plugins: torrey's
/// `uscale`/`vscale`/`uoffset`/`voffset` (`uvscale` sets both scales) are applied first, then
/// Mitsuba 3's `to_uv` transform: uv' = to_uv(scale * uv + offset).
fn uv_transform(ctx: &Ctx, props: &mut Props) -> Result<Affine2> {
    let uv = props.float(ctx, &["uvscale"], 1.0)?;
    let us = props.float(ctx, &["uscale"], uv)?;
    let vs = props.float(ctx, &["vscale"], uv)?;
    let uo = props.float(ctx, &["uoffset"], 0.0)?;
    let vo = props.float(ctx, &["voffset"], 0.0)?;
    let scale_offset =
        Affine2::from_scale_angle_translation(Vec2::new(us, vs), 0.0, Vec2::new(uo, vo));
    let to_uv = props
        .transform(ctx, &["to_uv"], true)?
        .map_or(Affine2::IDENTITY, to_affine2);
    Ok(to_uv * scale_offset)
}

/// `bitmap` parameters (also read by `envmap`):
///
/// | name | type | default |
/// | --- | --- | --- |
/// | `filename` | string | required; found with the scene file's resolver (`<path>` folders, then its folder) |
/// | `uscale`, `vscale` | float | 1 |
/// | `uvscale` | float | 1 (sets both scales) |
/// | `uoffset`, `voffset` | float | 0 |
/// | `to_uv` | transform | identity (applied after scale/offset) |
/// | `raw` | boolean | false (true: no sRGB decoding of 8-bit images) |
/// | `filter_type` | string | `bilinear` (`nearest`; `trilinear`/`ewa` read as bilinear) |
/// | `wrap_mode` | string | `repeat` (`mirror`, `clamp`; `zero`/`one` read as clamp) |
pub(crate) fn parse_bitmap(ctx: &mut Ctx, props: &mut Props, elem: &Element) -> Result<Bitmap> {
    let Some(file) = props.string(ctx, &["filename"])? else {
        return Err(ctx.err(
            elem.pos,
            format!("missing required parameter 'filename' of {}", props.owner),
        ));
    };
    let filename = input_file(ctx, file, "texture")?;
    let to_uv = uv_transform(ctx, props)?;
    let raw = props.boolean(ctx, &["raw"], false)?;
    let filter = match props.string(ctx, &["filter_type"])? {
        None => FilterType::Bilinear,
        Some(a) => match a.value.as_str() {
            "bilinear" => FilterType::Bilinear,
            "nearest" => FilterType::Nearest,
            "trilinear" | "ewa" => {
                ctx.warn(
                    a.value_pos,
                    format!("filter_type '{}' is read as bilinear", a.value),
                );
                FilterType::Bilinear
            }
            v => {
                return Err(ctx.err(
                    a.value_pos,
                    format!("unknown filter_type '{v}' (expected bilinear or nearest)"),
                ))
            }
        },
    };
    let wrap = match props.string(ctx, &["wrap_mode"])? {
        None => WrapMode::Repeat,
        Some(a) => match a.value.as_str() {
            "repeat" => WrapMode::Repeat,
            "mirror" => WrapMode::Mirror,
            "clamp" => WrapMode::Clamp,
            "zero" | "one" => {
                ctx.warn(
                    a.value_pos,
                    format!("wrap_mode '{}' is read as clamp", a.value),
                );
                WrapMode::Clamp
            }
            v => {
                return Err(ctx.err(
                    a.value_pos,
                    format!("unknown wrap_mode '{v}' (expected repeat, mirror or clamp)"),
                ))
            }
        },
    };
    Ok(Bitmap {
        filename,
        to_uv,
        raw,
        filter,
        wrap,
        location: ctx.location(file.value_pos),
    })
}

/// A nested `<texture type="bitmap">` read as a bitmap only (for envmaps): not added to the
/// scene's texture table.
pub(crate) fn bitmap_element(ctx: &mut Ctx, elem: &Element) -> Result<Bitmap> {
    let ty = plugin_type(ctx, elem)?;
    if ty != "bitmap" {
        return Err(unknown_type(ctx, elem, "texture here", &["bitmap"]));
    }
    let mut props = Props::new(ctx, elem, "texture 'bitmap'".into())?;
    let b = parse_bitmap(ctx, &mut props, elem)?;
    props.finish(ctx);
    Ok(b)
}

/// `rawconstant`'s `value`: a `<float>` (one channel) or a `<vector>`/`<point>` (three), as
/// Mitsuba's properties type it; any other tag is an error, as in Mitsuba.
fn raw_constant(ctx: &Ctx, props: &mut Props, elem: &Element) -> Result<TextureKind> {
    let Some(e) = props.take("value") else {
        return Err(ctx.err(
            elem.pos,
            "missing required parameter 'value' of texture 'rawconstant' (a <float> or a 3D <vector>)",
        ));
    };
    match e.tag.as_str() {
        "float" => {
            let a = e.attr("value").ok_or_else(|| {
                ctx.err(e.pos, "missing required attribute 'value' on <float name=\"value\">")
            })?;
            let v = crate::values::float(&a.value).map_err(|m| {
                ctx.err(
                    a.value_pos,
                    format!("{m} in parameter 'value' of texture 'rawconstant'"),
                )
            })?;
            Ok(TextureKind::RawConstant {
                value: Vec3::splat(v),
                channels: 1,
            })
        }
        "vector" | "point" => Ok(TextureKind::RawConstant {
            value: props.xyz(ctx, e, 0.0)?,
            channels: 3,
        }),
        t => Err(ctx.err(
            e.pos,
            format!("parameter 'value' of texture 'rawconstant' must be a <float> or a 3D <vector> (as in Mitsuba), found <{t}>"),
        )),
    }
}

/// The texture types this parser reads.
pub(crate) const KNOWN: &[&str] = &["bitmap", "checkerboard", "mesh_attribute", "rawconstant"];

/// Parses a `<texture>` (top level or inline), adds it to the scene and registers its id.
///
/// `bitmap`: see [`parse_bitmap`]. `checkerboard`:
///
/// | name | type | default |
/// | --- | --- | --- |
/// | `color0` | colour | 0.4 |
/// | `color1` | colour | 0.2 |
/// | `to_uv`, `uscale`, `vscale`, `uoffset`, `voffset`, `uvscale` | as bitmap | identity |
///
/// `mesh_attribute` (the shapes that use it must have the attribute: checked with the shape):
///
/// | name | type | default |
/// | --- | --- | --- |
/// | `name` | string | required; starts with `vertex_` or `face_` |
/// | `scale` | float | 1 |
///
/// `rawconstant` (Mitsuba 3.9.1's: no colour conversion, no range check):
///
/// | name | type | default |
/// | --- | --- | --- |
/// | `value` | `<float>` (one channel, read as grey) or `<vector>`/`<point>` (three; not usable as a float parameter) | required |
pub(crate) fn parse_texture(ctx: &mut Ctx, elem: &Element) -> Result<TextureId> {
    if let Some(IdTarget::Texture(t)) = ctx.already(elem) {
        // A `<ref>` made us parse it before its place in the document.
        return Ok(t);
    }
    let ty = plugin_type(ctx, elem)?;
    if !KNOWN.contains(&ty) {
        return Err(unknown_type(ctx, elem, "texture", KNOWN));
    }
    let mut props = Props::new(ctx, elem, format!("texture '{ty}'"))?;
    let kind = if ty == "bitmap" {
        TextureKind::Bitmap(parse_bitmap(ctx, &mut props, elem)?)
    } else if ty == "mesh_attribute" {
        let Some(name) = props.string(ctx, &["name"])? else {
            return Err(ctx.err(
                elem.pos,
                "missing required parameter 'name' of texture 'mesh_attribute'",
            ));
        };
        if !name.value.starts_with("vertex_") && !name.value.starts_with("face_") {
            return Err(ctx.err(
                name.value_pos,
                format!(
                    "invalid mesh attribute name '{}': it must start with 'vertex_' or 'face_' (as in Mitsuba)",
                    name.value
                ),
            ));
        }
        let name = name.value.to_string();
        TextureKind::MeshAttribute {
            name,
            scale: props.float(ctx, &["scale"], 1.0)?,
            location: ctx.location(elem.pos),
        }
    } else if ty == "rawconstant" {
        raw_constant(ctx, &mut props, elem)?
    } else {
        TextureKind::Checkerboard {
            color0: props.color(ctx, &["color0"], Vec3::splat(0.4))?,
            color1: props.color(ctx, &["color1"], Vec3::splat(0.2))?,
            to_uv: uv_transform(ctx, &mut props)?,
        }
    };
    props.finish(ctx);
    ctx.textures.push(Texture {
        id: elem.attr_value("id").map(String::from),
        kind,
    });
    let index = ctx.textures.len() - 1;
    ctx.register_id(elem, IdTarget::Texture(index))?;
    Ok(index)
}
