//! Wavefront OBJ through tobj: one index per vertex (positions, normals and uvs share indices),
//! every model merged into one mesh, polygons triangulated here ([`triangulate`]). Materials in
//! MTL files are ignored.

use crate::mesh::Budget;
use crate::scene::TriangleMesh;
use glam::{Vec2, Vec3};
use std::path::Path;

/// Loads an OBJ file; `flip_v` maps v to 1 - v (Mitsuba's `flip_tex_coords`, default on).
/// `mtllib` statements are not followed: materials are ignored anyway, and a named file could
/// be anything (`mtllib /dev/zero` would be read forever).
#[allow(clippy::field_reassign_with_default)]
pub(crate) fn load(path: &Path, flip_v: bool, budget: &Budget) -> Result<TriangleMesh, String> {
    // Built by assignment so optional tobj fields (feature `merging`) keep their defaults.
    let mut options = tobj::LoadOptions::default();
    options.single_index = true;
    // Polygons come back whole (their arities in `face_arities`) and are triangulated below.
    options.triangulate = false;
    options.ignore_points = true;
    options.ignore_lines = true;
    let file = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let mut reader = std::io::BufReader::new(file);
    let located = || {
        // tobj says what went wrong but not where; find the place in the text.
        std::fs::read(path)
            .ok()
            .and_then(|bytes| locate_error(&String::from_utf8_lossy(&bytes)))
    };
    let (models, _materials) = tobj::load_obj_buf(&mut reader, &options, |_| {
        Err(tobj::LoadError::OpenFileFailed)
    })
    .map_err(|e| located().unwrap_or_else(|| e.to_string()))?;
    let vertices: usize = models.iter().map(|m| m.mesh.positions.len() / 3).sum();
    let triangles: usize = models
        .iter()
        .map(|m| match m.mesh.face_arities.as_slice() {
            [] => m.mesh.indices.len() / 3,
            arities => arities
                .iter()
                .map(|&a| (a as usize).saturating_sub(2))
                .sum(),
        })
        .sum();
    budget.check(vertices, triangles)?;
    let finite = models.iter().all(|m| {
        let src = &m.mesh;
        src.positions.iter().all(|v| v.is_finite())
            && src.normals.iter().all(|v| v.is_finite())
            && src.texcoords.iter().all(|v| v.is_finite())
    });
    if !finite {
        if let Some(e) = located() {
            return Err(e);
        }
    }
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
        triangulate(&src.indices, &src.face_arities, base, &mut mesh.indices);
    }
    Ok(mesh)
}

/// Appends the triangles of the faces `indices` (`arities` vertices each; none: all triangles),
/// offset by `base`. Triangles and quads are kept as tobj's fan splits them (a quad's diagonal
/// from its first vertex, as Mitsuba's loader does). Larger polygons are cut as a zig-zag strip,
/// alternating between the two ends of the vertex list: the same surface as a fan for a planar
/// convex polygon, but without its slivers, which all overlap at the first vertex and made the
/// BVH build quadratic (a 30,000-gon took 4 s, a 100,000-gon 42 s).
fn triangulate(indices: &[u32], arities: &[u32], base: u32, out: &mut Vec<[u32; 3]>) {
    if arities.is_empty() {
        out.extend(
            indices
                .chunks_exact(3)
                .map(|t| [base + t[0], base + t[1], base + t[2]]),
        );
        return;
    }
    let mut start = 0usize;
    for &arity in arities {
        let n = arity as usize;
        let Some(face) = indices.get(start..start + n) else {
            break;
        };
        start += n;
        let v = |i: usize| base + face[i];
        match n {
            0..=2 => {}
            3 | 4 => out.extend((1..n - 1).map(|i| [v(0), v(i), v(i + 1)])),
            _ => {
                let (mut lo, mut hi) = (0, n - 1);
                let mut front = true;
                while hi - lo >= 2 {
                    if front {
                        out.push([v(lo), v(lo + 1), v(hi)]);
                        lo += 1;
                    } else {
                        out.push([v(lo), v(hi - 1), v(hi)]);
                        hi -= 1;
                    }
                    front = !front;
                }
            }
        }
    }
}

