//! Stanford PLY, hand-written: `ascii`, `binary_little_endian` and `binary_big_endian`.
//! Reads vertex `x y z`, optional `nx ny nz`, optional texture coordinates (`u v`, `s t`,
//! `texture_u texture_v` or `texture_s texture_t`; not flipped) and faces from a
//! `vertex_indices`/`vertex_index` list (any count and index types; polygons are split into
//! fans, so quads become two triangles). Other scalar properties of vertices and faces become
//! mesh attributes named as Mitsuba 3.9.1's loader names them ([`attribute_groups`]); every
//! other element and property is skipped.

use crate::mesh::Budget;
use crate::scene::{MeshAttribute, TriangleMesh};
use glam::{Vec2, Vec3};
use std::path::Path;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn from_name(s: &str) -> Option<Scalar> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

#[derive(Debug)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Debug)]
struct Property {
    name: String,
    kind: Kind,
}

#[derive(Debug)]
struct ElementDef {
    name: String,
    count: usize,
    props: Vec<Property>,
}

#[derive(Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    Binary { big_endian: bool },
}

/// The body after the header: ASCII text read token by token (nothing is allocated per token,
/// so a file with more data than its header declares costs no memory), or raw bytes.
enum Body<'a> {
    Ascii {
        text: &'a [u8],
        pos: usize,
        /// The line `pos` is on.
        line: usize,
    },
    Binary {
        data: &'a [u8],
        pos: usize,
        big_endian: bool,
    },
}

impl Body<'_> {
    fn read(&mut self, s: Scalar, what: &dyn Fn() -> String) -> Result<f64, String> {
        match self {
            Body::Ascii { text, pos, line } => {
                while let Some(&c) = text.get(*pos) {
                    if !c.is_ascii_whitespace() {
                        break;
                    }
                    *line += (c == b'\n') as usize;
                    *pos += 1;
                }
                let start = *pos;
                while text.get(*pos).is_some_and(|c| !c.is_ascii_whitespace()) {
                    *pos += 1;
                }
                if start == *pos {
                    return Err(format!(
                        "line {line}: unexpected end of file while reading {}",
                        what()
                    ));
                }
                let line = *line;
                let tok = std::str::from_utf8(&text[start..*pos]).unwrap_or("(not text)");
                let v = if matches!(s, Scalar::F32 | Scalar::F64) {
                    tok.parse::<f64>().ok()
                } else {
                    tok.parse::<i64>().ok().map(|i| i as f64)
                };
                v.ok_or_else(|| format!("line {line}: cannot parse '{tok}' as {s:?} in {}", what()))
            }
            Body::Binary {
                data,
                pos,
                big_endian,
            } => {
                let n = s.size();
                let Some(b) = data.get(*pos..*pos + n) else {
                    return Err(format!(
                        "unexpected end of file at byte {} while reading {}",
                        *pos,
                        what()
                    ));
                };
                *pos += n;
                let mut a = [0u8; 8];
                a[..n].copy_from_slice(b);
                if *big_endian {
                    a[..n].reverse();
                }
                Ok(match s {
                    Scalar::I8 => a[0] as i8 as f64,
                    Scalar::U8 => a[0] as f64,
                    Scalar::I16 => i16::from_le_bytes([a[0], a[1]]) as f64,
                    Scalar::U16 => u16::from_le_bytes([a[0], a[1]]) as f64,
                    Scalar::I32 => i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
                    Scalar::U32 => u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
                    Scalar::F32 => f32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
                    Scalar::F64 => f64::from_le_bytes(a),
                })
            }
        }
    }
}

