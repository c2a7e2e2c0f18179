//! Eight camera rays of one pixel traced together through the eight-wide BVH.
//!
//! The samples of a pixel leave the camera's origin in nearly the same direction, so they visit
//! nearly the same nodes. A packet tests each inner node once for all of them
//! ([`crate::bvh8::Nodes8::test_packet`]: the slab distances bounded over the packet, which accepts
//! every child box one of the rays enters), and each triangle once for all of them: the rays share
//! their origin, so the watertight test's vertex coordinates relative to it are shared too, and
//! only the shear differs from lane to lane. Every lane computes exactly the operations of the
//! single-ray test ([`crate::triangle4`]) in the same order, and falls back to it where that test
//! does (an edge function exactly zero), and each ray keeps its own closest distance: every ray
//! finds the hit it finds alone, bit for bit. Only which of two triangles at exactly the same
//! distance wins can differ, as between node widths. Rays whose directions differ in octant or
//! in largest axis (a pixel straddling a plane) are not packed: the caller traces them one by one.

#[cfg(target_arch = "x86_64")]
use crate::{
    bvh::{nearest_first, reciprocal, ChildRef, ClosestHit, Leaves, NEAR_FAR},
    bvh8::Nodes8,
    geometry::{Ray, WatertightRay},
    triangle4::{Ray4, Triangle4},
};
#[cfg(target_arch = "x86_64")]
use glam::Vec3A;
#[cfg(target_arch = "x86_64")]
use std::{arch::x86_64::*, mem::MaybeUninit};

/// Rays per packet (one AVX2 register's lanes; packets need eight-wide nodes, which need AVX2).
pub const PACKET: usize = 8;

/// Per-packet constants of the interval box test: per axis the range of the rays' reciprocal
/// directions and origin × each end, and the bound rows the packet's octant enters and leaves by.
#[cfg(target_arch = "x86_64")]
pub(crate) struct PacketBox {
    pub(crate) inv_min: [f32; 3],
    pub(crate) inv_max: [f32; 3],
    pub(crate) org_inv_min: [f32; 3],
    pub(crate) org_inv_max: [f32; 3],
    pub(crate) near: [usize; 3],
    pub(crate) far: [usize; 3],
}

/// Stack entries of a packet traversal; a deeper tree is not traced in packets.
#[cfg(target_arch = "x86_64")]
const STACK_SIZE: usize = 128;

/// The closest hits, in (0, ∞), of the rays from `origin` along the unit directions `dirs`, or
/// None when they cannot be traced as one packet (directions in different octants or with
/// different largest axes, or a tree deeper than the fixed stack).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
pub(crate) unsafe fn closest_hits(
    nodes: &Nodes8,
    leaves: &Leaves,
    root: ChildRef,
    stack_needed: usize,
    origin: Vec3A,
    dirs: &[Vec3A; PACKET],
) -> Option<[Option<ClosestHit>; PACKET]> {
    if stack_needed > STACK_SIZE {
        return None;
    }
    let rays = dirs.map(|dir| Ray {
        origin,
        dir,
        tmax: f32::INFINITY,
    });
    let invs = rays.each_ref().map(reciprocal);
    let watertight: [WatertightRay; PACKET] =
        std::array::from_fn(|k| WatertightRay::with_reciprocal(&rays[k], invs[k]));
    let octant = |inv: Vec3A| inv.cmplt(Vec3A::ZERO).bitmask() & 7;
    let packet_octant = octant(invs[0]);
    let axes = watertight[0].axes();
    if (1..PACKET).any(|k| octant(invs[k]) != packet_octant || watertight[k].axes() != axes) {
        return None;
    }
    let inv_min = invs.iter().fold(invs[0], |m, &inv| m.min(inv));
    let inv_max = invs.iter().fold(invs[0], |m, &inv| m.max(inv));
    let (near, far) = NEAR_FAR[packet_octant as usize];
    let box_packet = PacketBox {
        inv_min: inv_min.to_array(),
        inv_max: inv_max.to_array(),
        org_inv_min: (origin * inv_min).to_array(),
        org_inv_max: (origin * inv_max).to_array(),
        near,
        far,
    };
    let triangle_packet = TrianglePacket::new(&watertight, origin);
    let mut hits = Hits::new();
    let stack = &mut [const { MaybeUninit::uninit() }; STACK_SIZE];
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
                        triangle_packet.intersect(block, &mut hits, &rays, &watertight);
                    }
                }
                None => {
                    // Leaves with spheres: each ray on its own.
                    for k in 0..PACKET {
                        let ray4 = Ray4::new(&watertight[k], origin);
                        let tmax = hits.t_of(k);
                        if let Some(h) = leaves.intersect_general(leaf, &rays[k], &ray4, tmax) {
                            hits.set(k, h.t, h.prim, h.b1, h.b2);
                        }
                    }
                }
            }
            // Nodes are skipped only when no ray can find a closer hit in them.
            hits.t_max()
        },
    );
    Some(hits.finish())
}

/// The closest hit of each lane's ray so far: distance, the watertight test's determinant and
/// the two edge functions that become the barycentrics (divided once, at the end), primitive
/// (`u32::MAX`: none yet).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct Hits {
    t: __m256,
    det: __m256,
    v: __m256,
    w: __m256,
    prim: __m256i,
}

#[cfg(target_arch = "x86_64")]
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

    /// Lane `k` takes a hit found by a single-ray test (barycentrics already divided).
    #[inline(never)]
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

#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn lanes(v: __m256) -> [f32; PACKET] {
    let mut a = [0.0; PACKET];
    _mm256_storeu_ps(a.as_mut_ptr(), v);
    a
}

/// The packet's constants of the watertight triangle test: the shared axis permutation and
/// origin, and each lane's shear.
#[cfg(target_arch = "x86_64")]
struct TrianglePacket {
    axes: [usize; 3],
    origin: [f32; 3],
    shear: [__m256; 3],
}

#[cfg(target_arch = "x86_64")]
impl TrianglePacket {
    #[inline(always)]
    unsafe fn new(watertight: &[WatertightRay; PACKET], origin: Vec3A) -> Self {
        let axes = watertight[0].axes();
        let shear = |i: usize| {
            let s: [f32; PACKET] = std::array::from_fn(|k| watertight[k].shear()[i]);
            _mm256_loadu_ps(s.as_ptr())
        };
        let o = origin.to_array();
        Self {
            axes,
            origin: [o[axes[0]], o[axes[1]], o[axes[2]]],
            shear: [shear(0), shear(1), shear(2)],
        }
    }

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
        rays: &[Ray; PACKET],
        watertight: &[WatertightRay; PACKET],
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
                let ray4 = Ray4::new(&watertight[k], rays[k].origin);
                if let Some((lane, t, b1, b2)) = block.intersect(&ray4, &rays[k], hits.t_of(k)) {
                    hits.set(k, t, block.prim[lane], b1, b2);
                }
            }
        }
    }
}
