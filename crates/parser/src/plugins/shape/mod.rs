//! Shape plugins: `obj`, `ply`, `serialized`, `sphere`, `rectangle`, `cube`, `disk`, `cylinder`,
//! `sdfgrid`, `shapegroup`, `instance`.

mod area;
mod instance;
mod mesh;
mod sdfgrid;

pub(crate) use area::{define_area_emitter, parse_area_emitter};
pub(crate) use instance::warn_unused_groups;
use instance::{parse_instance, parse_shapegroup};
use mesh::{cube_mesh, mesh};
use sdfgrid::sdf_grid;

use crate::context::{plugin_type, unknown_type, Ctx, IdTarget};
use crate::error::Result;
use crate::media::MediumId;
use crate::plugins::bsdf::parse_bsdf;
use crate::plugins::medium::parse_medium;
use crate::props::Props;
use crate::scene::{Bsdf, BsdfId, BsdfKind, ColorParam, Dialect, Geometry, Shape, TextureKind};
use crate::xml::Element;
use glam::{Mat4, Vec3};

/// The types this parser reads (see `torrey_parser::accepted_plugins`).
pub(crate) const KNOWN: &[&str] = &[
    "obj",
    "ply",
    "serialized",
    "sphere",
    "rectangle",
    "cube",
    "disk",
    "cylinder",
    "sdfgrid",
    "shapegroup",
    "instance",
];

/// How far from the origin world-space geometry may reach: 1e14. The BVH builder sums surface
/// areas of bounding boxes (an extent of 2e19 already has an infinite area in f32), and ray
/// arithmetic squares distances; 1e14 leaves room for both with millions of primitives.
pub(crate) const WORLD_EXTENT: f64 = 1e14;

