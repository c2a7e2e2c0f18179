//! Triangle meshes: Mitsuba's `cube` and the mesh files (`obj`, `ply`, `serialized`).

use crate::context::Ctx;
use crate::error::Result;
use crate::files::input_file;
use crate::mesh::{obj, ply, serialized, smooth_normals, validate, Budget};
use crate::props::Props;
use crate::scene::TriangleMesh;
use crate::xml::Element;
use glam::Vec3;

/// Mitsuba's `cube`: [-1, 1]^3 as 12 triangles, each face with its own 4 vertices, flat
/// normals and uvs (0,1), (1,1), (1,0), (0,0) at its corners, in Mitsuba's vertex order
/// (checked against Mitsuba 3.9.1's vertex_positions, vertex_normals, vertex_texcoords, faces).
pub(super) fn cube_mesh() -> TriangleMesh {
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

/// Reads a mesh file named by the `filename` parameter; errors name the file and point at it.
pub(super) fn mesh(
    ctx: &mut Ctx,
    props: &mut Props,
    elem: &Element,
    ty: &str,
) -> Result<TriangleMesh> {
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
