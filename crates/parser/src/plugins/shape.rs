//! Shape plugins: `obj`, `ply`, `serialized`, `sphere`, `rectangle`, `cube`, `disk`, `cylinder`,
//! `sdfgrid`, `shapegroup`, `instance`.

use crate::context::{plugin_type, unknown_type, Ctx, IdTarget};
use crate::error::Result;
use crate::files::input_file;
use crate::media::MediumId;
use crate::mesh::{obj, ply, serialized, smooth_normals, validate, Budget};
use crate::plugins::bsdf::{color_param, parse_bsdf};
use crate::plugins::medium::parse_medium;
use crate::props::Props;
use crate::scene::{
    Bsdf, BsdfId, BsdfKind, ColorParam, Dialect, Geometry, Instance, Shape, ShapeGroup,
    TextureKind, TriangleMesh, Warning,
};
use crate::xml::Element;
use glam::{Mat3, Mat4, Vec3};

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

/// Mitsuba's `cube`: [-1, 1]^3 as 12 triangles, each face with its own 4 vertices, flat
/// normals and uvs (0,1), (1,1), (1,0), (0,0) at its corners, in Mitsuba's vertex order
/// (checked against Mitsuba 3.9.1's vertex_positions, vertex_normals, vertex_texcoords, faces).
fn cube_mesh() -> TriangleMesh {
    // (normal, the face's four corners in Mitsuba's order)
    const FACES: [([f32; 3], [[f32; 3]; 4]); 6] = [
        (
            [0.0, -1.0, 0.0],
            [
                [1.0, -1.0, -1.0],
                [1.0, -1.0, 1.0],
                [-1.0, -1.0, 1.0],
                [-1.0, -1.0, -1.0],
            ],
        ),
        (
            [0.0, 1.0, 0.0],
            [
                [1.0, 1.0, -1.0],
                [-1.0, 1.0, -1.0],
                [-1.0, 1.0, 1.0],
                [1.0, 1.0, 1.0],
            ],
        ),
        (
            [1.0, 0.0, 0.0],
            [
                [1.0, -1.0, -1.0],
                [1.0, 1.0, -1.0],
                [1.0, 1.0, 1.0],
                [1.0, -1.0, 1.0],
            ],
        ),
        (
            [0.0, 0.0, 1.0],
            [
                [1.0, -1.0, 1.0],
                [1.0, 1.0, 1.0],
                [-1.0, 1.0, 1.0],
                [-1.0, -1.0, 1.0],
            ],
        ),
        (
            [-1.0, 0.0, 0.0],
            [
                [-1.0, -1.0, 1.0],
                [-1.0, 1.0, 1.0],
                [-1.0, 1.0, -1.0],
                [-1.0, -1.0, -1.0],
            ],
        ),
        (
            [0.0, 0.0, -1.0],
            [
                [1.0, 1.0, -1.0],
                [1.0, -1.0, -1.0],
                [-1.0, -1.0, -1.0],
                [-1.0, 1.0, -1.0],
            ],
        ),
    ];
    const UVS: [[f32; 2]; 4] = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
    let mut m = TriangleMesh::default();
    for (f, (normal, corners)) in FACES.iter().enumerate() {
        for (c, uv) in corners.iter().zip(UVS) {
            m.positions.push(Vec3::from(*c));
            m.normals.push(Vec3::from(*normal));
            m.uvs.push(uv.into());
        }
        let b = 4 * f as u32;
        m.indices.push([b, b + 1, b + 2]);
        m.indices.push([b + 3, b, b + 2]);
    }
    m
}