/// Why a shape cannot be placed in world space, if it cannot: its vertices (or its sphere's or
/// rectangle's extent) moved by `to_world` must stay within [`WORLD_EXTENT`] of the origin.
pub(super) fn world_problem(geometry: &Geometry, to_world: Mat4) -> Option<String> {
    // The largest coordinate magnitude, in f64 so that nothing overflows while measuring.
    let m = to_world.as_dmat4();
    let farthest = |points: &mut dyn Iterator<Item = glam::DVec3>| {
        points.fold(0.0f64, |acc, p| {
            let p = m.transform_point3(p).abs().max_element();
            if p.is_nan() {
                f64::INFINITY
            } else {
                acc.max(p)
            }
        })
    };
    let reach = match geometry {
        Geometry::Mesh(mesh) => farthest(&mut mesh.positions.iter().map(|p| p.as_dvec3())),
        Geometry::Sphere { center, radius } => {
            let c = m.transform_point3(center.as_dvec3()).abs().max_element();
            let axes = [m.x_axis, m.y_axis, m.z_axis].map(|a| a.truncate().length());
            c + *radius as f64 * axes.iter().fold(0.0f64, |a, &b| a.max(b))
        }
        Geometry::Rectangle | Geometry::Disk => farthest(
            &mut [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                .into_iter()
                .map(|(x, y)| glam::DVec3::new(x, y, 0.0)),
        ),
        Geometry::Cylinder { p0, p1, radius } => {
            let ends = farthest(&mut [p0.as_dvec3(), p1.as_dvec3()].into_iter());
            let axes = [m.x_axis, m.y_axis, m.z_axis].map(|a| a.truncate().length());
            ends + *radius as f64 * axes.iter().fold(0.0f64, |a, &b| a.max(b))
        }
        Geometry::SdfGrid(_) => farthest(
            &mut (0..8)
                .map(|c| glam::DVec3::new((c & 1) as f64, (c >> 1 & 1) as f64, (c >> 2) as f64)),
        ),
    };
    (reach.is_nan() || reach > WORLD_EXTENT).then(|| {
        format!(
            "moved to world space by its to_world, the geometry reaches {reach:.3e}, beyond the {WORLD_EXTENT:e} torrey supports"
        )
    })
}

/// Every `mesh_attribute` texture that bsdf `bsdf` uses must name an attribute `geometry` has,
/// with one channel where a float parameter reads it (Mitsuba fails at render time otherwise;
/// torrey at load, at the shape).
fn check_mesh_attributes(
    ctx: &Ctx,
    elem: &Element,
    owner: &str,
    geometry: &Geometry,
    bsdf: BsdfId,
) -> Result<()> {
    let Some(uses) = ctx.bsdf_textures.get(&bsdf) else {
        return Ok(());
    };
    for &(t, float) in uses {
        let TextureKind::MeshAttribute { name, location, .. } = &ctx.textures[t].kind else {
            continue;
        };
        let found = match geometry {
            Geometry::Mesh(m) => m.attributes.iter().find(|a| &a.name == name),
            _ => None,
        };
        if let Some(a) = found.filter(|a| float && a.channels != 1) {
            return Err(ctx.err(
                elem.pos,
                format!(
                    "the mesh_attribute texture at {location} reads '{name}' of {owner} as a float parameter, but it has {} channels (as in Mitsuba, a float needs one)",
                    a.channels
                ),
            ));
        }
        let found = found.is_some();
        if !found {
            let has = match geometry {
                Geometry::Mesh(m) if !m.attributes.is_empty() => format!(
                    "it has {}",
                    m.attributes
                        .iter()
                        .map(|a| a.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                Geometry::Mesh(_) => "it has no attributes".to_string(),
                _ => "only meshes have attributes".to_string(),
            };
            return Err(ctx.err(
                elem.pos,
                format!(
                    "{owner} has no attribute '{name}' for the mesh_attribute texture at {location} ({has})"
                ),
            ));
        }
    }
    Ok(())
}

/// Parses a `<shape>`; inline bsdfs are added to the scene.
///
/// | shapes | name | type | default |
/// | --- | --- | --- | --- |
/// | all | `to_world` (`toWorld`) | transform | identity |
/// | all | `flip_normals` (`flipNormals`) | boolean | false |
/// | all | nested `<bsdf>` or `<ref>` | bsdf | none (Mitsuba's diffuse 0.5) |
/// | all | nested `<emitter type="area">` | `radiance`: colour (default 1), or a `<texture>` / `<ref>` (evaluated at the surface's uv) | none |
/// | obj, ply, serialized | `filename` | string | required |
/// | obj, ply, serialized | `face_normals` (`faceNormals`) | boolean | false |
/// | obj, ply | `flip_tex_coords` (`flipTexCoords`) | boolean | true for obj, false for ply |
/// | rectangle, cube | `face_normals` | boolean | false (read, no effect: flat already) |
/// | serialized | `shape_index` (`shapeIndex`) | integer | 0 |
/// | sphere | `center` | point | 0 |
/// | sphere | `radius` | float | 1 (must be positive) |
/// | cylinder | `p0`, `p1` | point | (0, 0, 0), (0, 0, 1) (must differ) |
/// | cylinder | `radius` | float | 1 (must be positive) |
pub(crate) fn parse_shape(ctx: &mut Ctx, elem: &Element) -> Result<Vec<Shape>> {
    let ty = plugin_type(ctx, elem)?;
    if !KNOWN.contains(&ty) {
        return Err(unknown_type(ctx, elem, "shape", KNOWN));
    }
    match ty {
        "shapegroup" => return parse_shapegroup(ctx, elem),
        "instance" => return parse_instance(ctx, elem),
        _ => {}
    }
    let mut props = Props::new(ctx, elem, format!("shape '{ty}'"))?;
    ctx.register_id(elem, IdTarget::Other)?;
    let to_world = props
        .transform(ctx, &["to_world"], false)?
        .unwrap_or(Mat4::IDENTITY);
    // Mitsuba's sdfgrid has no flip_normals: left unread, it is warned about as unused.
    let flip_normals = ty != "sdfgrid" && props.boolean(ctx, &["flip_normals"], false)?;
    let geometry = match ty {
        "sphere" => {
            let center = props.point(ctx, &["center"])?.unwrap_or(Vec3::ZERO);
            let radius = match props.opt_float_pos(ctx, &["radius"])? {
                None => 1.0,
                Some((r, pos)) if r <= 0.0 => {
                    return Err(ctx.err(pos, format!("sphere radius must be positive, found {r}")))
                }
                Some((r, _)) => r,
            };
            Geometry::Sphere { center, radius }
        }
        "rectangle" => {
            props.boolean(ctx, &["face_normals"], false)?;
            Geometry::Rectangle
        }
        "disk" => Geometry::Disk,
        "cylinder" => {
            let p0 = props.point(ctx, &["p0"])?.unwrap_or(Vec3::ZERO);
            let p1_pos = elem
                .children
                .iter()
                .find(|c| c.attr_value("name") == Some("p1"))
                .map_or(elem.pos, |c| c.pos);
            let p1 = props.point(ctx, &["p1"])?.unwrap_or(Vec3::Z);
            let radius = match props.opt_float_pos(ctx, &["radius"])? {
                None => 1.0,
                Some((r, pos)) if r <= 0.0 => {
                    return Err(ctx.err(pos, format!("cylinder radius must be positive, found {r}")))
                }
                Some((r, _)) => r,
            };
            if p0 == p1 {
                return Err(ctx.err(p1_pos, "cylinder p0 and p1 must differ"));
            }
            Geometry::Cylinder { p0, p1, radius }
        }
        "cube" => {
            props.boolean(ctx, &["face_normals"], false)?;
            Geometry::Mesh(cube_mesh())
        }
        "sdfgrid" => Geometry::SdfGrid(sdf_grid(ctx, &mut props, elem, to_world)?),
        _ => Geometry::Mesh(mesh(ctx, &mut props, elem, ty)?),
    };

    if let Some(problem) = world_problem(&geometry, to_world) {
        return Err(ctx.err(elem.pos, format!("{}: {problem}", props.owner)));
    }

    let mut candidates: Vec<&Element> = props.take_tag("bsdf");
    let mut emitters = props.take_tag("emitter");
    let (mut interior, mut exterior) = (None, None);
    for m in props.take_tag("medium") {
        *media_slot(ctx, m, &mut interior, &mut exterior)? = Some(parse_medium(ctx, m)?);
    }
    for r in props.take_tag("ref") {
        // Mitsuba resolves a shape's refs by what they name: a bsdf, an area emitter, a medium.
        match ctx.lookup(r)? {
            IdTarget::Bsdf(_) => candidates.push(r),
            IdTarget::AreaEmitter(_) => emitters.push(r),
            IdTarget::Medium(id) => *media_slot(ctx, r, &mut interior, &mut exterior)? = Some(id),
            _ => {
                return Err(ctx.err(
                    r.pos,
                    format!(
                        "<ref id=\"{}\"> in a shape must name a bsdf, an area emitter or a medium",
                        r.attr_value("id").unwrap_or("")
                    ),
                ))
            }
        }
    }
    emitters.sort_by_key(|e| (e.pos.line, e.pos.column));
    candidates.sort_by_key(|e| (e.pos.line, e.pos.column));
    if let Some(second) = candidates.get(1) {
        return Err(ctx.err(
            second.pos,
            format!("{} has more than one bsdf", props.owner),
        ));
    }
    let bsdf: Option<BsdfId> = match candidates.first() {
        None => None,
        Some(e) if e.tag == "ref" => match ctx.lookup(e)? {
            IdTarget::Bsdf(b) => Some(b),
            _ => {
                return Err(ctx.err(
                    e.pos,
                    format!(
                        "<ref id=\"{}\"> in a shape must name a bsdf",
                        e.attr_value("id").unwrap_or("")
                    ),
                ))
            }
        },
        Some(e) => Some(parse_bsdf(ctx, e)?),
    };

    if let Some(b) = bsdf {
        check_mesh_attributes(ctx, elem, &props.owner, &geometry, b)?;
    }

    if let Some(second) = emitters.get(1) {
        return Err(ctx.err(
            second.pos,
            format!("{} has more than one emitter", props.owner),
        ));
    }
    let emitter = match emitters.first() {
        None => None,
        Some(e) if e.tag == "ref" => match ctx.lookup(e)? {
            IdTarget::AreaEmitter(i) => Some(ctx.area_emitters[i]),
            _ => unreachable!("only area emitter refs are collected as emitters"),
        },
        Some(e) => Some(parse_area_emitter(ctx, e)?),
    };
    let (emitter, emitter_texture) = match emitter {
        Some((radiance, texture)) => (Some(radiance), texture),
        None => (None, None),
    };
    if emitter.is_some() && ty == "sdfgrid" {
        return Err(ctx.err(
            emitters[0].pos,
            "shape 'sdfgrid' cannot be an area emitter (Mitsuba cannot sample points on it either)",
        ));
    }
    // Mitsuba gives an emitting shape without a bsdf a black diffuse one (it does not reflect);
    // other shapes get diffuse 0.5 (`bsdf: None`). The torrey course keeps 0.5 for both.
    let bsdf = match bsdf {
        None if emitter.is_some() && ctx.dialect == Dialect::Mitsuba3 => {
            ctx.bsdfs.push(Bsdf {
                id: None,
                kind: BsdfKind::Diffuse {
                    reflectance: ColorParam::Constant(Vec3::ZERO),
                },
                two_sided: false,
                normal_map: None,
                bump_map: None,
                perturb: Default::default(),
            });
            Some(ctx.bsdfs.len() - 1)
        }
        b => b,
    };
    props.finish(ctx);
    Ok(vec![Shape {
        geometry,
        to_world,
        bsdf,
        emitter,
        emitter_texture,
        flip_normals,
        interior,
        exterior,
        location: ctx.location(elem.pos),
    }])
}

/// Where a shape's `<medium>` or medium `<ref>` goes: its `name`, `interior` or `exterior`.
fn media_slot<'s>(
    ctx: &Ctx,
    elem: &Element,
    interior: &'s mut Option<MediumId>,
    exterior: &'s mut Option<MediumId>,
) -> Result<&'s mut Option<MediumId>> {
    let slot = match elem.attr_value("name") {
        Some("interior") => interior,
        Some("exterior") => exterior,
        other => {
            return Err(ctx.err(
                elem.pos,
                format!(
                    "a shape's medium must be named 'interior' or 'exterior', found {}",
                    other.map_or("no name".to_string(), |n| format!("'{n}'"))
                ),
            ))
        }
    };
    if slot.is_some() {
        return Err(ctx.err(elem.pos, "a shape has one interior and one exterior medium"));
    }
    Ok(slot)
}
