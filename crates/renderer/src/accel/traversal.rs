//! The traversal loops, written once for every node layout: closest hit (nearest child first,
//! farther ones stacked with their entry distance) and any hit (first blocker ends the search).
//! A layout provides the box test of one node ([`InnerNodes`]); the loops are instantiated inside
//! functions compiled for that layout's instruction set.

use super::leaves::{closest_in_blocks, Leaves};
use super::triangle4::Ray4;
use super::ClosestHit;
use crate::ray::Ray;
use glam::Vec3A;
use std::mem::MaybeUninit;

/// A child reference: an inner node index, or a leaf, or `EMPTY` (only ever the root of an
/// empty scene: unused node lanes point at an empty leaf, see [`super::leaves::Leaves`]). A leaf
/// of triangles only is `LEAF | block count << 27 | first block` (count 1-15), so its blocks are
/// found without a further memory access; other leaves are `LEAF | leaf index` (count 0) into the
/// leaf records.
pub(crate) type ChildRef = u32;
pub(crate) const LEAF: u32 = 1 << 31;
pub(crate) const LEAF_COUNT_SHIFT: u32 = 27;
pub(crate) const LEAF_INDEX_MASK: u32 = (1 << LEAF_COUNT_SHIFT) - 1;
pub(crate) const EMPTY: u32 = u32::MAX;

/// Entries of the fixed traversal stack (2 KiB, left uninitialised); a BVH deeper than this
/// needs uses a heap stack instead. A closest-hit traversal pushes at most width - 1 entries
/// per level: 256 entries cover eight-wide trees 36 levels deep and sixteen-wide ones 17 deep.
pub(crate) const STACK_SIZE: usize = 256;

