//! Building the wide BVH: obvhs's binary BVH, flattened into nodes of four, eight or sixteen children and
//! leaves of triangle blocks.

use super::leaves::Leaves;
use super::nodes4::Nodes4;
use super::traversal::{ChildRef, EMPTY};
use super::{Layout, PrimGeom};
use crate::shapes::sdfgrid::SdfVoxel;
use glam::Vec3A;
use obvhs::{aabb::Aabb, bvh2::Bvh2, BvhBuildParams};

impl PrimGeom {
    /// Whether the builder can place it: every coordinate (and radius) finite, and so is its
    /// box's extent and surface area (a triangle with corners at ±3e38 has finite corners but an
    /// infinite extent). The scene drops the others before building.
    pub fn is_finite(&self) -> bool {
        let coordinates = match *self {
            PrimGeom::Triangle { p0, p1, p2 } => p0.is_finite() && p1.is_finite() && p2.is_finite(),
            PrimGeom::Sphere { center, radius } => center.is_finite() && radius.is_finite(),
            PrimGeom::Disk { to_object } | PrimGeom::Cylinder { to_object } => {
                to_object.is_finite() && to_object.inverse_affine().is_finite()
            }
            PrimGeom::SdfVoxel { min, max, .. } => min.is_finite() && max.is_finite(),
        };
        coordinates && {
            let b = self.aabb();
            let extent = b.max - b.min;
            extent.is_finite() && b.half_area().is_finite()
        }
    }

    pub(crate) fn aabb(&self) -> Aabb {
        match *self {
            PrimGeom::Triangle { p0, p1, p2 } => Aabb {
                min: p0.min(p1).min(p2),
                max: p0.max(p1).max(p2),
            },
            PrimGeom::Sphere { center, radius } => Aabb {
                min: center - Vec3A::splat(radius),
                max: center + Vec3A::splat(radius),
            },
            // The object-space box's corners (z = 0 for a disk, 0..1 for a cylinder) mapped to
            // world space.
            PrimGeom::Disk { to_object } | PrimGeom::Cylinder { to_object } => {
                let to_world = to_object.inverse_affine();
                let z_max = if matches!(self, PrimGeom::Disk { .. }) {
                    0.0
                } else {
                    1.0
                };
                let mut b = Aabb {
                    min: Vec3A::splat(f32::INFINITY),
                    max: Vec3A::splat(f32::NEG_INFINITY),
                };
                for i in 0..8 {
                    let corner = Vec3A::new(
                        if i & 1 == 0 { -1.0 } else { 1.0 },
                        if i & 2 == 0 { -1.0 } else { 1.0 },
                        if i & 4 == 0 { 0.0 } else { z_max },
                    );
                    let p = to_world.transform_point3a(corner);
                    b.min = b.min.min(p);
                    b.max = b.max.max(p);
                }
                b
            }
            PrimGeom::SdfVoxel { min, max, .. } => Aabb { min, max },
        }
    }
}

/// The children of BVH2 inner node `index` that become one wide node: its two children, then
/// the child with the largest surface area opened until there are `width` (or only leaves).
fn wide_children(bvh2: &Bvh2, index: usize, width: usize) -> Vec<usize> {
    let first = bvh2.nodes[index].first_index as usize;
    let mut children = vec![first, first + 1];
    while children.len() < width {
        let widest = children
            .iter()
            .enumerate()
            .filter(|(_, &c)| !bvh2.nodes[c].is_leaf())
            .max_by(|a, b| {
                let area = |c: usize| bvh2.nodes[c].aabb().half_area();
                area(*a.1).total_cmp(&area(*b.1))
            })
            .map(|(slot, _)| slot);
        let Some(slot) = widest else { break };
        let opened = bvh2.nodes[children[slot]].first_index as usize;
        children.splice(slot..=slot, [opened, opened + 1]);
    }
    children
}

/// Structure-of-arrays bounds rows `[min x, min y, min z, max x, max y, max z]` of a wide
/// node's children, lane i for child i; unused lanes get an inverted box that no ray enters.
fn wide_bounds<const W: usize>(bvh2: &Bvh2, children: &[usize]) -> [[f32; W]; 6] {
    let mut rows = [[f32::INFINITY; W]; 6];
    for row in &mut rows[3..] {
        *row = [f32::NEG_INFINITY; W];
    }
    for (lane, &c) in children.iter().enumerate() {
        let aabb = bvh2.nodes[c].aabb();
        for axis in 0..3 {
            rows[axis][lane] = aabb.min[axis];
            rows[axis + 3][lane] = aabb.max[axis];
        }
    }
    rows
}

/// Builds the wide nodes of one width from a BVH2.
pub(crate) struct WideBuilder<'a> {
    bvh2: &'a Bvh2,
    geoms: &'a [PrimGeom],
    sdf_voxels: &'a [SdfVoxel],
    leaves: Leaves,
    depth: usize,
}

