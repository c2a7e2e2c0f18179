//! Eight camera rays of one pixel traced together through the eight-wide BVH.
//!
//! The samples of a pixel leave the camera's origin in nearly the same direction, so they visit
//! nearly the same nodes. A packet tests each inner node once for all of them
//! ([`Nodes8::test_packet`]: the slab distances bounded over the packet, which accepts
//! every child box one of the rays enters), and each triangle once for all of them: the rays share
//! their origin, so the watertight test's vertex coordinates relative to it are shared too, and
//! only the shear differs from lane to lane. Every lane computes exactly the operations of the
//! single-ray test ([`Triangle4`]) in the same order, and falls back to it where that test
//! does (an edge function exactly zero), and each ray keeps its own closest distance: every ray
//! finds the hit it finds alone, bit for bit. Only which of two triangles at exactly the same
//! distance wins can differ, as between node widths. Rays whose directions differ in octant or
//! in largest axis (a pixel straddling a plane) are not packed: the caller traces them one by one.

use super::Nodes8;
use crate::accel::leaves::Leaves;
use crate::accel::traversal::{nearest_first, reciprocal, ChildRef, NEAR_FAR, STACK_SIZE};
use crate::accel::triangle4::{Ray4, Triangle4};
use crate::accel::x86_64::avx512::Nodes16;
use crate::accel::ClosestHit;
use crate::ray::Ray;
use crate::shapes::triangle::PERMUTATION;
use glam::Vec3A;
use std::{arch::x86_64::*, mem::MaybeUninit};

/// Rays per packet (one AVX2 register's lanes; packets need eight-wide nodes, which need AVX2).
pub const PACKET: usize = 8;

/// Per-packet constants of the interval box test: per axis the range of the rays' reciprocal
/// directions and origin × each end, and the bound rows the packet's octant enters and leaves by.
pub(crate) struct PacketBox {
    pub(crate) inv_min: [f32; 3],
    pub(crate) inv_max: [f32; 3],
    pub(crate) org_inv_min: [f32; 3],
    pub(crate) org_inv_max: [f32; 3],
    pub(crate) near: [usize; 3],
    pub(crate) far: [usize; 3],
}

