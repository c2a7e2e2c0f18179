//! Four triangles tested against one ray at once: the watertight test of
//! [`crate::shapes::triangle::intersect_triangle_pre`] (Woop, Benthin and Wald 2013) on 4-wide SIMD lanes.
//!
//! The vertices are stored structure-of-arrays, one `Vec4` per vertex and axis, so the per-ray
//! axis permutation of the watertight test is just a choice of which array to read. Unused lanes
//! hold NaN vertices: every comparison on them is false, so they never report a hit.

use crate::ray::Ray;
use crate::shapes::triangle::{intersect_triangle_pre, WatertightRay, PERMUTATION};
use glam::{Vec3A, Vec3Swizzles, Vec4};

/// Up to four triangles in structure-of-arrays layout, with their primitive indices.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub(crate) struct Triangle4 {
    /// `v[vertex][axis]`: lane i holds triangle i's vertex coordinate.
    v: [[Vec4; 3]; 3],
    /// The primitive index of each lane (meaningless for unused lanes).
    pub(crate) prim: [u32; 4],
}

impl Triangle4 {
    /// Packs up to four triangles `(p0, p1, p2, primitive index)`.
    pub(crate) fn new(tris: &[(Vec3A, Vec3A, Vec3A, u32)]) -> Self {
        assert!(!tris.is_empty() && tris.len() <= 4, "1 to 4 triangles");
        let mut v = [[[f32::NAN; 4]; 3]; 3];
        let mut prim = [u32::MAX; 4];
        for (lane, &(p0, p1, p2, index)) in tris.iter().enumerate() {
            for (vertex, p) in [p0, p1, p2].into_iter().enumerate() {
                for axis in 0..3 {
                    v[vertex][axis][lane] = p[axis];
                }
            }
            prim[lane] = index;
        }
        Self {
            v: v.map(|vertex| vertex.map(Vec4::from_array)),
            prim,
        }
    }

