//! A 4-wide BVH laid out for single-ray traversal on the CPU.
//!
//! obvhs builds a high-quality binary BVH (PLOC, reinsertion, SAH leaf collapsing); this module
//! flattens it into nodes of four children whose boxes are stored structure-of-arrays, so one
//! ray is tested against four boxes with a handful of SIMD instructions, and into leaves whose
//! triangles are precomputed [`Triangle4`] blocks. obvhs's own CPU traversal of its compressed
//! wide BVH decodes quantised GPU-oriented nodes for every visit; this layout does not.

use crate::geometry::{intersect_sphere, Ray, WatertightRay};
use crate::triangle4::{Ray4, Triangle4};
use glam::{Vec3, Vec3A, Vec4};
use obvhs::{aabb::Aabb, bvh2::Bvh2, BvhBuildParams};
use std::mem::MaybeUninit;
use std::time::Duration;

/// Geometry of one BVH primitive, in world space.
#[derive(Clone, Copy, Debug)]
pub enum PrimGeom {
    Triangle { p0: Vec3, p1: Vec3, p2: Vec3 },
    Sphere { center: Vec3, radius: f32 },
}

impl PrimGeom {
    fn aabb(&self) -> Aabb {
        match *self {
            PrimGeom::Triangle { p0, p1, p2 } => Aabb {
                min: Vec3A::from(p0.min(p1).min(p2)),
                max: Vec3A::from(p0.max(p1).max(p2)),
            },
            PrimGeom::Sphere { center, radius } => Aabb {
                min: Vec3A::from(center - Vec3::splat(radius)),
                max: Vec3A::from(center + Vec3::splat(radius)),
            },
        }
    }
}

/// The closest hit along a ray: distance, primitive index, triangle barycentrics.
#[derive(Clone, Copy, Debug)]
pub struct ClosestHit {
    pub t: f32,
    pub prim: u32,
    pub b1: f32,
    pub b2: f32,
}

/// A child reference: an inner node index, or a leaf, or `EMPTY`. A leaf of triangles only is
/// `LEAF | block count << 27 | first block` (count 1-15), so its blocks are found without a
/// further memory access; other leaves are `LEAF | leaf index` (count 0) into `leaves`.
type ChildRef = u32;
const LEAF: u32 = 1 << 31;
const LEAF_COUNT_SHIFT: u32 = 27;
const LEAF_INDEX_MASK: u32 = (1 << LEAF_COUNT_SHIFT) - 1;
const EMPTY: u32 = u32::MAX;

/// An inner node: four child boxes, structure-of-arrays. `bounds` is
/// `[min x, min y, min z, max x, max y, max z]`, lane i for child i; an empty slot has an
/// inverted box (+inf min, -inf max) that no ray enters.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Node4 {
    bounds: [Vec4; 6],
    children: [ChildRef; 4],
}

/// A leaf: a run of triangle blocks and a run of spheres.
#[derive(Clone, Copy, Debug)]
struct Leaf {
    first_block: u32,
    block_count: u32,
    first_sphere: u32,
    sphere_count: u32,
}

#[derive(Clone, Copy, Debug)]
struct SphereRef {
    center: Vec3,
    radius: f32,
    prim: u32,
}

/// Entries of the fixed traversal stack; a BVH deeper than this uses a heap stack instead.
const STACK_SIZE: usize = 128;

pub struct Bvh4 {
    nodes: Vec<Node4>,
    leaves: Vec<Leaf>,
    blocks: Vec<Triangle4>,
    spheres: Vec<SphereRef>,
    root: ChildRef,
    /// The largest stack a traversal can need: three pushes per level below the root, plus one.
    stack_needed: usize,
}

/// Per-ray constants of the box test: reciprocal direction, origin × reciprocal, and which
/// bound (min or max) is the near one on each axis.
struct BoxRay {
    inv: [Vec4; 3],
    org_inv: [Vec4; 3],
    near: [usize; 3],
    far: [usize; 3],
}

/// The bound rows (of `Node4::bounds`) a ray enters and leaves each axis' slab through, by the
/// octant of its direction (bit i set: negative along axis i, so it enters through the max bound).
const NEAR_FAR: [([usize; 3], [usize; 3]); 8] = {
    let mut table = [([0; 3], [0; 3]); 8];
    let mut octant = 0;
    while octant < 8 {
        let mut axis = 0;
        while axis < 3 {
            let negative = (octant >> axis) & 1;
            table[octant].0[axis] = axis + 3 * negative;
            table[octant].1[axis] = axis + 3 * (1 - negative);
            axis += 1;
        }
        octant += 1;
    }
    table
};

