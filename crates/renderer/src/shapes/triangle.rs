//! Triangles: the watertight ray test (Woop, Benthin and Wald 2013), shared by the single-ray
//! path and the BVH's four-wide blocks, and uniform sampling by area for emitting meshes.

use crate::ray::Ray;
use glam::{Vec2, Vec3A};

/// Result of a triangle test: distance and the barycentrics of vertices 1 and 2.
#[derive(Clone, Copy, Debug)]
pub struct TriangleHit {
    pub t: f32,
    pub b1: f32,
    pub b2: f32,
}

/// Per-ray constants of the watertight triangle test: the axis permutation that makes the ray
/// direction's largest component z, and the shear that maps the direction to +z. Computed once
/// per ray, then shared by every triangle the traversal visits.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    origin: Vec3A,
    /// The axis of the direction's largest component; the permutation (kz+1, kz+2, kz) mod 3 is
    /// cyclic, so it is one swizzle chosen by kz.
    kz: u8,
    shear: Vec3A,
}

impl WatertightRay {
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let kz = largest_axis(ray.dir);
        let dp = permute(ray.dir, kz);
        Self::with_shear(ray, kz, dp, 1.0 / dp.z)
    }

    /// [`WatertightRay::new`] for a ray whose reciprocal direction `inv` is at hand (the box test
    /// computes it): 1/d along the largest axis is one of its lanes, so the division is shared.
    /// With [`WatertightRay::axes`] and [`WatertightRay::shear`], the reference the SIMD tests'
    /// constants (`Ray4::for_ray`) are checked against.
    #[cfg(test)]
    #[inline]
    pub fn with_reciprocal(ray: &Ray, inv: Vec3A) -> Self {
        let kz = largest_axis(ray.dir);
        // The permutation moves axis kz to z, so the permuted 1/d_z is simply 1/d[kz]. Read
        // through an array: glam's `Index` is a `match`, a three-way branch on a random axis.
        let sz = [inv.x, inv.y, inv.z, inv.z][kz as usize & 3];
        Self::with_shear(ray, kz, permute(ray.dir, kz), sz)
    }

    #[inline(always)]
    fn with_shear(ray: &Ray, kz: u8, dp: Vec3A, sz: f32) -> Self {
        Self {
            origin: ray.origin,
            kz,
            shear: Vec3A::new(-dp.x * sz, -dp.y * sz, sz),
        }
    }

    #[inline(always)]
    fn permute(&self, v: Vec3A) -> Vec3A {
        permute(v, self.kz)
    }

    /// The source axes of the permuted x, y and z: `permute(v) == (v[axes[0]], v[axes[1]], v[axes[2]])`.
    #[cfg(test)]
    #[inline(always)]
    pub fn axes(&self) -> [usize; 3] {
        PERMUTATION[self.kz as usize & 3]
    }

    /// The shear (sx, sy, sz) that maps the permuted direction to +z.
    #[cfg(test)]
    #[inline(always)]
    pub fn shear(&self) -> Vec3A {
        self.shear
    }
}

/// The axis of `d`'s largest component, from three comparisons and a table instead of a branch
/// tree (which mispredicts on random directions): bit 0 = |x| > |y|, bit 1 = |x| > |z|,
/// bit 2 = |y| > |z|.
#[inline(always)]
fn largest_axis(d: Vec3A) -> u8 {
    const LARGEST: [u8; 8] = [2, 2, 2, 0, 1, 2, 1, 0];
    let ad = d.abs();
    LARGEST[(ad.x > ad.y) as usize | ((ad.x > ad.z) as usize) << 1 | ((ad.y > ad.z) as usize) << 2]
}

/// The source axes of the cyclic permutation (kz+1, kz+2, kz) mod 3 that moves axis kz to z, by
/// kz (row 3 is padding, so that `kz & 3` needs no bounds check).
pub(crate) const PERMUTATION: [[usize; 3]; 4] = [[1, 2, 0], [2, 0, 1], [0, 1, 2], [0, 1, 2]];