impl WideBuilder<'_> {
    /// Converts the subtree under BVH2 inner node `index` into `W`-wide nodes appended to
    /// `nodes`: `make` creates a node from its bounds rows and child references (all the empty
    /// leaf at first), `set_child` fills in its children once they are built. Returns the
    /// subtree's reference.
    pub(crate) fn add_inner<const W: usize, N>(
        &mut self,
        nodes: &mut Vec<N>,
        index: usize,
        level: usize,
        make: &impl Fn([[f32; W]; 6], [ChildRef; W]) -> N,
        set_child: &impl Fn(&mut N, usize, ChildRef),
    ) -> ChildRef {
        self.depth = self.depth.max(level);
        let children = wide_children(self.bvh2, index, W);
        let node_index = nodes.len();
        nodes.push(make(
            wide_bounds::<W>(self.bvh2, &children),
            [Leaves::EMPTY_LEAF; W],
        ));
        for (lane, &c) in children.iter().enumerate() {
            let node = &self.bvh2.nodes[c];
            let child = if node.is_leaf() {
                self.leaves.add(
                    self.bvh2,
                    node.first_index,
                    node.prim_count,
                    self.geoms,
                    self.sdf_voxels,
                )
            } else {
                self.add_inner(nodes, c, level + 1, make, set_child)
            };
            set_child(&mut nodes[node_index], lane, child);
        }
        node_index as ChildRef
    }
}

/// Primitive count from which a scene counts as large: it gets obvhs's medium build instead of
/// the slowest, best one, which would take seconds.
pub(super) const LARGE_SCENE: usize = 100_000;

/// Camera samples per primitive from which the slowest, best build is taken. Measured
/// (callgrind, one thread): it costs about 28k instructions per primitive more than the medium
/// one and saves 3.2% of matpreview-glass's render instructions (many rays per sample), 2.5%
/// of matpreview-copper's, 0.8% of bunny-sss's: break-even at 60, 117 and 138 samples per
/// primitive. A worse tree also costs cache misses that instructions do not show (glass's
/// render CPU rose more than its instructions), so the medium build is kept to renders well
/// below the lowest break-even: previews, where the build is most of the wait.
pub(crate) const HIGH_QUALITY_SAMPLES_PER_PRIM: u64 = 32;

/// Whether `prims` primitives serving `samples` camera samples get the slowest, best build.
fn high_quality(prims: usize, samples: u64) -> bool {
    prims < LARGE_SCENE && samples / HIGH_QUALITY_SAMPLES_PER_PRIM >= prims as u64
}

/// Builds the nodes and leaves over `geoms`, `width` children per node (8 only on CPUs with AVX2
/// and FMA, 16 only with AVX-512, which the caller checks; 4 otherwise), with the effort that
/// `samples` camera samples make worth it: the layout, the leaves, the root reference and the
/// depth of the inner nodes below the root.
pub(super) fn build(
    geoms: &[PrimGeom],
    sdf_voxels: &[SdfVoxel],
    width: usize,
    samples: u64,
) -> (Layout, Leaves, ChildRef, usize) {
    let mut leaves = Leaves::new();
    let empty_layout = || Layout::Four(Nodes4::empty());
    if geoms.is_empty() {
        return (empty_layout(), leaves, EMPTY, 0);
    }
    let aabbs: Vec<Aabb> = geoms.iter().map(PrimGeom::aabb).collect();
    // The highest-quality build pays off while it is cheap against the render's rays; past ~100k
    // primitives it costs seconds, so large scenes take the medium one. Leaves of up to four
    // primitives fill one Triangle4 block; testing four triangles costs about as much as testing
    // one, hence the high traversal cost given to the SAH leaf collapse.
    let mut params = if high_quality(geoms.len(), samples) {
        BvhBuildParams::very_slow_build()
    } else {
        BvhBuildParams::medium_build()
    };
    // Measured alternatives, no faster (renders, one thread, within ±2%): a collapse cost of 1
    // or 6, and leaves of up to eight (two blocks) with a cost of 3 or 6.
    params.max_prims_per_leaf = 4;
    params.collapse_traversal_cost = 3.0;
    // obvhs's build, with its PLOC clustering made O(n log n) on overlapping boxes (ploc.rs).
    let bvh2 = super::ploc::build_bvh2(&aabbs, params);
    let root = &bvh2.nodes[0];
    if root.is_leaf() {
        let root = leaves.add(&bvh2, root.first_index, root.prim_count, geoms, sdf_voxels);
        return (empty_layout(), leaves, root, 0);
    }
    let mut builder = WideBuilder {
        bvh2: &bvh2,
        geoms,
        sdf_voxels,
        leaves,
        depth: 0,
    };
    #[cfg(target_arch = "x86_64")]
    match width {
        8 => {
            let (nodes, root) = super::x86_64::avx2::Nodes8::build(&mut builder);
            return (Layout::Eight(nodes), builder.leaves, root, builder.depth);
        }
        16 => {
            let (nodes, root) = super::x86_64::avx512::Nodes16::build(&mut builder);
            return (Layout::Sixteen(nodes), builder.leaves, root, builder.depth);
        }
        _ => {}
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = width; // four-wide nodes only
    let (nodes, root) = Nodes4::build(&mut builder);
    (Layout::Four(nodes), builder.leaves, root, builder.depth)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The best build from 32 camera samples per primitive, below the large-scene size.
    #[test]
    fn the_best_build_serves_enough_samples_per_primitive() {
        assert!(high_quality(61_600, 61_600 * 32));
        assert!(!high_quality(61_600, 61_600 * 32 - 1));
        assert!(high_quality(12, 320 * 213));
        assert!(!high_quality(LARGE_SCENE, u64::MAX));
        assert!(high_quality(LARGE_SCENE - 1, u64::MAX));
    }
}