impl BoxRay {
    /// The reciprocal direction. A zero direction component would give 0 × inf = NaN on a box
    /// face through the origin; a tiny replacement keeps the slabs finite and the test
    /// conservative. (The largest component, all the watertight triangle test reads, is never
    /// replaced for a non-zero direction.)
    #[inline(always)]
    fn reciprocal(ray: &Ray) -> Vec3A {
        let d = Vec3A::from(ray.dir);
        let tiny = d.abs().cmplt(Vec3A::splat(1e-20));
        Vec3A::ONE / Vec3A::select(tiny, Vec3A::splat(1e-20).copysign(d), d)
    }

    #[inline(always)]
    fn new(ray: &Ray, inv: Vec3A) -> Self {
        let org_inv = Vec3A::from(ray.origin) * inv;
        let (near, far) = NEAR_FAR[inv.cmplt(Vec3A::ZERO).bitmask() as usize & 7];
        Self {
            inv: [Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z)],
            org_inv: [
                Vec4::splat(org_inv.x),
                Vec4::splat(org_inv.y),
                Vec4::splat(org_inv.z),
            ],
            near,
            far,
        }
    }

    /// Entry distances of the four boxes and the mask of boxes hit within (0, tmax).
    #[inline(always)]
    fn test(&self, node: &Node4, tmax: f32) -> (Vec4, u32) {
        let b = &node.bounds;
        // SAFETY: `near` and `far` hold indices below 6, set in `BoxRay::new`.
        let t = |i: usize, a: usize| unsafe { *b.get_unchecked(i) } * self.inv[a] - self.org_inv[a];
        let near = t(self.near[0], 0)
            .max(t(self.near[1], 1))
            .max(t(self.near[2], 2).max(Vec4::ZERO));
        // Rounding in the slab distances may shrink a box by an ulp or two; widening the exit
        // distance keeps rays that graze a box edge (pbrt's 1 + 2γ₃ factor, γ₃ = 3 × 2⁻²⁴).
        let far = t(self.far[0], 0)
            .min(t(self.far[1], 1))
            .min(t(self.far[2], 2));
        let far = (far * (1.0 + 3.0 * f32::EPSILON)).min(Vec4::splat(tmax));
        (near, near.cmple(far).bitmask())
    }
}

/// A ray's constants for the box and the triangle tests, sharing the reciprocal direction.
#[inline(always)]
fn ray_constants(ray: &Ray) -> (BoxRay, Ray4) {
    let inv = BoxRay::reciprocal(ray);
    let ray4 = Ray4::new(&WatertightRay::with_reciprocal(ray, inv.into()), ray.origin);
    (BoxRay::new(ray, inv), ray4)
}

