//! Shadow rays traced together as any-hit packets of eight (AVX2) or sixteen (AVX-512) through
//! the wide BVH, each lane answering exactly what its ray answers alone.
//!
//! A shadow ray's answer is one boolean: is anything in (0, tmax)? It does not depend on the
//! order the traversal visits nodes or tests triangles, only on which triangles the ray is
//! tested against and on each test's verdict. So every lane here does the single-ray arithmetic
//! of [`crate::accel::traversal::any_hit`], with its own origin, direction and limit, the SIMD
//! lanes running across the rays instead of across a node's children or a block's triangles:
//! - box tests: a node's children one at a time, each lane computing the slab distances
//!   `bound × 1/d − origin × 1/d` (one fused multiply-subtract), maxima, minima, widening and
//!   limit in the order and operand order of [`crate::accel::x86_64::avx2::Nodes8`]'s test, so
//!   each lane enters exactly the boxes its ray enters (NaNs included: the minimum and maximum
//!   instructions return their second operand for NaN inputs, as in the single-ray test). A
//!   child is visited with the mask of the lanes that entered it and all its ancestors, so a
//!   lane reaches exactly the leaves its ray reaches.
//! - triangle tests: [`Triangle4::occludes`] lane by lane: the same sheared edge functions,
//!   the same division-free distance test, and, where an edge function of the block is exactly
//!   zero for a lane, that lane's verdict for the block is the single-ray test's (which then
//!   takes its double-precision fallback). Leaves with spheres, disks or cylinders are tested
//!   ray by ray.
//!
//! The lanes share their octant (the bound rows they enter and leave through) and the largest
//! axis of their direction (the watertight test's axis permutation): the caller groups rays by
//! both ([`crate::accel::Accel::occluded_batch`]). A lane that hits is done; the packet ends when
//! all are.

use crate::accel::leaves::Leaves;
use crate::accel::traversal::{
    reciprocal, ChildRef, InnerNodes, EXIT_WIDENING, LEAF, NEAR_FAR, STACK_SIZE,
};
use crate::accel::triangle4::{Ray4, Triangle4};
use crate::accel::SHADOW_BATCH;
use crate::ray::Ray;
use crate::shapes::triangle::PERMUTATION;
use std::mem::MaybeUninit;

/// The most rays a packet holds (sixteen, with AVX-512).
pub(crate) const MAX_LANES: usize = 16;

/// One SIMD register's worth of f32 lanes, eight (AVX2) or sixteen (AVX-512), with the
/// operations of the single-ray tests. Comparisons return bit masks, lane i in bit i. Every
/// function is `#[inline(always)]` and only called from kernels compiled with the instruction set
/// it needs.
pub(crate) trait Lanes {
    /// Lanes per register.
    const N: usize;
    type F: Copy;
    /// # Safety (all functions)
    /// The CPU has the instruction set of the implementation.
    unsafe fn splat(x: f32) -> Self::F;
    /// The first [`Lanes::N`] values of `a`.
    unsafe fn load(a: &[f32; MAX_LANES]) -> Self::F;
    unsafe fn add(a: Self::F, b: Self::F) -> Self::F;
    unsafe fn sub(a: Self::F, b: Self::F) -> Self::F;
    unsafe fn mul(a: Self::F, b: Self::F) -> Self::F;
    /// `a × b − c`, rounded once.
    unsafe fn fmsub(a: Self::F, b: Self::F, c: Self::F) -> Self::F;
    /// The x86 minimum: `b` where either is NaN.
    unsafe fn min(a: Self::F, b: Self::F) -> Self::F;
    /// The x86 maximum: `b` where either is NaN.
    unsafe fn max(a: Self::F, b: Self::F) -> Self::F;
    unsafe fn xor(a: Self::F, b: Self::F) -> Self::F;
    unsafe fn or(a: Self::F, b: Self::F) -> Self::F;
    /// `a` with the sign bit of `s` flipped into it.
    unsafe fn flip_sign_by(a: Self::F, s: Self::F) -> Self::F;
    unsafe fn abs(a: Self::F) -> Self::F;
    /// Ordered comparisons (false where either is NaN).
    unsafe fn le(a: Self::F, b: Self::F) -> u32;
    unsafe fn lt(a: Self::F, b: Self::F) -> u32;
    unsafe fn gt(a: Self::F, b: Self::F) -> u32;
    unsafe fn eq(a: Self::F, b: Self::F) -> u32;
    /// The lanes whose sign bit is set.
    unsafe fn negative(a: Self::F) -> u32;
}

/// Wide nodes whose bounds a packet reads one child at a time.
pub(crate) trait ShadowNodes: InnerNodes {
    /// Bound `row` (`[min x, min y, min z, max x, max y, max z]`) of child `child` of inner node
    /// `r`.
    ///
    /// # Safety
    /// `r` is an inner node of these nodes, `row < 6`, `child < WIDTH`.
    unsafe fn bound(&self, r: ChildRef, row: usize, child: usize) -> f32;
}