/// Parses the header; returns the format, the element definitions and where the body starts.
fn header(data: &[u8]) -> Result<(Format, Vec<ElementDef>, usize), String> {
    let mut pos = 0;
    let mut line_no = 0;
    let mut format = None;
    let mut elements: Vec<ElementDef> = Vec::new();
    loop {
        let Some(len) = data[pos..].iter().position(|&b| b == b'\n') else {
            return Err("header has no 'end_header' line".into());
        };
        let line = std::str::from_utf8(&data[pos..pos + len])
            .map_err(|_| format!("line {}: header is not text", line_no + 1))?
            .trim_end_matches('\r');
        pos += len + 1;
        line_no += 1;
        let words: Vec<&str> = line.split_whitespace().collect();
        if line_no == 1 {
            if line.trim() != "ply" {
                return Err("line 1: not a PLY file (expected 'ply')".into());
            }
            continue;
        }
        let bad = |what: &str| format!("line {line_no}: {what}: '{line}'");
        match words.first().copied() {
            None | Some("comment") | Some("obj_info") => {}
            Some("format") => {
                format = Some(match words.get(1).copied() {
                    Some("ascii") => Format::Ascii,
                    Some("binary_little_endian") => Format::Binary { big_endian: false },
                    Some("binary_big_endian") => Format::Binary { big_endian: true },
                    _ => return Err(bad("unknown format")),
                });
            }
            Some("element") => {
                let (Some(name), Some(count)) = (words.get(1), words.get(2)) else {
                    return Err(bad("malformed element line"));
                };
                let count = count.parse().map_err(|_| bad("bad element count"))?;
                elements.push(ElementDef {
                    name: name.to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            Some("property") => {
                let Some(el) = elements.last_mut() else {
                    return Err(bad("property before any element"));
                };
                let (kind, name) = if words.get(1) == Some(&"list") {
                    match (
                        words.get(2).and_then(|w| Scalar::from_name(w)),
                        words.get(3).and_then(|w| Scalar::from_name(w)),
                        words.get(4),
                    ) {
                        (Some(count), Some(item), Some(n)) => (Kind::List { count, item }, n),
                        _ => return Err(bad("malformed list property")),
                    }
                } else {
                    match (
                        words.get(1).and_then(|w| Scalar::from_name(w)),
                        words.get(2),
                    ) {
                        (Some(s), Some(n)) => (Kind::Scalar(s), n),
                        _ => return Err(bad("malformed property")),
                    }
                };
                el.props.push(Property {
                    name: name.to_string(),
                    kind,
                });
            }
            Some("end_header") => break,
            Some(_) => return Err(bad("unknown header line")),
        }
    }
    let format = format.ok_or("header has no 'format' line")?;
    Ok((format, elements, pos))
}

/// Properties of vertices that are not attributes: position, normal, texture coordinates.
const VERTEX_RESERVED: &[&str] = &[
    "x",
    "y",
    "z",
    "nx",
    "ny",
    "nz",
    "u",
    "v",
    "s",
    "t",
    "texture_u",
    "texture_v",
    "texture_s",
    "texture_t",
];

/// The mesh attributes an element's scalar properties form, as Mitsuba 3.9.1's PLY loader
/// groups them (checked against it): `r g b [a]` or `red green blue [alpha]` form
/// `<element>_color`; `<name>_r _g _b` form `<element>_<name>_color`; other names with a
/// postfix after their last underscore (`n_x n_y n_z`, `w_0`) group by the part before it
/// (`<element>_n`, `<element>_w`). Names without a postfix are ignored, and so are groups of
/// other than 1 or 3 values (colours keep their first three). Returns (name, property
/// indices).
fn attribute_groups(element: &str, props: &[Property]) -> Vec<(String, Vec<usize>)> {
    let mut groups: Vec<(String, Vec<usize>)> = Vec::new();
    for (i, p) in props.iter().enumerate() {
        if !matches!(p.kind, Kind::Scalar(_))
            || (element == "vertex" && VERTEX_RESERVED.contains(&p.name.as_str()))
        {
            continue;
        }
        let n = p.name.as_str();
        let group = if ["r", "g", "b", "a", "red", "green", "blue", "alpha"].contains(&n) {
            "color".to_string()
        } else if let Some((prefix, postfix)) = n.rsplit_once('_') {
            if ["r", "g", "b", "a"].contains(&postfix) {
                format!("{prefix}_color")
            } else {
                prefix.to_string()
            }
        } else {
            continue;
        };
        let name = format!("{element}_{group}");
        match groups.iter_mut().find(|(g, _)| *g == name) {
            Some((_, members)) => members.push(i),
            None => groups.push((name, vec![i])),
        }
    }
    groups.retain_mut(|(name, members)| {
        if name.ends_with("color") && members.len() == 4 {
            members.truncate(3);
        }
        members.len() == 1 || members.len() == 3
    });
    groups
}

/// Reads a PLY mesh file.
pub(crate) fn load(path: &Path, budget: &Budget) -> Result<TriangleMesh, String> {
    let data = std::fs::read(path).map_err(|e| e.to_string())?;
    parse(&data, budget)
}

/// Parses PLY bytes. The declared vertex and face counts are checked against `budget` before
/// reading them, and polygons are counted as they are split.
pub(crate) fn parse(data: &[u8], budget: &Budget) -> Result<TriangleMesh, String> {
    let (format, elements, start) = header(data)?;
    for el in &elements {
        match el.name.as_str() {
            "vertex" => budget.check(el.count, 0)?,
            "face" => budget.check(0, el.count)?,
            _ => {}
        }
    }
    let header_lines = data[..start].iter().filter(|&&b| b == b'\n').count();
    let mut body = match format {
        Format::Ascii => Body::Ascii {
            text: &data[start..],
            pos: 0,
            line: header_lines + 1,
        },
        Format::Binary { big_endian } => Body::Binary {
            data: &data[start..],
            pos: 0,
            big_endian,
        },
    };
    let mut mesh = TriangleMesh::default();
    for el in &elements {
        let is_vertex = el.name == "vertex";
        let is_face = el.name == "face";
        let find = |names: &[&str]| {
            el.props
                .iter()
                .position(|p| names.contains(&p.name.as_str()))
        };
        let (xi, yi, zi) = (find(&["x"]), find(&["y"]), find(&["z"]));
        let normal = [find(&["nx"]), find(&["ny"]), find(&["nz"])];
        let has_normals = normal.iter().all(Option::is_some);
        let ui = find(&["u", "s", "texture_u", "texture_s"]);
        let vi = find(&["v", "t", "texture_v", "texture_t"]);
        let has_uvs = ui.is_some() && vi.is_some();
        if is_vertex && (xi.is_none() || yi.is_none() || zi.is_none()) {
            return Err("vertex element lacks x, y or z".into());
        }
        let fi = find(&["vertex_indices", "vertex_index"]);
        if is_face && el.count > 0 && fi.is_none() {
            return Err("face element has no vertex_indices list".into());
        }
        if el.props.is_empty() {
            continue; // nothing to read, however many it declares
        }
        let groups = if is_vertex || is_face {
            attribute_groups(&el.name, &el.props)
        } else {
            Vec::new()
        };
        let first_attribute = mesh.attributes.len();
        for (name, members) in &groups {
            mesh.attributes.push(MeshAttribute {
                name: name.clone(),
                channels: members.len(),
                values: Vec::new(),
            });
        }
        let mut values = vec![0.0f64; el.props.len()];
        let mut list: Vec<u32> = Vec::new();
        for r in 0..el.count {
            for (pi, p) in el.props.iter().enumerate() {
                let what = || format!("property '{}' of {} {r}", p.name, el.name);
                match p.kind {
                    Kind::Scalar(s) => values[pi] = body.read(s, &what)?,
                    Kind::List { count, item } => {
                        let n = body.read(count, &what)?;
                        if n < 0.0 {
                            return Err(format!("negative list length in {}", what()));
                        }
                        let keep = is_face && Some(pi) == fi;
                        if keep {
                            list.clear();
                        }
                        for _ in 0..n as usize {
                            let v = body.read(item, &what)?;
                            if keep {
                                if v < 0.0 || v > u32::MAX as f64 {
                                    return Err(format!(
                                        "vertex index {v} out of range in {}",
                                        what()
                                    ));
                                }
                                list.push(v as u32);
                            }
                        }
                    }
                }
            }
            if is_vertex {
                let g = |i: Option<usize>| values[i.unwrap()] as f32;
                mesh.positions.push(Vec3::new(g(xi), g(yi), g(zi)));
                if has_normals {
                    mesh.normals
                        .push(Vec3::new(g(normal[0]), g(normal[1]), g(normal[2])));
                }
                if has_uvs {
                    mesh.uvs.push(Vec2::new(g(ui), g(vi)));
                }
                for (k, (_, members)) in groups.iter().enumerate() {
                    let a = &mut mesh.attributes[first_attribute + k];
                    a.values.extend(members.iter().map(|&m| values[m] as f32));
                }
            } else if is_face {
                if list.len() < 3 {
                    return Err(format!(
                        "face {r} has {} vertices; at least 3 needed",
                        list.len()
                    ));
                }
                budget.check(0, mesh.indices.len() + list.len() - 2)?;
                for k in 1..list.len() - 1 {
                    mesh.indices.push([list[0], list[k], list[k + 1]]);
                    for (g, (_, members)) in groups.iter().enumerate() {
                        let a = &mut mesh.attributes[first_attribute + g];
                        a.values.extend(members.iter().map(|&m| values[m] as f32));
                    }
                }
            }
        }
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    const UNLIMITED: Budget = Budget {
        vertices: u64::MAX,
        triangles: u64::MAX,
    };

    #[test]
    fn elements_without_properties_take_no_time() {
        let text = "ply\nformat ascii 1.0\nelement nothing 18446744073709551615\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        let m = parse(text.as_bytes(), &UNLIMITED).unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2]]);
    }

    #[test]
    fn declared_counts_are_checked_before_reading() {
        let text = "ply\nformat ascii 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
        let small = Budget {
            vertices: 1000,
            triangles: 1000,
        };
        let e = parse(text.as_bytes(), &small).unwrap_err();
        assert!(
            e.starts_with("4000000000 vertices are more than the 1000"),
            "{e}"
        );
    }

    #[test]
    fn ascii_quad_with_extra_properties() {
        let text = "ply\nformat ascii 1.0\ncomment hi\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty float confidence\nproperty float s\nproperty float t\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 1 0 0\n1 0 0 1 1 0\n1 1 0 1 1 1\n0 1 0 1 0 1\n4 0 1 2 3\n";
        let m = parse(text.as_bytes(), &UNLIMITED).unwrap();
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.uvs[2], Vec2::new(1.0, 1.0));
        assert!(m.normals.is_empty());
    }

    /// Attribute names and channel counts as Mitsuba 3.9.1's loader gives them for the same
    /// headers; integer colours keep their values (Mitsuba does not normalise them either).
    #[test]
    fn extra_properties_become_mitsuba_named_attributes() {
        let text = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\nproperty float quality\nproperty float n_x\nproperty float n_y\nproperty float n_z\nproperty float w_0\nproperty float q_0\nproperty float q_1\nproperty float k_r\nproperty float k_g\nproperty float k_b\nelement face 1\nproperty list uchar int vertex_indices\nproperty float weight_0\nproperty uchar r\nproperty uchar g\nproperty uchar b\nend_header\n\
            0 0 0 255 0 0 9 7 1 2 3 4 5 6 7 8 9\n1 0 0 0 255 0 9 7 1 2 3 4 5 6 7 8 9\n1 1 0 0 0 255 9 7 1 2 3 4 5 6 7 8 9\n0 1 0 1 2 3 9 7 1 2 3 4 5 6 7 8 9\n4 0 1 2 3 0.25 10 20 30\n";
        let m = parse(text.as_bytes(), &UNLIMITED).unwrap();
        let names: Vec<(&str, usize)> = m
            .attributes
            .iter()
            .map(|a| (a.name.as_str(), a.channels))
            .collect();
        assert_eq!(
            names,
            [
                ("vertex_color", 3),
                ("vertex_n", 3),
                ("vertex_w", 1),
                ("vertex_k_color", 3),
                ("face_weight", 1),
                ("face_color", 3),
            ]
        );
        assert_eq!(
            m.attributes[0].values[..6],
            [255.0, 0.0, 0.0, 0.0, 255.0, 0.0]
        );
        assert_eq!(m.attributes[0].values.len(), 12);
        // The quad's two triangles share its values.
        assert_eq!(m.attributes[4].values, [0.25, 0.25]);
        assert_eq!(m.attributes[5].values, [10.0, 20.0, 30.0, 10.0, 20.0, 30.0]);
    }

    #[test]
    fn ascii_error_names_line() {
        let text = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 zero 0\n";
        let e = parse(text.as_bytes(), &UNLIMITED).unwrap_err();
        assert!(e.starts_with("line 8: cannot parse 'zero'"), "{e}");
    }

    #[test]
    fn truncated_binary() {
        let mut d = b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n".to_vec();
        d.extend_from_slice(&1.0f32.to_le_bytes());
        let e = parse(&d, &UNLIMITED).unwrap_err();
        assert!(e.contains("unexpected end of file"), "{e}");
        assert!(e.contains("property 'y' of vertex 0"), "{e}");
    }
}