/// The closest hit in (0, tmax) among the triangles of `blocks`.
#[inline(always)]
fn closest_in_blocks(
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

impl Bvh4 {
    /// Builds the BVH over `geoms`; primitive indices in hits refer to positions in `geoms`.
    pub fn build(geoms: &[PrimGeom]) -> Self {
        let mut bvh = Self {
            nodes: Vec::new(),
            leaves: Vec::new(),
            blocks: Vec::new(),
            spheres: Vec::new(),
            root: EMPTY,
            stack_needed: 1,
        };
        if geoms.is_empty() {
            return bvh;
        }
        let aabbs: Vec<Aabb> = geoms.iter().map(PrimGeom::aabb).collect();
        // The highest-quality build pays off while it is cheap; past ~100k primitives it costs
        // seconds, so large scenes take the medium one. Leaves of up to four primitives fill one
        // Triangle4 block; testing four triangles costs about as much as testing one, hence the
        // high traversal cost given to the SAH leaf collapse.
        let mut params = if geoms.len() < 100_000 {
            BvhBuildParams::very_slow_build()
        } else {
            BvhBuildParams::medium_build()
        };
        params.max_prims_per_leaf = 4;
        params.collapse_traversal_cost = 3.0;
        let bvh2 = obvhs::bvh2::builder::build_bvh2(&aabbs, params, &mut Duration::default());
        let root = &bvh2.nodes[0];
        let mut depth = 0;
        bvh.root = if root.is_leaf() {
            bvh.add_leaf(&bvh2, root.first_index, root.prim_count, geoms)
        } else {
            bvh.add_inner(&bvh2, 0, geoms, 1, &mut depth)
        };
        bvh.stack_needed = 3 * depth + 1;
        bvh
    }

    /// Converts the subtree under BVH2 inner node `index` into Node4s; returns its reference.
    fn add_inner(
        &mut self,
        bvh2: &Bvh2,
        index: usize,
        geoms: &[PrimGeom],
        level: usize,
        depth: &mut usize,
    ) -> ChildRef {
        *depth = (*depth).max(level);
        // Open the child with the largest surface area until there are four (or only leaves).
        let first = bvh2.nodes[index].first_index as usize;
        let mut children = vec![first, first + 1];
        while children.len() < 4 {
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
        let node_index = self.nodes.len();
        let mut bounds = [[f32::INFINITY; 4], [f32::INFINITY; 4], [f32::INFINITY; 4]]
            .into_iter()
            .chain([[f32::NEG_INFINITY; 4]; 3])
            .collect::<Vec<_>>();
        for (lane, &c) in children.iter().enumerate() {
            let aabb = bvh2.nodes[c].aabb();
            for axis in 0..3 {
                bounds[axis][lane] = aabb.min[axis];
                bounds[axis + 3][lane] = aabb.max[axis];
            }
        }
        self.nodes.push(Node4 {
            bounds: std::array::from_fn(|i| Vec4::from_array(bounds[i])),
            children: [EMPTY; 4],
        });
        for (lane, &c) in children.iter().enumerate() {
            let node = &bvh2.nodes[c];
            let child = if node.is_leaf() {
                self.add_leaf(bvh2, node.first_index, node.prim_count, geoms)
            } else {
                self.add_inner(bvh2, c, geoms, level + 1, depth)
            };
            self.nodes[node_index].children[lane] = child;
        }
        node_index as ChildRef
    }

    fn add_leaf(&mut self, bvh2: &Bvh2, first: u32, count: u32, geoms: &[PrimGeom]) -> ChildRef {
        let prims = &bvh2.primitive_indices[first as usize..(first + count) as usize];
        let mut tris = Vec::new();
        let first_sphere = self.spheres.len() as u32;
        for &prim in prims {
            match geoms[prim as usize] {
                PrimGeom::Triangle { p0, p1, p2 } => tris.push((p0, p1, p2, prim)),
                PrimGeom::Sphere { center, radius } => self.spheres.push(SphereRef {
                    center,
                    radius,
                    prim,
                }),
            }
        }
        let first_block = self.blocks.len() as u32;
        self.blocks.extend(tris.chunks(4).map(Triangle4::new));
        let block_count = self.blocks.len() as u32 - first_block;
        let sphere_count = self.spheres.len() as u32 - first_sphere;
        if sphere_count == 0 && (1..16).contains(&block_count) && first_block <= LEAF_INDEX_MASK {
            return LEAF | block_count << LEAF_COUNT_SHIFT | first_block;
        }
        self.leaves.push(Leaf {
            first_block,
            block_count: self.blocks.len() as u32 - first_block,
            first_sphere,
            sphere_count: self.spheres.len() as u32 - first_sphere,
        });
        LEAF | (self.leaves.len() as u32 - 1)
    }

    /// Inner node `r`.
    #[inline(always)]
    fn node(&self, r: ChildRef) -> &Node4 {
        debug_assert!((r as usize) < self.nodes.len());
        // SAFETY: inner references are indices into `nodes`, written by `add_inner` only.
        unsafe { self.nodes.get_unchecked(r as usize) }
    }

    /// The triangle blocks of leaf `r` when its reference carries them (a leaf of triangles
    /// only); None for a leaf stored in `leaves`.
    #[inline(always)]
    fn packed_blocks(&self, r: ChildRef) -> Option<&[Triangle4]> {
        let first = (r & LEAF_INDEX_MASK) as usize;
        let count = ((r & !LEAF) >> LEAF_COUNT_SHIFT) as usize;
        if count == 0 {
            return None;
        }
        debug_assert!(first + count <= self.blocks.len());
        // SAFETY: `add_leaf` packs only block ranges that it has just pushed to `blocks`.
        Some(unsafe { self.blocks.get_unchecked(first..first + count) })
    }

    /// Closest hit in (0, tmax) among the triangles and spheres of leaf `r` of `leaves`. Kept
    /// out of line: leaves with spheres are rare, and inlining the sphere test into the
    /// traversal loops costs every ray registers and set-up.
    #[inline(never)]
    fn intersect_leaf(&self, r: ChildRef, ray: &Ray, ray4: &Ray4, tmax: f32) -> Option<ClosestHit> {
        let leaf = &self.leaves[(r & LEAF_INDEX_MASK) as usize];
        let blocks = leaf.first_block as usize..(leaf.first_block + leaf.block_count) as usize;
        let spheres = leaf.first_sphere as usize..(leaf.first_sphere + leaf.sphere_count) as usize;
        let mut best = closest_in_blocks(&self.blocks[blocks], ray4, ray, tmax);
        let mut tmax = best.map_or(tmax, |h| h.t);
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
        best
    }

    /// Closest hit with t in (0, ray.tmax).
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<ClosestHit> {
        if self.root == EMPTY {
            return None;
        }
        if self.stack_needed <= STACK_SIZE {
            // Uninitialised: zeroing 1 KiB per ray showed up in profiles as 3% memset.
            self.intersect_with(ray, &mut [const { MaybeUninit::uninit() }; STACK_SIZE])
        } else {
            self.intersect_deep(ray)
        }
    }

    /// [`Bvh4::intersect`] for trees too deep for the fixed stack (never seen in practice).
    #[cold]
    #[inline(never)]
    fn intersect_deep(&self, ray: &Ray) -> Option<ClosestHit> {
        self.intersect_with(ray, &mut vec![MaybeUninit::uninit(); self.stack_needed])
    }

    #[cold]
    #[inline(never)]
    fn occluded_deep(&self, ray: &Ray) -> bool {
        self.occluded_with(ray, &mut vec![MaybeUninit::uninit(); self.stack_needed])
    }

    /// True when anything lies along the ray with t in (0, ray.tmax); stops at the first hit.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        if self.root == EMPTY {
            return false;
        }
        if self.stack_needed <= STACK_SIZE {
            self.occluded_with(ray, &mut [const { MaybeUninit::uninit() }; STACK_SIZE])
        } else {
            self.occluded_deep(ray)
        }
    }

    #[inline(always)]
    fn intersect_with(
        &self,
        ray: &Ray,
        stack: &mut [MaybeUninit<(ChildRef, f32)>],
    ) -> Option<ClosestHit> {
        let (box_ray, ray4) = ray_constants(ray);
        let mut tmax = ray.tmax;
        let mut best: Option<ClosestHit> = None;
        let mut top = 0usize;
        let mut current = self.root;
        loop {
            if current & LEAF == 0 {
                let node = self.node(current);
                let (near, mut mask) = box_ray.test(node, tmax);
                if mask != 0 {
                    let near = near.to_array();
                    let first = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    if mask == 0 {
                        current = node.children[first];
                        continue;
                    }
                    let second = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    if mask == 0 {
                        // Two children, the common case: visit the nearer, push the farther.
                        let (near_lane, far_lane) = if near[second] < near[first] {
                            (second, first)
                        } else {
                            (first, second)
                        };
                        stack[top] = MaybeUninit::new((node.children[far_lane], near[far_lane]));
                        top += 1;
                        current = node.children[near_lane];
                        continue;
                    }
                    // Three or four children: push them all sorted far to near (insertion into the
                    // top of the stack), then continue with the nearest.
                    let base = top;
                    mask |= 1 << second;
                    let mut lane = first;
                    loop {
                        let entry = (node.children[lane], near[lane]);
                        let mut i = top;
                        // SAFETY (all reads below): entries below `top` have been written.
                        while i > base && unsafe { stack[i - 1].assume_init() }.1 < entry.1 {
                            stack[i] = stack[i - 1];
                            i -= 1;
                        }
                        stack[i] = MaybeUninit::new(entry);
                        top += 1;
                        if mask == 0 {
                            break;
                        }
                        lane = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                    }
                    top -= 1;
                    current = unsafe { stack[top].assume_init() }.0;
                    continue;
                }
            } else if let Some(hit) = match self.packed_blocks(current) {
                Some(blocks) => closest_in_blocks(blocks, &ray4, ray, tmax),
                None => self.intersect_leaf(current, ray, &ray4, tmax),
            } {
                tmax = hit.t;
                best = Some(hit);
            }
            // Pop the nearest pending node that can still hold a closer hit.
            loop {
                if top == 0 {
                    return best;
                }
                top -= 1;
                let (node, near) = unsafe { stack[top].assume_init() };
                if near <= tmax {
                    current = node;
                    break;
                }
            }
        }
    }

    #[inline(always)]
    fn occluded_with(&self, ray: &Ray, stack: &mut [MaybeUninit<ChildRef>]) -> bool {
        let (box_ray, ray4) = ray_constants(ray);
        let tmax = ray.tmax;
        let mut top = 0usize;
        let mut current = self.root;
        loop {
            if current & LEAF == 0 {
                let node = self.node(current);
                let (_, mut mask) = box_ray.test(node, tmax);
                // Any hit ends the search, so order does not matter: push all but one.
                while mask != 0 {
                    let lane = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    stack[top] = MaybeUninit::new(node.children[lane]);
                    top += 1;
                }
            } else if let Some(blocks) = self.packed_blocks(current) {
                for block in blocks {
                    if block.occludes(&ray4, ray, tmax) {
                        return true;
                    }
                }
            } else if self.intersect_leaf(current, ray, &ray4, tmax).is_some() {
                return true;
            }
            if top == 0 {
                return false;
            }
            top -= 1;
            current = unsafe { stack[top].assume_init() };
        }
    }
}