/// The constants of a run of shadow rays, structure-of-arrays, in group order (rays of one
/// octant and largest axis next to each other): what the single-ray set-up computes, once per
/// ray. A packet is a window of [`MAX_LANES`] entries; the entries past a group's end (another
/// group's, or stale ones) fill its unused lanes, whose answers are dropped.
pub(crate) struct ShadowBatch {
    inv: [[f32; PADDED]; 3],
    org_inv: [[f32; PADDED]; 3],
    tmax: [f32; PADDED],
    shear: [[f32; PADDED]; 3],
    /// The origin's coordinates along the permuted axes.
    origin: [[f32; PADDED]; 3],
}

/// Entries of a [`ShadowBatch`]: a run of rays and one window more.
const PADDED: usize = SHADOW_BATCH + MAX_LANES;

impl ShadowBatch {
    /// All entries zero (reused from run to run: no per-run initialisation).
    pub(crate) fn new() -> Box<Self> {
        Box::new(Self {
            inv: [[0.0; PADDED]; 3],
            org_inv: [[0.0; PADDED]; 3],
            tmax: [0.0; PADDED],
            shear: [[0.0; PADDED]; 3],
            origin: [[0.0; PADDED]; 3],
        })
    }

    /// Entry `i` (below [`SHADOW_BATCH`]) takes `ray`'s constants, those of the single-ray
    /// set-up.
    #[inline(always)]
    pub(crate) fn set(&mut self, i: usize, ray: &Ray) {
        let inv = reciprocal(ray);
        let org_inv = ray.origin * inv;
        let (_, shear, origin) = Ray4::for_ray(ray, inv).lane_constants();
        for axis in 0..3 {
            self.inv[axis][i] = inv[axis];
            self.org_inv[axis][i] = org_inv[axis];
            self.shear[axis][i] = shear[axis];
            self.origin[axis][i] = origin[axis];
        }
        self.tmax[i] = ray.tmax;
    }
}

/// Up to sixteen shadow rays of one group: entries `start..start + rays.len()` of a
/// [`ShadowBatch`], the rays themselves (for the single-ray fallbacks), and the group's box rows
/// and axis permutation.
pub(crate) struct ShadowPacket<'a> {
    batch: &'a ShadowBatch,
    start: usize,
    rays: &'a [Ray],
    near: [usize; 3],
    far: [usize; 3],
    axes: [usize; 3],
}

impl<'a> ShadowPacket<'a> {
    /// A packet of `rays` (1 to 16), whose constants are entries `start..` of `batch` and whose
    /// group key is `key` ([`group_key`]).
    pub(crate) fn new(batch: &'a ShadowBatch, start: usize, rays: &'a [Ray], key: usize) -> Self {
        assert!((1..=MAX_LANES).contains(&rays.len()) && start + rays.len() <= SHADOW_BATCH);
        let (near, far) = NEAR_FAR[key / 3];
        Self {
            batch,
            start,
            rays,
            near,
            far,
            axes: PERMUTATION[key % 3],
        }
    }

    /// The rays, lane by lane.
    pub(crate) fn rays(&self) -> &[Ray] {
        self.rays
    }

    /// The window of `row` this packet's lanes read.
    #[inline(always)]
    fn lanes<'r>(&self, row: &'r [f32; PADDED]) -> &'r [f32; MAX_LANES] {
        // In bounds: `start` <= SHADOW_BATCH (checked in `new`), PADDED = SHADOW_BATCH + 16.
        row[self.start..self.start + MAX_LANES].try_into().unwrap()
    }
}

/// The group of a ray: its octant (the bound rows its box tests read, [`NEAR_FAR`]) and the
/// largest axis of its direction (the watertight test's permutation), `octant × 3 + axis`,
/// computed as the single-ray set-up does.
#[inline(always)]
pub(crate) fn group_key(ray: &Ray) -> usize {
    let inv = reciprocal(ray);
    let octant = inv.cmplt(glam::Vec3A::ZERO).bitmask() as usize & 7;
    octant * 3 + Ray4::largest_axis(ray.dir)
}

