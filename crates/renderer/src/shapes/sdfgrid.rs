//! Mitsuba 3's `sdfgrid`: the zero set of the trilinear interpolant of a grid of signed distances
//! spanning [0, 1]^3 in object space (sample (i, j, k) at (i / (nx − 1), j / (ny − 1),
//! k / (nz − 1))), placed by `to_world`.
//!
//! Every voxel whose corners are not all of one sign is a BVH primitive
//! ([`PrimGeom::SdfVoxel`]) bounded by the tight box of its piece of surface (the corners on it
//! and the crossings of its twelve edges, Hansson-Söderlund and Akenine-Möller 2023; the extent
//! of the zero set of a trilinear function along an axis ends at such points). A ray meets the
//! voxel where the interpolant along it, a cubic in t, first changes sign: the interval is cut
//! at the cubic's turning points into monotonic pieces, and the first piece whose ends differ
//! in sign holds the root, which a safeguarded Newton iteration finds (Marmitt et al. 2004, as
//! Mitsuba does). The values at the voxel's entry and exit faces are the bilinear interpolants
//! of those faces, so that two neighbours agree on their shared face and no hit falls between
//! them.
//!
//! Normals (Mitsuba 3.9.1's): the geometric normal is the interpolant's gradient in the hit's
//! voxel; the shading normal is the same (`normals` = `analytic`) or the smooth normal of
//! Hansson-Söderlund, Evans and Akenine-Möller (JCGT 2022), a trilinear blend of the gradients
//! of the eight voxels around the grid vertex nearest to the hit, each the finite differences
//! of the interpolant across that voxel along each axis, at the hit's position along the other
//! two (`smooth`, the default). Hits have no uv (zero), as in Mitsuba.

use super::object_rows::ObjectRows;
use super::PrimGeom;
use super::{PrimInfo, SurfaceHit};
use crate::ray::ClosestHit;
use crate::ray::Ray;
use glam::{Affine3A, Mat3A, Mat4, Vec2, Vec3A};
use std::sync::Arc;
use torrey_parser as desc;

/// A grid's samples and placement, read by the hits on its voxels.
#[derive(Clone, Debug)]
pub struct SdfGridData {
    pub grid: Arc<desc::SdfGrid>,
    pub to_world: Affine3A,
    pub to_object: Affine3A,
    /// The inverse transpose of `to_world`'s linear part: object normals to world normals.
    pub normal_matrix: Mat3A,
}

/// A voxel with surface, as a leaf of the BVH tests it: the map from world (or shape group)
/// space onto the voxel's unit cube and its eight corner samples (corner c at (c & 1,
/// c >> 1 & 1, c >> 2)).
#[derive(Clone, Copy, Debug)]
pub struct SdfVoxel {
    pub to_voxel: ObjectRows,
    pub values: [f32; 8],
}

/// An `sdfgrid` shape: its grid in [`crate::shapes::mesh::MeshData::sdf_grids`].
#[derive(Clone, Copy, Debug)]
pub struct SdfGridShape {
    pub grid: u32,
}

/// Where a voxel of the table ([`crate::shapes::mesh::MeshData::sdf_voxels`]) is: its cell
/// (i, j, k) in its grid, and its box (the BVH primitive's).
#[derive(Clone, Copy, Debug)]
pub struct SdfCell {
    pub cell: [u32; 3],
    pub min: Vec3A,
    pub max: Vec3A,
}

impl SdfGridData {
    /// The grid placed by `to_world`; None when the transform is singular or not finite.
    pub fn new(grid: Arc<desc::SdfGrid>, to_world: Mat4) -> Option<Self> {
        let to_world = Affine3A::from_mat4(to_world);
        let det = to_world.matrix3.determinant();
        if !(det.is_finite() && det != 0.0 && to_world.translation.is_finite()) {
            return None;
        }
        Some(Self {
            grid,
            to_world,
            to_object: to_world.inverse(),
            normal_matrix: to_world.matrix3.inverse().transpose(),
        })
    }

