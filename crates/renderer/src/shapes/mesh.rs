//! Triangle meshes (OBJ, PLY, serialized, and Mitsuba's rectangle): world-space vertex data, the
//! surface at a triangle hit, and uniform area sampling of an emitting mesh.

use super::triangle::sample_triangle_uniform;
use super::PrimGeom;
use super::{PrimInfo, SurfaceHit};
use crate::ray::ClosestHit;
use crate::sampling::Frame;
use glam::{Mat3, Mat4, Vec2, Vec3A};
use torrey_light::AliasTable;
use torrey_parser as desc;

/// All triangles of the scene in world space, concatenated; and the grids of the `sdfgrid`
/// shapes, with the table of their voxels that hold surface (the BVH primitives).
#[derive(Default)]
pub struct MeshData {
    pub positions: Vec<Vec3A>,
    pub normals: Vec<Vec3A>,
    pub uvs: Vec<Vec2>,
    /// Triangles kept (degenerate ones are dropped); their indices are in [`PrimInfo`].
    pub triangle_count: usize,
    /// Each `sdfgrid` shape's grid ([`super::sdfgrid::SdfGridShape::grid`]).
    pub sdf_grids: Vec<super::sdfgrid::SdfGridData>,
    /// Every voxel with surface of every grid: what the BVH tests; an `sdfgrid` primitive's
    /// record holds its index here (`indices[0]`).
    pub sdf_voxels: Vec<super::sdfgrid::SdfVoxel>,
    /// The same voxels' cells and boxes.
    pub sdf_cells: Vec<super::sdfgrid::SdfCell>,
}

impl MeshData {
    /// Whether the triangle with (global) vertex indices `idx` becomes a primitive: zero-area
    /// triangles can never be hit, and non-finite ones could not be placed in the BVH (their
    /// bounds order nothing).
    pub fn keeps_triangle(&self, idx: [u32; 3]) -> bool {
        let p0 = self.positions[idx[0] as usize];
        let p1 = self.positions[idx[1] as usize];
        let p2 = self.positions[idx[2] as usize];
        (p1 - p0).cross(p2 - p0).length_squared() != 0.0
            && PrimGeom::Triangle { p0, p1, p2 }.is_finite()
    }
}

/// What a mesh shape's hits need beyond its triangles' vertices.
#[derive(Clone, Copy, Debug)]
pub struct MeshShape {
    pub has_normals: bool,
    /// Every triangle's three vertex normals are the same (flat-shaded faces, as in box meshes
    /// with one normal per face): the shading normal is that normal, without the interpolation
    /// and normalisation (a square root and a division on the path from a hit to its shading).
    pub flat_normals: bool,
    pub has_uvs: bool,
}

impl MeshShape {
    /// A shape without primitives (one left out of the scene keeps its index).
    pub const EMPTY: MeshShape = MeshShape {
        has_normals: false,
        flat_normals: false,
        has_uvs: false,
    };

    /// Transforms mesh `m` to world space and appends its vertices to `mesh` and its triangles
    /// to the BVH primitives `geoms` and their records `prims`. Degenerate (zero-area) triangles
    /// are dropped: they can never be hit and would only cost traversal time.
    pub fn add(
        mesh: &mut MeshData,
        geoms: &mut Vec<PrimGeom>,
        prims: &mut Vec<PrimInfo>,
        shape: u32,
        m: &desc::TriangleMesh,
        to_world: Mat4,
    ) -> Self {
        let base = mesh.positions.len() as u32;
        let has_normals = m.normals.len() == m.positions.len() && !m.normals.is_empty();
        let has_uvs = m.uvs.len() == m.positions.len() && !m.uvs.is_empty();
        mesh.positions.extend(
            m.positions
                .iter()
                .map(|&p| Vec3A::from(to_world.transform_point3(p))),
        );
        // Normals transform with the inverse transpose.
        let normal_matrix = Mat3::from_mat4(to_world).inverse().transpose();
        if has_normals {
            mesh.normals.extend(
                m.normals
                    .iter()
                    .map(|&n| Vec3A::from(normal_matrix * n).normalize_or(Vec3A::Z)),
            );
        } else {
            mesh.normals
                .extend(std::iter::repeat_n(Vec3A::Z, m.positions.len()));
        }
        if has_uvs {
            mesh.uvs.extend(m.uvs.iter().copied());
        } else {
            mesh.uvs
                .extend(std::iter::repeat_n(Vec2::ZERO, m.positions.len()));
        }
        let normal = |i: u32| mesh.normals[(i + base) as usize];
        let flat_normals = has_normals
            && m.indices
                .iter()
                .all(|t| normal(t[0]) == normal(t[1]) && normal(t[0]) == normal(t[2]));
        for tri in &m.indices {
            let idx = [tri[0] + base, tri[1] + base, tri[2] + base];
            if !mesh.keeps_triangle(idx) {
                continue;
            }
            let p0 = mesh.positions[idx[0] as usize];
            let p1 = mesh.positions[idx[1] as usize];
            let p2 = mesh.positions[idx[2] as usize];
            let geom = PrimGeom::Triangle { p0, p1, p2 };
            prims.push(PrimInfo {
                ng: (p1 - p0).cross(p2 - p0).normalize_or(Vec3A::Z),
                indices: idx,
                shape,
            });
            mesh.triangle_count += 1;
            geoms.push(geom);
        }
        MeshShape {
            has_normals,
            flat_normals,
            has_uvs,
        }
    }

