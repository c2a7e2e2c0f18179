//! Grid volumes (Mitsuba's `gridvolume`) and the majorant grid torrey tracks heterogeneous media
//! against.
//!
//! A grid spans the unit cube of its local space; its samples sit at cell centres
//! ((i + 0.5) / n), looked up trilinearly with indices clamped to the grid (Mitsuba's
//! `dr::Texture` with `clamp`) or at the nearest sample.
//!
//! The majorant grid (beyond Mitsuba, which tracks against one global majorant): a coarse grid
//! over the same unit cube, each cell holding the smallest and the largest value any lookup
//! inside it can return (over the samples whose filter support overlaps the cell, no more).
//! Rays walk its cells with a 3D DDA (pbrt-v4's `DDAMajorantIterator`); in each cell free
//! flights are drawn against that cell's majorant, so empty space costs one step per cell and
//! a sparse cloud is tracked with few null collisions; the minorant is residual ratio
//! tracking's control (`tracking.rs`).

use super::walk::MajorantWalk;
use glam::{Mat4, Vec3A};
use std::sync::OnceLock;
use torrey_parser as desc;

/// A grid's values, with its placement and filter.
#[derive(Clone, Debug)]
pub struct Grid {
    size: [u32; 3],
    channels: u32,
    data: Vec<f32>,
    pub to_local: Mat4,
    nearest: bool,
    /// `max_value` (or the largest value): the global majorant before `scale`.
    pub max: f32,
}

impl Grid {
    pub fn from_desc(g: &desc::GridVolume) -> Self {
        Grid {
            size: g.size,
            channels: g.channels,
            data: g.data.clone(),
            to_local: g.to_local,
            nearest: g.nearest,
            max: g.max,
        }
    }

    /// The sample at integer indices (clamped to the grid), as RGB.
    #[inline(always)]
    fn at(&self, x: i32, y: i32, z: i32) -> Vec3A {
        let [nx, ny, nz] = self.size.map(|s| s as i32);
        let (x, y, z) = (x.clamp(0, nx - 1), y.clamp(0, ny - 1), z.clamp(0, nz - 1));
        let i = ((z * ny + y) * nx + x) as usize * self.channels as usize;
        if self.channels == 1 {
            Vec3A::splat(self.data[i])
        } else {
            Vec3A::new(self.data[i], self.data[i + 1], self.data[i + 2])
        }
    }

    /// The value at a point of the grid's local space.
    #[inline]
    pub fn eval_local(&self, p: Vec3A) -> Vec3A {
        let n = Vec3A::new(
            self.size[0] as f32,
            self.size[1] as f32,
            self.size[2] as f32,
        );
        if self.nearest {
            let i = (p * n).floor();
            return self.at(i.x as i32, i.y as i32, i.z as i32);
        }
        let pos = p * n - Vec3A::splat(0.5);
        let i = pos.floor();
        let f = pos - i;
        let (x, y, z) = (i.x as i32, i.y as i32, i.z as i32);
        let lerp = |a: Vec3A, b: Vec3A, t: f32| a + (b - a) * t;
        let c00 = lerp(self.at(x, y, z), self.at(x + 1, y, z), f.x);
        let c10 = lerp(self.at(x, y + 1, z), self.at(x + 1, y + 1, z), f.x);
        let c01 = lerp(self.at(x, y, z + 1), self.at(x + 1, y, z + 1), f.x);
        let c11 = lerp(self.at(x, y + 1, z + 1), self.at(x + 1, y + 1, z + 1), f.x);
        lerp(lerp(c00, c10, f.y), lerp(c01, c11, f.y), f.z)
    }

    /// The value at a world point.
    #[inline]
    pub fn eval(&self, p: Vec3A) -> Vec3A {
        self.eval_local(self.to_local.transform_point3a(p))
    }

    /// The smallest and the largest value (over every channel) among samples x0..=x1,
    /// y0..=y1, z0..=z1 (clamped to the grid).
    fn range_in(&self, lo: [i32; 3], hi: [i32; 3]) -> [f32; 2] {
        let clamp = |v: i32, a: usize| v.clamp(0, self.size[a] as i32 - 1);
        let (mut min, mut max) = (f32::INFINITY, 0.0f32);
        for z in clamp(lo[2], 2)..=clamp(hi[2], 2) {
            for y in clamp(lo[1], 1)..=clamp(hi[1], 1) {
                for x in clamp(lo[0], 0)..=clamp(hi[0], 0) {
                    let v = self.at(x, y, z);
                    min = min.min(v.min_element());
                    max = max.max(v.max_element());
                }
            }
        }
        [min.max(0.0), max]
    }
}