    /// Samples minus one along each axis: the voxels per axis.
    fn resolution(&self) -> Vec3A {
        let [nx, ny, nz] = self.grid.size;
        Vec3A::new((nx - 1) as f32, (ny - 1) as f32, (nz - 1) as f32)
    }

    /// Every voxel with surface as a BVH primitive, in the order x fastest, then y, then z;
    /// its record goes to `voxels` and its cell and box to `cells` (at the same index, the
    /// primitive's `index`).
    pub fn primitives(
        &self,
        voxels: &mut Vec<SdfVoxel>,
        cells: &mut Vec<SdfCell>,
    ) -> Vec<PrimGeom> {
        let g = &*self.grid;
        let [nx, ny, nz] = g.size;
        let res = self.resolution();
        let mut out = Vec::with_capacity(g.surface_voxels as usize);
        for k in 0..nz - 1 {
            for j in 0..ny - 1 {
                for i in 0..nx - 1 {
                    if !g.voxel_has_surface(i, j, k) {
                        continue;
                    }
                    let values = g.corners(i, j, k);
                    let cell = Vec3A::new(i as f32, j as f32, k as f32);
                    // Voxel cube -> object space: p = (cell + q) / res.
                    let to_object = Affine3A::from_mat3_translation(
                        glam::Mat3::from_diagonal((1.0 / res).into()),
                        (cell / res).into(),
                    );
                    let voxel_to_world = self.to_world * to_object;
                    let (lo, hi) = tight_box(&values);
                    // A little margin: rounding in the box tests must not lose hits on its
                    // boundary (the hit itself is confined to the voxel's cube).
                    let lo = (lo - 1e-3).max(Vec3A::ZERO);
                    let hi = (hi + 1e-3).min(Vec3A::ONE);
                    let mut min = Vec3A::splat(f32::INFINITY);
                    let mut max = Vec3A::splat(f32::NEG_INFINITY);
                    for c in 0..8 {
                        let q = Vec3A::new(
                            if c & 1 == 0 { lo.x } else { hi.x },
                            if c & 2 == 0 { lo.y } else { hi.y },
                            if c & 4 == 0 { lo.z } else { hi.z },
                        );
                        let p = voxel_to_world.transform_point3a(q);
                        min = min.min(p);
                        max = max.max(p);
                    }
                    let pad = (max - min) * 1e-5 + max.abs().max(min.abs()) * 4.0 * f32::EPSILON;
                    let index = voxels.len() as u32;
                    let (min, max) = (min - pad, max + pad);
                    voxels.push(SdfVoxel {
                        to_voxel: ObjectRows::from_affine(voxel_to_world.inverse()),
                        values,
                    });
                    cells.push(SdfCell {
                        cell: [i, j, k],
                        min,
                        max,
                    });
                    out.push(PrimGeom::SdfVoxel { min, max, index });
                }
            }
        }
        out
    }

    /// The surface at `hit` along `ray` on the voxel in `cell`.
    pub fn surface(
        &self,
        ray: &Ray,
        prim: &PrimInfo,
        hit: &ClosestHit,
        cell: [u32; 3],
    ) -> SurfaceHit {
        let p = ray.origin + hit.t * ray.dir;
        let local = self.to_object.transform_point3a(p);
        let [i, j, k] = cell;
        let res = self.resolution();
        let cell = Vec3A::new(i as f32, j as f32, k as f32);
        let w = (local * res - cell).clamp(Vec3A::ZERO, Vec3A::ONE);
        let grad = trilinear_gradient(&self.grid.corners(i, j, k), w) * res;
        let ng = (self.normal_matrix * grad).normalize_or_zero();
        let ns = if self.grid.smooth_normals {
            (self.normal_matrix * smooth_normal(&self.grid, local)).normalize_or(ng)
        } else {
            ng
        };
        SurfaceHit {
            t: hit.t,
            p,
            ng,
            ns,
            uv: Vec2::ZERO,
            dpdu: Vec3A::ZERO,
            dpdv: Vec3A::ZERO,
            bary: Vec2::ZERO,
            shape: prim.shape,
            prim: hit.prim,
        }
    }
}

