//! The walk through a majorant grid's cells along a ray: a 3D DDA (Amanatides and Woo; pbrt-v4's
//! `DDAMajorantIterator`).
//!
//! Each axis keeps its own scalars (the parameter of its next cell boundary, the step between
//! boundaries, the step of the cell's linear index and the cells left before the grid's side),
//! chosen by branches rather than by an axis index: indexed arrays kept the walk's state in
//! memory, and a step (most of them through empty cells of a sparse cloud) waited on a store
//! and a reload.

use glam::Vec3A;

/// One axis of the walk.
#[derive(Clone, Copy)]
struct Axis {
    /// The ray parameter at which the walk crosses into the next cell along this axis.
    next: f32,
    /// The parameter between two crossings.
    delta: f32,
    /// The linear index's change at a crossing.
    stride: isize,
    /// Crossings left before the walk leaves the grid.
    left: u32,
}

impl Axis {
    /// The axis of a walk that starts at cell `cell` (of `res`) at parameter `t0`, grid
    /// coordinate `p`, direction `d` (in cells per unit parameter), linear index step `stride`.
    #[inline(always)]
    fn new(cell: i32, res: u32, t0: f32, p: f32, d: f32, stride: isize) -> Self {
        if d > 0.0 {
            Axis {
                next: t0 + ((cell + 1) as f32 - p) / d,
                delta: 1.0 / d,
                stride,
                left: res - cell as u32,
            }
        } else if d < 0.0 {
            Axis {
                next: t0 + (cell as f32 - p) / d,
                delta: -1.0 / d,
                stride: -stride,
                left: cell as u32 + 1,
            }
        } else {
            Axis {
                next: f32::INFINITY,
                delta: f32::INFINITY,
                stride: 0,
                left: u32::MAX,
            }
        }
    }
}

/// [`super::grid::MajorantGrid::walk`]: yields (t_enter, t_exit, [minorant, majorant]) per
/// cell.
pub struct MajorantWalk<'a> {
    values: &'a [[f32; 2]],
    index: isize,
    x: Axis,
    y: Axis,
    z: Axis,
    t: f32,
    t1: f32,
}

impl<'a> MajorantWalk<'a> {
    /// The walk of the local-space ray `o + t d` over t in [t0, t1] (inside the unit cube)
    /// through the cells `values` (x fastest) of a `res` grid.
    #[inline]
    pub fn new(
        values: &'a [[f32; 2]],
        res: [u32; 3],
        o: Vec3A,
        d: Vec3A,
        t0: f32,
        t1: f32,
    ) -> Self {
        let n = Vec3A::new(res[0] as f32, res[1] as f32, res[2] as f32);
        let p = (o + d * t0) * n;
        let dn = d * n;
        let cell = [0, 1, 2].map(|a| (p[a].floor() as i32).clamp(0, res[a] as i32 - 1));
        let (sx, sy) = (1isize, res[0] as isize);
        let sz = sy * res[1] as isize;
        MajorantWalk {
            values,
            index: cell[0] as isize + cell[1] as isize * sy + cell[2] as isize * sz,
            x: Axis::new(cell[0], res[0], t0, p.x, dn.x, sx),
            y: Axis::new(cell[1], res[1], t0, p.y, dn.y, sy),
            z: Axis::new(cell[2], res[2], t0, p.z, dn.z, sz),
            t: t0,
            t1,
        }
    }
}

/// Crosses into the next cell along `axis`; returns the parameter of the crossing and whether
/// the walk is still inside the grid.
#[inline(always)]
fn cross(axis: &mut Axis, index: &mut isize) -> (f32, bool) {
    let at = axis.next;
    axis.next += axis.delta;
    *index += axis.stride;
    axis.left -= 1;
    (at, axis.left > 0)
}

impl Iterator for MajorantWalk<'_> {
    type Item = (f32, f32, [f32; 2]);

    #[inline]
    fn next(&mut self) -> Option<Self::Item> {
        if !(self.t < self.t1) {
            return None;
        }
        let value = self.values[self.index as usize];
        let (at, inside) = if self.x.next < self.y.next && self.x.next < self.z.next {
            cross(&mut self.x, &mut self.index)
        } else if self.y.next < self.z.next {
            cross(&mut self.y, &mut self.index)
        } else {
            cross(&mut self.z, &mut self.index)
        };
        let exit = at.min(self.t1);
        let item = (self.t, exit, value);
        self.t = if inside { exit } else { self.t1 };
        Some(item)
    }
}
