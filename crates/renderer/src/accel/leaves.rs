//! The leaves of a BVH, whatever its node width: blocks of four triangles, spheres, disks,
//! cylinders and `sdfgrid` voxels, and the records of leaves that hold anything but triangles.

use super::traversal::{reciprocal, ChildRef, LEAF, LEAF_COUNT_SHIFT, LEAF_INDEX_MASK};
use super::triangle4::{Ray4, Triangle4};
use super::{ClosestHit, PrimGeom};
use crate::ray::Ray;
use crate::shapes::cylinder::intersect_cylinder;
use crate::shapes::disk::intersect_disk;
use crate::shapes::object_rows::ObjectRows;
use crate::shapes::sdfgrid::{intersect_sdf_voxel, SdfVoxel};
use crate::shapes::sphere::intersect_sphere;
use glam::Vec3A;
use obvhs::bvh2::Bvh2;

/// A leaf: a run of triangle blocks and a run of spheres.
#[derive(Clone, Copy, Debug)]
struct Leaf {
    first_block: u32,
    block_count: u32,
    first_sphere: u32,
    sphere_count: u32,
    first_quadric: u32,
    quadric_count: u32,
    first_sdf: u32,
    sdf_count: u32,
}

/// An `sdfgrid` voxel in a leaf: its samples and placement, and its primitive index.
#[derive(Clone, Copy, Debug)]
struct SdfRef {
    voxel: SdfVoxel,
    prim: u32,
}

/// A disk or a cylinder in a leaf: its world-to-object transform and primitive index.
#[derive(Clone, Copy, Debug)]
struct QuadricRef {
    to_object: ObjectRows,
    cylinder: bool,
    prim: u32,
}

#[derive(Clone, Copy, Debug)]
struct SphereRef {
    center: Vec3A,
    radius: f32,
    prim: u32,
}

/// The closest hit in (0, tmax) among the triangles of `blocks`.
#[inline(always)]
pub(crate) fn closest_in_blocks(
    blocks: &[Triangle4],
    ray4: &Ray4,
    ray: &Ray,
    tmax: f32,
) -> Option<ClosestHit> {
    let mut tmax = tmax;
    let mut best = None;
    for block in blocks {
        if let Some((lane, t, b1, b2)) = block.intersect(ray4, ray, tmax) {
            tmax = t;
            best = Some(ClosestHit {
                t,
                prim: block.prim[lane],
                b1,
                b2,
            });
        }
    }
    best
}

/// The leaves of a BVH, whatever its node width: triangle blocks, spheres, and the records of
/// leaves that hold spheres.
pub(crate) struct Leaves {
    leaves: Vec<Leaf>,
    blocks: Vec<Triangle4>,
    spheres: Vec<SphereRef>,
    quadrics: Vec<QuadricRef>,
    sdf: Vec<SdfRef>,
}

impl Leaves {
    /// Leaves with only the empty leaf, [`Leaves::EMPTY_LEAF`], in them.
    pub(crate) fn new() -> Self {
        Self {
            leaves: vec![Leaf {
                first_block: 0,
                block_count: 0,
                first_sphere: 0,
                sphere_count: 0,
                first_quadric: 0,
                quadric_count: 0,
                first_sdf: 0,
                sdf_count: 0,
            }],
            blocks: Vec::new(),
            spheres: Vec::new(),
            quadrics: Vec::new(),
            sdf: Vec::new(),
        }
    }

    /// A leaf holding nothing: what unused lanes of a wide node point at, so that every child
    /// reference a traversal can read is valid whatever the box test answers for it.
    pub(crate) const EMPTY_LEAF: ChildRef = LEAF;

