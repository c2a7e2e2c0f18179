//! Four-wide inner nodes tested through glam's `Vec4`: SSE2 on x86-64 (every such CPU), NEON or
//! scalar code elsewhere. The portable layout, used on CPUs without AVX2 and FMA and when
//! `TORREY_SIMD=portable` asks for it.

use super::build::WideBuilder;
use super::traversal::{slab_setup, ChildRef, InnerNodes, EXIT_WIDENING};
use crate::ray::Ray;
use glam::{Vec3A, Vec4};

/// A four-wide inner node: four child boxes, structure-of-arrays. `bounds` is
/// `[min x, min y, min z, max x, max y, max z]`, lane i for child i; an empty slot has an
/// inverted box (+inf min, -inf max) that no finite ray enters, and a reference to the empty leaf.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub(crate) struct Node4 {
    bounds: [Vec4; 6],
    children: [ChildRef; 4],
}

/// Four-wide nodes.
pub(crate) struct Nodes4(Vec<Node4>);

impl Nodes4 {
    /// No nodes: the layout of a BVH whose root is a leaf (or that is empty).
    pub(crate) fn empty() -> Self {
        Self(Vec::new())
    }

    /// Converts the BVH2 of `builder` below its root; returns the nodes and the root reference.
    pub(crate) fn build(builder: &mut WideBuilder) -> (Self, ChildRef) {
        let mut nodes = Vec::new();
        let root = builder.add_inner::<4, Node4>(
            &mut nodes,
            0,
            1,
            &|rows, children| Node4 {
                bounds: rows.map(Vec4::from_array),
                children,
            },
            &|node, lane, child| node.children[lane] = child,
        );
        (Self(nodes), root)
    }
}

impl InnerNodes for Nodes4 {
    const WIDTH: usize = 4;
    type RayConsts = BoxRay;
    type Distances = [f32; 4];

    #[inline(always)]
    fn ray_consts(ray: &Ray, inv: Vec3A) -> BoxRay {
        BoxRay::new(ray, inv)
    }

    #[inline(always)]
    fn test(&self, r: ChildRef, c: &BoxRay, tmax: f32) -> ([f32; 4], u32) {
        debug_assert!((r as usize) < self.0.len());
        // SAFETY: inner references are indices into the nodes, written by the build only.
        let node = unsafe { self.0.get_unchecked(r as usize) };
        let (near, mask) = c.test(node, tmax);
        (near.to_array(), mask)
    }

    #[inline(always)]
    fn children(&self, r: ChildRef) -> &[ChildRef] {
        debug_assert!((r as usize) < self.0.len());
        // SAFETY: as in `test`.
        unsafe { &self.0.get_unchecked(r as usize).children }
    }
}

/// Per-ray constants of the four-wide box test: reciprocal direction, origin × reciprocal, and
/// which bound (min or max) is the near one on each axis.
pub(crate) struct BoxRay {
    inv: [Vec4; 3],
    org_inv: [Vec4; 3],
    near: [usize; 3],
    far: [usize; 3],
}

impl BoxRay {
    #[inline(always)]
    pub(crate) fn new(ray: &Ray, inv: Vec3A) -> Self {
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
