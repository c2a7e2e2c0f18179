//! Mesh file readers (OBJ through tobj, PLY and Mitsuba's serialized format by hand) and the
//! shared post-processing: index validation and smooth vertex normals.
//!
//! Readers return plain messages; the shape parser adds the mesh file name and the XML
//! position of the `filename` element.

pub(crate) mod obj;
pub(crate) mod ply;
pub(crate) mod serialized;

use crate::scene::TriangleMesh;
use glam::Vec3;

/// Angle-weighted vertex normals (Thürmer and Wüthrich 1998), as Mitsuba 3 computes them for
/// meshes without normals: each triangle adds its unit normal, weighted by its interior angle at
/// the vertex. Unlike area weighting this does not depend on how a surface is triangulated, and
/// it makes torrey's shading match Mitsuba's on coarse meshes with strongly bent normals.
/// Vertices touched only by degenerate triangles get +z.
pub fn smooth_normals(positions: &[Vec3], indices: &[[u32; 3]]) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; positions.len()];
    for t in indices {
        let p = t.map(|i| positions[i as usize]);
        let Some(face) = (p[1] - p[0]).cross(p[2] - p[0]).try_normalize() else {
            continue;
        };
        for k in 0..3 {
            let e1 = p[(k + 1) % 3] - p[k];
            let e2 = p[(k + 2) % 3] - p[k];
            let angle = e1.angle_between(e2);
            if angle.is_finite() {
                n[t[k] as usize] += face * angle;
            }
        }
    }
    n.into_iter()
        .map(|v| v.try_normalize().unwrap_or(Vec3::Z))
        .collect()
}

/// How many more vertices and triangles the scene's limits allow. Loaders check the counts a
/// file declares against it before allocating for them.
pub(crate) struct Budget {
    pub vertices: u64,
    pub triangles: u64,
}

impl Budget {
    /// An error when `vertices` or `triangles` (declared or loaded) exceed what is left.
    pub fn check(&self, vertices: usize, triangles: usize) -> Result<(), String> {
        if vertices as u64 > self.vertices {
            return Err(format!(
                "{vertices} vertices are more than the {} the scene may still have (raise with --limit mesh_vertices=N)",
                self.vertices
            ));
        }
        if triangles as u64 > self.triangles {
            return Err(format!(
                "{triangles} triangles are more than the {} the scene may still have (raise with --limit mesh_triangles=N)",
                self.triangles
            ));
        }
        Ok(())
    }
}

/// Checks that every index names a vertex, the per-vertex arrays have matching lengths and
/// every position, normal and texture coordinate is finite (a NaN vertex gives a triangle
/// NaN bounds, which no acceleration structure can sort).
pub(crate) fn validate(mesh: &TriangleMesh) -> Result<(), String> {
    if let Some(i) = mesh.positions.iter().position(|p| !p.is_finite()) {
        let p = mesh.positions[i];
        return Err(format!(
            "vertex {i} has a position that is not finite ({} {} {})",
            p.x, p.y, p.z
        ));
    }
    if let Some(i) = mesh.normals.iter().position(|n| !n.is_finite()) {
        return Err(format!("vertex {i} has a normal that is not finite"));
    }
    if let Some(i) = mesh.uvs.iter().position(|t| !t.is_finite()) {
        return Err(format!(
            "vertex {i} has texture coordinates that are not finite"
        ));
    }
    let n = mesh.positions.len();
    for (k, t) in mesh.indices.iter().enumerate() {
        if let Some(&i) = t.iter().find(|&&i| i as usize >= n) {
            return Err(format!(
                "triangle {k} uses vertex {i}, but there are only {n} vertices"
            ));
        }
    }
    if !mesh.normals.is_empty() && mesh.normals.len() != n {
        return Err(format!("{} normals for {n} vertices", mesh.normals.len()));
    }
    if !mesh.uvs.is_empty() && mesh.uvs.len() != n {
        return Err(format!(
            "{} texture coordinates for {n} vertices",
            mesh.uvs.len()
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smooth_normals_are_angle_weighted() {
        // Two triangles sharing vertex 0, both with a right angle there: a big one in the z=0
        // plane (normal +z) and a small one in the x=0 plane (normal +x). Equal angles give
        // equal weights, whatever the areas.
        let p = vec![
            Vec3::ZERO,
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
        ];
        let idx = vec![[0, 1, 2], [0, 3, 4]];
        let n = smooth_normals(&p, &idx);
        let expect = Vec3::new(1.0, 0.0, 1.0).normalize();
        assert!((n[0] - expect).length() < 1e-6, "{:?}", n[0]);
        assert!((n[1] - Vec3::Z).length() < 1e-6);
        assert!((n[4] - Vec3::X).length() < 1e-6);
    }
}