/// The box (in the voxel's unit cube) of the zero set of the trilinear interpolant of `f`:
/// the corners where f is 0 and the points where an edge's values change sign.
pub fn tight_box(f: &[f32; 8]) -> (Vec3A, Vec3A) {
    let corner = |c: usize| Vec3A::new((c & 1) as f32, (c >> 1 & 1) as f32, (c >> 2) as f32);
    let mut lo = Vec3A::ONE;
    let mut hi = Vec3A::ZERO;
    for (c, &v) in f.iter().enumerate() {
        if v == 0.0 {
            lo = lo.min(corner(c));
            hi = hi.max(corner(c));
        }
    }
    for (c, &a) in f.iter().enumerate() {
        for axis in 0..3 {
            if c & (1 << axis) != 0 {
                continue;
            }
            let b = f[c | 1 << axis];
            if a * b <= 0.0 && a != b {
                let mut p = corner(c);
                p[axis] = a / (a - b);
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
    }
    if lo.cmpgt(hi).any() {
        // Cannot happen for a voxel with surface; keep the whole cube then.
        return (Vec3A::ZERO, Vec3A::ONE);
    }
    (lo, hi)
}

/// The trilinear interpolant of corner values `f` at `p` in the unit cube.
#[inline]
pub fn trilinear(f: &[f32; 8], p: Vec3A) -> f32 {
    let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
    let x00 = lerp(f[0], f[1], p.x);
    let x10 = lerp(f[2], f[3], p.x);
    let x01 = lerp(f[4], f[5], p.x);
    let x11 = lerp(f[6], f[7], p.x);
    lerp(lerp(x00, x10, p.y), lerp(x01, x11, p.y), p.z)
}

/// Its gradient (per unit of the cube): each partial derivative is the bilinear interpolant of
/// the differences along the four parallel edges.
#[inline]
pub fn trilinear_gradient(f: &[f32; 8], p: Vec3A) -> Vec3A {
    let bilerp = |v: [f32; 4], u: f32, w: f32| {
        let a = v[0] + (v[1] - v[0]) * u;
        let b = v[2] + (v[3] - v[2]) * u;
        a + (b - a) * w
    };
    Vec3A::new(
        bilerp(
            [f[1] - f[0], f[3] - f[2], f[5] - f[4], f[7] - f[6]],
            p.y,
            p.z,
        ),
        bilerp(
            [f[2] - f[0], f[3] - f[1], f[6] - f[4], f[7] - f[5]],
            p.x,
            p.z,
        ),
        bilerp(
            [f[4] - f[0], f[5] - f[1], f[6] - f[2], f[7] - f[3]],
            p.x,
            p.y,
        ),
    )
}

/// The smooth normal at object-space point `p` (not normalised, object space): Mitsuba 3.9.1's
/// blend of the gradients of the eight voxels around the grid vertex nearest to `p`.
pub fn smooth_normal(grid: &desc::SdfGrid, p: Vec3A) -> Vec3A {
    let size = grid.size.map(|s| s as i64);
    let res = Vec3A::new(
        (size[0] - 1) as f32,
        (size[1] - 1) as f32,
        (size[2] - 1) as f32,
    );
    let sp = p * res;
    // The lower corner of the 2 x 2 x 2 voxels around the nearest vertex, and where p is
    // between their centres.
    let v: [i64; 3] = std::array::from_fn(|a| sp[a].round() as i64 - 1);
    let mut uvw = Vec3A::new(
        sp.x - v[0] as f32 - 0.5,
        sp.y - v[1] as f32 - 0.5,
        sp.z - v[2] as f32 - 0.5,
    );
    // The cell holding p, and p in it.
    let cell: [i64; 3] = std::array::from_fn(|a| (sp[a].floor() as i64).clamp(0, size[a] - 2));
    let w = Vec3A::new(
        sp.x - cell[0] as f32,
        sp.y - cell[1] as f32,
        sp.z - cell[2] as f32,
    );
    let sample = |q: [i64; 3]| {
        let c: [u32; 3] = std::array::from_fn(|a| q[a].clamp(0, size[a] - 1) as u32);
        grid.value(c[0], c[1], c[2])
    };
    // The interpolant on the sample plane q along axis a, at p along the other two.
    let plane = |a: usize, q: i64| {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        let f: [f32; 4] = std::array::from_fn(|n| {
            let mut idx = [0i64; 3];
            idx[a] = q;
            idx[b] = cell[b] + (n & 1) as i64;
            idx[c] = cell[c] + (n >> 1) as i64;
            sample(idx)
        });
        let lo = f[0] + (f[1] - f[0]) * w[b];
        let hi = f[2] + (f[3] - f[2]) * w[b];
        lo + (hi - lo) * w[c]
    };
    // Along each axis, the differences across the pair's lower voxel (d0) and upper one (d1):
    // one of them is the cell holding p, the other reaches the next sample plane on the other
    // side (zero past the grid's end, where indices are clamped).
    let mut d0 = Vec3A::ZERO;
    let mut d1 = Vec3A::ZERO;
    for a in 0..3 {
        let upper = cell[a] != v[a];
        let g0 = plane(a, cell[a]);
        let g1 = plane(a, cell[a] + 1);
        let gq = plane(a, cell[a] + if upper { -1 } else { 2 });
        let dc = g1 - g0;
        let dq = if upper { g0 - gq } else { gq - g1 };
        d0[a] = if upper { dq } else { dc } * res[a];
        d1[a] = if upper { dc } else { dq } * res[a];
    }
    // Voxels before the grid's start take no part: their blending weight is zero.
    let inside: [bool; 3] = std::array::from_fn(|a| v[a] >= 0);
    for a in 0..3 {
        if !inside[a] {
            uvw[a] = 1.0;
        }
    }
    let n: [Vec3A; 8] = std::array::from_fn(|i| {
        let hi = [i & 1 != 0, i & 2 != 0, i & 4 != 0];
        if (0..3).all(|a| hi[a] || inside[a]) {
            Vec3A::new(
                if hi[0] { d1.x } else { d0.x },
                if hi[1] { d1.y } else { d0.y },
                if hi[2] { d1.z } else { d0.z },
            )
            .normalize_or_zero()
        } else {
            Vec3A::ZERO
        }
    });
    let lerp = |a: Vec3A, b: Vec3A, t: f32| a + (b - a) * t;
    lerp(
        lerp(lerp(n[0], n[1], uvw.x), lerp(n[2], n[3], uvw.x), uvw.y),
        lerp(lerp(n[4], n[5], uvw.x), lerp(n[6], n[7], uvw.x), uvw.y),
        uvw.z,
    )
}

/// Ray / voxel intersection: the first t in (0, tmax) where the trilinear interpolant of the
/// voxel's corners is zero along the ray. t is the same in world and voxel space (the map is
/// affine and the direction is not renormalised).
#[inline(never)]
pub fn intersect_sdf_voxel(ray: &Ray, v: &SdfVoxel, tmax: f32) -> Option<f32> {
    let o = v.to_voxel.point(ray.origin);
    let d = v.to_voxel.vector(ray.dir);
    // Slab test against the unit cube, with the faces the ray enters and leaves by.
    let inv = Vec3A::ONE / d;
    let t_lo = (Vec3A::ZERO - o) * inv;
    let t_hi = (Vec3A::ONE - o) * inv;
    // A ray parallel to a slab: ±inf outside it; NaN on its boundary plane counts as inside.
    let near = t_lo.min(t_hi);
    let far = t_lo.max(t_hi);
    let near = Vec3A::select(near.is_nan_mask(), Vec3A::NEG_INFINITY, near);
    let far = Vec3A::select(far.is_nan_mask(), Vec3A::INFINITY, far);
    let t0 = near.max_element().max(0.0);
    let t1 = far.min_element().min(tmax);
    if t0.partial_cmp(&t1) != Some(std::cmp::Ordering::Less) {
        return None;
    }
    let f = &v.values;
    // Entry and exit points, snapped to the face crossed (where the interpolant is the face's
    // bilinear one, the same in both voxels sharing it).
    let snap = |t: f32, slab: Vec3A, toward: bool| {
        let p = o + d * t;
        let mut q = p.clamp(Vec3A::ZERO, Vec3A::ONE);
        for a in 0..3 {
            if slab[a] == t {
                // The face this axis's slab puts at t: where the ray enters (or leaves) it.
                q[a] = if (d[a] >= 0.0) == toward { 0.0 } else { 1.0 };
            }
        }
        q
    };
    let p0 = snap(t0, near, true);
    let p1 = snap(t1, far, false);
    let f0 = trilinear(f, p0);
    let f1 = trilinear(f, p1);
    // The interpolant along the ray as a cubic in s = t − t0, from the entry point.
    let e = o + d * t0;
    let k0 = f[0];
    let k1 = f[1] - f[0];
    let k2 = f[2] - f[0];
    let k4 = f[4] - f[0];
    let k3 = f[3] - f[2] - k1;
    let k5 = f[5] - f[4] - k1;
    let k6 = f[6] - f[4] - k2;
    let k7 = f[7] - f[6] - f[5] + f[4] - k3;
    let (ox, oy, oz) = (e.x, e.y, e.z);
    let (dx, dy, dz) = (d.x, d.y, d.z);
    let c0 = k0
        + k1 * ox
        + k2 * oy
        + k4 * oz
        + k3 * ox * oy
        + k5 * ox * oz
        + k6 * oy * oz
        + k7 * ox * oy * oz;
    let c1 = k1 * dx
        + k2 * dy
        + k4 * dz
        + k3 * (ox * dy + oy * dx)
        + k5 * (ox * dz + oz * dx)
        + k6 * (oy * dz + oz * dy)
        + k7 * (dx * oy * oz + ox * dy * oz + ox * oy * dz);
    let c2 = k3 * dx * dy
        + k5 * dx * dz
        + k6 * dy * dz
        + k7 * (ox * dy * dz + dx * oy * dz + dx * dy * oz);
    let c3 = k7 * dx * dy * dz;
    let s = first_root(t1 - t0, f0, f1, [c0, c1, c2, c3])?;
    let t = t0 + s;
    (t > 0.0 && t < tmax).then_some(t)
}

/// The first s in [0, len] where the cubic c0 + c1 s + c2 s² + c3 s³ changes sign, with f0 and
/// f1 its values at the ends (given: the faces' values); None without a sign change.
fn first_root(len: f32, f0: f32, f1: f32, c: [f32; 4]) -> Option<f32> {
    let eval = |s: f32| ((c[3] * s + c[2]) * s + c[1]) * s + c[0];
    let deriv = |s: f32| (3.0 * c[3] * s + 2.0 * c[2]) * s + c[1];
    // Turning points: roots of 3 c3 s² + 2 c2 s + c1, in order.
    let (a, b, cc) = (3.0 * c[3], 2.0 * c[2], c[1]);
    let mut turns = [f32::NAN; 2];
    if a != 0.0 {
        let disc = b as f64 * b as f64 - 4.0 * a as f64 * cc as f64;
        if disc >= 0.0 {
            let q = -0.5 * (b as f64 + (b as f64).signum() * disc.sqrt());
            let (r0, r1) = if q != 0.0 {
                ((q / a as f64) as f32, (cc as f64 / q) as f32)
            } else {
                (0.0, 0.0)
            };
            turns = [r0.min(r1), r0.max(r1)];
        }
    } else if b != 0.0 {
        turns[0] = -cc / b;
    }
    let (mut lo, mut hi, mut f_lo, mut f_hi) = (0.0f32, len, f0, f1);
    for r in turns {
        if !(r > lo && r < hi) {
            continue;
        }
        let fr = eval(r);
        if f_lo * fr <= 0.0 {
            hi = r;
            f_hi = fr;
        } else {
            lo = r;
            f_lo = fr;
        }
    }
    let sign = f_lo * f_hi;
    if sign > 0.0 || sign.is_nan() {
        return None;
    }
    if f_lo == 0.0 {
        return Some(lo);
    }
    // Start from the secant; Newton steps that leave the bracket become bisections.
    let mut s = lo + (hi - lo) * (f_lo / (f_lo - f_hi));
    if !(s >= lo && s <= hi) {
        s = 0.5 * (lo + hi);
    }
    for _ in 0..64 {
        let fs = eval(s);
        if fs == 0.0 {
            return Some(s);
        }
        if (fs < 0.0) == (f_lo < 0.0) {
            lo = s;
        } else {
            hi = s;
        }
        let step = s - fs / deriv(s);
        let next = if step > lo && step < hi {
            step
        } else {
            0.5 * (lo + hi)
        };
        let done = (next - s).abs() <= 1e-7 * (1.0 + next.abs()) || hi - lo <= f32::EPSILON * hi;
        s = next;
        if done {
            break;
        }
    }
    Some(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(size: [u32; 3], f: impl Fn(Vec3A) -> f32, smooth: bool) -> Arc<desc::SdfGrid> {
        let mut values = Vec::new();
        for k in 0..size[2] {
            for j in 0..size[1] {
                for i in 0..size[0] {
                    values.push(f(Vec3A::new(
                        i as f32 / (size[0] - 1) as f32,
                        j as f32 / (size[1] - 1) as f32,
                        k as f32 / (size[2] - 1) as f32,
                    )));
                }
            }
        }
        let mut g = desc::SdfGrid {
            size,
            values,
            smooth_normals: smooth,
            surface_voxels: 0,
        };
        let mut n = 0;
        for k in 0..size[2] - 1 {
            for j in 0..size[1] - 1 {
                for i in 0..size[0] - 1 {
                    n += g.voxel_has_surface(i, j, k) as u64;
                }
            }
        }
        g.surface_voxels = n;
        Arc::new(g)
    }

    /// The closest hit over all voxels, by brute force.
    fn trace(data: &SdfGridData, ray: &Ray) -> Option<(f32, SurfaceHit)> {
        let (mut voxels, mut cells) = (Vec::new(), Vec::new());
        data.primitives(&mut voxels, &mut cells);
        let mut best: Option<(f32, usize)> = None;
        for (n, v) in voxels.iter().enumerate() {
            if let Some(t) = intersect_sdf_voxel(ray, v, best.map_or(ray.tmax, |b| b.0)) {
                best = Some((t, n));
            }
        }
        let (t, n) = best?;
        let info = PrimInfo {
            ng: Vec3A::ZERO,
            indices: [n as u32, 0, 0],
            shape: 0,
        };
        let hit = ClosestHit {
            t,
            prim: n as u32,
            b1: 0.0,
            b2: 0.0,
        };
        Some((t, data.surface(ray, &info, &hit, cells[n].cell)))
    }

    /// A plane's signed distance is trilinear: hits and normals are exact, through a
    /// non-uniform scale and a translation, on a grid whose sides differ.
    #[test]
    fn planes_are_exact() {
        let n = Vec3A::new(0.3, -0.5, 0.8).normalize();
        let g = grid([7, 5, 9], |p| n.dot(p - Vec3A::splat(0.45)), false);
        let to_world = Mat4::from_translation(glam::Vec3::new(1.0, -2.0, 0.5))
            * Mat4::from_scale(glam::Vec3::new(2.0, 3.0, 0.5));
        let data = SdfGridData::new(g, to_world).unwrap();
        let world_n = (data.normal_matrix * n).normalize();
        let mut rng = torrey_testkit::Rng::new(3);
        let mut hits = 0;
        for _ in 0..2000 {
            let o = Vec3A::new(
                rng.f32() * 8.0 - 3.0,
                rng.f32() * 10.0 - 6.5,
                rng.f32() * 4.0 - 1.5,
            );
            let target =
                data.to_world
                    .transform_point3a(Vec3A::new(rng.f32(), rng.f32(), rng.f32()));
            let ray = Ray {
                origin: o,
                dir: (target - o).normalize(),
                tmax: f32::INFINITY,
            };
            // The exact hit: where the plane, in world space, meets the ray inside the box.
            let lo = data.to_object.transform_point3a(o);
            let ld = data.to_object.transform_vector3a(ray.dir);
            let t = -n.dot(lo - Vec3A::splat(0.45)) / n.dot(ld);
            let inside =
                (lo + t * ld).cmpge(Vec3A::ZERO).all() && (lo + t * ld).cmple(Vec3A::ONE).all();
            let got = trace(&data, &ray);
            if inside && t > 0.0 {
                let (tt, s) = got.unwrap_or_else(|| panic!("missed the plane at t {t}"));
                assert!((tt - t).abs() < 1e-4 * (1.0 + t), "t {tt} vs {t}");
                assert!((s.ng - world_n).length() < 1e-4, "{} vs {world_n}", s.ng);
                hits += 1;
            } else if let Some((tt, _)) = got {
                // Only grazing the box's edge: the exact hit is just outside.
                let p = lo + tt * ld;
                assert!(
                    p.cmpge(Vec3A::splat(-1e-4)).all() && p.cmple(Vec3A::splat(1.0 + 1e-4)).all()
                );
            }
        }
        assert!(hits > 500, "{hits}");
    }

    /// A sphere's distance sampled coarsely: the hit lies on the interpolant's zero set, its
    /// geometric normal is the interpolant's gradient there, and the smooth normal is unit
    /// and within a few degrees of the true sphere's.
    #[test]
    fn sphere_hits_lie_on_the_zero_set() {
        let c = Vec3A::splat(0.5);
        let g = grid([9, 9, 9], |p| (p - c).length() - 0.35, true);
        let data = SdfGridData::new(g.clone(), Mat4::IDENTITY).unwrap();
        let mut rng = torrey_testkit::Rng::new(9);
        for _ in 0..500 {
            let o = Vec3A::new(rng.f32(), rng.f32(), rng.f32()) * 6.0 - 2.5;
            let target = c + (Vec3A::new(rng.f32(), rng.f32(), rng.f32()) - 0.5) * 0.4;
            let ray = Ray {
                origin: o,
                dir: (target - o).normalize(),
                tmax: f32::INFINITY,
            };
            let (t, s) = trace(&data, &ray).expect("rays towards the centre hit");
            let res = 8.0;
            let sp = s.p * res;
            let cell = sp.floor().clamp(Vec3A::ZERO, Vec3A::splat(7.0));
            let f = g.corners(cell.x as u32, cell.y as u32, cell.z as u32);
            assert!(trilinear(&f, sp - cell).abs() < 1e-4, "value at the hit");
            assert!(((s.p - c).length() - 0.35).abs() < 0.02);
            assert!((s.ns.length() - 1.0).abs() < 1e-4);
            assert!(s.ns.dot((s.p - c).normalize()) > 0.99, "{}", s.ns);
            assert!(s.ng.dot(ray.dir) < 0.0 && t > 0.0);
        }
    }

    /// The smooth normal is continuous across voxel faces where the analytic one jumps.
    #[test]
    fn smooth_normals_are_continuous() {
        let c = Vec3A::new(0.5, 0.45, 0.55);
        let g = grid([6, 6, 6], |p| (p - c).length() - 0.3, true);
        // Points just either side of the face x = 0.4 (sample plane 2 of 5), near the surface.
        let y = 0.45;
        let z = c.z + (0.3f32 * 0.3 - (0.4 - c.x) * (0.4 - c.x) - 0.0).sqrt();
        let a = smooth_normal(&g, Vec3A::new(0.4 - 1e-4, y, z)).normalize();
        let b = smooth_normal(&g, Vec3A::new(0.4 + 1e-4, y, z)).normalize();
        assert!((a - b).length() < 1e-3, "{a} vs {b}");
    }
}
