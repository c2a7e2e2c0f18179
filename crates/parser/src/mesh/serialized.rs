//! Mitsuba's `serialized` mesh format: a u16 magic 0x041C and u16 version (3 or 4), then one
//! zlib stream per shape, and at the end of the file a table of shape offsets (u64 for v4,
//! u32 for v3) followed by the u32 shape count. Each stream holds u32 flags, (v4) a
//! NUL-terminated name, u64 vertex and triangle counts, positions, optional normals (0x1),
//! uvs (0x2) and colours (0x8), in f32 (0x1000) or f64 (0x2000), then u32 indices (u64 when
//! there are more than 2^32 vertices). Texture coordinates are not flipped.

use crate::scene::TriangleMesh;
use glam::{Vec2, Vec3};
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
pub(crate) fn load(path: &Path, index: usize) -> Result<TriangleMesh, String> {
    let data = std::fs::read(path).map_err(|e| e.to_string())?;
    parse(&data, index)
}

pub(crate) fn parse(d: &[u8], index: usize) -> Result<TriangleMesh, String> {
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
    let entry = if version == 4 { 8 } else { 4 };
    let table = d
        .len()
        .checked_sub(4 + entry * count)
        .ok_or_else(|| "corrupt shape table".to_string())?;
    let offset_of = |i: usize| -> Option<usize> {
        if version == 4 {
            u64_at(d, table + 8 * i).map(|v| v as usize)
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
    if start + 4 > end || end > d.len() {
        return Err(format!("corrupt offset {start} for shape {index}"));
    }
    let raw = miniz_oxide::inflate::decompress_to_vec_zlib(&d[start + 4..end])
        .map_err(|e| format!("cannot decompress shape {index}: {:?}", e.status))?;
    let mut c = Cursor { d: &raw, p: 0 };
    let flags = c.u32()?;
    if version == 4 {
        while c.bytes(1)?[0] != 0 {}
    }
    let nv = c.u64()? as usize;
    let nt = c.u64()? as usize;
    if nv.saturating_mul(12) > raw.len() || nt.saturating_mul(12) > raw.len() {
        return Err(format!(
            "shape {index}: counts ({nv} vertices, {nt} triangles) exceed the data"
        ));
    }
    let double = flags & DOUBLE != 0;
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
        c.vec3s(nv, double)?;
    }
    let wide = nv > u32::MAX as usize;
    mesh.indices = (0..nt)
        .map(|_| {
            let mut t = [0u32; 3];
            for v in &mut t {
                *v = if wide { c.u64()? as u32 } else { c.u32()? };
            }
            Ok(t)
        })
        .collect::<Result<_, String>>()?;
    Ok(mesh)
}
