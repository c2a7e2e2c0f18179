//! Sixteen camera rays of one pixel traced together with AVX-512: the packets of
//! [`crate::accel::x86_64::avx2::packet`], one 512-bit register per quantity instead of one
//! 256-bit register. The node test is per packet (an interval over the rays' reciprocal
//! directions), so sixteen rays share each node test that eight shared before; the triangle test
//! is per lane, with the single-ray arithmetic in each lane, in the same order, and the same
//! fallback to the single-ray test where an edge function is exactly zero: every ray finds the
//! hit it finds alone, bit for bit (only which of two triangles at exactly the same distance wins
//! can differ, as between node widths).

use crate::accel::leaves::Leaves;
use crate::accel::traversal::{nearest_first, ChildRef, NEAR_FAR, STACK_SIZE};
use crate::accel::triangle4::Triangle4;
use crate::accel::x86_64::avx2::packet::{single_ray, PacketBox};
use crate::accel::x86_64::avx2::Nodes8;
use crate::accel::x86_64::avx512::Nodes16;
use crate::accel::ClosestHit;
use crate::shapes::triangle::PERMUTATION;
use glam::Vec3A;
use std::{arch::x86_64::*, mem::MaybeUninit};

/// Rays per packet: one AVX-512 register's lanes.
pub const PACKET16: usize = 16;

/// Bitwise operations on float lanes through the integer ones of AVX-512F (the float ones need
/// AVX-512DQ, which [`super::available`] does not require).
#[inline(always)]
unsafe fn and(a: __m512, b: __m512) -> __m512 {
    _mm512_castsi512_ps(_mm512_and_si512(
        _mm512_castps_si512(a),
        _mm512_castps_si512(b),
    ))
}

#[inline(always)]
unsafe fn or(a: __m512, b: __m512) -> __m512 {
    _mm512_castsi512_ps(_mm512_or_si512(
        _mm512_castps_si512(a),
        _mm512_castps_si512(b),
    ))
}

#[inline(always)]
unsafe fn xor(a: __m512, b: __m512) -> __m512 {
    _mm512_castsi512_ps(_mm512_xor_si512(
        _mm512_castps_si512(a),
        _mm512_castps_si512(b),
    ))
}

