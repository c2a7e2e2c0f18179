//! Plugin parsers (one module per kind, as in Mitsuba) and the scene assembly.

pub(crate) mod bsdf;
pub(crate) mod emitter;
pub(crate) mod sensor;
pub(crate) mod shape;
pub(crate) mod texture;

use crate::context::Ctx;
use crate::error::{ParseError, Result};
use crate::props::{describe, SKIPPED_TAGS};
use crate::scene::{Dialect, Light, Scene};
use crate::values;
use crate::xml::{location, Element};
use glam::Vec3;
use std::collections::HashMap;
use std::path::Path;

/// Reads `<scene version>`: below 2.0.0 is the torrey dialect.
fn dialect(root: &Element, file: &Path) -> Result<Dialect> {
    let err = |pos, message: String| ParseError {
        location: location(file, pos),
        message,
    };
    let Some(v) = root.attr("version") else {
        return Err(err(
            root.pos,
            "missing required attribute 'version' on <scene>".into(),
        ));
    };
    let major = v
        .value
        .split('.')
        .next()
        .and_then(|m| m.trim().parse::<u32>().ok())
        .ok_or_else(|| {
            err(
                v.value_pos,
                format!("cannot parse scene version '{}'", v.value),
            )
        })?;
    Ok(if major < 2 {
        Dialect::Torrey
    } else {
        Dialect::Mitsuba3
    })
}

/// Applies `$name` substitution to every attribute below `elem`, except `<default>`s' own.
/// `growth` is how many bytes substitution may still add to the document: a long default
/// referenced a million times must not inflate a small file into gigabytes.
fn substitute_tree(
    elem: &mut Element,
    defaults: &HashMap<String, String>,
    file: &Path,
    growth: &mut u64,
) -> Result<()> {
    for child in &mut elem.children {
        if child.tag == "default" {
            continue;
        }
        for a in &mut child.attrs {
            let value = values::substitute(&a.value, defaults).map_err(|name| ParseError {
                location: location(file, a.value_pos),
                message: format!(
                    "undefined parameter '${name}' in attribute '{}' of <{}> (add <default name=\"{name}\" .../> or -D {name}=...)",
                    a.name, child.tag
                ),
            })?;
            let added = value.len().saturating_sub(a.value.len()) as u64;
            *growth = growth.checked_sub(added).ok_or_else(|| ParseError {
                location: location(file, a.value_pos),
                message: "substituting <default> values makes the scene larger than the scene_bytes limit (raise with --limit scene_bytes=N)".into(),
            })?;
            a.value = value;
        }
        substitute_tree(child, defaults, file, growth)?;
    }
    Ok(())
}

/// Builds a [`Scene`] from the parsed document.
pub(crate) fn parse_scene(
    mut root: Element,
    path: &Path,
    overrides: &[(String, String)],
    limits: &crate::limits::Limits,
) -> Result<Scene> {
    if root.tag != "scene" {
        return Err(ParseError {
            location: location(path, root.pos),
            message: format!("the root element must be <scene>, found <{}>", root.tag),
        });
    }
    let dialect = dialect(&root, path)?;
    let mut ctx = Ctx::new(path, dialect, limits);
    // A name defined twice keeps its first value, as in Mitsuba 3, with a warning.
    let mut defaults: HashMap<String, String> = HashMap::new();
    for d in root.children.iter().filter(|c| c.tag == "default") {
        let get = |n: &str| {
            d.attr_value(n).ok_or_else(|| ParseError {
                location: location(path, d.pos),
                message: format!("missing required attribute '{n}' on <default>"),
            })
        };
        let name = get("name")?;
        let value = get("value")?;
        if defaults.contains_key(name) {
            ctx.warn(
                d.pos,
                format!("<default name=\"{name}\"> is given again; the first value is used"),
            );
        } else {
            defaults.insert(name.to_string(), value.to_string());
        }
    }
    for (k, v) in overrides {
        defaults.insert(k.clone(), v.clone());
    }
    let mut growth = limits.scene_bytes;
    substitute_tree(&mut root, &defaults, path, &mut growth)?;

    let mut camera_parts = None;
    let mut integrator = None;
    let mut shapes = Vec::new();
    let mut lights = Vec::new();
    let mut has_background = false;
    for child in &root.children {
        match child.tag.as_str() {
            "default" => {}
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
                let i = sensor::parse_integrator(&mut ctx, child)?;
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
            "shape" => shapes.push(shape::parse_shape(&mut ctx, child)?),
            "emitter" => {
                let light = emitter::parse_emitter(&mut ctx, child)?;
                has_background |= matches!(light, Light::Envmap { .. } | Light::Constant { .. });
                lights.push(light);
            }
            "background" => {
                lights.push(emitter::parse_background(&mut ctx, child)?);
                has_background = true;
            }
            t if SKIPPED_TAGS.contains(&t) => {
                ctx.warn(
                    child.pos,
                    format!("{} is not supported; ignored", describe(child)),
                );
            }
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
            sensor::default_film(),
            sensor::default_sampler(),
        )
    });
    let warnings = ctx.finish_warnings();
    Ok(Scene {
        path: path.to_path_buf(),
        dialect,
        camera,
        film,
        sampler,
        integrator: integrator.unwrap_or_else(sensor::default_integrator),
        textures: ctx.textures,
        bsdfs: ctx.bsdfs,
        shapes,
        lights,
        warnings,
    })
}
