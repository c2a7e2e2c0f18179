//! Participating media (Mitsuba 3's `<medium>`), their phase functions (`<phase>`) and volumes
//! (`<volume>`).
//!
//! `homogeneous`, `heterogeneous`:
//!
//! | name | type | default |
//! | --- | --- | --- |
//! | `sigma_t` | float, rgb, spectrum or `<volume>` | 1 (per unit length; `homogeneous` needs a constant) |
//! | `albedo` | float, rgb, spectrum or `<volume>` | 0.75 (values above 1 are clamped to 1 with a warning) |
//! | `scale` | float | 1 (multiplies `sigma_t`; not negative) |
//! | `sample_emitters` | boolean | true (next-event estimation at scattering events) |
//! | `has_spectral_extinction` | boolean | accepted; no effect on the image |
//! | nested `<phase>` | phase function | `isotropic` |
//!
//! Phase functions: `isotropic`; `hg` (`g`, float in (-1, 1), default 0.8); `rayleigh`;
//! `blendphase` (`weight`, float in [0, 1], default 0.5; two nested `<phase>`s:
//! (1 - weight) · first + weight · second, in document order whatever their names, as
//! Mitsuba 3.9.1 takes them).
//!
//! Volumes: `constvolume` (`value`: float, rgb or spectrum, default 1); `gridvolume`:
//!
//! | name | type | default |
//! | --- | --- | --- |
//! | `filename` | string | required: Mitsuba's binary `.vol` (1 or 3 channels) |
//! | `to_world` | transform | identity: the grid spans the unit cube of its local space |
//! | `use_grid_bbox` | boolean | false: true places the grid in the file's bounding box (before `to_world`) |
//! | `filter_type` | string | `trilinear` (`nearest`) |
//! | `max_value` | float | the largest value of the grid: the majorant is built on it |
//! | `wrap_mode` | string | `clamp` (the only mode; others are read as clamp with a warning) |
//! | `raw`, `accel` | boolean | accepted; no effect in RGB |

use crate::context::{plugin_type, unknown_type, Ctx, IdTarget};
use crate::error::Result;
use crate::files::input_file;
use crate::media::{GridVolume, Medium, MediumId, Phase, Volume};
use crate::props::Props;
use crate::xml::Element;
use glam::{Mat4, Vec3};
use std::sync::Arc;

pub(crate) const MEDIA: &[&str] = &["homogeneous", "heterogeneous"];
pub(crate) const PHASES: &[&str] = &["isotropic", "hg", "rayleigh", "blendphase"];
pub(crate) const VOLUMES: &[&str] = &["constvolume", "gridvolume"];

/// Reads a `<medium>`, adds it to the scene's media and registers its id.
pub(crate) fn parse_medium(ctx: &mut Ctx, elem: &Element) -> Result<MediumId> {
    if let Some(IdTarget::Medium(m)) = ctx.already(elem) {
        return Ok(m); // parsed already, for a `<ref>` that came before it
    }
    let ty = plugin_type(ctx, elem)?;
    if !MEDIA.contains(&ty) {
        return Err(unknown_type(ctx, elem, "medium", MEDIA));
    }
    let mut props = Props::new(ctx, elem, format!("medium '{ty}'"))?;
    let homogeneous = ty == "homogeneous";
    let sigma_t = volume_param(ctx, &mut props, "sigma_t", 1.0)?;
    if let (true, Volume::Grid(_)) = (homogeneous, &sigma_t) {
        let pos = named(elem, "sigma_t").map_or(elem.pos, |e| e.pos);
        return Err(ctx.err(
            pos,
            "medium 'homogeneous' needs a constant sigma_t; a grid extinction is medium 'heterogeneous'",
        ));
    }
    let mut albedo = volume_param(ctx, &mut props, "albedo", 0.75)?;
    clamp_albedo(ctx, elem, &mut albedo);
    let scale = props.float_where(ctx, &["scale"], 1.0, "at least 0", |s| s >= 0.0)?;
    let sample_emitters = props.boolean(ctx, &["sample_emitters"], true)?;
    props.ignore(&["has_spectral_extinction"]);
    let phases = props.take_tag("phase");
    let phase = match phases.first() {
        Some(p) => parse_phase(ctx, p)?,
        None => Phase::Isotropic,
    };
    if let Some(extra) = phases.get(1) {
        return Err(ctx.err(extra.pos, "a medium has one phase function"));
    }
    props.finish(ctx);
    ctx.media.push(Medium {
        id: elem.attr_value("id").map(str::to_string),
        homogeneous,
        sigma_t,
        albedo,
        scale,
        phase,
        sample_emitters,
    });
    let index = ctx.media.len() - 1;
    ctx.register_id(elem, IdTarget::Medium(index))?;
    Ok(index)
}

