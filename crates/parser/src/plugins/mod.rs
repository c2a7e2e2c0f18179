//! Plugin parsers (one module per kind, as in Mitsuba) and the scene assembly.

pub(crate) mod bsdf;
pub(crate) mod emitter;
pub(crate) mod integrator;
pub(crate) mod medium;
pub(crate) mod sensor;
pub(crate) mod shape;
pub(crate) mod texture;

use crate::context::{Ctx, IdTarget};
use crate::error::{ParseError, Result};
use crate::include::{self, Sources};
use crate::props::SKIPPED_TAGS;
use crate::scene::{Dialect, Light, Scene};
use crate::xml::{location, Element};
use glam::Vec3;
use std::path::Path;

/// bsdf types only the torrey course has (its own phong, blinn, blinn_microfacet and mirror).
const TORREY_BSDFS: &[&str] = &[
    "mirror",
    "phong",
    "blinn",
    "blinnphong",
    "blinn_microfacet",
    "blinnphong_microfacet",
];

/// The first element (depth first, document order) that only the torrey course dialect has.
fn torrey_marker(elem: &Element) -> Option<&Element> {
    for c in &elem.children {
        if c.tag == "background"
            || (c.tag == "bsdf"
                && c.attr_value("type")
                    .is_some_and(|t| TORREY_BSDFS.contains(&t)))
        {
            return Some(c);
        }
        if let Some(m) = torrey_marker(c) {
            return Some(m);
        }
    }
    None
}

/// Decides the dialect: `<scene version>` 2.0 and up is Mitsuba 3; 1.x exists only in the torrey
/// course; 0.x (Mitsuba 0.5/0.6 and the course's older files) is the torrey dialect only when the
/// file has something only the course has (a `<background>`, the course's bsdfs). Returns the
/// dialect and why, for the summary line.
fn dialect(root: &Element, sources: &Sources) -> Result<(Dialect, String)> {
    let Some(v) = root.attr("version") else {
        return Err(sources.err(root.pos, "missing required attribute 'version' on <scene>"));
    };
    let major = v
        .value
        .split('.')
        .next()
        .and_then(|m| m.trim().parse::<u32>().ok())
        .ok_or_else(|| {
            sources.err(
                v.value_pos,
                format!("cannot parse scene version '{}'", v.value),
            )
        })?;
    Ok(match major {
        2.. => (Dialect::Mitsuba3, format!("scene version {}", v.value)),
        1 => (
            Dialect::Torrey,
            format!("scene version {} (the torrey course's)", v.value),
        ),
        0 => match torrey_marker(root) {
            Some(m) => {
                let what = match m.attr_value("type") {
                    Some(t) if m.tag == "bsdf" => format!("bsdf '{t}'"),
                    _ => format!("<{}>", m.tag),
                };
                (
                    Dialect::Torrey,
                    format!(
                        "scene version {} with the torrey course's {what} at {}",
                        v.value,
                        sources.location(m.pos)
                    ),
                )
            }
            None => (
                Dialect::Mitsuba3,
                format!(
                    "scene version {} without torrey course elements: Mitsuba's semantics",
                    v.value
                ),
            ),
        },
    })
}

/// Builds a [`Scene`] from the parsed document; `dialect` overrides the detected dialect.
pub(crate) fn parse_scene(
    root: Element,
    path: &Path,
    overrides: &[(String, String)],
    forced: Option<Dialect>,
    limits: &crate::limits::Limits,
) -> Result<Scene> {
    if root.tag != "scene" {
        return Err(ParseError {
            location: location(path, root.pos),
            message: format!("the root element must be <scene>, found <{}>", root.tag),
        });
    }
    let expanded = include::expand(root, path, overrides, limits)?;
    let root = expanded.root;
    let (detected, reason) = dialect(&root, &expanded.sources)?;
    let (dialect, dialect_reason) = match forced {
        Some(d) if d != detected => (d, format!("forced (detected {reason})")),
        Some(d) => (d, format!("forced, as detected ({reason})")),
        None => (detected, reason),
    };
    let mut ctx = Ctx::new(expanded.sources, dialect, limits);
    ctx.warnings = expanded.warnings;
    let mut camera_parts = None;
    let mut integrator = None;
    let mut shapes = Vec::new();
    let mut lights = Vec::new();
    let mut has_background = false;
    for child in &root.children {
        match child.tag.as_str() {
            "alias" => ctx.alias(child)?,
            "sensor" => {
                if camera_parts.is_some() {
                    ctx.warn(
                        child.pos,
                        "only the first <sensor> is used; this one is ignored",
                    );
                } else {
                    camera_parts = Some(sensor::parse_sensor(&mut ctx, child)?);
                }
            }
            "integrator" => {
                let i = integrator::parse_integrator(&mut ctx, child)?;
                if integrator.is_some() {
                    ctx.warn(
                        child.pos,
                        "only the first <integrator> is used; this one is ignored",
                    );
                } else {
                    integrator = Some(i);
                }
            }
            "bsdf" => {
                bsdf::parse_bsdf(&mut ctx, child)?;
            }
            "texture" => {
                texture::parse_texture(&mut ctx, child)?;
            }
            "shape" => shapes.extend(shape::parse_shape(&mut ctx, child)?),
            "emitter" if child.attr_value("type") == Some("area") && child.attr("id").is_some() => {
                // Declared here, attached to shapes by `<ref>` (as Mitsuba allows).
                let emission = shape::parse_area_emitter(&mut ctx, child)?;
                ctx.area_emitters.push(emission);
                let index = ctx.area_emitters.len() - 1;
                ctx.register_id(child, IdTarget::AreaEmitter(index))?;
            }
            "emitter" => {
                let light = emitter::parse_emitter(&mut ctx, child)?;
                has_background |= matches!(light, Light::Envmap { .. } | Light::Constant { .. });
                lights.push(light);
            }
            "background" => {
                lights.push(emitter::parse_background(&mut ctx, child)?);
                has_background = true;
            }
            "medium" => {
                medium::parse_medium(&mut ctx, child)?;
            }
            t if SKIPPED_TAGS.contains(&t) => ctx.warn_media(child, None),
            t @ ("film" | "sampler" | "rfilter") => {
                return Err(ctx.err(child.pos, format!("<{t}> must be inside a <sensor>")));
            }
            t => {
                return Err(ctx.err(child.pos, format!("unknown tag <{t}> in <scene>")));
            }
        }
    }
    if dialect == Dialect::Torrey && !has_background {
        // The torrey course renderer's default environment: constant 0.5 grey.
        lights.push(Light::Constant {
            radiance: Vec3::splat(0.5),
        });
    }
    let (camera, film, sampler) = camera_parts.unwrap_or_else(|| {
        (
            sensor::default_camera(dialect),
            sensor::default_film(dialect),
            sensor::default_sampler(),
        )
    });
    shape::warn_unused_groups(&mut ctx);
    let warnings = ctx.finish_warnings();
    Ok(Scene {
        path: path.to_path_buf(),
        dialect,
        dialect_reason,
        camera,
        film,
        sampler,
        integrator: integrator.unwrap_or_else(integrator::default_integrator),
        textures: ctx.textures,
        bsdfs: ctx.bsdfs,
        shapes,
        shape_groups: ctx.shape_groups,
        instances: ctx.instances,
        lights,
        media: ctx.media,
        files: ctx.files.into_inner(),
        warnings,
    })
}