/// Defines a sixteen-ray packet kernel through `$nodes` nodes (a macro, like the eight-ray one,
/// so that its closures inherit the function's target features).
macro_rules! packet16_kernel {
    ($(#[$doc:meta])* $name:ident, $nodes:ty) => {
        $(#[$doc])*
        #[target_feature(enable = "avx512f,avx512bw,avx512vl,avx2,fma")]
        pub(crate) unsafe fn $name(
            nodes: &$nodes,
            leaves: &Leaves,
            root: ChildRef,
            origin: Vec3A,
            dirs: &[Vec3A; PACKET16],
            out: &mut [Option<ClosestHit>; PACKET16],
        ) -> bool {
            // The rays' set-up, sixteen lanes at a time, with the single-ray arithmetic
            // (`traversal::reciprocal`, `Ray4::for_ray`) in each lane.
            let d: [__m512; 3] = std::array::from_fn(|axis| {
                let c: [f32; PACKET16] = std::array::from_fn(|k| dirs[k].to_array()[axis]);
                _mm512_loadu_ps(c.as_ptr())
            });
            let sign = _mm512_set1_ps(-0.0);
            let tiny = _mm512_set1_ps(1e-20);
            let abs = |v: __m512| _mm512_andnot_si512(
                _mm512_castps_si512(sign),
                _mm512_castps_si512(v),
            );
            let inv = d.map(|d| {
                let is_tiny =
                    _mm512_cmp_ps_mask::<_CMP_LT_OQ>(_mm512_castsi512_ps(abs(d)), tiny);
                let replaced = or(tiny, and(d, sign));
                _mm512_div_ps(_mm512_set1_ps(1.0), _mm512_mask_blend_ps(is_tiny, d, replaced))
            });
            // One octant for all lanes, and no NaN (the interval bounds below take no NaN).
            let mut packet_octant = 0;
            for (axis, &inv) in inv.iter().enumerate() {
                if _mm512_cmp_ps_mask::<_CMP_UNORD_Q>(inv, inv) != 0 {
                    return false;
                }
                match _mm512_cmp_ps_mask::<_CMP_LT_OQ>(inv, _mm512_setzero_ps()) {
                    0 => {}
                    0xffff => packet_octant |= 1 << axis,
                    _ => return false,
                }
            }
            // One largest axis for all lanes (as in `Ray4::for_ray`).
            let a = d.map(|d| _mm512_castsi512_ps(abs(d)));
            let greater = |i: usize, j: usize| _mm512_cmp_ps_mask::<_CMP_GT_OQ>(a[i], a[j]);
            let (x_y, x_z, y_z) = (greater(0, 1), greater(0, 2), greater(1, 2));
            let largest_x = x_y & x_z;
            let largest_y = !x_y & y_z;
            let kz = match (largest_x, largest_y) {
                (0xffff, _) => 0,
                (_, 0xffff) => 1,
                (0, 0) => 2,
                _ => return false,
            };
            let axes = PERMUTATION[kz];
            let shear_z = inv[kz];
            let shear = [
                _mm512_mul_ps(xor(d[axes[0]], sign), shear_z),
                _mm512_mul_ps(xor(d[axes[1]], sign), shear_z),
                shear_z,
            ];
            let inv_min = Vec3A::from_array(inv.map(|v| _mm512_reduce_min_ps(v)));
            let inv_max = Vec3A::from_array(inv.map(|v| _mm512_reduce_max_ps(v)));
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
            let triangle_packet = TrianglePacket16 {
                axes,
                origin: [o[axes[0]], o[axes[1]], o[axes[2]]],
                shear,
            };
            let mut hits = Hits16::new();
            let stack = &mut [const { MaybeUninit::uninit() }; STACK_SIZE];
            // SAFETY: the tree's stack need fits STACK_SIZE (the caller's contract).
            nearest_first(
                nodes,
                root,
                f32::INFINITY,
                stack,
                #[inline(always)]
                |node, packet_tmax| nodes.test_packet(node, &box_packet, packet_tmax),
                #[inline(always)]
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
                    _mm512_reduce_max_ps(hits.t)
                },
            );
            *out = hits.finish();
            true
        }
    };
}

packet16_kernel!(
    /// The closest hits, in (0, ∞), of the rays from `origin` along the unit directions `dirs`,
    /// written to `out`; false when they cannot be traced as one packet (directions in different
    /// octants or with different largest axes, or a NaN).
    ///
    /// # Safety
    /// The CPU must have AVX-512 ([`super::available`]), `root` must be an inner node of
    /// `nodes` (or a leaf of `leaves`), and the tree's stack need must fit [`STACK_SIZE`].
    closest_hits16_8,
    Nodes8
);

packet16_kernel!(
    /// [`closest_hits16_8`] through sixteen-wide nodes.
    ///
    /// # Safety
    /// As for [`closest_hits16_8`].
    closest_hits16_16,
    Nodes16
);

/// The closest hit of each lane's ray so far (see the eight-ray packets' `Hits`).
#[derive(Clone, Copy)]
struct Hits16 {
    t: __m512,
    det: __m512,
    v: __m512,
    w: __m512,
    prim: __m512i,
}

impl Hits16 {
    #[inline(always)]
    unsafe fn new() -> Self {
        Self {
            t: _mm512_set1_ps(f32::INFINITY),
            det: _mm512_set1_ps(1.0),
            v: _mm512_setzero_ps(),
            w: _mm512_setzero_ps(),
            prim: _mm512_set1_epi32(-1),
        }
    }

    #[inline(always)]
    unsafe fn t_of(&self, k: usize) -> f32 {
        lanes(self.t)[k]
    }

    /// Lane `k` takes a hit found by a single-ray test (barycentrics already divided). Out of
    /// line (rare), compiled with AVX-512 like its callers.
    #[inline(never)]
    #[target_feature(enable = "avx512f,avx512bw,avx512vl,avx2,fma")]
    unsafe fn set(&mut self, k: usize, t: f32, prim: u32, b1: f32, b2: f32) {
        let with = |v: __m512, x: f32| {
            let mut a = lanes(v);
            a[k] = x;
            _mm512_loadu_ps(a.as_ptr())
        };
        self.t = with(self.t, t);
        self.det = with(self.det, 1.0);
        self.v = with(self.v, b1);
        self.w = with(self.w, b2);
        self.prim = _mm512_castps_si512(with(_mm512_castsi512_ps(self.prim), f32::from_bits(prim)));
    }

    /// Lanes in `mask` take `other`'s values.
    #[inline(always)]
    unsafe fn blend(&mut self, other: &Hits16, mask: __mmask16) {
        self.t = _mm512_mask_blend_ps(mask, self.t, other.t);
        self.det = _mm512_mask_blend_ps(mask, self.det, other.det);
        self.v = _mm512_mask_blend_ps(mask, self.v, other.v);
        self.w = _mm512_mask_blend_ps(mask, self.w, other.w);
        self.prim = _mm512_mask_blend_epi32(mask, self.prim, other.prim);
    }

    #[inline(always)]
    unsafe fn finish(&self) -> [Option<ClosestHit>; PACKET16] {
        let t = lanes(self.t);
        let b1 = lanes(_mm512_div_ps(self.v, self.det));
        let b2 = lanes(_mm512_div_ps(self.w, self.det));
        let mut prim = [0u32; PACKET16];
        _mm512_storeu_si512(prim.as_mut_ptr().cast(), self.prim);
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
unsafe fn lanes(v: __m512) -> [f32; PACKET16] {
    let mut a = [0.0; PACKET16];
    _mm512_storeu_ps(a.as_mut_ptr(), v);
    a
}

/// The packet's constants of the watertight triangle test: the shared axis permutation and
/// origin, and each lane's shear.
struct TrianglePacket16 {
    axes: [usize; 3],
    origin: [f32; 3],
    shear: [__m512; 3],
}

impl TrianglePacket16 {
    /// The eight-ray packets' `TrianglePacket::intersect`, sixteen lanes at a time: the same
    /// arithmetic in the same order, comparisons into mask registers.
    #[inline(always)]
    unsafe fn intersect(
        &self,
        block: &Triangle4,
        hits: &mut Hits16,
        origin: Vec3A,
        dirs: &[Vec3A; PACKET16],
    ) {
        let before = *hits;
        let [kx, ky, kz] = self.axes;
        let [ox, oy, oz] = self.origin;
        let [sx, sy, sz] = self.shear;
        let zero = _mm512_setzero_ps();
        let mut exact_zero: __mmask16 = 0;
        for (lane, &prim) in block.prim.iter().enumerate() {
            if prim == u32::MAX {
                break; // unused lanes are the last ones
            }
            let p = |vertex: usize, axis: usize| block.coordinate(vertex, axis, lane);
            let (a_z, b_z, c_z) = (p(0, kz) - oz, p(1, kz) - oz, p(2, kz) - oz);
            let sheared = |x: f32, s: __m512, z: f32| {
                _mm512_add_ps(_mm512_set1_ps(x), _mm512_mul_ps(s, _mm512_set1_ps(z)))
            };
            let ax = sheared(p(0, kx) - ox, sx, a_z);
            let ay = sheared(p(0, ky) - oy, sy, a_z);
            let bx = sheared(p(1, kx) - ox, sx, b_z);
            let by = sheared(p(1, ky) - oy, sy, b_z);
            let cx = sheared(p(2, kx) - ox, sx, c_z);
            let cy = sheared(p(2, ky) - oy, sy, c_z);
            let u = _mm512_sub_ps(_mm512_mul_ps(cx, by), _mm512_mul_ps(cy, bx));
            let v = _mm512_sub_ps(_mm512_mul_ps(ax, cy), _mm512_mul_ps(ay, cx));
            let w = _mm512_sub_ps(_mm512_mul_ps(bx, ay), _mm512_mul_ps(by, ax));
            let eq = |x| _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(x, zero);
            let lt = |x| _mm512_cmp_ps_mask::<_CMP_LT_OQ>(x, zero);
            let gt = |x| _mm512_cmp_ps_mask::<_CMP_GT_OQ>(x, zero);
            exact_zero |= eq(u) | eq(v) | eq(w);
            let negative = lt(u) | lt(v) | lt(w);
            let positive = gt(u) | gt(v) | gt(w);
            let det = _mm512_add_ps(_mm512_add_ps(u, v), w);
            let scaled = |z: f32| _mm512_mul_ps(sz, _mm512_set1_ps(z));
            let t_num = _mm512_add_ps(
                _mm512_add_ps(_mm512_mul_ps(u, scaled(a_z)), _mm512_mul_ps(v, scaled(b_z))),
                _mm512_mul_ps(w, scaled(c_z)),
            );
            let t = _mm512_div_ps(t_num, det);
            let hit = !(negative & positive) & gt(t) & _mm512_cmp_ps_mask::<_CMP_LT_OQ>(t, hits.t);
            let found = Hits16 {
                t,
                det,
                v,
                w,
                prim: _mm512_set1_epi32(prim as i32),
            };
            hits.blend(&found, hit);
        }
        if exact_zero != 0 {
            hits.blend(&before, exact_zero);
            let mut fallback = exact_zero as u32;
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