    /// Coordinate `axis` of vertex `vertex` of the triangle in `lane` (NaN in unused lanes).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) fn coordinate(&self, vertex: usize, axis: usize, lane: usize) -> f32 {
        // Through a reference, not `to_array`: one broadcast from memory, not a copy first.
        let lanes: &[f32; 4] = self.v[vertex][axis].as_ref();
        lanes[lane]
    }

    /// The vertices of one lane.
    fn lane(&self, lane: usize) -> (Vec3A, Vec3A, Vec3A) {
        let p = |vertex: usize| {
            Vec3A::new(
                self.v[vertex][0][lane],
                self.v[vertex][1][lane],
                self.v[vertex][2][lane],
            )
        };
        (p(0), p(1), p(2))
    }

    /// Whether the ray hits any of the four with t in (0, tmax): what an any-hit query needs,
    /// without the closest lane's distance and barycentrics.
    #[inline(always)]
    pub(crate) fn occludes(&self, r: &Ray4, ray: &Ray, tmax: f32) -> bool {
        let Some(e) = self.edges(r) else {
            return self.intersect_scalar(ray, tmax).is_some();
        };
        // The closest-hit conditions without its division: in a lane whose edge functions share
        // a sign, det is non-zero with that sign, and 0 < t_num / det < tmax reads
        // 0 < t_num s < tmax |det| with s = sign(det).
        let t_scaled = flip_sign_by(e.t_num, e.det);
        let inside = t_scaled.cmpgt(Vec4::ZERO) & t_scaled.cmplt(e.det.abs() * Vec4::splat(tmax));
        inside.bitmask() & !e.mixed.is_negative_bitmask() != 0
    }

    /// The closest hit among the four with t in (0, tmax): (lane, t, b1, b2), where b1 and b2
    /// weight vertices 1 and 2.
    #[inline(always)]
    pub(crate) fn intersect(
        &self,
        r: &Ray4,
        ray: &Ray,
        tmax: f32,
    ) -> Option<(usize, f32, f32, f32)> {
        let Some(EdgeTest {
            v,
            w,
            det,
            t_num,
            mixed,
        }) = self.edges(r)
        else {
            return self.intersect_scalar(ray, tmax);
        };
        let t = t_num / det;
        let in_range = t.cmpgt(Vec4::ZERO) & t.cmplt(Vec4::splat(tmax));
        let mut bits = in_range.bitmask() & !mixed.is_negative_bitmask();
        if bits == 0 {
            return None;
        }
        let ts = t.to_array();
        let mut best = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        while bits != 0 {
            let lane = bits.trailing_zeros() as usize;
            if ts[lane] < ts[best] {
                best = lane;
            }
            bits &= bits - 1;
        }
        let det = det.to_array()[best];
        Some((
            best,
            ts[best],
            v.to_array()[best] / det,
            w.to_array()[best] / det,
        ))
    }

    /// The watertight test's sheared edge functions and distance numerator for the four lanes;
    /// None when an edge function is exactly zero in some lane, which needs the double-precision
    /// fallback of the scalar test (rare, so the whole block takes the scalar path then).
    #[inline(always)]
    fn edges(&self, r: &Ray4) -> Option<EdgeTest> {
        let [kx, ky, kz] = r.axes;
        let (sx, sy, sz) = (r.shear[0], r.shear[1], r.shear[2]);
        let [ox, oy, oz] = r.origin;
        let (v0, v1, v2) = (&self.v[0], &self.v[1], &self.v[2]);
        let (a_z, b_z, c_z) = (v0[kz] - oz, v1[kz] - oz, v2[kz] - oz);
        let ax = (v0[kx] - ox) + sx * a_z;
        let ay = (v0[ky] - oy) + sy * a_z;
        let bx = (v1[kx] - ox) + sx * b_z;
        let by = (v1[ky] - oy) + sy * b_z;
        let cx = (v2[kx] - ox) + sx * c_z;
        let cy = (v2[ky] - oy) + sy * c_z;

        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        let zero = Vec4::ZERO;
        if (u.cmpeq(zero) | v.cmpeq(zero) | w.cmpeq(zero)).any() {
            return None;
        }
        Some(EdgeTest {
            v,
            w,
            det: u + v + w,
            t_num: u * (sz * a_z) + v * (sz * b_z) + w * (sz * c_z),
            mixed: mixed_signs(u, v, w),
        })
    }

    /// The scalar test on every used lane: exact agreement with the one-triangle path. Takes the
    /// ray, not its precomputed constants: built here, they stay out of the callers' set-up
    /// (inlined into a traversal, the compiler hoisted them into every query's prologue).
    #[cold]
    #[inline(never)]
    fn intersect_scalar(&self, ray: &Ray, tmax: f32) -> Option<(usize, f32, f32, f32)> {
        let wr = &WatertightRay::new(ray);
        let mut best: Option<(usize, f32, f32, f32)> = None;
        for lane in 0..4 {
            if self.prim[lane] == u32::MAX {
                continue;
            }
            let (p0, p1, p2) = self.lane(lane);
            let limit = best.map_or(tmax, |b| b.1);
            if let Some(h) = intersect_triangle_pre(wr, p0, p1, p2, limit) {
                best = Some((lane, h.t, h.b1, h.b2));
            }
        }
        best
    }
}

/// The per-lane quantities of the watertight test that the closest-hit and any-hit tests share:
/// edge functions v and w (u is folded into det), their sum det, the scaled distance numerator
/// (t = t_num / det), and `mixed`, negative in the lanes whose edge functions differ in sign (the
/// ray passes outside).
struct EdgeTest {
    v: Vec4,
    w: Vec4,
    det: Vec4,
    t_num: Vec4,
    mixed: Vec4,
}

/// Negative (sign bit set) in the lanes where u, v and w do not all share a sign, for edge
/// functions none of which is zero ([`Triangle4::edges`] sends those to the scalar test): then
/// the signs are the sign bits, and two XORs and an OR of them decide what six comparisons did.
/// A lane with a NaN edge function may come out either way; its det and t are NaN, which no
/// distance test accepts.
#[inline(always)]
fn mixed_signs(u: Vec4, v: Vec4, w: Vec4) -> Vec4 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{__m128, _mm_or_ps, _mm_xor_ps};
        let (u, v, w) = (__m128::from(u), __m128::from(v), __m128::from(w));
        // SAFETY: SSE is part of the x86-64 baseline.
        Vec4::from(unsafe { _mm_or_ps(_mm_xor_ps(u, v), _mm_xor_ps(u, w)) })
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let zero = Vec4::ZERO;
        let negative = u.cmplt(zero) | v.cmplt(zero) | w.cmplt(zero);
        let positive = u.cmpgt(zero) | v.cmpgt(zero) | w.cmpgt(zero);
        Vec4::select(negative & positive, Vec4::NEG_ONE, Vec4::ONE)
    }
}