    pub(crate) fn add(
        &mut self,
        bvh2: &Bvh2,
        first: u32,
        count: u32,
        geoms: &[PrimGeom],
        sdf_voxels: &[SdfVoxel],
    ) -> ChildRef {
        let prims = &bvh2.primitive_indices[first as usize..(first + count) as usize];
        let mut tris = Vec::new();
        let first_sphere = self.spheres.len() as u32;
        let first_quadric = self.quadrics.len() as u32;
        let first_sdf = self.sdf.len() as u32;
        for &prim in prims {
            match geoms[prim as usize] {
                PrimGeom::Triangle { p0, p1, p2 } => tris.push((p0, p1, p2, prim)),
                PrimGeom::Sphere { center, radius } => self.spheres.push(SphereRef {
                    center,
                    radius,
                    prim,
                }),
                PrimGeom::Disk { to_object } => self.quadrics.push(QuadricRef {
                    to_object,
                    cylinder: false,
                    prim,
                }),
                PrimGeom::Cylinder { to_object } => self.quadrics.push(QuadricRef {
                    to_object,
                    cylinder: true,
                    prim,
                }),
                PrimGeom::SdfVoxel { index, .. } => self.sdf.push(SdfRef {
                    // The table the BVH is built with holds every voxel its primitives name.
                    voxel: sdf_voxels[index as usize],
                    prim,
                }),
            }
        }
        let first_block = self.blocks.len() as u32;
        self.blocks.extend(tris.chunks(4).map(Triangle4::new));
        let block_count = self.blocks.len() as u32 - first_block;
        let sphere_count = self.spheres.len() as u32 - first_sphere;
        let quadric_count = self.quadrics.len() as u32 - first_quadric;
        let sdf_count = self.sdf.len() as u32 - first_sdf;
        if sphere_count == 0
            && quadric_count == 0
            && sdf_count == 0
            && (1..16).contains(&block_count)
            && first_block <= LEAF_INDEX_MASK
        {
            return LEAF | block_count << LEAF_COUNT_SHIFT | first_block;
        }
        self.leaves.push(Leaf {
            first_block,
            block_count: self.blocks.len() as u32 - first_block,
            first_sphere,
            sphere_count: self.spheres.len() as u32 - first_sphere,
            first_quadric,
            quadric_count,
            first_sdf,
            sdf_count,
        });
        LEAF | (self.leaves.len() as u32 - 1)
    }

    /// The triangle blocks of leaf `r` when its reference carries them (a leaf of triangles
    /// only); None for a leaf stored in `leaves`.
    #[inline(always)]
    pub(crate) fn packed_blocks(&self, r: ChildRef) -> Option<&[Triangle4]> {
        let first = (r & LEAF_INDEX_MASK) as usize;
        let count = ((r & !LEAF) >> LEAF_COUNT_SHIFT) as usize;
        if count == 0 {
            return None;
        }
        debug_assert!(first + count <= self.blocks.len());
        // SAFETY: `add` packs only block ranges that it has just pushed to `blocks`.
        Some(unsafe { self.blocks.get_unchecked(first..first + count) })
    }

    /// Closest hit in (0, tmax) among the triangles, spheres, disks and cylinders of leaf `r`
    /// of `leaves`. Kept out of line: leaves with analytic shapes are rare, and inlining the
    /// sphere test into the traversal loops costs every ray registers and set-up. It builds the
    /// triangle test's constants itself, only for a leaf with triangle blocks: taking the
    /// caller's by reference made every call spill them to memory, most leaves here having no
    /// triangles (spheres, rectangles).
    #[inline(never)]
    pub(crate) fn intersect_general(
        &self,
        r: ChildRef,
        ray: &Ray,
        tmax: f32,
    ) -> Option<ClosestHit> {
        let leaf = &self.leaves[(r & LEAF_INDEX_MASK) as usize];
        let mut best = None;
        let mut tmax = tmax;
        if leaf.block_count > 0 {
            let blocks = leaf.first_block as usize..(leaf.first_block + leaf.block_count) as usize;
            let ray4 = Ray4::for_ray(ray, reciprocal(ray));
            best = closest_in_blocks(&self.blocks[blocks], &ray4, ray, tmax);
            tmax = best.map_or(tmax, |h| h.t);
        }
        let spheres = leaf.first_sphere as usize..(leaf.first_sphere + leaf.sphere_count) as usize;
        for s in &self.spheres[spheres] {
            if let Some(t) = intersect_sphere(ray, s.center, s.radius, 0.0, tmax) {
                tmax = t;
                best = Some(ClosestHit {
                    t,
                    prim: s.prim,
                    b1: 0.0,
                    b2: 0.0,
                });
            }
        }
        let quadrics =
            leaf.first_quadric as usize..(leaf.first_quadric + leaf.quadric_count) as usize;
        for q in &self.quadrics[quadrics] {
            let t = if q.cylinder {
                intersect_cylinder(ray, &q.to_object, tmax)
            } else {
                intersect_disk(ray, &q.to_object, tmax)
            };
            if let Some(t) = t {
                tmax = t;
                best = Some(ClosestHit {
                    t,
                    prim: q.prim,
                    b1: 0.0,
                    b2: 0.0,
                });
            }
        }
        let sdf = leaf.first_sdf as usize..(leaf.first_sdf + leaf.sdf_count) as usize;
        for v in &self.sdf[sdf] {
            if let Some(t) = intersect_sdf_voxel(ray, &v.voxel, tmax) {
                tmax = t;
                best = Some(ClosestHit {
                    t,
                    prim: v.prim,
                    b1: 0.0,
                    b2: 0.0,
                });
            }
        }
        best
    }
}