/// Defines a packet kernel: `$name` traces a packet through `$nodes` nodes inside a function
/// compiled with `$features`. The body is a macro, not a generic function, so that its closures
/// (the node and leaf tests handed to the traversal loop) are defined inside the
/// `#[target_feature]` function and inherit its features: closures of a generic helper are
/// compiled for the baseline, and when LLVM declines to inline one, every intrinsic in it
/// becomes a call (measured: 20-35% slower renders).
macro_rules! packet_kernel {
    ($(#[$doc:meta])* $name:ident, $nodes:ty, $features:literal) => {
        $(#[$doc])*
        #[target_feature(enable = $features)]
        pub(crate) unsafe fn $name(
            nodes: &$nodes,
            leaves: &Leaves,
            root: ChildRef,
            origin: Vec3A,
            dirs: &[Vec3A; PACKET],
            out: &mut [Option<ClosestHit>; PACKET],
        ) -> bool {
            // The rays' set-up, eight lanes at a time, with the single-ray arithmetic
            // (`bvh::reciprocal`, `WatertightRay::with_reciprocal`) in each lane.
            let d: [__m256; 3] = std::array::from_fn(|axis| {
                let c: [f32; PACKET] = std::array::from_fn(|k| dirs[k].to_array()[axis]);
                _mm256_loadu_ps(c.as_ptr())
            });
            let sign = _mm256_set1_ps(-0.0);
            let tiny = _mm256_set1_ps(1e-20);
            let inv = d.map(|d| {
                let is_tiny = _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_andnot_ps(sign, d), tiny);
                let replaced = _mm256_or_ps(tiny, _mm256_and_ps(d, sign));
                _mm256_div_ps(_mm256_set1_ps(1.0), _mm256_blendv_ps(d, replaced, is_tiny))
            });
            // One octant for all lanes.
            let mut packet_octant = 0;
            for (axis, &inv) in inv.iter().enumerate() {
                match _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(inv, _mm256_setzero_ps())) {
                    0 => {}
                    0xff => packet_octant |= 1 << axis,
                    _ => return false,
                }
            }
            // One largest axis for all lanes (`geometry::largest_axis`: x when |x| > |y| and |x| > |z|,
            // else y when |y| > |z| and not |x| > |y|, else z).
            let a = d.map(|d| _mm256_andnot_ps(sign, d));
            let greater = |i: usize, j: usize| _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(a[i], a[j]));
            let (x_y, x_z, y_z) = (greater(0, 1), greater(0, 2), greater(1, 2));
            let largest_x = x_y & x_z;
            let largest_y = !x_y & y_z & 0xff;
            let kz = match (largest_x, largest_y) {
                (0xff, _) => 0,
                (_, 0xff) => 1,
                (0, 0) => 2,
                _ => return false,
            };
            let axes = PERMUTATION[kz];
            let shear_z = inv[kz];
            let shear = [
                _mm256_mul_ps(_mm256_xor_ps(d[axes[0]], sign), shear_z),
                _mm256_mul_ps(_mm256_xor_ps(d[axes[1]], sign), shear_z),
                shear_z,
            ];
            let inv_lanes = [lanes(inv[0]), lanes(inv[1]), lanes(inv[2])];
            let inv_min = Vec3A::from_array(inv_lanes.map(|l| l.into_iter().fold(f32::INFINITY, f32::min)));
            let inv_max =
                Vec3A::from_array(inv_lanes.map(|l| l.into_iter().fold(f32::NEG_INFINITY, f32::max)));
            let (near, far) = NEAR_FAR[packet_octant];
            let box_packet = PacketBox {
                inv_min: inv_min.to_array(),
                inv_max: inv_max.to_array(),
                org_inv_min: (origin * inv_min).to_array(),
                org_inv_max: (origin * inv_max).to_array(),
                near,
                far,
            };
            let o = origin.to_array();
            let triangle_packet = TrianglePacket {
                axes,
                origin: [o[axes[0]], o[axes[1]], o[axes[2]]],
                shear,
            };
            let mut hits = Hits::new();
            let stack = &mut [const { MaybeUninit::uninit() }; STACK_SIZE];
            // SAFETY: the tree's stack need fits STACK_SIZE (the caller's contract).
            nearest_first(
                nodes,
                root,
                f32::INFINITY,
                stack,
                |node, packet_tmax| nodes.test_packet(node, &box_packet, packet_tmax),
                |leaf, _| {
                    match leaves.packed_blocks(leaf) {
                        Some(blocks) => {
                            for block in blocks {
                                triangle_packet.intersect(block, &mut hits, origin, dirs);
                            }
                        }
                        None => {
                            // Leaves with spheres: each ray on its own.
                            for (k, &dir) in dirs.iter().enumerate() {
                                let (ray, _) = single_ray(origin, dir);
                                let tmax = hits.t_of(k);
                                if let Some(h) = leaves.intersect_general(leaf, &ray, tmax) {
                                    hits.set(k, h.t, h.prim, h.b1, h.b2);
                                }
                            }
                        }
                    }
                    // Nodes are skipped only when no ray can find a closer hit in them.
                    hits.t_max()
                },
            );
            *out = hits.finish();
            true
        }
    };
}

packet_kernel!(
    /// The closest hits, in (0, ∞), of the rays from `origin` along the unit directions `dirs`,
    /// written to `out`; false when they cannot be traced as one packet (directions in different
    /// octants or with different largest axes).
    ///
    /// # Safety
    /// The CPU must have AVX2 and FMA, `root` must be an inner node of `nodes` (or a leaf of
    /// `leaves`), and the tree's stack need must fit [`STACK_SIZE`].
    closest_hits,
    Nodes8,
    "avx2,fma"
);

packet_kernel!(
    /// [`closest_hits`] through sixteen-wide nodes.
    ///
    /// # Safety
    /// As for [`closest_hits`], and the CPU must have AVX-512F.
    closest_hits16,
    Nodes16,
    "avx512f,avx2,fma"
);