/// `x` times the sign of `s` (`x * s.signum()` for non-NaN `s`): the sign bit of `s` flipped
/// into `x`, exact like the product.
#[inline(always)]
fn flip_sign_by(x: Vec4, s: Vec4) -> Vec4 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{__m128, _mm_and_ps, _mm_set1_ps, _mm_xor_ps};
        // SAFETY: SSE is part of the x86-64 baseline.
        Vec4::from(unsafe {
            let sign = _mm_and_ps(__m128::from(s), _mm_set1_ps(-0.0));
            _mm_xor_ps(__m128::from(x), sign)
        })
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        x * s.signum()
    }
}

/// Per-ray constants of the 4-wide watertight test: the permuted axes, the shear and the
/// origin splatted to all lanes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Ray4 {
    axes: [usize; 3],
    shear: [Vec4; 3],
    origin: [Vec4; 3],
}

impl Ray4 {
    /// The constants of `ray`, whose reciprocal direction is `inv`: those of
    /// `WatertightRay::with_reciprocal(ray, inv)`, with the largest axis found by one 3-lane
    /// comparison (|x| > |y|, |x| > |z|, |y| > |z| in its bits 0-2, as `largest_axis` indexes its
    /// table) instead of three scalar ones: the set-up every query pays, short shadow rays
    /// included.
    #[inline(always)]
    pub(crate) fn for_ray(ray: &Ray, inv: Vec3A) -> Self {
        let kz = Self::largest_axis(ray.dir);
        let axes = PERMUTATION[kz];
        let (d, inv, o) = (ray.dir.to_array(), inv.to_array(), ray.origin.to_array());
        let sz = inv[kz];
        Self {
            axes,
            shear: [
                Vec4::splat(-d[axes[0]] * sz),
                Vec4::splat(-d[axes[1]] * sz),
                Vec4::splat(sz),
            ],
            origin: [
                Vec4::splat(o[axes[0]]),
                Vec4::splat(o[axes[1]]),
                Vec4::splat(o[axes[2]]),
            ],
        }
    }