/// The medium a `<ref>` or nested `<medium>` names.
pub(crate) fn medium_of(ctx: &mut Ctx, elem: &Element, owner: &str) -> Result<MediumId> {
    if elem.tag == "medium" {
        return parse_medium(ctx, elem);
    }
    match ctx.lookup(elem)? {
        IdTarget::Medium(m) => Ok(m),
        _ => Err(ctx.err(
            elem.pos,
            format!(
                "<ref id=\"{}\"> in {owner} must name a medium",
                elem.attr_value("id").unwrap_or("")
            ),
        )),
    }
}

fn named<'e>(elem: &'e Element, name: &str) -> Option<&'e Element> {
    elem.children
        .iter()
        .find(|c| c.attr_value("name") == Some(name))
}

/// Albedos above 1 would add energy at every scattering event: clamped, with a warning.
fn clamp_albedo(ctx: &mut Ctx, elem: &Element, albedo: &mut Volume) {
    let pos = named(elem, "albedo").map_or(elem.pos, |e| e.pos);
    match albedo {
        Volume::Constant(c) if c.max_element() > 1.0 => {
            ctx.warn(
                pos,
                format!("albedo {} {} {} is above 1; clamped to 1", c.x, c.y, c.z),
            );
            *c = c.min(Vec3::ONE);
        }
        Volume::Grid(g) if g.max > 1.0 => {
            let g = Arc::make_mut(g);
            let over = g.data.iter().filter(|&&v| v > 1.0).count();
            ctx.warn(
                pos,
                format!(
                    "{over} albedo values of the grid are above 1 (up to {}); clamped to 1",
                    g.max
                ),
            );
            g.data.iter_mut().for_each(|v| *v = v.min(1.0));
            g.max = 1.0;
        }
        _ => {}
    }
}

/// A volume parameter: a constant (float, rgb, spectrum) or a nested `<volume>`.
fn volume_param(ctx: &mut Ctx, props: &mut Props, name: &str, default: f32) -> Result<Volume> {
    let Some(e) = props.take(name) else {
        return Ok(Volume::Constant(Vec3::splat(default)));
    };
    if e.tag == "volume" {
        return parse_volume(ctx, e);
    }
    Ok(Volume::Constant(props.color_of(ctx, e)?))
}

/// Reads a `<volume>`: `constvolume` or `gridvolume`.
pub(crate) fn parse_volume(ctx: &mut Ctx, elem: &Element) -> Result<Volume> {
    let ty = plugin_type(ctx, elem)?;
    if !VOLUMES.contains(&ty) {
        return Err(unknown_type(ctx, elem, "volume", VOLUMES));
    }
    let mut props = Props::new(ctx, elem, format!("volume '{ty}'"))?;
    let to_world = props.transform(ctx, &["to_world"], false)?;
    let volume = if ty == "constvolume" {
        Volume::Constant(props.color(ctx, &["value"], Vec3::ONE)?)
    } else {
        Volume::Grid(Arc::new(parse_grid(ctx, &mut props, elem, to_world)?))
    };
    props.finish(ctx);
    Ok(volume)
}