/// The lanes of `packet` (bit i for ray i) that something blocks in (0, tmax).
///
/// # Safety
/// `L`'s instruction set is present; `root` is an inner node of `nodes` or a leaf of `leaves`;
/// the tree's stack need fits [`STACK_SIZE`]; `L::N` >= the packet's ray count.
#[inline(always)]
pub(crate) unsafe fn occluded_lanes<L: Lanes, N: ShadowNodes>(
    nodes: &N,
    leaves: &Leaves,
    root: ChildRef,
    packet: &ShadowPacket,
) -> u32 {
    debug_assert!(packet.rays.len() <= L::N);
    let used = (1u32 << packet.rays.len()) - 1;
    let mut hit = 0u32;
    // SAFETY: (the whole body) the caller's contract; stack accesses are below `top`, which
    // stays within STACK_SIZE as in the single-ray traversal (one entry per node on the path and
    // at most width − 1 waiting below each, whatever the lanes).
    unsafe {
        let batch = packet.batch;
        let inv = load3::<L>(packet, &batch.inv);
        let org_inv = load3::<L>(packet, &batch.org_inv);
        let tmax = L::load(packet.lanes(&batch.tmax));
        let zero = L::splat(0.0);
        let widening = L::splat(EXIT_WIDENING);
        let (near_rows, far_rows) = (packet.near, packet.far);
        let stack = &mut [const { MaybeUninit::<(ChildRef, u32)>::uninit() }; STACK_SIZE];
        stack[0] = MaybeUninit::new((root, used));
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let (node, lanes) = stack.get_unchecked(top).assume_init();
            let active = lanes & !hit;
            if active == 0 {
                continue;
            }
            if node & LEAF == 0 {
                for child in 0..N::WIDTH {
                    // Unused lanes point at the empty leaf: nothing to find there.
                    let child_ref = nodes.child(node, child);
                    if child_ref == Leaves::EMPTY_LEAF {
                        continue;
                    }
                    // Macros, not closures: a closure is a function of its own, compiled without
                    // the kernel's features, and every intrinsic in it a call if not inlined.
                    macro_rules! t {
                        ($row:expr, $axis:expr) => {
                            L::fmsub(
                                L::splat(nodes.bound(node, $row, child)),
                                inv[$axis],
                                org_inv[$axis],
                            )
                        };
                    }
                    let near = L::max(
                        L::max(t!(near_rows[0], 0), t!(near_rows[1], 1)),
                        L::max(t!(near_rows[2], 2), zero),
                    );
                    let far = L::min(
                        L::min(t!(far_rows[0], 0), t!(far_rows[1], 1)),
                        t!(far_rows[2], 2),
                    );
                    let far = L::min(L::mul(far, widening), tmax);
                    let entered = L::le(near, far) & active;
                    if entered != 0 {
                        debug_assert!(top < STACK_SIZE);
                        *stack.get_unchecked_mut(top) = MaybeUninit::new((child_ref, entered));
                        top += 1;
                    }
                }
            } else if let Some(blocks) = leaves.packed_blocks(node) {
                let mut active = active;
                for block in blocks {
                    let blocked = block_occludes::<L>(block, packet, tmax, active);
                    hit |= blocked;
                    active &= !blocked;
                    if active == 0 {
                        break;
                    }
                }
            } else {
                let mut rest = active;
                while rest != 0 {
                    let k = rest.trailing_zeros() as usize;
                    rest &= rest - 1;
                    let ray = &packet.rays[k];
                    if leaves.intersect_general(node, ray, ray.tmax).is_some() {
                        hit |= 1 << k;
                    }
                }
            }
            if hit == used {
                break;
            }
        }
    }
    hit
}

