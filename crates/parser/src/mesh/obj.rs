//! Wavefront OBJ through tobj: triangulated, one index per vertex (positions, normals and uvs
//! share indices), every model merged into one mesh. Materials in MTL files are ignored.

use crate::scene::TriangleMesh;
use glam::{Vec2, Vec3};
use std::path::Path;

/// Loads an OBJ file; `flip_v` maps v to 1 - v (Mitsuba's `flip_tex_coords`, default on).
#[allow(clippy::field_reassign_with_default)]
pub(crate) fn load(path: &Path, flip_v: bool) -> Result<TriangleMesh, String> {
    // Built by assignment so optional tobj fields (feature `merging`) keep their defaults.
    let mut options = tobj::LoadOptions::default();
    options.single_index = true;
    options.triangulate = true;
    options.ignore_points = true;
    options.ignore_lines = true;
    let (models, _materials) = tobj::load_obj(path, &options).map_err(|e| e.to_string())?;
    let mut mesh = TriangleMesh::default();
    let mut all_normals = true;
    let mut all_uvs = true;
    for m in &models {
        let nv = m.mesh.positions.len() / 3;
        all_normals &= m.mesh.normals.len() == nv * 3;
        all_uvs &= m.mesh.texcoords.len() == nv * 2;
    }
    for m in models {
        let base = mesh.positions.len() as u32;
        let src = &m.mesh;
        mesh.positions.extend(
            src.positions
                .chunks_exact(3)
                .map(|p| Vec3::new(p[0], p[1], p[2])),
        );
        if all_normals {
            mesh.normals.extend(
                src.normals
                    .chunks_exact(3)
                    .map(|n| Vec3::new(n[0], n[1], n[2])),
            );
        }
        if all_uvs {
            mesh.uvs.extend(
                src.texcoords
                    .chunks_exact(2)
                    .map(|t| Vec2::new(t[0], if flip_v { 1.0 - t[1] } else { t[1] })),
            );
        }
        mesh.indices.extend(
            src.indices
                .chunks_exact(3)
                .map(|t| [base + t[0], base + t[1], base + t[2]]),
        );
    }
    Ok(mesh)
}