/// Cells of the majorant grid along each axis: one per 2 samples, at most 64 (on a sparse 64³
/// cloud, 32³ cells took 0.8x the relMSE x CPU seconds of 16³, 64³ about 1.0x). The
/// environment variable `TORREY_MAJORANT_GRID` sets a fixed count (1: one global majorant, as
/// Mitsuba; for comparisons).
fn majorant_cells(samples: u32) -> u32 {
    static FIXED: OnceLock<Option<u32>> = OnceLock::new();
    let fixed = *FIXED.get_or_init(|| {
        std::env::var("TORREY_MAJORANT_GRID")
            .ok()
            .and_then(|v| v.trim().parse::<u32>().ok())
            .map(|v| v.clamp(1, 256))
    });
    fixed.unwrap_or_else(|| samples.div_ceil(2).clamp(1, 64))
}

/// How far (in samples) a lookup point may stray out of its cell by rounding: positions and the
/// walk's cell boundaries carry float error of about 1e-7 of the coordinates' size in samples.
const ROUNDING: f32 = 0.01;

/// Local bounds of a grid over the unit cube: per cell, the smallest and the largest value a
/// lookup inside it can return (the samples whose filter support overlaps the cell, no more:
/// 4 per axis at 2 samples a cell with trilinear filtering).
#[derive(Clone, Debug)]
pub struct MajorantGrid {
    pub res: [u32; 3],
    /// Per cell [minorant, majorant], before the medium's scale; the majorant never above the
    /// grid's `max`.
    values: Vec<[f32; 2]>,
    /// The box (in the unit cube) of the cells with a positive majorant: rays are walked only
    /// through it (empty when no cell is).
    occupied: [Vec3A; 2],
}

impl MajorantGrid {
    /// The bounds of `grid` (before the medium's scale).
    pub fn new(grid: &Grid) -> Self {
        let res = grid.size.map(majorant_cells);
        let mut values = Vec::with_capacity((res[0] * res[1] * res[2]) as usize);
        for cz in 0..res[2] {
            for cy in 0..res[1] {
                for cx in 0..res[0] {
                    let c = [cx, cy, cz];
                    let (mut lo, mut hi) = ([0i32; 3], [0i32; 3]);
                    for a in 0..3 {
                        let n = grid.size[a] as f32;
                        let r = res[a] as f32;
                        let (a0, a1) = (c[a] as f32 / r * n, (c[a] + 1) as f32 / r * n);
                        if grid.nearest {
                            // Lookups read sample floor(p n).
                            lo[a] = (a0 - ROUNDING).floor() as i32;
                            hi[a] = (a1 + ROUNDING).floor() as i32;
                        } else {
                            // Lookups read samples floor(p n − 0.5) and the next.
                            lo[a] = (a0 - 0.5 - ROUNDING).floor() as i32;
                            hi[a] = (a1 - 0.5 + ROUNDING).floor() as i32 + 1;
                        }
                    }
                    let [min, max] = grid.range_in(lo, hi);
                    let max = max.min(grid.max);
                    values.push([min.min(max), max]);
                }
            }
        }
        let (mut lo, mut hi) = (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY));
        let n = Vec3A::new(res[0] as f32, res[1] as f32, res[2] as f32);
        for (i, v) in values.iter().enumerate() {
            if v[1] > 0.0 {
                let i = i as u32;
                let c = Vec3A::new(
                    (i % res[0]) as f32,
                    (i / res[0] % res[1]) as f32,
                    (i / (res[0] * res[1])) as f32,
                );
                lo = lo.min(c / n);
                hi = hi.max((c + Vec3A::ONE) / n);
            }
        }
        MajorantGrid {
            res,
            values,
            occupied: [lo, hi],
        }
    }

    /// Whether some cell's minorant is positive (for tests).
    #[cfg(test)]
    pub fn values_min_positive(&self) -> bool {
        self.values.iter().any(|v| v[0] > 0.0)
    }

    /// The parameter range [t0, t1] in which the local-space ray `o + t d` is inside the box
    /// of the cells with a positive majorant (None when it misses the box).
    #[inline]
    pub fn span(&self, o: Vec3A, d: Vec3A) -> Option<(f32, f32)> {
        let [lo, hi] = self.occupied;
        if !(lo.x <= hi.x) {
            return None;
        }
        box_span(o, d, lo, hi)
    }

    /// The cells a local-space ray `o + t d` crosses for t in [t0, t1] (inside the unit cube),
    /// in order.
    pub fn walk(&self, o: Vec3A, d: Vec3A, t0: f32, t1: f32) -> MajorantWalk<'_> {
        MajorantWalk::new(&self.values, self.res, o, d, t0, t1)
    }
}

/// The parameter range [t0, t1] in which the ray `o + t d` is inside the unit cube (for tests).
#[cfg(test)]
pub fn unit_cube_span(o: Vec3A, d: Vec3A) -> Option<(f32, f32)> {
    box_span(o, d, Vec3A::ZERO, Vec3A::ONE)
}

