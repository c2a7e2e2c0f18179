//! Mitsuba's `serialized` mesh format: a u16 magic 0x041C and u16 version (3 or 4), then one
//! zlib stream per shape, and at the end of the file a table of shape offsets (u64 for v4,
//! u32 for v3) followed by the u32 shape count. Each stream holds u32 flags, (v4) a
//! NUL-terminated name, u64 vertex and triangle counts, positions, optional normals (0x1),
//! uvs (0x2) and colours (0x8), in f32 (0x1000) or f64 (0x2000), then u32 indices (u64 when
//! there are more than 2^32 vertices). Texture coordinates are not flipped.

use crate::mesh::Budget;
use crate::scene::TriangleMesh;
use glam::{Vec2, Vec3};
use miniz_oxide::inflate::{decompress_to_vec_zlib_with_limit, TINFLStatus};
use std::path::Path;

const MAGIC: u16 = 0x041C;
const HAS_NORMALS: u32 = 0x0001;
const HAS_UVS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
const DOUBLE: u32 = 0x2000;

fn u16_at(d: &[u8], p: usize) -> Option<u16> {
    Some(u16::from_le_bytes(d.get(p..p + 2)?.try_into().ok()?))
}
fn u32_at(d: &[u8], p: usize) -> Option<u32> {
    Some(u32::from_le_bytes(d.get(p..p + 4)?.try_into().ok()?))
}
fn u64_at(d: &[u8], p: usize) -> Option<u64> {
    Some(u64::from_le_bytes(d.get(p..p + 8)?.try_into().ok()?))
}

struct Cursor<'a> {
    d: &'a [u8],
    p: usize,
}

impl Cursor<'_> {
    fn bytes(&mut self, n: usize) -> Result<&[u8], String> {
        let b = self.d.get(self.p..self.p + n).ok_or_else(|| {
            format!(
                "shape data ends early (at byte {} of {})",
                self.p,
                self.d.len()
            )
        })?;
        self.p += n;
        Ok(b)
    }
    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.bytes(4)?.try_into().unwrap()))
    }
    fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.bytes(8)?.try_into().unwrap()))
    }
    fn real(&mut self, double: bool) -> Result<f32, String> {
        Ok(if double {
            f64::from_le_bytes(self.bytes(8)?.try_into().unwrap()) as f32
        } else {
            f32::from_le_bytes(self.bytes(4)?.try_into().unwrap())
        })
    }
    fn vec3s(&mut self, n: usize, double: bool) -> Result<Vec<Vec3>, String> {
        (0..n)
            .map(|_| {
                Ok(Vec3::new(
                    self.real(double)?,
                    self.real(double)?,
                    self.real(double)?,
                ))
            })
            .collect()
    }
}

/// Reads shape number `index` of a serialized file.
pub(crate) fn load(path: &Path, index: usize, budget: &Budget) -> Result<TriangleMesh, String> {
    let data = std::fs::read(path).map_err(|e| e.to_string())?;
    parse(&data, index, budget)
}

/// Bytes inflated first to read a shape's header (flags, name, counts).
const HEADER_PEEK: usize = 64 << 10;

/// The shape header at the start of an inflated stream: flags, counts and the header's length.
fn shape_header(raw: &[u8], version: u16) -> Result<(u32, u64, u64, usize), String> {
    let mut c = Cursor { d: raw, p: 0 };
    let flags = c.u32()?;
    if version == 4 {
        while c
            .bytes(1)
            .map_err(|_| "shape name is not terminated within 64 KiB".to_string())?[0]
            != 0
        {}
    }
    let nv = c.u64()?;
    let nt = c.u64()?;
    Ok((flags, nv, nt, c.p))
}