/// Cyclic axis permutation that moves axis `kz` to z. Indexed loads rather than a `match`: kz is
/// random from ray to ray, and a branch on it mispredicted about once per ray in profiles.
#[inline(always)]
fn permute(v: Vec3A, kz: u8) -> Vec3A {
    let [x, y, z] = PERMUTATION[kz as usize & 3];
    let a = v.to_array();
    Vec3A::new(a[x], a[y], a[z])
}

/// Watertight ray/triangle intersection (Woop, Benthin and Wald 2013): edges shared by two
/// triangles are never missed by both, so closed meshes do not leak rays.
#[inline]
#[cfg(test)]
pub fn intersect_triangle(
    ray: &Ray,
    p0: Vec3A,
    p1: Vec3A,
    p2: Vec3A,
    tmax: f32,
) -> Option<TriangleHit> {
    intersect_triangle_pre(&WatertightRay::new(ray), p0, p1, p2, tmax)
}

/// [`intersect_triangle`] with the per-ray constants precomputed.
#[inline(always)]
pub fn intersect_triangle_pre(
    wr: &WatertightRay,
    p0: Vec3A,
    p1: Vec3A,
    p2: Vec3A,
    tmax: f32,
) -> Option<TriangleHit> {
    let (sx, sy, sz) = (wr.shear.x, wr.shear.y, wr.shear.z);
    let a = wr.permute(p0 - wr.origin);
    let b = wr.permute(p1 - wr.origin);
    let c = wr.permute(p2 - wr.origin);
    let ax = a.x + sx * a.z;
    let ay = a.y + sy * a.z;
    let bx = b.x + sx * b.z;
    let by = b.y + sy * b.z;
    let cx = c.x + sx * c.z;
    let cy = c.y + sy * c.z;

    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    // Fall back to double precision on the edges, where f32 cancellation decides the sign.
    if u == 0.0 || v == 0.0 || w == 0.0 {
        u = (cx as f64 * by as f64 - cy as f64 * bx as f64) as f32;
        v = (ax as f64 * cy as f64 - ay as f64 * cx as f64) as f32;
        w = (bx as f64 * ay as f64 - by as f64 * ax as f64) as f32;
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let az = sz * a.z;
    let bz = sz * b.z;
    let cz = sz * c.z;
    let t_scaled = u * az + v * bz + w * cz;
    // t = t_scaled / det must lie in (0, tmax); compare without dividing, respecting det's sign.
    if det < 0.0 && (t_scaled >= 0.0 || t_scaled < tmax * det) {
        return None;
    }
    if det > 0.0 && (t_scaled <= 0.0 || t_scaled > tmax * det) {
        return None;
    }
    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;
    if !(t > 0.0 && t < tmax) {
        return None;
    }
    // u weights p0, v weights p1, w weights p2.
    Some(TriangleHit {
        t,
        b1: v * inv_det,
        b2: w * inv_det,
    })
}

/// Uniformly samples a triangle by area: returns barycentrics (b1, b2) of the second and third
/// vertex (b0 = 1 - b1 - b2). Uses Heitz's low-distortion square-to-triangle warp, which keeps
/// stratified samples well spread.
#[inline]
pub fn sample_triangle_uniform(u: Vec2) -> (f32, f32) {
    // Heitz's two cases (u.x < u.y: b0 = u.x / 2, b1 = u.y - b0; else b1 = u.y / 2, b0 = u.x - b1)
    // from min and max, without a branch that mispredicts half the time.
    let half = 0.5 * u.x.min(u.y);
    let rest = u.x.max(u.y) - half;
    let (b0, b1) = torrey_fastmath::swap_if(u.x < u.y, rest, half);
    let b2 = (1.0 - b0 - b1).max(0.0);
    (b1, b2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use torrey_testkit::{assert_chi_square, Rng};

    #[test]
    fn triangle_samples_are_uniform() {
        // Reference triangle (0,0), (1,0), (0,1): the point is (b1, b2). Split it into n^2 equal
        // sub-triangles on a grid; each should get 1/n^2 of the samples.
        let n = 8usize;
        let samples = 100_000;
        let mut hist = vec![0.0f64; n * n * 2];
        let mut rng = Rng::new(10);
        for _ in 0..samples {
            let (b1, b2) = sample_triangle_uniform(rng.vec2());
            assert!(b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 + 1e-6, "{b1} {b2}");
            let (x, y) = (b1 * n as f32, b2 * n as f32);
            let (i, j) = ((x as usize).min(n - 1), (y as usize).min(n - 1));
            let upper = (x - i as f32) + (y - j as f32) > 1.0;
            hist[(j * n + i) * 2 + upper as usize] += 1.0;
        }
        let expected: Vec<f64> = (0..n * n * 2)
            .map(|k| {
                let (cell, upper) = (k / 2, k % 2 == 1);
                let (i, j) = (cell % n, cell / n);
                let inside = if upper { i + j + 1 < n } else { i + j < n };
                if inside {
                    samples as f64 / (n * n) as f64
                } else {
                    0.0
                }
            })
            .collect();
        assert_chi_square("sample_triangle_uniform", &hist, &expected);
    }

    fn ray(o: Vec3A, d: Vec3A) -> Ray {
        Ray {
            origin: o,
            dir: d,
            tmax: f32::INFINITY,
        }
    }

    #[test]
    fn triangle_hit_and_barycentrics() {
        let (p0, p1, p2) = (Vec3A::ZERO, Vec3A::X, Vec3A::Y);
        let h = intersect_triangle(
            &ray(Vec3A::new(0.25, 0.5, 1.0), -Vec3A::Z),
            p0,
            p1,
            p2,
            f32::INFINITY,
        )
        .unwrap();
        assert!((h.t - 1.0).abs() < 1e-6);
        assert!((h.b1 - 0.25).abs() < 1e-6 && (h.b2 - 0.5).abs() < 1e-6);
        // Either orientation of the ray hits (no culling).
        assert!(intersect_triangle(
            &ray(Vec3A::new(0.25, 0.25, -1.0), Vec3A::Z),
            p0,
            p1,
            p2,
            10.0
        )
        .is_some());
        // Outside and behind are misses; tmax is respected.
        assert!(
            intersect_triangle(&ray(Vec3A::new(0.8, 0.8, 1.0), -Vec3A::Z), p0, p1, p2, 10.0)
                .is_none()
        );
        assert!(
            intersect_triangle(&ray(Vec3A::new(0.2, 0.2, 1.0), Vec3A::Z), p0, p1, p2, 10.0)
                .is_none()
        );
        assert!(
            intersect_triangle(&ray(Vec3A::new(0.2, 0.2, 1.0), -Vec3A::Z), p0, p1, p2, 0.5)
                .is_none()
        );
    }

    #[test]
    fn shared_edge_is_watertight() {
        // Two triangles sharing the diagonal of a unit square; rays aimed exactly at the diagonal
        // must hit at least one of them.
        let (a, b, c, d) = (Vec3A::ZERO, Vec3A::X, Vec3A::new(1.0, 1.0, 0.0), Vec3A::Y);
        let mut misses = 0;
        for i in 0..1000 {
            let s = (i as f32 + 0.5) / 1000.0;
            let r = ray(
                Vec3A::new(s, s, 3.7),
                Vec3A::new(0.0001 * s, -0.0003, -1.0).normalize(),
            );
            let target = Vec3A::new(s, s, 0.0);
            let r = Ray {
                dir: (target - r.origin).normalize(),
                ..r
            };
            let h1 = intersect_triangle(&r, a, b, c, f32::INFINITY);
            let h2 = intersect_triangle(&r, a, c, d, f32::INFINITY);
            if h1.is_none() && h2.is_none() {
                misses += 1;
            }
        }
        assert_eq!(misses, 0);
    }
}
