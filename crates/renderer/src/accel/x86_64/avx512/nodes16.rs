//! Sixteen-wide BVH nodes tested with AVX-512: one 512-bit slab test covers a node's sixteen
//! child boxes, for one ray ([`InnerNodes::test`]) or a packet ([`Nodes16::test_packet`]). The
//! comparison writes a mask register directly, so no movemask follows it.

use crate::accel::build::WideBuilder;
use crate::accel::traversal::{
    near_far_offsets, slab_setup_offsets, ChildRef, InnerNodes, EXIT_WIDENING,
};
use crate::accel::x86_64::avx2::packet::PacketBox;
use crate::accel::x86_64::shadow_packet::ShadowNodes;
use crate::ray::Ray;
use glam::Vec3A;
use std::arch::x86_64::*;

/// A sixteen-wide inner node: `bounds` rows `[min x, min y, min z, max x, max y, max z]`, lane i
/// for child i (unused lanes hold an inverted box), one cache line per row.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct Node16 {
    bounds: [[f32; 16]; 6],
    children: [ChildRef; 16],
}

/// Sixteen-wide nodes. Only built when [`super::available`] holds, which makes the AVX-512 code
/// in [`InnerNodes::test`] sound to run.
pub(crate) struct Nodes16(Vec<Node16>);

/// Per-ray constants of the sixteen-wide box test: reciprocal direction and origin × reciprocal
/// per axis, and the byte offsets of the near and far bound rows.
pub(crate) struct BoxRay16 {
    inv: [f32; 3],
    org_inv: [f32; 3],
    near: [u32; 3],
    far: [u32; 3],
}

/// The near and far bound rows' byte offsets by octant (rows of 16 floats).
const ROW_OFFSETS: [([u32; 3], [u32; 3]); 8] = near_far_offsets(16 * 4);

impl Nodes16 {
    /// Converts the BVH2 of `builder` below its root; returns the nodes and the root reference.
    pub(crate) fn build(builder: &mut WideBuilder) -> (Self, ChildRef) {
        assert!(super::available(), "sixteen-wide nodes need AVX-512");
        let mut nodes = Vec::new();
        let root = builder.add_inner::<16, Node16>(
            &mut nodes,
            0,
            1,
            &|bounds, children| Node16 { bounds, children },
            &|node, lane, child| node.children[lane] = child,
        );
        (Self(nodes), root)
    }

    /// The packet box test of [`crate::accel::x86_64::avx2::Nodes8::test_packet`], sixteen
    /// children at a time.
    #[inline(always)]
    pub(crate) fn test_packet(&self, r: ChildRef, c: &PacketBox, tmax: f32) -> ([f32; 16], u32) {
        debug_assert!((r as usize) < self.0.len());
        // SAFETY: as in `InnerNodes::test`.
        unsafe {
            let b = &self.0.get_unchecked(r as usize).bounds;
            let t = |row: usize, inv: f32, org_inv: f32| {
                _mm512_fmsub_ps(
                    _mm512_load_ps(b.get_unchecked(row).as_ptr()),
                    _mm512_set1_ps(inv),
                    _mm512_set1_ps(org_inv),
                )
            };
            let entry = |axis: usize| {
                let row = c.near[axis];
                _mm512_min_ps(
                    t(row, c.inv_min[axis], c.org_inv_min[axis]),
                    t(row, c.inv_max[axis], c.org_inv_max[axis]),
                )
            };
            let exit = |axis: usize| {
                let row = c.far[axis];
                _mm512_max_ps(
                    t(row, c.inv_min[axis], c.org_inv_min[axis]),
                    t(row, c.inv_max[axis], c.org_inv_max[axis]),
                )
            };
            let near = _mm512_max_ps(
                _mm512_max_ps(entry(0), entry(1)),
                _mm512_max_ps(entry(2), _mm512_setzero_ps()),
            );
            let far = _mm512_min_ps(_mm512_min_ps(exit(0), exit(1)), exit(2));
            entered(near, far, tmax)
        }
    }
}

impl ShadowNodes for Nodes16 {
    #[inline(always)]
    unsafe fn bound(&self, r: ChildRef, row: usize, child: usize) -> f32 {
        debug_assert!((r as usize) < self.0.len() && row < 6 && child < 16);
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

impl InnerNodes for Nodes16 {
    const WIDTH: usize = 16;
    type RayConsts = BoxRay16;
    type Distances = [f32; 16];

    #[inline(always)]
    fn ray_consts(ray: &Ray, inv: Vec3A) -> BoxRay16 {
        let (org_inv, near, far) = slab_setup_offsets(ray, inv, &ROW_OFFSETS);
        BoxRay16 {
            inv: inv.to_array(),
            org_inv: org_inv.to_array(),
            near,
            far,
        }
    }

    #[inline(always)]
    fn test(&self, r: ChildRef, c: &BoxRay16, tmax: f32) -> ([f32; 16], u32) {
        debug_assert!((r as usize) < self.0.len());
        // SAFETY: inner references are indices into the nodes, written by the build only;
        // the row offsets are those of rows below 6, aligned like the rows (`ROW_OFFSETS`);
        // AVX-512 is present (see `Nodes16`).
        unsafe {
            let b = &self.0.get_unchecked(r as usize).bounds;
            // bound × 1/d − origin × 1/d as one fused multiply-subtract, as the eight-wide test.
            let t = |offset: u32, axis: usize| {
                _mm512_fmsub_ps(
                    _mm512_load_ps(b.as_ptr().cast::<u8>().add(offset as usize).cast()),
                    _mm512_set1_ps(c.inv[axis]),
                    _mm512_set1_ps(c.org_inv[axis]),
                )
            };
            let near = _mm512_max_ps(
                _mm512_max_ps(t(c.near[0], 0), t(c.near[1], 1)),
                _mm512_max_ps(t(c.near[2], 2), _mm512_setzero_ps()),
            );
            let far = _mm512_min_ps(
                _mm512_min_ps(t(c.far[0], 0), t(c.far[1], 1)),
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
unsafe fn entered(near: __m512, far: __m512, tmax: f32) -> ([f32; 16], u32) {
    let far = _mm512_min_ps(
        _mm512_mul_ps(far, _mm512_set1_ps(EXIT_WIDENING)),
        _mm512_set1_ps(tmax),
    );
    let mask = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(near, far) as u32;
    let mut nears = [0.0f32; 16];
    _mm512_storeu_ps(nears.as_mut_ptr(), near);
    (nears, mask)
}