/// The inner nodes of a BVH as a traversal sees them: for one ray, the entry distances of a
/// node's children and which of them the ray enters. Implemented by each node layout (four-wide
/// [`super::nodes4::Nodes4`], eight-wide AVX2 [`super::x86_64::avx2::Nodes8`]); the traversal
/// loops are written once, generic over it, whatever the width.
pub(crate) trait InnerNodes {
    /// Children per node.
    const WIDTH: usize;
    /// Per-ray constants of the box test.
    type RayConsts;
    /// The entry distances of a node's children, one per lane.
    type Distances: Copy + std::ops::Index<usize, Output = f32>;
    fn ray_consts(ray: &Ray, inv: Vec3A) -> Self::RayConsts;
    /// Entry distances of node `r`'s children and the mask of children the ray enters within
    /// (0, tmax). The mask has bits only below [`InnerNodes::WIDTH`].
    fn test(&self, r: ChildRef, c: &Self::RayConsts, tmax: f32) -> (Self::Distances, u32);
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

/// [`NEAR_FAR`] as byte offsets into a node's `bounds` whose rows are `row_bytes` long: what a
/// wide node test adds to the node's address, without scaling row indices in every query's
/// set-up.
pub(crate) const fn near_far_offsets(row_bytes: usize) -> [([u32; 3], [u32; 3]); 8] {
    let mut table = [([0; 3], [0; 3]); 8];
    let mut octant = 0;
    while octant < 8 {
        let mut axis = 0;
        while axis < 3 {
            table[octant].0[axis] = (NEAR_FAR[octant].0[axis] * row_bytes) as u32;
            table[octant].1[axis] = (NEAR_FAR[octant].1[axis] * row_bytes) as u32;
            axis += 1;
        }
        octant += 1;
    }
    table
}

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

/// [`slab_setup`] with the near and far rows as byte offsets from `table` (a
/// [`near_far_offsets`] table).
#[inline(always)]
pub(crate) fn slab_setup_offsets(
    ray: &Ray,
    inv: Vec3A,
    table: &[([u32; 3], [u32; 3]); 8],
) -> (Vec3A, [u32; 3], [u32; 3]) {
    let (near, far) = table[inv.cmplt(Vec3A::ZERO).bitmask() as usize & 7];
    (ray.origin * inv, near, far)
}

/// A ray's constants for the box and the triangle tests, sharing the reciprocal direction.
#[inline(always)]
fn ray_constants<N: InnerNodes>(ray: &Ray) -> (N::RayConsts, Ray4) {
    let inv = reciprocal(ray);
    let ray4 = Ray4::for_ray(ray, inv);
    (N::ray_consts(ray, inv), ray4)
}

/// Closest-hit traversal: nearest child first, farther ones on the stack with their entry
/// distance, popped only while they can still hold a closer hit.
///
/// # Safety
/// `stack` must hold the tree's [`super::Accel`] `stack_needed` entries (see [`push`]).
#[inline(always)]
pub(crate) unsafe fn closest_hit<N: InnerNodes>(
    nodes: &N,
    leaves: &Leaves,
    root: ChildRef,
    ray: &Ray,
    stack: &mut [MaybeUninit<(ChildRef, f32)>],
) -> Option<ClosestHit> {
    let (box_ray, ray4) = ray_constants::<N>(ray);
    let mut best: Option<ClosestHit> = None;
    // SAFETY: the caller's stack holds `stack_needed` entries.
    unsafe {
        nearest_first(
            nodes,
            root,
            ray.tmax,
            stack,
            |node, tmax| nodes.test(node, &box_ray, tmax),
            |leaf, tmax| {
                let hit = match leaves.packed_blocks(leaf) {
                    Some(blocks) => closest_in_blocks(blocks, &ray4, ray, tmax),
                    None => leaves.intersect_general(leaf, ray, tmax),
                };
                match hit {
                    Some(hit) => {
                        best = Some(hit);
                        hit.t
                    }
                    None => tmax,
                }
            },
        )
    };
    best
}

/// Writes entry `i` of a traversal stack, without a bounds check: the traversals' pushes are on
/// every query's path.
///
/// # Safety
/// `i < stack.len()`. The traversals guarantee it for stacks of `stack_needed` entries,
/// (width − 1) × depth + 1: below each inner node on the current path at most width − 1 of its
/// children wait on the stack, and the deepest one pushes at most width before it pops one.
/// NaN rays, which enter every box, stay within that bound too.
#[inline(always)]
unsafe fn push(stack: &mut [MaybeUninit<(ChildRef, f32)>], i: usize, entry: (ChildRef, f32)) {
    debug_assert!(i < stack.len());
    // SAFETY: `i` is in bounds (the caller's contract).
    unsafe { *stack.get_unchecked_mut(i) = MaybeUninit::new(entry) }
}

/// Reads entry `i` of a traversal stack, without a bounds check.
///
/// # Safety
/// Entry `i` has been written by [`push`] (so `i < stack.len()`).
#[inline(always)]
unsafe fn entry(stack: &[MaybeUninit<(ChildRef, f32)>], i: usize) -> (ChildRef, f32) {
    debug_assert!(i < stack.len());
    // SAFETY: the entry is in bounds and initialised (the caller's contract).
    unsafe { stack.get_unchecked(i).assume_init() }
}

/// The loop of a closest-hit traversal, for one ray or a packet: `test` gives an inner node's
/// children's entry distances and the mask of those entered before `tmax`; `leaf` tests a leaf's
/// primitives and returns the new `tmax` (the distance beyond which nothing is looked at).
/// Visits the nearest entered child first and stacks the others far to near.
///
/// # Safety
/// `stack` must hold the tree's `stack_needed` entries (see [`push`]).
#[inline(always)]
pub(crate) unsafe fn nearest_first<N: InnerNodes>(
    nodes: &N,
    root: ChildRef,
    tmax: f32,
    stack: &mut [MaybeUninit<(ChildRef, f32)>],
    mut test: impl FnMut(ChildRef, f32) -> (N::Distances, u32),
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
                    // SAFETY: (all stack accesses below) within `stack_needed` (see `push`);
                    // reads are of entries below `top`, which have been written.
                    unsafe { push(stack, top, (nodes.child(current, far_lane), near[far_lane])) };
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
                    let new = (nodes.child(current, lane), near[lane]);
                    let mut i = top;
                    // SAFETY: reads are of entries `base..top`, written by this node's pushes above;
                    // writes are at most at `top`, within `stack_needed` (see `push`: this node
                    // pushes at most width entries before one is popped).
                    unsafe {
                        while i > base && entry(stack, i - 1).1 < new.1 {
                            push(stack, i, entry(stack, i - 1));
                            i -= 1;
                        }
                        push(stack, i, new);
                    }
                    top += 1;
                    if mask == 0 {
                        break;
                    }
                    lane = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                }
                top -= 1;
                // SAFETY: `top` was incremented once per child pushed above, so entry `top - 1`
                // (now `top`) has been written.
                current = unsafe { entry(stack, top) }.0;
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
            // SAFETY: entries below the old `top` have been written by `push`, and `top` was
            // decremented just above.
            let (node, near) = unsafe { entry(stack, top) };
            if near <= tmax {
                current = node;
                break;
            }
        }
    }
}

/// Any-hit traversal: children in no particular order, done at the first blocker.
///
/// # Safety
/// `stack` must hold the tree's [`super::Accel`] `stack_needed` entries (see [`push`]).
#[inline(always)]
pub(crate) unsafe fn any_hit<N: InnerNodes>(
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
                // SAFETY: within `stack_needed` (see `push`).
                unsafe { push(stack, top, (nodes.child(current, lane), 0.0)) };
                top += 1;
            }
        } else if let Some(blocks) = leaves.packed_blocks(current) {
            for block in blocks {
                if block.occludes(&ray4, ray, tmax) {
                    return true;
                }
            }
        } else if leaves.intersect_general(current, ray, tmax).is_some() {
            return true;
        }
        if top == 0 {
            return false;
        }
        top -= 1;
        // SAFETY: entries below `top` have been written.
        current = unsafe { entry(stack, top) }.0;
    }
}