    /// Mitsuba's rectangle: [-1,1]^2 at z = 0, normal +z, uv = ((x+1)/2, (y+1)/2).
    pub fn rectangle() -> desc::TriangleMesh {
        let positions = vec![
            glam::Vec3::new(-1.0, -1.0, 0.0),
            glam::Vec3::new(1.0, -1.0, 0.0),
            glam::Vec3::new(1.0, 1.0, 0.0),
            glam::Vec3::new(-1.0, 1.0, 0.0),
        ];
        let uvs = positions
            .iter()
            .map(|p| Vec2::new((p.x + 1.0) * 0.5, (p.y + 1.0) * 0.5))
            .collect();
        desc::TriangleMesh {
            positions,
            normals: vec![glam::Vec3::Z; 4],
            uvs,
            indices: vec![[0, 1, 2], [0, 2, 3]],
            attributes: Vec::new(),
        }
    }

    /// The surface at a hit on triangle `prim`: barycentric position, interpolated (or flat, or
    /// geometric) shading normal, and when `needs_uv` the interpolated uv and dp/du, dp/dv.
    #[inline(always)]
    pub fn surface(
        &self,
        mesh: &MeshData,
        prim: &PrimInfo,
        hit: &ClosestHit,
        needs_uv: bool,
    ) -> SurfaceHit {
        let [i0, i1, i2] = prim.indices;
        let (i0, i1, i2) = (i0 as usize, i1 as usize, i2 as usize);
        let (p0, p1, p2) = (mesh.positions[i0], mesh.positions[i1], mesh.positions[i2]);
        let b0 = 1.0 - hit.b1 - hit.b2;
        let p = b0 * p0 + hit.b1 * p1 + hit.b2 * p2;
        let e1 = p1 - p0;
        let e2 = p2 - p0;
        let ng = prim.ng;
        let ns = if self.flat_normals {
            mesh.normals[i0]
        } else if self.has_normals {
            let n = b0 * mesh.normals[i0] + hit.b1 * mesh.normals[i1] + hit.b2 * mesh.normals[i2];
            n.normalize_or(ng)
        } else {
            ng
        };
        // Without uvs Mitsuba uses the barycentrics as uv, so dp/du = e1, dp/dv = e2.
        let (uv, dpdu, dpdv) = if !needs_uv {
            (Vec2::ZERO, Vec3A::ZERO, Vec3A::ZERO)
        } else if self.has_uvs {
            let (t0, t1, t2) = (mesh.uvs[i0], mesh.uvs[i1], mesh.uvs[i2]);
            let uv = b0 * t0 + hit.b1 * t1 + hit.b2 * t2;
            let (d1, d2) = (t1 - t0, t2 - t0);
            let det = d1.x * d2.y - d1.y * d2.x;
            if det.abs() > 1e-12 {
                let inv = 1.0 / det;
                let dpdu = (d2.y * e1 - d1.y * e2) * inv;
                let dpdv = (d1.x * e2 - d2.x * e1) * inv;
                (uv, dpdu, dpdv)
            } else {
                let frame = Frame::from_normal(ng);
                (uv, frame.s, frame.t)
            }
        } else {
            (Vec2::new(hit.b1, hit.b2), e1, e2)
        };
        SurfaceHit {
            t: hit.t,
            p,
            ng,
            ns,
            uv,
            dpdu,
            dpdv,
            bary: Vec2::new(hit.b1, hit.b2),
            shape: prim.shape,
            prim: hit.prim,
        }
    }
}