/// `shapegroup` (with an `id`): its nested shapes are stored once, in the group's own space, and
/// drawn only where `instance`s place them. As in Mitsuba, a group holds no emitters, no groups
/// and no instances. Returns no shapes of its own.
///
/// | name | type | default |
/// | --- | --- | --- |
/// | nested `<shape>`s | shape | none |
fn parse_shapegroup(ctx: &mut Ctx, elem: &Element) -> Result<Vec<Shape>> {
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
fn parse_instance(ctx: &mut Ctx, elem: &Element) -> Result<Vec<Shape>> {
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

/// How far from the origin world-space geometry may reach: 1e14. The BVH builder sums surface
/// areas of bounding boxes (an extent of 2e19 already has an infinite area in f32), and ray
/// arithmetic squares distances; 1e14 leaves room for both with millions of primitives.
pub(crate) const WORLD_EXTENT: f64 = 1e14;

/// Reads a mesh file named by the `filename` parameter; errors name the file and point at it.
fn mesh(ctx: &mut Ctx, props: &mut Props, elem: &Element, ty: &str) -> Result<TriangleMesh> {
    let Some(file) = props.string(ctx, &["filename"])? else {
        return Err(ctx.err(
            elem.pos,
            format!("missing required parameter 'filename' of {}", props.owner),
        ));
    };
    let path = input_file(ctx, file, "mesh")?;
    let face_normals = props.boolean(ctx, &["face_normals"], false)?;
    // Mitsuba 3.9.1's serialized has no flip_tex_coords (it refuses the parameter; here it
    // stays unused and is reported so).
    let flip_v = ty != "serialized" && props.boolean(ctx, &["flip_tex_coords"], ty == "obj")?;
    let shape_index = match props.opt_int_pos(ctx, &["shape_index"])? {
        None => 0,
        Some((i, _)) if i >= 0 && ty == "serialized" => i as usize,
        Some((_, pos)) if ty == "serialized" => {
            return Err(ctx.err(pos, "shape_index must not be negative"))
        }
        Some((_, pos)) => {
            ctx.warn(
                pos,
                "shape_index only applies to serialized shapes; ignored",
            );
            0
        }
    };
    let budget = Budget {
        vertices: ctx.limits.mesh_vertices.saturating_sub(ctx.vertices),
        triangles: ctx.limits.mesh_triangles.saturating_sub(ctx.triangles),
    };
    let loaded = match ty {
        "obj" => obj::load(&path, flip_v, &budget),
        "ply" => ply::load(&path, &budget),
        _ => serialized::load(&path, shape_index, &budget),
    };
    let mut mesh = loaded
        .and_then(|m| budget.check(m.positions.len(), m.indices.len()).map(|_| m))
        .and_then(|m| validate(&m).map(|_| m))
        .map_err(|m| {
            ctx.err(
                file.value_pos,
                format!("in mesh file '{}': {m}", file.value),
            )
        })?;
    ctx.vertices += mesh.positions.len() as u64;
    ctx.triangles += mesh.indices.len() as u64;
    if mesh.indices.is_empty() {
        return Err(ctx.err(
            file.value_pos,
            format!("mesh file '{}' has no triangles", file.value),
        ));
    }
    if flip_v && ty != "obj" {
        for uv in &mut mesh.uvs {
            uv.y = 1.0 - uv.y;
        }
    }
    if face_normals {
        mesh.normals.clear();
    } else if mesh.normals.is_empty() {
        mesh.normals = smooth_normals(&mesh.positions, &mesh.indices);
    }
    Ok(mesh)
}

/// Why a shape cannot be placed in world space, if it cannot: its vertices (or its sphere's or
/// rectangle's extent) moved by `to_world` must stay within [`WORLD_EXTENT`] of the origin.
fn world_problem(geometry: &Geometry, to_world: Mat4) -> Option<String> {
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

/// Mitsuba's `sdfgrid`: a `.vol` grid of one channel (read by [`crate::vol`]) whose samples
/// span [0, 1]^3 in object space, the file's own bounding box ignored, as Mitsuba 3.9.1 does.
///
/// | name | type | default |
/// | --- | --- | --- |
/// | `filename` | string | required: a `.vol` file (version 3, float32, one channel, at least 2 samples along each axis, finite values, at least one voxel whose corners are not all of one sign) |
/// | `normals` | string | `smooth` (Hansson-Söderlund et al.'s blend of the gradients of the voxels around the hit, continuous across voxels) or `analytic` (the gradient of the trilinear interpolant in the hit's voxel) |
/// | `to_world` | transform | identity |
///
/// Not parameters of Mitsuba's `sdfgrid`: `flip_normals` (Mitsuba reports it unreferenced;
/// here it is warned about and ignored), an area emitter (an error: Mitsuba cannot sample one
/// on it), uvs (hits have uv 0).
fn sdf_grid(
    ctx: &mut Ctx,
    props: &mut Props,
    elem: &Element,
    to_world: Mat4,
) -> Result<std::sync::Arc<crate::scene::SdfGrid>> {
    let Some(file) = props.string(ctx, &["filename"])? else {
        return Err(ctx.err(
            elem.pos,
            "missing required parameter 'filename' of shape 'sdfgrid' (a .vol file)",
        ));
    };
    let smooth_normals = match props.string(ctx, &["normals"])? {
        None => true,
        Some(a) => match a.value.as_str() {
            "smooth" => true,
            "analytic" => false,
            v => {
                return Err(ctx.err(
                    a.value_pos,
                    format!(
                    "unknown normals mode '{v}' of shape 'sdfgrid' (expected smooth or analytic)"
                ),
                ))
            }
        },
    };
    let path = input_file(ctx, file, "sdfgrid")?;
    let in_file = |ctx: &Ctx, m: String| {
        ctx.err(
            file.value_pos,
            format!("in sdfgrid file '{}': {m}", file.value),
        )
    };
    let budget = ctx.limits.volume_values.saturating_sub(ctx.volume_values);
    let grid = crate::vol::read_vol_file(&path, budget).map_err(|e| in_file(ctx, e.0))?;
    if grid.channels != 1 {
        return Err(in_file(
            ctx,
            format!(
                "it has {} channels; an sdfgrid needs 1 (as in Mitsuba)",
                grid.channels
            ),
        ));
    }
    if grid.size.iter().any(|&s| s < 2) {
        let [x, y, z] = grid.size;
        return Err(in_file(
            ctx,
            format!("it has {x} x {y} x {z} samples; an sdfgrid needs at least 2 along each axis"),
        ));
    }
    if grid.trailing_bytes > 0 {
        ctx.warn(
            file.value_pos,
            format!(
                "sdfgrid file '{}' has {} bytes after its last value; ignored (as Mitsuba does)",
                file.value, grid.trailing_bytes
            ),
        );
    }
    let mut sdf = crate::scene::SdfGrid {
        size: grid.size,
        values: grid.data,
        smooth_normals,
        surface_voxels: 0,
    };
    let [nx, ny, nz] = sdf.size;
    let mut surface_voxels = 0u64;
    for k in 0..nz - 1 {
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                surface_voxels += sdf.voxel_has_surface(i, j, k) as u64;
            }
        }
    }
    if surface_voxels == 0 {
        return Err(in_file(
            ctx,
            "no voxel has corner samples of both signs: the grid has no surface (Mitsuba: \"SDFGrid should at least have one non-empty voxel\")"
                .into(),
        ));
    }
    // Each voxel with surface is a primitive of the BVH, as a triangle is.
    if ctx.triangles.saturating_add(surface_voxels) > ctx.limits.mesh_triangles {
        return Err(in_file(
            ctx,
            format!(
            "its {surface_voxels} voxels with surface and the {} triangles before it make more primitives than the limit of {} (raise with --limit mesh_triangles=N)",
            ctx.triangles, ctx.limits.mesh_triangles
        ),
        ));
    }
    ctx.triangles += surface_voxels;
    ctx.volume_values += sdf.values.len() as u64;
    sdf.surface_voxels = surface_voxels;
    // Mitsuba 3.9.1 warns about rotations in an sdfgrid's to_world; its voxels' boxes then
    // ignore the rotation and it misses hits.
    let m = Mat3::from_mat4(to_world);
    let scale = m.to_cols_array().iter().fold(0.0f32, |a, v| a.max(v.abs()));
    let off_diagonal = [
        m.x_axis.y, m.x_axis.z, m.y_axis.x, m.y_axis.z, m.z_axis.x, m.z_axis.y,
    ];
    if off_diagonal.iter().any(|v| v.abs() > 1e-6 * scale) {
        ctx.warn(
            elem.pos,
            "the to_world of shape 'sdfgrid' rotates or shears it: torrey renders that, but Mitsuba 3.9.1 warns and can miss hits (its voxel boxes ignore the rotation); place the grid with a shapegroup and an instance to get the same picture from both",
        );
    }
    Ok(std::sync::Arc::new(sdf))
}

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