    /// The permuted axes, the shear and the origin along the permuted axes: one lane of a
    /// shadow packet.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) fn lane_constants(&self) -> ([usize; 3], [f32; 3], [f32; 3]) {
        (self.axes, self.shear.map(|s| s.x), self.origin.map(|o| o.x))
    }

    /// The watertight test's axis z for direction `dir`: the largest by the comparison bits
    /// (`shapes::triangle::largest_axis`'s table).
    #[inline(always)]
    pub(crate) fn largest_axis(dir: Vec3A) -> usize {
        const LARGEST: [usize; 8] = [2, 2, 2, 0, 1, 2, 1, 0];
        let ad = dir.abs();
        LARGEST[ad.xxy().cmpgt(ad.yzz()).bitmask() as usize & 7]
    }

    /// The constants from a [`WatertightRay`]: the reference [`Ray4::for_ray`] is tested against
    /// (the traversals build theirs with `for_ray`).
    #[cfg(test)]
    #[inline(always)]
    pub(crate) fn new(wr: &WatertightRay, origin: Vec3A) -> Self {
        let axes = wr.axes();
        let shear = wr.shear();
        let origin = origin.to_array();
        Self {
            axes,
            shear: [
                Vec4::splat(shear.x),
                Vec4::splat(shear.y),
                Vec4::splat(shear.z),
            ],
            origin: [
                Vec4::splat(origin[axes[0]]),
                Vec4::splat(origin[axes[1]]),
                Vec4::splat(origin[axes[2]]),
            ],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every lane agrees with the scalar test, hits and misses alike, including unused lanes.
    #[test]
    fn agrees_with_the_scalar_test() {
        let mut rng = torrey_testkit::Rng::new(0x9e37_79b9);
        let mut rnd = || rng.range(-1.0, 1.0);
        let mut hits = 0;
        for case in 0..20_000 {
            let count = 1 + case % 4;
            let tris: Vec<_> = (0..count)
                .map(|i| {
                    let c = Vec3A::new(rnd(), rnd(), rnd());
                    let p1 = c + Vec3A::new(rnd(), rnd(), rnd());
                    let p2 = c + Vec3A::new(rnd(), rnd(), rnd());
                    (c, p1, p2, 10 + i as u32)
                })
                .collect();
            let block = Triangle4::new(&tris);
            // Aim near the first triangle's centroid so that hits are common.
            let origin = Vec3A::new(rnd(), rnd(), rnd()) * 3.0;
            let target =
                (tris[0].0 + tris[0].1 + tris[0].2) / 3.0 + Vec3A::new(rnd(), rnd(), rnd()) * 0.3;
            let ray = Ray {
                origin,
                dir: (target - origin).normalize(),
                tmax: f32::INFINITY,
            };
            let tmax = if case % 3 == 0 { 1.5 } else { f32::INFINITY };
            let wr = WatertightRay::new(&ray);
            let simd = block.intersect(&Ray4::new(&wr, ray.origin), &ray, tmax);
            let scalar = block.intersect_scalar(&ray, tmax);
            let occludes = block.occludes(&Ray4::new(&wr, ray.origin), &ray, tmax);
            assert_eq!(occludes, simd.is_some(), "any-hit and closest-hit disagree");
            match (simd, scalar) {
                (None, None) => {}
                (Some(a), Some(b)) => {
                    hits += 1;
                    assert_eq!(a.0, b.0, "lane");
                    assert!((a.1 - b.1).abs() <= 1e-5 * b.1.max(1.0), "{a:?} vs {b:?}");
                    assert!((a.2 - b.2).abs() < 1e-4 && (a.3 - b.3).abs() < 1e-4);
                    assert_eq!(block.prim[a.0], 10 + a.0 as u32);
                }
                other => panic!("simd and scalar disagree: {other:?}"),
            }
        }
        assert!(hits > 5000, "the test rays should hit often, got {hits}");
    }

    /// `Ray4::for_ray` builds the constants `Ray4::new` builds from a `WatertightRay`, bit for
    /// bit, on random directions and on ties, zeros, infinities and NaNs.
    #[test]
    fn for_ray_matches_the_watertight_constants() {
        let mut rng = torrey_testkit::Rng::new(77);
        let special = [0.0, -0.0, 1.0, -1.0, 0.5, f32::INFINITY, f32::NAN, 1e-30];
        let mut dirs = Vec::new();
        for &x in &special {
            for &y in &special {
                for &z in &special {
                    dirs.push(Vec3A::new(x, y, z));
                }
            }
        }
        for _ in 0..10_000 {
            dirs.push(Vec3A::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            ));
        }
        for dir in dirs {
            let ray = Ray {
                origin: Vec3A::new(0.25, -3.0, 7.5),
                dir,
                tmax: f32::INFINITY,
            };
            let inv = crate::accel::traversal::reciprocal(&ray);
            let a = Ray4::for_ray(&ray, inv);
            let b = Ray4::new(&WatertightRay::with_reciprocal(&ray, inv), ray.origin);
            assert_eq!(a.axes, b.axes, "{dir:?}");
            let bits =
                |r: &Ray4| [r.shear, r.origin].map(|v| v.map(|l| l.to_array().map(f32::to_bits)));
            assert_eq!(bits(&a), bits(&b), "{dir:?}");
        }
    }

    /// A ray through a vertex shared by triangles hits (exact zero edge functions).
    #[test]
    fn shared_vertex_is_hit() {
        let block = Triangle4::new(&[
            (Vec3A::ZERO, Vec3A::X, Vec3A::Y, 0),
            (Vec3A::ZERO, Vec3A::Y, -Vec3A::X, 1),
        ]);
        let ray = Ray {
            origin: Vec3A::new(0.0, 0.0, 1.0),
            dir: -Vec3A::Z,
            tmax: f32::INFINITY,
        };
        let wr = WatertightRay::new(&ray);
        let hit = block.intersect(&Ray4::new(&wr, ray.origin), &ray, f32::INFINITY);
        assert!(hit.is_some_and(|h| (h.1 - 1.0).abs() < 1e-6));
    }
}