/// Where an OBJ file that tobj rejected goes wrong: "line L, column C: problem" for the first
/// statement that does not parse or names a vertex that is not defined before it. tobj reports
/// only the kind of error; this second pass over the text (run only after a failure) finds the
/// place, so that the message can point at it. None when it finds nothing wrong.
fn locate_error(text: &str) -> Option<String> {
    // Counts of positions, texture coordinates and normals defined so far.
    let mut counts = [0usize; 3];
    const KINDS: [&str; 3] = ["vertex", "texture coordinate", "normal"];
    const PLURALS: [&str; 3] = ["vertices", "texture coordinates", "normals"];
    for (line_index, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or("");
        let at = |token: &str| {
            // Tokens are slices of `line`, so their offset is a pointer difference.
            let column = token.as_ptr() as usize - raw.as_ptr() as usize + 1;
            format!("line {}, column {column}", line_index + 1)
        };
        let mut words = line.split_whitespace();
        let Some(keyword) = words.next() else {
            continue;
        };
        let (kind, needed) = match keyword {
            "v" => (0, 3),
            "vt" => (1, 1),
            "vn" => (2, 3),
            "f" => {
                let vertices: Vec<&str> = words.collect();
                if vertices.len() < 3 {
                    return Some(format!(
                        "{}: a face needs at least 3 vertices, found {}",
                        at(keyword),
                        vertices.len()
                    ));
                }
                for vertex in vertices {
                    let mut offset = 0;
                    for (slot, part) in vertex.split('/').enumerate() {
                        let token = &vertex[offset..offset + part.len()];
                        offset += part.len() + 1;
                        if slot > 2 {
                            return Some(format!(
                                "{}: face vertex '{vertex}' has more than 3 indices",
                                at(vertex)
                            ));
                        }
                        if part.is_empty() && slot > 0 {
                            continue; // "1//3": no texture coordinate
                        }
                        let Ok(index) = part.parse::<i64>() else {
                            return Some(format!(
                                "{}: cannot parse '{part}' as a {} index",
                                at(token),
                                KINDS[slot]
                            ));
                        };
                        let defined = counts[slot] as i64;
                        let resolved = if index < 0 {
                            defined + index + 1
                        } else {
                            index
                        };
                        if index == 0 || resolved < 1 || resolved > defined {
                            let defined_text = if defined == 1 {
                                format!("1 {} is", KINDS[slot])
                            } else {
                                format!("{defined} {} are", PLURALS[slot])
                            };
                            return Some(format!(
                                "{}: face refers to {} {index}, but {defined_text} defined before this line",
                                at(token),
                                KINDS[slot],
                            ));
                        }
                    }
                }
                continue;
            }
            _ => continue,
        };
        let mut found = 0;
        for word in words.take(needed) {
            match word.parse::<f32>() {
                Err(_) => {
                    return Some(format!(
                        "{}: cannot parse '{word}' as a {} coordinate",
                        at(word),
                        KINDS[kind]
                    ))
                }
                Ok(v) if !v.is_finite() => {
                    return Some(format!(
                        "{}: {} coordinate '{word}' is not a finite 32-bit float",
                        at(word),
                        KINDS[kind]
                    ))
                }
                Ok(_) => {}
            }
            found += 1;
        }
        if found < needed {
            return Some(format!(
                "{}: a {} needs {needed} numbers, found {found}",
                at(keyword),
                KINDS[kind]
            ));
        }
        counts[kind] += 1;
    }
    None
}

#[cfg(test)]
mod tests {
    use super::{locate_error, triangulate};
    use glam::Vec2;

    /// Triangles and quads as a fan from the first vertex; a hexagon as a zig-zag strip: 4
    /// triangles, consistently wound, covering the polygon once (their areas sum to its area).
    #[test]
    fn polygons_are_triangulated_without_slivers() {
        let mut out = Vec::new();
        triangulate(&[0, 1, 2, 3, 4, 5, 6], &[3, 4], 10, &mut out);
        assert_eq!(out, vec![[10, 11, 12], [13, 14, 15], [13, 15, 16]]);
        let hexagon: Vec<Vec2> = (0..6)
            .map(|i| {
                let a = i as f32 * std::f32::consts::TAU / 6.0;
                Vec2::new(a.cos(), a.sin())
            })
            .collect();
        let mut out = Vec::new();
        triangulate(&[0, 1, 2, 3, 4, 5], &[6], 0, &mut out);
        assert_eq!(out.len(), 4);
        let signed_area = |t: &[u32; 3]| {
            let (a, b, c) = (
                hexagon[t[0] as usize],
                hexagon[t[1] as usize],
                hexagon[t[2] as usize],
            );
            0.5 * (b - a).perp_dot(c - a)
        };
        assert!(out.iter().all(|t| signed_area(t) > 0.0), "{out:?}");
        let total: f32 = out.iter().map(signed_area).sum();
        assert!((total - 1.5 * 3f32.sqrt()).abs() < 1e-5, "{total}");
    }

    #[test]
    fn finds_line_and_column_of_bad_statements() {
        let cases = [
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n", "line 4, column 7: face refers to vertex 9, but 3 vertices are defined before this line"),
            ("v 0 0 0\nv 1 x 0\n", "line 2, column 5: cannot parse 'x' as a vertex coordinate"),
            ("v 0 0\n", "line 1, column 1: a vertex needs 3 numbers, found 2"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", "line 4, column 1: a face needs at least 3 vertices, found 2"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n", "line 5, column 9: face refers to texture coordinate 2, but 1 texture coordinate is defined before this line"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\n  f 1//a 2 3\n", "line 4, column 8: cannot parse 'a' as a normal index"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n", "line 4, column 9: face refers to vertex -4, but 3 vertices are defined before this line"),
            ("v 0 0 0\nf 0 1 1\n", "line 2, column 3: face refers to vertex 0, but 1 vertex is defined before this line"),
            ("v 0 0 0\nv 1 nan 0\n", "line 2, column 5: vertex coordinate 'nan' is not a finite 32-bit float"),
            ("vn 0 0 1e39\n", "line 1, column 8: normal coordinate '1e39' is not a finite 32-bit float"),
        ];
        for (text, expected) in cases {
            assert_eq!(locate_error(text).as_deref(), Some(expected), "{text:?}");
        }
    }

    #[test]
    fn valid_files_have_no_error() {
        let text =
            "# a quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0 # trailing comment\nvt 0 0\nvn 0 0 1\n\
                    f 1/1/1 2/1/1 3/1/1 4/1/1\nf -4//-1 -3//-1 -2//-1\ng group\nusemtl m\ns off\n";
        assert_eq!(locate_error(text), None);
    }
}
