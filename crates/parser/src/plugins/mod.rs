//! Plugin parsers (one module per kind, as in Mitsuba) and the scene assembly.

pub(crate) mod bsdf;
pub(crate) mod dialect;
pub(crate) mod emitter;
pub(crate) mod integrator;
pub(crate) mod medium;
pub(crate) mod sensor;
pub(crate) mod shape;
pub(crate) mod texture;

use crate::context::Ctx;
use crate::error::{ParseError, Result};
use crate::include;
use crate::props::SKIPPED_TAGS;
use crate::scene::{Dialect, Light, Scene};
use crate::xml::{location, Element};
use glam::Vec3;
use std::path::Path;

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
    let (detected, reason) = dialect::detect(&root, &expanded.sources)?;
    let (dialect, dialect_reason) = match forced {
        Some(d) if d != detected => (d, format!("forced (detected {reason})")),
        Some(d) => (d, format!("forced, as detected ({reason})")),
        None => (detected, reason),
    };
    let mut ctx = Ctx::new(expanded.sources, dialect, limits);
    ctx.warnings = expanded.warnings;
    ctx.declare_ids(&root)?;
    let mut camera_parts = None;
    let mut integrator = None;
    let mut shapes = Vec::new();
    let mut lights = Vec::new();
    let mut has_background = false;
    for child in &root.children {
        match child.tag.as_str() {
            // Declared with the ids, before parsing (Ctx::declare_ids).
            "alias" => {}
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
                shape::define_area_emitter(&mut ctx, child)?;
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