/// The closest hit of each lane's ray so far: distance, the watertight test's determinant and
/// the two edge functions that become the barycentrics (divided once, at the end), primitive
/// (`u32::MAX`: none yet).
#[derive(Clone, Copy)]
struct Hits {
    t: __m256,
    det: __m256,
    v: __m256,
    w: __m256,
    prim: __m256i,
}

impl Hits {
    #[inline(always)]
    unsafe fn new() -> Self {
        Self {
            t: _mm256_set1_ps(f32::INFINITY),
            det: _mm256_set1_ps(1.0),
            v: _mm256_setzero_ps(),
            w: _mm256_setzero_ps(),
            prim: _mm256_set1_epi32(-1),
        }
    }

    #[inline(always)]
    unsafe fn t_of(&self, k: usize) -> f32 {
        lanes(self.t)[k]
    }

    #[inline(always)]
    unsafe fn t_max(&self) -> f32 {
        lanes(self.t).into_iter().fold(0.0, f32::max)
    }

    /// Lane `k` takes a hit found by a single-ray test (barycentrics already divided). Out of
    /// line (rare), and compiled with AVX2 like its callers, so that its vectors never cross into
    /// code without it.
    #[inline(never)]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn set(&mut self, k: usize, t: f32, prim: u32, b1: f32, b2: f32) {
        let with = |v: __m256, x: f32| {
            let mut a = lanes(v);
            a[k] = x;
            _mm256_loadu_ps(a.as_ptr())
        };
        self.t = with(self.t, t);
        self.det = with(self.det, 1.0);
        self.v = with(self.v, b1);
        self.w = with(self.w, b2);
        self.prim = _mm256_castps_si256(with(_mm256_castsi256_ps(self.prim), f32::from_bits(prim)));
    }

    /// Lanes where `mask` is set take `other`'s values.
    #[inline(always)]
    unsafe fn blend(&mut self, other: &Hits, mask: __m256) {
        self.t = _mm256_blendv_ps(self.t, other.t, mask);
        self.det = _mm256_blendv_ps(self.det, other.det, mask);
        self.v = _mm256_blendv_ps(self.v, other.v, mask);
        self.w = _mm256_blendv_ps(self.w, other.w, mask);
        self.prim = _mm256_castps_si256(_mm256_blendv_ps(
            _mm256_castsi256_ps(self.prim),
            _mm256_castsi256_ps(other.prim),
            mask,
        ));
    }

    #[inline(always)]
    unsafe fn finish(&self) -> [Option<ClosestHit>; PACKET] {
        let t = lanes(self.t);
        let b1 = lanes(_mm256_div_ps(self.v, self.det));
        let b2 = lanes(_mm256_div_ps(self.w, self.det));
        let mut prim = [0u32; PACKET];
        _mm256_storeu_si256(prim.as_mut_ptr() as *mut __m256i, self.prim);
        std::array::from_fn(|k| {
            (prim[k] != u32::MAX).then_some(ClosestHit {
                t: t[k],
                prim: prim[k],
                b1: b1[k],
                b2: b2[k],
            })
        })
    }
}

#[inline(always)]
unsafe fn lanes(v: __m256) -> [f32; PACKET] {
    let mut a = [0.0; PACKET];
    _mm256_storeu_ps(a.as_mut_ptr(), v);
    a
}

/// One lane's ray and its constants for the single-ray tests (the rare fallbacks of the eight-
/// and sixteen-ray packets).
#[cold]
pub(crate) fn single_ray(origin: Vec3A, dir: Vec3A) -> (Ray, Ray4) {
    let ray = Ray {
        origin,
        dir,
        tmax: f32::INFINITY,
    };
    let ray4 = Ray4::for_ray(&ray, reciprocal(&ray));
    (ray, ray4)
}

/// The packet's constants of the watertight triangle test: the shared axis permutation and
/// origin, and each lane's shear.
struct TrianglePacket {
    axes: [usize; 3],
    origin: [f32; 3],
    shear: [__m256; 3],
}

