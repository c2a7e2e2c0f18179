//! The scene's shapes. Each file holds everything of its shape: construction from the parsed
//! description, intersection, the surface at a hit (position, normals, uv and its derivatives),
//! and area sampling with its pdf for shapes that emit. A new shape is a file, a [`ShapeKind`]
//! variant with one-line arms below, its primitive in [`PrimGeom`] (or triangles),
//! the parser mapping and the docs.

pub mod attributes;
pub mod cylinder;
pub mod disk;
pub mod instance;
pub mod mesh;
pub mod object_rows;
pub mod prim_geom;
pub mod sdfgrid;
pub mod sphere;
pub mod triangle;

pub use prim_geom::PrimGeom;

use crate::ray::ClosestHit;
use crate::ray::Ray;
use cylinder::Cylinder;
use disk::Disk;
use glam::{Vec2, Vec3A};
use mesh::{MeshData, MeshShape};
use sdfgrid::SdfGridShape;
use sphere::Sphere;

/// What a hit needs to know about a BVH primitive, one load away from the hit's primitive index:
/// its shape and, for a triangle, its unit geometric normal and vertex indices into [`MeshData`].
/// (Indices and normal in a separate per-triangle array would put one more dependent load
/// between a hit and its shading.)
#[derive(Clone, Copy, Debug)]
pub struct PrimInfo {
    /// (p1 − p0) × (p2 − p0), normalised; zero for a sphere.
    pub ng: Vec3A,
    /// Zero for a sphere; an `sdfgrid` voxel's index in [`MeshData::sdf_voxels`] first.
    pub indices: [u32; 3],
    pub shape: u32,
}

/// The differential geometry at a ray hit.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    pub t: f32,
    pub p: Vec3A,
    /// Geometric normal (after `flip_normals`), not turned towards the ray.
    pub ng: Vec3A,
    /// Shading normal (interpolated vertex normal, or `ng`), not turned towards the ray.
    pub ns: Vec3A,
    /// Texture coordinates and their position derivatives; only computed when the material reads
    /// a texture (zero otherwise: nothing else uses them, and spheres pay two inverse
    /// trigonometric functions for them).
    pub uv: Vec2,
    pub dpdu: Vec3A,
    pub dpdv: Vec3A,
    /// The barycentrics (b1, b2) of a triangle hit, for `mesh_attribute` textures; zero on
    /// analytic shapes.
    pub bary: Vec2,
    pub shape: u32,
    pub prim: u32,
}

/// The geometry of a shape.
#[derive(Clone, Copy, Debug)]
pub enum ShapeKind {
    Mesh(MeshShape),
    Sphere(Sphere),
    Disk(Disk),
    Cylinder(Cylinder),
    SdfGrid(SdfGridShape),
}

/// A shape of the scene: its geometry, material, emitter and orientation.
#[derive(Clone, Copy, Debug)]
pub struct Shape {
    pub kind: ShapeKind,
    pub material: u32,
    pub area_light: Option<u32>,
    /// The shape emits a textured radiance: its hits need uv.
    pub textured_emission: bool,
    pub flip_normals: bool,
}

impl Shape {
    /// The surface at `hit`, a closest hit along `ray` on primitive `prim` of this shape; uv and
    /// its derivatives only when `needs_uv`.
    #[inline(always)]
    pub fn surface(
        &self,
        mesh: &MeshData,
        prim: &PrimInfo,
        ray: &Ray,
        hit: &ClosestHit,
        needs_uv: bool,
    ) -> SurfaceHit {
        let mut sh = match &self.kind {
            ShapeKind::Mesh(m) => m.surface(mesh, prim, hit, needs_uv),
            ShapeKind::Sphere(s) => s.surface(ray, prim, hit, needs_uv),
            ShapeKind::Disk(d) => d.surface(ray, prim, hit, needs_uv),
            ShapeKind::Cylinder(c) => c.surface(ray, prim, hit, needs_uv),
            ShapeKind::SdfGrid(g) => {
                let index = prim.indices[0] as usize;
                mesh.sdf_grids[g.grid as usize].surface(ray, prim, hit, mesh.sdf_cells[index].cell)
            }
        };
        if self.flip_normals {
            sh.ng = -sh.ng;
            sh.ns = -sh.ns;
        }
        sh
    }
}
