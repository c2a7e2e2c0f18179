//! Wide BVHs laid out for single-ray traversal on the CPU.
//!
//! obvhs builds a high-quality binary BVH (PLOC, reinsertion, SAH leaf collapsing); this module
//! flattens it into nodes of four or eight children whose boxes are stored structure-of-arrays,
//! so one ray is tested against all of a node's boxes with a handful of SIMD instructions, and
//! into leaves whose triangles are precomputed [`Triangle4`] blocks. Eight-wide nodes (AVX2 and
//! FMA, [`crate::bvh8`]) are used when the CPU has both: two thirds of the levels, each one
//! 8-wide test, which measured 11-28% more rays per second than four-wide nodes on the project's
//! scenes (`cargo bench --bench traversal`). Four-wide nodes (SSE, every x86-64 CPU and other
//! targets through glam) are the fallback. obvhs's own CPU traversal
//! of its compressed wide BVH decodes quantised GPU-oriented nodes for every visit; this layout
//! does not.

use crate::geometry::{intersect_sphere, Ray, WatertightRay};
use crate::triangle4::{Ray4, Triangle4};
use glam::{Vec3A, Vec4};
use obvhs::{aabb::Aabb, bvh2::Bvh2, BvhBuildParams};
use std::mem::MaybeUninit;
use std::time::Duration;

/// Geometry of one BVH primitive, in world space.
#[derive(Clone, Copy, Debug)]
pub enum PrimGeom {
    Triangle { p0: Vec3A, p1: Vec3A, p2: Vec3A },
    Sphere { center: Vec3A, radius: f32 },
}