fn parse_grid(
    ctx: &mut Ctx,
    props: &mut Props,
    elem: &Element,
    to_world: Option<Mat4>,
) -> Result<GridVolume> {
    let Some(file) = props.string(ctx, &["filename"])? else {
        return Err(ctx.err(
            elem.pos,
            format!("missing required parameter 'filename' of {}", props.owner),
        ));
    };
    let path = input_file(ctx, file, "volume")?;
    let grid = crate::vol::read_vol_file(
        &path,
        ctx.limits.volume_values.saturating_sub(ctx.volume_values),
    )
    .map_err(|e| {
        ctx.err(
            file.value_pos,
            format!("in volume file '{}': {e}", file.value),
        )
    })?;
    ctx.volume_values += grid.data.len() as u64;
    if grid.channels != 1 && grid.channels != 3 {
        return Err(ctx.err(
            file.value_pos,
            format!(
                "in volume file '{}': {} channels; a volume has 1 or 3",
                file.value, grid.channels
            ),
        ));
    }
    let mut data = grid.data;
    let negative = data.iter().filter(|&&v| v < 0.0).count();
    if negative > 0 {
        ctx.warn(
            file.value_pos,
            format!(
                "volume file '{}': {negative} negative values clamped to 0",
                file.value
            ),
        );
        data.iter_mut().for_each(|v| *v = v.max(0.0));
    }
    let nearest = match props.string(ctx, &["filter_type"])? {
        None => false,
        Some(a) => match a.value.as_str() {
            "trilinear" => false,
            "nearest" => true,
            other => {
                return Err(ctx.err(
                    a.value_pos,
                    format!("filter_type must be 'trilinear' or 'nearest', found '{other}'"),
                ))
            }
        },
    };
    if let Some(a) = props.string(ctx, &["wrap_mode"])? {
        if a.value != "clamp" {
            ctx.warn(
                a.value_pos,
                format!("wrap_mode '{}' is read as 'clamp'", a.value),
            );
        }
    }
    props.ignore(&["raw", "accel"]);
    let mut to_local = to_world.unwrap_or(Mat4::IDENTITY).inverse();
    if props.boolean(ctx, &["use_grid_bbox"], false)? {
        let [lo, hi] = grid.bbox.map(Vec3::from);
        let extent = (hi - lo).max(Vec3::splat(f32::MIN_POSITIVE));
        let bbox = Mat4::from_scale(extent.recip()) * Mat4::from_translation(-lo);
        to_local = bbox * to_local;
    }
    if !to_local.is_finite() {
        return Err(ctx.err(
            elem.pos,
            format!("{}: to_world is not invertible", props.owner),
        ));
    }
    let data_max = data.iter().fold(0.0f32, |m, &v| m.max(v));
    let max = props.float_where(ctx, &["max_value"], data_max, "at least 0", |v| v >= 0.0)?;
    Ok(GridVolume {
        size: grid.size,
        channels: grid.channels,
        data,
        to_local,
        nearest,
        max,
    })
}

/// Reads a `<phase>`.
pub(crate) fn parse_phase(ctx: &mut Ctx, elem: &Element) -> Result<Phase> {
    let ty = plugin_type(ctx, elem)?;
    if !PHASES.contains(&ty) {
        return Err(unknown_type(ctx, elem, "phase", PHASES));
    }
    let mut props = Props::new(ctx, elem, format!("phase '{ty}'"))?;
    let phase = match ty {
        "isotropic" => Phase::Isotropic,
        "rayleigh" => Phase::Rayleigh,
        "hg" => {
            Phase::Hg(props.float_where(ctx, &["g"], 0.8, "in (-1, 1)", |g| g > -1.0 && g < 1.0)?)
        }
        _ => {
            let weight = props.float_where(ctx, &["weight"], 0.5, "in [0, 1]", |w| {
                (0.0..=1.0).contains(&w)
            })?;
            // In document order, whatever their names (as Mitsuba 3.9.1 reads them).
            let nested = props.take_tag("phase");
            if nested.len() != 2 {
                return Err(ctx.err(
                    elem.pos,
                    format!(
                        "phase 'blendphase' needs two nested phase functions, found {}",
                        nested.len()
                    ),
                ));
            }
            let first = parse_phase(ctx, nested[0])?;
            let second = parse_phase(ctx, nested[1])?;
            Phase::Blend(weight, Box::new(first), Box::new(second))
        }
    };
    props.finish(ctx);
    Ok(phase)
}