/// The lanes among `active` that a triangle of `block` blocks: [`Triangle4::occludes`] in each
/// lane (see the module comment).
///
/// # Safety
/// As for [`occluded_lanes`].
#[inline(always)]
unsafe fn block_occludes<L: Lanes>(
    block: &Triangle4,
    packet: &ShadowPacket,
    tmax: L::F,
    active: u32,
) -> u32 {
    // SAFETY: (the whole body) the caller's contract.
    unsafe {
        let [kx, ky, kz] = packet.axes;
        let [ox, oy, oz] = load3::<L>(packet, &packet.batch.origin);
        let [sx, sy, sz] = load3::<L>(packet, &packet.batch.shear);
        let zero = L::splat(0.0);
        let mut exact_zero = 0u32;
        let mut blocked = 0u32;
        for (lane, &prim) in block.prim.iter().enumerate() {
            if prim == u32::MAX {
                break; // unused lanes are the last ones (NaN vertices: never a zero, never a hit)
            }
            macro_rules! p {
                ($vertex:expr, $axis:expr) => {
                    L::splat(block.coordinate($vertex, $axis, lane))
                };
            }
            // (vertex − origin) + shear × z, as `Triangle4::edges` (no fused multiply-add).
            macro_rules! sheared {
                ($vertex:expr, $axis:expr, $o:expr, $s:expr, $z:expr) => {
                    L::add(L::sub(p!($vertex, $axis), $o), L::mul($s, $z))
                };
            }
            let (a_z, b_z, c_z) = (
                L::sub(p!(0, kz), oz),
                L::sub(p!(1, kz), oz),
                L::sub(p!(2, kz), oz),
            );
            let ax = sheared!(0, kx, ox, sx, a_z);
            let ay = sheared!(0, ky, oy, sy, a_z);
            let bx = sheared!(1, kx, ox, sx, b_z);
            let by = sheared!(1, ky, oy, sy, b_z);
            let cx = sheared!(2, kx, ox, sx, c_z);
            let cy = sheared!(2, ky, oy, sy, c_z);
            let u = L::sub(L::mul(cx, by), L::mul(cy, bx));
            let v = L::sub(L::mul(ax, cy), L::mul(ay, cx));
            let w = L::sub(L::mul(bx, ay), L::mul(by, ax));
            exact_zero |= L::eq(u, zero) | L::eq(v, zero) | L::eq(w, zero);
            let mixed = L::negative(L::or(L::xor(u, v), L::xor(u, w)));
            let det = L::add(L::add(u, v), w);
            let t_num = L::add(
                L::add(L::mul(u, L::mul(sz, a_z)), L::mul(v, L::mul(sz, b_z))),
                L::mul(w, L::mul(sz, c_z)),
            );
            let t_scaled = L::flip_sign_by(t_num, det);
            let inside = L::gt(t_scaled, zero) & L::lt(t_scaled, L::mul(L::abs(det), tmax));
            blocked |= inside & !mixed;
        }
        // A lane with an exact zero anywhere in the block takes the single-ray test's answer for
        // the whole block, as its ray does alone.
        let mut fallback = exact_zero & active;
        blocked &= active & !exact_zero;
        while fallback != 0 {
            let k = fallback.trailing_zeros() as usize;
            fallback &= fallback - 1;
            if block_occludes_single(block, &packet.rays[k]) {
                blocked |= 1 << k;
            }
        }
        blocked
    }
}

/// Three rows of lanes.
///
/// # Safety
/// `L`'s instruction set is present.
#[inline(always)]
unsafe fn load3<L: Lanes>(packet: &ShadowPacket, rows: &[[f32; PADDED]; 3]) -> [L::F; 3] {
    // SAFETY: the caller's contract.
    unsafe {
        [
            L::load(packet.lanes(&rows[0])),
            L::load(packet.lanes(&rows[1])),
            L::load(packet.lanes(&rows[2])),
        ]
    }
}

/// The single-ray any-hit test of one block (the rare fallback of [`block_occludes`]).
#[cold]
#[inline(never)]
fn block_occludes_single(block: &Triangle4, ray: &Ray) -> bool {
    block.occludes(&Ray4::for_ray(ray, reciprocal(ray)), ray, ray.tmax)
}

/// Defines a kernel `$name`: [`occluded_lanes`] with lanes `$lanes` through nodes `$nodes`,
/// compiled with `$features`.
macro_rules! shadow_kernel {
    ($(#[$doc:meta])* $name:ident, $lanes:ty, $nodes:ty, $features:literal) => {
        $(#[$doc])*
        #[target_feature(enable = $features)]
        pub(crate) unsafe fn $name(
            nodes: &$nodes,
            leaves: &Leaves,
            root: ChildRef,
            packet: &ShadowPacket,
        ) -> u32 {
            // SAFETY: the caller's contract.
            unsafe { occluded_lanes::<$lanes, $nodes>(nodes, leaves, root, packet) }
        }
    };
}

use super::avx2::{Lanes8, Nodes8};
use super::avx512::{Lanes16, Nodes16};

shadow_kernel!(
    /// The lanes of `packet` (up to eight rays) that something blocks, through eight-wide nodes.
    ///
    /// # Safety
    /// The CPU must have AVX2 and FMA, `root` must be an inner node of `nodes` (or a leaf of
    /// `leaves`), the tree's stack need must fit [`STACK_SIZE`], and the packet must hold at
    /// most eight rays.
    occluded8_8,
    Lanes8,
    Nodes8,
    "avx2,fma"
);

shadow_kernel!(
    /// [`occluded8_8`] through sixteen-wide nodes.
    ///
    /// # Safety
    /// As for [`occluded8_8`], and the CPU must have AVX-512F.
    occluded8_16,
    Lanes8,
    Nodes16,
    "avx512f,avx2,fma"
);

shadow_kernel!(
    /// [`occluded8_8`] for packets of up to sixteen rays.
    ///
    /// # Safety
    /// As for [`occluded8_8`], the CPU must have AVX-512F, and the packet may hold sixteen rays.
    occluded16_8,
    Lanes16,
    Nodes8,
    "avx512f,avx2,fma"
);

shadow_kernel!(
    /// [`occluded16_8`] through sixteen-wide nodes.
    ///
    /// # Safety
    /// As for [`occluded16_8`].
    occluded16_16,
    Lanes16,
    Nodes16,
    "avx512f,avx2,fma"
);