impl PrimGeom {
    fn aabb(&self) -> Aabb {
        match *self {
            PrimGeom::Triangle { p0, p1, p2 } => Aabb {
                min: p0.min(p1).min(p2),
                max: p0.max(p1).max(p2),
            },
            PrimGeom::Sphere { center, radius } => Aabb {
                min: center - Vec3A::splat(radius),
                max: center + Vec3A::splat(radius),
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
pub(crate) type ChildRef = u32;
pub(crate) const LEAF: u32 = 1 << 31;
const LEAF_COUNT_SHIFT: u32 = 27;
const LEAF_INDEX_MASK: u32 = (1 << LEAF_COUNT_SHIFT) - 1;
pub(crate) const EMPTY: u32 = u32::MAX;

/// A four-wide inner node: four child boxes, structure-of-arrays. `bounds` is
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
    center: Vec3A,
    radius: f32,
    prim: u32,
}

/// Entries of the fixed traversal stack; a BVH deeper than this uses a heap stack instead.
const STACK_SIZE: usize = 128;

/// The inner nodes of a BVH as a traversal sees them: for one ray, the entry distances of a
/// node's children and which of them the ray enters. Implemented by the four-wide SSE layout
/// ([`Nodes4`]) and the eight-wide AVX2 layout ([`crate::bvh8::Nodes8`]); the traversal loops
/// are written once, generic over it.
pub(crate) trait InnerNodes {
    /// Per-ray constants of the box test.
    type RayConsts;
    fn ray_consts(ray: &Ray, inv: Vec3A) -> Self::RayConsts;
    /// Entry distances of node `r`'s children (the first 4 or 8 lanes) and the mask of children
    /// the ray enters within (0, tmax).
    fn test(&self, r: ChildRef, c: &Self::RayConsts, tmax: f32) -> ([f32; 8], u32);
    /// The child references of inner node `r`.
    fn children(&self, r: ChildRef) -> &[ChildRef];

    /// Child `lane` of inner node `r`; `lane` is a bit of a mask from [`InnerNodes::test`].
    #[inline(always)]
    fn child(&self, r: ChildRef, lane: usize) -> ChildRef {
        let children = self.children(r);
        debug_assert!(lane < children.len());
        // SAFETY: test masks have bits only for lanes below the node width.
        unsafe { *children.get_unchecked(lane) }
    }
}

/// Four-wide nodes.
pub(crate) struct Nodes4(Vec<Node4>);

impl Nodes4 {
    /// Converts the BVH2 of `builder` below its root; returns the nodes and the root reference.
    fn build(builder: &mut WideBuilder) -> (Self, ChildRef) {
        let mut nodes = Vec::new();
        let root = builder.add_inner::<4, Node4>(
            &mut nodes,
            0,
            1,
            &|rows| Node4 {
                bounds: rows.map(Vec4::from_array),
                children: [EMPTY; 4],
            },
            &|node, lane, child| node.children[lane] = child,
        );
        (Self(nodes), root)
    }
}

impl InnerNodes for Nodes4 {
    type RayConsts = BoxRay;

    #[inline(always)]
    fn ray_consts(ray: &Ray, inv: Vec3A) -> BoxRay {
        BoxRay::new(ray, inv)
    }

    #[inline(always)]
    fn test(&self, r: ChildRef, c: &BoxRay, tmax: f32) -> ([f32; 8], u32) {
        debug_assert!((r as usize) < self.0.len());
        // SAFETY: inner references are indices into the nodes, written by the build only.
        let node = unsafe { self.0.get_unchecked(r as usize) };
        let (near, mask) = c.test(node, tmax);
        let mut nears = [0.0; 8];
        nears[..4].copy_from_slice(&near.to_array());
        (nears, mask)
    }

    #[inline(always)]
    fn children(&self, r: ChildRef) -> &[ChildRef] {
        // SAFETY: as in `test`.
        unsafe { &self.0.get_unchecked(r as usize).children }
    }
}

/// The node layout a BVH was built with.
enum Layout {
    Four(Nodes4),
    #[cfg(target_arch = "x86_64")]
    Eight(crate::bvh8::Nodes8),
}

impl Layout {
    /// [`closest_hit`] on this layout's nodes.
    #[inline(always)]
    fn closest_hit(
        &self,
        leaves: &Leaves,
        root: ChildRef,
        ray: &Ray,
        stack: &mut [MaybeUninit<(ChildRef, f32)>],
    ) -> Option<ClosestHit> {
        match self {
            Layout::Four(nodes) => closest_hit(nodes, leaves, root, ray, stack),
            #[cfg(target_arch = "x86_64")]
            Layout::Eight(nodes) => nodes.closest_hit(leaves, root, ray, stack),
        }
    }

    /// [`any_hit`] on this layout's nodes.
    #[inline(always)]
    fn any_hit(
        &self,
        leaves: &Leaves,
        root: ChildRef,
        ray: &Ray,
        stack: &mut [MaybeUninit<(ChildRef, f32)>],
    ) -> bool {
        match self {
            Layout::Four(nodes) => any_hit(nodes, leaves, root, ray, stack),
            #[cfg(target_arch = "x86_64")]
            Layout::Eight(nodes) => nodes.any_hit(leaves, root, ray, stack),
        }
    }

    /// Children per inner node.
    fn width(&self) -> usize {
        match self {
            Layout::Four(_) => 4,
            #[cfg(target_arch = "x86_64")]
            Layout::Eight(_) => 8,
        }
    }
}

pub struct Bvh {
    layout: Layout,
    leaves: Leaves,
    root: ChildRef,
    /// The largest stack a traversal can need: width - 1 pushes per level below the root,
    /// plus one.
    stack_needed: usize,
}

/// Per-ray constants of the four-wide box test: reciprocal direction, origin × reciprocal, and
/// which bound (min or max) is the near one on each axis.
pub(crate) struct BoxRay {
    inv: [Vec4; 3],
    org_inv: [Vec4; 3],
    near: [usize; 3],
    far: [usize; 3],
}

/// The bound rows (of a node's `bounds`) a ray enters and leaves each axis' slab through, by the
/// octant of its direction (bit i set: negative along axis i, so it enters through the max bound).
pub(crate) const NEAR_FAR: [([usize; 3], [usize; 3]); 8] = {
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

/// Rounding in the slab distances may shrink a box by an ulp or two; widening the exit distance
/// by this factor keeps rays that graze a box edge (pbrt's 1 + 2γ₃ factor, γ₃ = 3 × 2⁻²⁴).
pub(crate) const EXIT_WIDENING: f32 = 1.0 + 3.0 * f32::EPSILON;

/// The reciprocal direction. A zero direction component would give 0 × inf = NaN on a box face
/// through the origin; a tiny replacement keeps the slabs finite and the test conservative. (The
/// largest component, all the watertight triangle test reads, is never replaced for a non-zero
/// direction.)
#[inline(always)]
pub(crate) fn reciprocal(ray: &Ray) -> Vec3A {
    let d = ray.dir;
    let tiny = d.abs().cmplt(Vec3A::splat(1e-20));
    Vec3A::ONE / Vec3A::select(tiny, Vec3A::splat(1e-20).copysign(d), d)
}

/// The slab test's per-ray values, whatever the node width: origin × reciprocal direction,
/// and the near and far bound rows of the ray's octant (from [`NEAR_FAR`]).
#[inline(always)]
pub(crate) fn slab_setup(ray: &Ray, inv: Vec3A) -> (Vec3A, [usize; 3], [usize; 3]) {
    let (near, far) = NEAR_FAR[inv.cmplt(Vec3A::ZERO).bitmask() as usize & 7];
    (ray.origin * inv, near, far)
}

impl BoxRay {
    #[inline(always)]
    fn new(ray: &Ray, inv: Vec3A) -> Self {
        let (org_inv, near, far) = slab_setup(ray, inv);
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
        let far = t(self.far[0], 0)
            .min(t(self.far[1], 1))
            .min(t(self.far[2], 2));
        let far = (far * EXIT_WIDENING).min(Vec4::splat(tmax));
        (near, near.cmple(far).bitmask())
    }
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

/// The leaves of a BVH, whatever its node width: triangle blocks, spheres, and the records of
/// leaves that hold spheres.
pub(crate) struct Leaves {
    leaves: Vec<Leaf>,
    blocks: Vec<Triangle4>,
    spheres: Vec<SphereRef>,
}

impl Leaves {
    fn add(&mut self, bvh2: &Bvh2, first: u32, count: u32, geoms: &[PrimGeom]) -> ChildRef {
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

    /// Closest hit in (0, tmax) among the triangles and spheres of leaf `r` of `leaves`. Kept
    /// out of line: leaves with spheres are rare, and inlining the sphere test into the
    /// traversal loops costs every ray registers and set-up.
    #[inline(never)]
    pub(crate) fn intersect_general(
        &self,
        r: ChildRef,
        ray: &Ray,
        ray4: &Ray4,
        tmax: f32,
    ) -> Option<ClosestHit> {
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
    leaves: Leaves,
    depth: usize,
}

impl WideBuilder<'_> {
    /// Converts the subtree under BVH2 inner node `index` into `W`-wide nodes appended to
    /// `nodes`: `make` creates a node from its bounds rows, `set_child` fills in its children
    /// once they are built. Returns the subtree's reference.
    pub(crate) fn add_inner<const W: usize, N>(
        &mut self,
        nodes: &mut Vec<N>,
        index: usize,
        level: usize,
        make: &impl Fn([[f32; W]; 6]) -> N,
        set_child: &impl Fn(&mut N, usize, ChildRef),
    ) -> ChildRef {
        self.depth = self.depth.max(level);
        let children = wide_children(self.bvh2, index, W);
        let node_index = nodes.len();
        nodes.push(make(wide_bounds::<W>(self.bvh2, &children)));
        for (lane, &c) in children.iter().enumerate() {
            let node = &self.bvh2.nodes[c];
            let child = if node.is_leaf() {
                self.leaves
                    .add(self.bvh2, node.first_index, node.prim_count, self.geoms)
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
const LARGE_SCENE: usize = 100_000;

/// Which node width to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BvhWidth {
    /// Eight when the CPU has AVX2 and FMA, else four.
    Auto,
    Four,
    /// Eight-wide nodes; falls back to four on a CPU without AVX2 and FMA.
    Eight,
}

impl Bvh {
    /// Builds the BVH over `geoms`; primitive indices in hits refer to positions in `geoms`.
    pub fn build(geoms: &[PrimGeom], width: BvhWidth) -> Self {
        let mut leaves = Leaves {
            leaves: Vec::new(),
            blocks: Vec::new(),
            spheres: Vec::new(),
        };
        #[cfg(not(target_arch = "x86_64"))]
        let _ = width; // four-wide nodes only
        #[cfg(target_arch = "x86_64")]
        let eight = crate::bvh8::available() && width != BvhWidth::Four;
        let empty_layout = || Layout::Four(Nodes4(Vec::new()));
        if geoms.is_empty() {
            return Self {
                layout: empty_layout(),
                leaves,
                root: EMPTY,
                stack_needed: 1,
            };
        }
        let aabbs: Vec<Aabb> = geoms.iter().map(PrimGeom::aabb).collect();
        // The highest-quality build pays off while it is cheap; past ~100k primitives it costs
        // seconds, so large scenes take the medium one. Leaves of up to four primitives fill one
        // Triangle4 block; testing four triangles costs about as much as testing one, hence the
        // high traversal cost given to the SAH leaf collapse.
        let mut params = if geoms.len() < LARGE_SCENE {
            BvhBuildParams::very_slow_build()
        } else {
            BvhBuildParams::medium_build()
        };
        params.max_prims_per_leaf = 4;
        params.collapse_traversal_cost = 3.0;
        let bvh2 = obvhs::bvh2::builder::build_bvh2(&aabbs, params, &mut Duration::default());
        let root = &bvh2.nodes[0];
        if root.is_leaf() {
            let root = leaves.add(&bvh2, root.first_index, root.prim_count, geoms);
            return Self {
                layout: empty_layout(),
                leaves,
                root,
                stack_needed: 1,
            };
        }
        let mut builder = WideBuilder {
            bvh2: &bvh2,
            geoms,
            leaves,
            depth: 0,
        };
        let four = |builder: &mut WideBuilder| {
            let (nodes, root) = Nodes4::build(builder);
            (Layout::Four(nodes), root)
        };
        #[cfg(target_arch = "x86_64")]
        let (layout, root) = if eight {
            let (nodes, root) = crate::bvh8::Nodes8::build(&mut builder);
            (Layout::Eight(nodes), root)
        } else {
            four(&mut builder)
        };
        #[cfg(not(target_arch = "x86_64"))]
        let (layout, root) = four(&mut builder);
        Self {
            // A node pushes at most all but one of its children, at each level below the root.
            stack_needed: (layout.width() - 1) * builder.depth + 1,
            layout,
            root,
            leaves: builder.leaves,
        }
    }

    /// Children per inner node (4 or 8).
    pub fn width(&self) -> usize {
        self.layout.width()
    }

    /// Closest hit with t in (0, ray.tmax).
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<ClosestHit> {
        if self.root == EMPTY {
            return None;
        }
        if self.stack_needed > STACK_SIZE {
            return self.intersect_deep(ray);
        }
        // Uninitialised: zeroing 1 KiB per ray showed up in profiles as 3% memset.
        let stack = &mut [const { MaybeUninit::uninit() }; STACK_SIZE];
        self.layout.closest_hit(&self.leaves, self.root, ray, stack)
    }

    /// True when anything lies along the ray with t in (0, ray.tmax); stops at the first hit.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        if self.root == EMPTY {
            return false;
        }
        if self.stack_needed > STACK_SIZE {
            return self.occluded_deep(ray);
        }
        let stack = &mut [const { MaybeUninit::uninit() }; STACK_SIZE];
        self.layout.any_hit(&self.leaves, self.root, ray, stack)
    }

    /// Closest hits of rays from one origin ([`crate::packet`]), or None when they are not traced
    /// as a packet (four-wide nodes, directions in different octants, a very deep tree): the
    /// caller then traces them one by one.
    #[inline]
    pub fn intersect_packet(
        &self,
        origin: Vec3A,
        dirs: &[Vec3A; crate::packet::PACKET],
    ) -> Option<[Option<ClosestHit>; crate::packet::PACKET]> {
        match &self.layout {
            // Eight-wide nodes are only built under an inner root (never for an empty scene).
            #[cfg(target_arch = "x86_64")]
            Layout::Eight(nodes) => {
                // SAFETY: `Nodes8` exists only on CPUs with AVX2 and FMA.
                unsafe {
                    crate::packet::closest_hits(
                        nodes,
                        &self.leaves,
                        self.root,
                        self.stack_needed,
                        origin,
                        dirs,
                    )
                }
            }
            _ => None,
        }
    }

    /// [`Bvh::intersect`] for trees too deep for the fixed stack (never seen in practice).
    #[cold]
    #[inline(never)]
    fn intersect_deep(&self, ray: &Ray) -> Option<ClosestHit> {
        let stack = &mut vec![MaybeUninit::uninit(); self.stack_needed];
        self.layout.closest_hit(&self.leaves, self.root, ray, stack)
    }

    #[cold]
    #[inline(never)]
    fn occluded_deep(&self, ray: &Ray) -> bool {
        let stack = &mut vec![MaybeUninit::uninit(); self.stack_needed];
        self.layout.any_hit(&self.leaves, self.root, ray, stack)
    }
}

/// A ray's constants for the box and the triangle tests, sharing the reciprocal direction.
#[inline(always)]
fn ray_constants<N: InnerNodes>(ray: &Ray) -> (N::RayConsts, Ray4) {
    let inv = reciprocal(ray);
    let ray4 = Ray4::new(&WatertightRay::with_reciprocal(ray, inv), ray.origin);
    (N::ray_consts(ray, inv), ray4)
}

/// Closest-hit traversal: nearest child first, farther ones on the stack with their entry
/// distance, popped only while they can still hold a closer hit. `stack` must hold
/// [`Bvh::stack_needed`] entries.
#[inline(always)]
pub(crate) fn closest_hit<N: InnerNodes>(
    nodes: &N,
    leaves: &Leaves,
    root: ChildRef,
    ray: &Ray,
    stack: &mut [MaybeUninit<(ChildRef, f32)>],
) -> Option<ClosestHit> {
    let (box_ray, ray4) = ray_constants::<N>(ray);
    let mut best: Option<ClosestHit> = None;
    nearest_first(
        nodes,
        root,
        ray.tmax,
        stack,
        |node, tmax| nodes.test(node, &box_ray, tmax),
        |leaf, tmax| {
            let hit = match leaves.packed_blocks(leaf) {
                Some(blocks) => closest_in_blocks(blocks, &ray4, ray, tmax),
                None => leaves.intersect_general(leaf, ray, &ray4, tmax),
            };
            match hit {
                Some(hit) => {
                    best = Some(hit);
                    hit.t
                }
                None => tmax,
            }
        },
    );
    best
}

/// The loop of a closest-hit traversal, for one ray or a packet: `test` gives an inner node's
/// children's entry distances and the mask of those entered before `tmax`; `leaf` tests a leaf's
/// primitives and returns the new `tmax` (the distance beyond which nothing is looked at).
/// Visits the nearest entered child first and stacks the others far to near.
#[inline(always)]
pub(crate) fn nearest_first<N: InnerNodes>(
    nodes: &N,
    root: ChildRef,
    tmax: f32,
    stack: &mut [MaybeUninit<(ChildRef, f32)>],
    mut test: impl FnMut(ChildRef, f32) -> ([f32; 8], u32),
    mut leaf: impl FnMut(ChildRef, f32) -> f32,
) {
    let mut tmax = tmax;
    let mut top = 0usize;
    let mut current = root;
    loop {
        if current & LEAF == 0 {
            let (near, mut mask) = test(current, tmax);
            if mask != 0 {
                let first = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if mask == 0 {
                    current = nodes.child(current, first);
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
                    stack[top] = MaybeUninit::new((nodes.child(current, far_lane), near[far_lane]));
                    top += 1;
                    current = nodes.child(current, near_lane);
                    continue;
                }
                // Three or more children: push them all sorted far to near (insertion into the
                // top of the stack), then continue with the nearest.
                let base = top;
                mask |= 1 << second;
                let mut lane = first;
                loop {
                    let entry = (nodes.child(current, lane), near[lane]);
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
        } else {
            tmax = leaf(current, tmax);
        }
        // Pop the nearest pending node that can still hold a closer hit.
        loop {
            if top == 0 {
                return;
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

/// Any-hit traversal: children in no particular order, done at the first blocker. `stack` must
/// hold [`Bvh::stack_needed`] entries.
#[inline(always)]
pub(crate) fn any_hit<N: InnerNodes>(
    nodes: &N,
    leaves: &Leaves,
    root: ChildRef,
    ray: &Ray,
    stack: &mut [MaybeUninit<(ChildRef, f32)>],
) -> bool {
    let (box_ray, ray4) = ray_constants::<N>(ray);
    let tmax = ray.tmax;
    let mut top = 0usize;
    let mut current = root;
    loop {
        if current & LEAF == 0 {
            let (_, mut mask) = nodes.test(current, &box_ray, tmax);
            // Any hit ends the search, so order does not matter: push them all.
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                stack[top] = MaybeUninit::new((nodes.child(current, lane), 0.0));
                top += 1;
            }
        } else if let Some(blocks) = leaves.packed_blocks(current) {
            for block in blocks {
                if block.occludes(&ray4, ray, tmax) {
                    return true;
                }
            }
        } else if leaves
            .intersect_general(current, ray, &ray4, tmax)
            .is_some()
        {
            return true;
        }
        if top == 0 {
            return false;
        }
        top -= 1;
        current = unsafe { stack[top].assume_init() }.0;
    }
}