impl TrianglePacket {
    /// Tests the block's triangles against every lane, keeping each lane's closest hit. The
    /// arithmetic is [`Triangle4`]'s, lane by lane: the relative vertex coordinates are scalars
    /// (the origin is shared), the shear a vector. Where an edge function is exactly zero for a
    /// lane in any of the block's triangles, that lane's result for the block is the single-ray
    /// test's, which then takes its double-precision fallback, as the single ray does.
    #[inline(always)]
    unsafe fn intersect(
        &self,
        block: &Triangle4,
        hits: &mut Hits,
        origin: Vec3A,
        dirs: &[Vec3A; PACKET],
    ) {
        let before = *hits;
        let [kx, ky, kz] = self.axes;
        let [ox, oy, oz] = self.origin;
        let [sx, sy, sz] = self.shear;
        let zero = _mm256_setzero_ps();
        let mut exact_zero = zero;
        for (lane, &prim) in block.prim.iter().enumerate() {
            if prim == u32::MAX {
                break; // unused lanes are the last ones
            }
            let p = |vertex: usize, axis: usize| block.coordinate(vertex, axis, lane);
            let (a_z, b_z, c_z) = (p(0, kz) - oz, p(1, kz) - oz, p(2, kz) - oz);
            let sheared = |x: f32, s: __m256, z: f32| {
                _mm256_add_ps(_mm256_set1_ps(x), _mm256_mul_ps(s, _mm256_set1_ps(z)))
            };
            let ax = sheared(p(0, kx) - ox, sx, a_z);
            let ay = sheared(p(0, ky) - oy, sy, a_z);
            let bx = sheared(p(1, kx) - ox, sx, b_z);
            let by = sheared(p(1, ky) - oy, sy, b_z);
            let cx = sheared(p(2, kx) - ox, sx, c_z);
            let cy = sheared(p(2, ky) - oy, sy, c_z);
            let u = _mm256_sub_ps(_mm256_mul_ps(cx, by), _mm256_mul_ps(cy, bx));
            let v = _mm256_sub_ps(_mm256_mul_ps(ax, cy), _mm256_mul_ps(ay, cx));
            let w = _mm256_sub_ps(_mm256_mul_ps(bx, ay), _mm256_mul_ps(by, ax));
            let eq = |x| _mm256_cmp_ps::<_CMP_EQ_OQ>(x, zero);
            let lt = |x| _mm256_cmp_ps::<_CMP_LT_OQ>(x, zero);
            let gt = |x| _mm256_cmp_ps::<_CMP_GT_OQ>(x, zero);
            exact_zero = _mm256_or_ps(exact_zero, _mm256_or_ps(_mm256_or_ps(eq(u), eq(v)), eq(w)));
            let negative = _mm256_or_ps(_mm256_or_ps(lt(u), lt(v)), lt(w));
            let positive = _mm256_or_ps(_mm256_or_ps(gt(u), gt(v)), gt(w));
            let det = _mm256_add_ps(_mm256_add_ps(u, v), w);
            let scaled = |z: f32| _mm256_mul_ps(sz, _mm256_set1_ps(z));
            let t_num = _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(u, scaled(a_z)), _mm256_mul_ps(v, scaled(b_z))),
                _mm256_mul_ps(w, scaled(c_z)),
            );
            let t = _mm256_div_ps(t_num, det);
            let hit = _mm256_andnot_ps(
                _mm256_and_ps(negative, positive),
                _mm256_and_ps(gt(t), _mm256_cmp_ps::<_CMP_LT_OQ>(t, hits.t)),
            );
            let found = Hits {
                t,
                det,
                v,
                w,
                prim: _mm256_set1_epi32(prim as i32),
            };
            hits.blend(&found, hit);
        }
        let mut fallback = _mm256_movemask_ps(exact_zero) as u32;
        if fallback != 0 {
            hits.blend(&before, exact_zero);
            while fallback != 0 {
                let k = fallback.trailing_zeros() as usize;
                fallback &= fallback - 1;
                let (ray, ray4) = single_ray(origin, dirs[k]);
                if let Some((lane, t, b1, b2)) = block.intersect(&ray4, &ray, hits.t_of(k)) {
                    hits.set(k, t, block.prim[lane], b1, b2);
                }
            }
        }
    }
}