pub(crate) fn parse(d: &[u8], index: usize, budget: &Budget) -> Result<TriangleMesh, String> {
    let short = || "file too short to be a serialized mesh".to_string();
    if u16_at(d, 0).ok_or_else(short)? != MAGIC {
        return Err("not a Mitsuba serialized file (bad magic number)".into());
    }
    let version = u16_at(d, 2).ok_or_else(short)?;
    if version != 3 && version != 4 {
        return Err(format!("unsupported serialized format version {version}"));
    }
    let count = u32_at(d, d.len().checked_sub(4).ok_or_else(short)?).ok_or_else(short)? as usize;
    if index >= count {
        return Err(format!(
            "shape_index {index} is out of range: the file holds {count} shapes"
        ));
    }
    let entry: usize = if version == 4 { 8 } else { 4 };
    let table = entry
        .checked_mul(count)
        .and_then(|t| d.len().checked_sub(4 + t))
        .ok_or_else(|| "corrupt shape table".to_string())?;
    let offset_of = |i: usize| -> Option<usize> {
        if version == 4 {
            u64_at(d, table + 8 * i).and_then(|v| usize::try_from(v).ok())
        } else {
            u32_at(d, table + 4 * i).map(|v| v as usize)
        }
    };
    let start = offset_of(index).ok_or_else(short)?;
    let end = if index + 1 < count {
        offset_of(index + 1).ok_or_else(short)?
    } else {
        table
    };
    if start.saturating_add(4) > end || end > d.len() {
        return Err(format!("corrupt offset {start} for shape {index}"));
    }
    let stream = &d[start + 4..end];
    // A zlib stream can inflate a thousandfold: read the header first, check the counts it
    // declares, and inflate no more than they account for.
    let peek = match decompress_to_vec_zlib_with_limit(stream, HEADER_PEEK) {
        Ok(v) => v,
        Err(e) if e.status == TINFLStatus::HasMoreOutput => e.output,
        Err(e) => return Err(format!("cannot decompress shape {index}: {:?}", e.status)),
    };
    let (flags, nv, nt, header_len) = shape_header(&peek, version)?;
    let (nv, nt) = match (usize::try_from(nv), usize::try_from(nt)) {
        (Ok(nv), Ok(nt)) => (nv, nt),
        _ => {
            return Err(format!(
                "shape {index}: impossible counts ({nv} vertices, {nt} triangles)"
            ))
        }
    };
    budget.check(nv, nt)?;
    let double = flags & DOUBLE != 0;
    let real = if double { 8u64 } else { 4 };
    let per_vertex = 3
        + 3 * u64::from(flags & HAS_NORMALS != 0)
        + 2 * u64::from(flags & HAS_UVS != 0)
        + 3 * u64::from(flags & HAS_COLORS != 0);
    let wide = nv > u32::MAX as usize;
    let index_size = if wide { 8u64 } else { 4 };
    let expected = header_len as u64 + nv as u64 * per_vertex * real + nt as u64 * 3 * index_size;
    let expected = usize::try_from(expected)
        .map_err(|_| format!("shape {index}: declared data does not fit in memory"))?;
    let raw = match decompress_to_vec_zlib_with_limit(stream, expected.saturating_add(1)) {
        Ok(v) => v,
        Err(e) if e.status == TINFLStatus::HasMoreOutput => {
            return Err(format!(
                "shape {index} inflates to more than the {expected} bytes its counts ({nv} vertices, {nt} triangles) account for"
            ))
        }
        Err(e) => return Err(format!("cannot decompress shape {index}: {:?}", e.status)),
    };
    if raw.len() < expected {
        return Err(format!(
            "shape {index}: counts ({nv} vertices, {nt} triangles) exceed the data ({} of {expected} bytes)",
            raw.len()
        ));
    }
    let mut c = Cursor {
        d: &raw,
        p: header_len,
    };
    let mut mesh = TriangleMesh {
        positions: c.vec3s(nv, double)?,
        ..Default::default()
    };
    if flags & HAS_NORMALS != 0 {
        mesh.normals = c.vec3s(nv, double)?;
    }
    if flags & HAS_UVS != 0 {
        mesh.uvs = (0..nv)
            .map(|_| Ok(Vec2::new(c.real(double)?, c.real(double)?)))
            .collect::<Result<_, String>>()?;
    }
    if flags & HAS_COLORS != 0 {
        // Mitsuba names them `vertex_color`, for `mesh_attribute`.
        let colors = c.vec3s(nv, double)?;
        mesh.attributes.push(crate::scene::MeshAttribute {
            name: "vertex_color".into(),
            channels: 3,
            values: colors.iter().flat_map(|c| c.to_array()).collect(),
        });
    }
    mesh.indices = (0..nt)
        .map(|_| {
            let mut t = [0u32; 3];
            for v in &mut t {
                *v = if wide {
                    u32::try_from(c.u64()?).unwrap_or(u32::MAX)
                } else {
                    c.u32()?
                };
            }
            Ok(t)
        })
        .collect::<Result<_, String>>()?;
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use miniz_oxide::deflate::compress_to_vec_zlib;

    /// A version-4 file holding one shape whose stream is `payload` (already the inflated bytes).
    fn file_with(payload: &[u8]) -> Vec<u8> {
        let mut d = Vec::new();
        d.extend_from_slice(&MAGIC.to_le_bytes());
        d.extend_from_slice(&4u16.to_le_bytes());
        d.extend_from_slice(&compress_to_vec_zlib(payload, 9));
        d.extend_from_slice(&0u64.to_le_bytes());
        d.extend_from_slice(&1u32.to_le_bytes());
        d
    }

    fn header(nv: u64, nt: u64) -> Vec<u8> {
        let mut p = Vec::new();
        p.extend_from_slice(&0x1000u32.to_le_bytes());
        p.extend_from_slice(b"bomb\0");
        p.extend_from_slice(&nv.to_le_bytes());
        p.extend_from_slice(&nt.to_le_bytes());
        p
    }

    const UNLIMITED: Budget = Budget {
        vertices: u64::MAX,
        triangles: u64::MAX,
    };

    #[test]
    fn a_stream_larger_than_its_counts_is_rejected_before_inflating_it() {
        // One triangle's worth of counts followed by 64 MiB of zeros (64 KiB compressed).
        let mut p = header(3, 1);
        p.resize(p.len() + (64 << 20), 0);
        let d = file_with(&p);
        assert!(d.len() < 100_000, "{}", d.len());
        let e = parse(&d, 0, &UNLIMITED).unwrap_err();
        assert!(e.contains("inflates to more than the 73 bytes"), "{e}");
    }

    #[test]
    fn declared_counts_are_checked_against_the_budget() {
        let d = file_with(&header(1 << 40, 1 << 40));
        let small = Budget {
            vertices: 1 << 20,
            triangles: 1 << 20,
        };
        let e = parse(&d, 0, &small).unwrap_err();
        assert!(e.starts_with("1099511627776 vertices are more than"), "{e}");
        let e = parse(&d, 0, &UNLIMITED).unwrap_err();
        assert!(e.contains("exceed the data"), "{e}");
    }
}
