//! Eight-wide BVH nodes tested with AVX2 and FMA: one 256-bit slab test covers a node's eight
//! child boxes, for one ray ([`InnerNodes::test`]) or a packet ([`Nodes8::test_packet`]).

use crate::accel::build::WideBuilder;
use crate::accel::traversal::{
    near_far_offsets, slab_setup_offsets, ChildRef, InnerNodes, EXIT_WIDENING,
};
use crate::accel::x86_64::shadow_packet::ShadowNodes;
use crate::ray::Ray;
use glam::Vec3A;
use std::arch::x86_64::*;

/// An eight-wide inner node: `bounds` rows `[min x, min y, min z, max x, max y, max z]`, lane i
/// for child i (unused lanes hold an inverted box).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(crate) struct Node8 {
    bounds: [[f32; 8]; 6],
    children: [ChildRef; 8],
}

/// Eight-wide nodes. Only built when [`super::available`] holds, which makes the AVX2 and FMA code in
/// [`InnerNodes::test`] sound to run.
pub(crate) struct Nodes8(Vec<Node8>);

/// Per-ray constants of the eight-wide box test: reciprocal direction and origin × reciprocal
/// per axis, and the byte offsets of the near and far bound rows.
pub(crate) struct BoxRay8 {
    inv: [f32; 3],
    org_inv: [f32; 3],
    near: [u32; 3],
    far: [u32; 3],
}

/// The near and far bound rows' byte offsets by octant (rows of 8 floats).
const ROW_OFFSETS: [([u32; 3], [u32; 3]); 8] = near_far_offsets(8 * 4);

impl Nodes8 {
    /// Converts the BVH2 of `builder` below its root; returns the nodes and the root reference.
    pub(crate) fn build(builder: &mut WideBuilder) -> (Self, ChildRef) {
        assert!(super::available(), "eight-wide nodes need AVX2 and FMA");
        let mut nodes = Vec::new();
        let root = builder.add_inner::<8, Node8>(
            &mut nodes,
            0,
            1,
            &|bounds, children| Node8 { bounds, children },
            &|node, lane, child| node.children[lane] = child,
        );
        (Self(nodes), root)
    }
}

impl Nodes8 {
    /// [`InnerNodes::test`] for a packet of rays from one origin: the entry distance of each
    /// child is bounded below, and its exit distance above, over all the packet's rays. Along
    /// each axis (bound − origin) × 1/d is linear in 1/d, so over the packet's range of 1/d it
    /// is extreme at the range's ends: two fused multiply-subtracts, then a minimum (entries) or
    /// a maximum (exits). The mask holds every child that one of the rays enters before `tmax`
    /// (the largest of the rays' limits), and possibly a few that none enters.
    #[inline(always)]
    pub(crate) fn test_packet(
        &self,
        r: ChildRef,
        c: &super::packet::PacketBox,
        tmax: f32,
    ) -> ([f32; 8], u32) {
        debug_assert!((r as usize) < self.0.len());
        // SAFETY: as in `InnerNodes::test`.
        unsafe {
            let b = &self.0.get_unchecked(r as usize).bounds;
            let t = |row: usize, inv: f32, org_inv: f32| {
                _mm256_fmsub_ps(
                    _mm256_load_ps(b.get_unchecked(row).as_ptr()),
                    _mm256_set1_ps(inv),
                    _mm256_set1_ps(org_inv),
                )
            };
            let entry = |axis: usize| {
                let row = c.near[axis];
                _mm256_min_ps(
                    t(row, c.inv_min[axis], c.org_inv_min[axis]),
                    t(row, c.inv_max[axis], c.org_inv_max[axis]),
                )
            };
            let exit = |axis: usize| {
                let row = c.far[axis];
                _mm256_max_ps(
                    t(row, c.inv_min[axis], c.org_inv_min[axis]),
                    t(row, c.inv_max[axis], c.org_inv_max[axis]),
                )
            };
            let near = _mm256_max_ps(
                _mm256_max_ps(entry(0), entry(1)),
                _mm256_max_ps(entry(2), _mm256_setzero_ps()),
            );
            let far = _mm256_min_ps(_mm256_min_ps(exit(0), exit(1)), exit(2));
            entered(near, far, tmax)
        }
    }
}

impl ShadowNodes for Nodes8 {
    #[inline(always)]
    unsafe fn bound(&self, r: ChildRef, row: usize, child: usize) -> f32 {
        debug_assert!((r as usize) < self.0.len() && row < 6 && child < 8);
        // SAFETY: the caller's contract (an inner node, a row and a child in range).
        unsafe {
            *self
                .0
                .get_unchecked(r as usize)
                .bounds
                .get_unchecked(row)
                .get_unchecked(child)
        }
    }
}

impl InnerNodes for Nodes8 {
    const WIDTH: usize = 8;
    type RayConsts = BoxRay8;
    type Distances = [f32; 8];

    #[inline(always)]
    fn ray_consts(ray: &Ray, inv: Vec3A) -> BoxRay8 {
        let (org_inv, near, far) = slab_setup_offsets(ray, inv, &ROW_OFFSETS);
        BoxRay8 {
            inv: inv.to_array(),
            org_inv: org_inv.to_array(),
            near,
            far,
        }
    }

    #[inline(always)]
    fn test(&self, r: ChildRef, c: &BoxRay8, tmax: f32) -> ([f32; 8], u32) {
        debug_assert!((r as usize) < self.0.len());
        // SAFETY: inner references are indices into the nodes, written by the build only;
        // the row offsets are those of rows below 6, aligned like the rows (`ROW_OFFSETS`); AVX2
        // and FMA are present (see `Nodes8`).
        unsafe {
            let b = &self.0.get_unchecked(r as usize).bounds;
            // Slab distances bound × 1/d − origin × 1/d as one fused multiply-subtract: one
            // rounding instead of two, so the exit widening stays conservative, and one operation
            // less on each node's dependent chain than the four-wide test's product and difference.
            let t = |offset: u32, axis: usize| {
                _mm256_fmsub_ps(
                    _mm256_load_ps(b.as_ptr().cast::<u8>().add(offset as usize).cast()),
                    _mm256_set1_ps(c.inv[axis]),
                    _mm256_set1_ps(c.org_inv[axis]),
                )
            };
            let near = _mm256_max_ps(
                _mm256_max_ps(t(c.near[0], 0), t(c.near[1], 1)),
                _mm256_max_ps(t(c.near[2], 2), _mm256_setzero_ps()),
            );
            let far = _mm256_min_ps(
                _mm256_min_ps(t(c.far[0], 0), t(c.far[1], 1)),
                t(c.far[2], 2),
            );
            entered(near, far, tmax)
        }
    }

    #[inline(always)]
    fn children(&self, r: ChildRef) -> &[ChildRef] {
        debug_assert!((r as usize) < self.0.len());
        // SAFETY: as in `test`.
        unsafe { &self.0.get_unchecked(r as usize).children }
    }
}

/// The end of both node tests: the children whose entry distance `near` is at most their exit
/// distance `far`, widened by [`EXIT_WIDENING`] and limited by `tmax`, and the entry distances.
#[inline(always)]
unsafe fn entered(near: __m256, far: __m256, tmax: f32) -> ([f32; 8], u32) {
    let far = _mm256_min_ps(
        _mm256_mul_ps(far, _mm256_set1_ps(EXIT_WIDENING)),
        _mm256_set1_ps(tmax),
    );
    let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32;
    let mut nears = [0.0f32; 8];
    _mm256_storeu_ps(nears.as_mut_ptr(), near);
    (nears, mask)
}