/// One triangle of an emitting mesh, stored with the emitter so that sampling it reads one
/// record instead of following primitive, index and vertex lists.
#[derive(Clone, Copy, Debug)]
pub struct EmitterTriangle {
    pub p0: Vec3A,
    pub e1: Vec3A,
    pub e2: Vec3A,
    /// The unit face normal (before `flip_normals`).
    pub normal: Vec3A,
}

/// An emitting mesh sampled uniformly by area: a triangle chosen in proportion to its area from
/// an alias table (one lookup instead of a cdf search), then a uniform point on it.
pub struct MeshEmitter {
    total_area: f32,
    triangles: AliasTable,
    geometry: Vec<EmitterTriangle>,
    /// Each triangle's vertex uvs, for a textured radiance ([`MeshEmitter::with_uvs`]; empty
    /// otherwise).
    uvs: Vec<[Vec2; 3]>,
}

impl MeshEmitter {
    /// The emitter over the triangles `prims` (of one shape) of `mesh`.
    pub fn new(mesh: &MeshData, prims: &[PrimInfo]) -> Self {
        let geometry: Vec<EmitterTriangle> = prims
            .iter()
            .map(|prim| {
                let [a, b, c] = prim.indices;
                let (a, b, c) = (
                    mesh.positions[a as usize],
                    mesh.positions[b as usize],
                    mesh.positions[c as usize],
                );
                EmitterTriangle {
                    p0: a,
                    e1: b - a,
                    e2: c - a,
                    normal: prim.ng,
                }
            })
            .collect();
        Self::from_triangles(geometry)
    }

    /// The emitter over `geometry`.
    pub fn from_triangles(geometry: Vec<EmitterTriangle>) -> Self {
        let areas: Vec<f32> = geometry
            .iter()
            .map(|t| 0.5 * t.e1.cross(t.e2).length())
            .collect();
        let total_area: f32 = areas.iter().sum();
        Self {
            total_area,
            triangles: AliasTable::new(&areas),
            geometry,
            uvs: Vec::new(),
        }
    }

    /// [`MeshEmitter::new`] that also keeps the triangles' uvs (zero without any), for
    /// [`MeshEmitter::sample_point_uv`].
    pub fn with_uvs(mesh: &MeshData, prims: &[PrimInfo]) -> Self {
        let mut emitter = Self::new(mesh, prims);
        emitter.uvs = prims
            .iter()
            .map(|prim| {
                prim.indices
                    .map(|i| mesh.uvs.get(i as usize).copied().unwrap_or(Vec2::ZERO))
            })
            .collect();
        emitter
    }

    /// [`MeshEmitter::sample_point`] with the point's interpolated uv (needs
    /// [`MeshEmitter::with_uvs`]).
    #[inline]
    pub fn sample_point_uv(&self, u: Vec2) -> (Vec3A, Vec3A, Vec2) {
        let (index, u_rest) = self.triangles.sample(u.x);
        let tri = &self.geometry[index];
        let (b1, b2) = sample_triangle_uniform(Vec2::new(u_rest, u.y));
        let uv = self.uvs.get(index).map_or(Vec2::ZERO, |t| {
            t[0] * (1.0 - b1 - b2) + t[1] * b1 + t[2] * b2
        });
        (tri.p0 + b1 * tri.e1 + b2 * tri.e2, tri.normal, uv)
    }

    /// A point uniform over the mesh's area and the face normal there (before `flip_normals`).
    #[inline(always)]
    pub fn sample_point(&self, u: Vec2) -> (Vec3A, Vec3A) {
        let (index, u_rest) = self.triangles.sample(u.x);
        let tri = &self.geometry[index];
        let (b1, b2) = sample_triangle_uniform(Vec2::new(u_rest, u.y));
        (tri.p0 + b1 * tri.e1 + b2 * tri.e2, tri.normal)
    }

    /// The emitting triangles.
    pub fn triangles(&self) -> &[EmitterTriangle] {
        &self.geometry
    }

    /// The area density of [`MeshEmitter::sample_point`]: 1 / area.
    #[inline(always)]
    pub fn total_area(&self) -> f32 {
        self.total_area
    }
}