/// The parameter range [t0, t1] in which the ray `o + t d` is inside the box [lo, hi].
#[inline]
fn box_span(o: Vec3A, d: Vec3A, lo: Vec3A, hi: Vec3A) -> Option<(f32, f32)> {
    let inv = d.recip();
    let a = (lo - o) * inv;
    let b = (hi - o) * inv;
    let lo = a.min(b);
    let hi = a.max(b);
    // NaN (0 · inf, a ray in a face's plane) is dropped by max/min's handling of NaN.
    let t0 = lo.x.max(lo.y).max(lo.z);
    let t1 = hi.x.min(hi.y).min(hi.z);
    (t0 <= t1).then_some((t0, t1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use torrey_testkit::Rng;

    fn grid(size: [u32; 3], f: impl Fn(u32, u32, u32) -> f32) -> Grid {
        let mut data = Vec::new();
        for z in 0..size[2] {
            for y in 0..size[1] {
                for x in 0..size[0] {
                    data.push(f(x, y, z));
                }
            }
        }
        let max = data.iter().fold(0.0f32, |m, &v| m.max(v));
        Grid {
            size,
            channels: 1,
            data,
            to_local: Mat4::IDENTITY,
            nearest: false,
            max,
        }
    }

    /// Samples sit at cell centres: the lookup there returns the sample; between two it
    /// interpolates; beyond the outer centres it is clamped.
    #[test]
    fn trilinear_lookup_places_samples_at_cell_centres() {
        let g = grid([4, 1, 1], |x, _, _| x as f32);
        assert_eq!(g.eval_local(Vec3A::new(0.125, 0.5, 0.5)).x, 0.0);
        assert_eq!(g.eval_local(Vec3A::new(0.375, 0.5, 0.5)).x, 1.0);
        assert!((g.eval_local(Vec3A::new(0.5, 0.5, 0.5)).x - 1.5).abs() < 1e-6);
        assert_eq!(g.eval_local(Vec3A::new(0.01, 0.5, 0.5)).x, 0.0);
        assert_eq!(g.eval_local(Vec3A::new(0.99, 0.5, 0.5)).x, 3.0);
    }

    /// Every lookup along random rays (the cells' ends included) lies between its cell's
    /// minorant and majorant, the walk covers the ray's span inside the occupied box without
    /// gaps, and lookups in the cube outside that box are 0.
    #[test]
    fn majorants_bound_every_lookup_along_the_walk() {
        let mut rng = Rng::new(3);
        let sparse = grid([13, 7, 9], |x, y, z| {
            if (x * 7 + y * 3 + z * 5) % 11 == 0 {
                5.0 + x as f32
            } else {
                0.0
            }
        });
        let dense = grid([16, 10, 9], |x, y, z| {
            1.0 + ((x * 5 + y * 3 + z * 7) % 6) as f32
        });
        let mut nearest = dense.clone();
        nearest.nearest = true;
        // One blob off-centre in a 40³ grid: most of the cube is outside the occupied box.
        let blob = grid([40, 40, 40], |x, y, z| {
            let r2 = [x, y, z]
                .map(|v| (v as i32 - 12).pow(2))
                .iter()
                .sum::<i32>();
            if r2 < 16 {
                2.0
            } else {
                0.0
            }
        });
        let empty = grid([6, 6, 6], |_, _, _| 0.0);
        for g in [sparse, dense, nearest, blob, empty] {
            let m = MajorantGrid::new(&g);
            walk_within_bounds(&g, &m, &mut rng);
        }
    }

    fn walk_within_bounds(g: &Grid, m: &MajorantGrid, rng: &mut Rng) {
        for _ in 0..2000 {
            let o = Vec3A::new(
                rng.range(-1.0, 2.0),
                rng.range(-1.0, 2.0),
                rng.range(-1.0, 2.0),
            );
            let d = Vec3A::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            let Some((t0, t1)) = unit_cube_span(o, d) else {
                continue;
            };
            let t0 = t0.max(0.0);
            let zero = |a: f32, b: f32| {
                for k in 0..=32 {
                    let v = g.eval_local(o + d * (a + (b - a) * k as f32 / 32.0)).x;
                    assert!(!(b > a) || v == 0.0, "{v} outside the occupied box");
                }
            };
            let Some((s0, s1)) = m.span(o, d) else {
                zero(t0, t1);
                continue;
            };
            let (s0, s1) = (s0.max(t0), s1.min(t1));
            zero(t0, s0 - 1e-4);
            zero(s1 + 1e-4, t1);
            let (t0, t1) = (s0, s1);
            let mut t = t0;
            for (a, b, [min, maj]) in m.walk(o, d, t0, t1) {
                assert!((a - t).abs() <= 1e-4 * (1.0 + t.abs()), "gap at {t}: {a}");
                for k in 0..=8 {
                    let s = a + (b - a) * k as f32 / 8.0;
                    let v = g.eval_local(o + d * s).x;
                    assert!(v <= maj + 1e-4, "{v} above {maj}");
                    assert!(v >= min - 1e-4, "{v} below {min}");
                }
                t = b;
            }
            if t1 > t0 {
                assert!((t - t1).abs() <= 1e-4 * (1.0 + t1.abs()), "{t} != {t1}");
            }
        }
    }
}
