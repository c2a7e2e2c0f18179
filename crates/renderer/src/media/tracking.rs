//! Tracking through a grid medium, cell by cell of its majorant grid: free flights (delta and
//! spectral tracking against the cell's majorant) and transmittance (residual ratio tracking
//! against the cell's minorant and majorant).
//!
//! Tentative collisions are drawn as one exponential optical depth spent across the cells
//! (μ times the length of each cell crossed), not one exponential per cell: by memorylessness
//! the same process, without a logarithm and a random number for every non-empty cell a ray
//! crosses without a collision.
//!
//! Transmittance is Novák et al.'s residual ratio tracking (2014), per cell: the cell's
//! minorant σc (the smallest value a lookup in it can return) is a control whose part
//! exp(−σc ℓ) is exact, and ratio tracking estimates the rest, T ·= (μ − σt) / (μ − σc) at
//! tentative collisions drawn at the residual rate μ − σc. In a dense cell that leaves few
//! collisions and a weight that stays near its mean (plain ratio tracking there multiplies
//! factors near 0, and Russian roulette turns them into a noisy 0 or 1); a cell whose values
//! are all equal costs one exponential and no lookup. Where the minorant is 0 (empty space
//! near a cloud, one global bound over a sparse grid) it is plain ratio tracking.

#[cfg(test)]
use super::grid::unit_cube_span;
use super::grid::{Grid, MajorantGrid};
use super::medium::{Field, Flight};
use glam::Vec3A;

/// The extinction of a grid medium: its grid times `scale`, with the grid's local bounds.
#[derive(Clone, Debug)]
pub struct GridDensity {
    pub grid: Grid,
    pub majorants: MajorantGrid,
    pub scale: f32,
}

/// Below this weight (every channel), transmittance estimates go on with Russian roulette.
const ROULETTE_BELOW: f32 = 0.05;

impl GridDensity {
    pub fn new(grid: Grid, scale: f32) -> Self {
        let majorants = MajorantGrid::new(&grid);
        GridDensity {
            grid,
            majorants,
            scale,
        }
    }

    /// The extinction at a point of the grid's local space, at most `bound` (a lookup beyond
    /// its cell's majorant only by rounding).
    #[inline(always)]
    fn sigma_t(&self, p: Vec3A, bound: f32) -> Vec3A {
        (self.grid.eval_local(p) * self.scale).min(Vec3A::splat(bound))
    }

    /// The ray `o + t d` (world space) in the grid's local space, and the span of t in which
    /// it is inside the grid, clipped to [0, `tmax`]; None when it misses the grid.
    #[inline(always)]
    fn local_span(&self, o: Vec3A, d: Vec3A, tmax: f32) -> Option<(Vec3A, Vec3A, f32, f32)> {
        let o_l = self.grid.to_local.transform_point3a(o);
        let d_l = self.grid.to_local.transform_vector3a(d);
        let (t0, t1) = self.majorants.span(o_l, d_l)?;
        Some((o_l, d_l, t0.max(0.0), t1.min(tmax)))
    }

    /// The next interaction along `o + t d` (world space) for t in [0, `tmax`]: spectral
    /// tracking against each cell's majorant, weighting `throughput`; `albedo` at a scattering
    /// event.
    pub fn sample(
        &self,
        o: Vec3A,
        d: Vec3A,
        tmax: f32,
        albedo: &Field,
        throughput: &mut Vec3A,
        u: &mut impl FnMut() -> f32,
    ) -> Flight {
        let Some((o_l, d_l, t0, t1)) = self.local_span(o, d, tmax) else {
            return Flight::Pass;
        };
        let mut depth = exponential(u);
        for (ta, tb, [_, max]) in self.majorants.walk(o_l, d_l, t0, t1) {
            let mu = max * self.scale;
            if !(mu > 0.0) {
                continue;
            }
            let mut t = ta;
            while next_collision(&mut t, tb, mu, &mut depth, u) {
                let sigma_t = self.sigma_t(o_l + d_l * t, mu);
                let sigma_n = Vec3A::splat(mu) - sigma_t;
                let w = *throughput;
                let (a, n) = ((w * sigma_t).element_sum(), (w * sigma_n).element_sum());
                if !(a + n > 0.0) {
                    *throughput = Vec3A::ZERO;
                    return Flight::Pass;
                }
                let p_real = a / (a + n);
                if u() < p_real {
                    let sigma_s = sigma_t * albedo.eval(o + d * t);
                    *throughput *= sigma_s / (mu * p_real);
                    return Flight::Scatter(t);
                }
                *throughput *= sigma_n / (mu * (1.0 - p_real));
            }
        }
        Flight::Pass
    }

    /// An unbiased estimate of the transmittance of `o + t d` (world space), t in [0, `tmax`]:
    /// residual ratio tracking, cell by cell.
    pub fn transmittance(
        &self,
        o: Vec3A,
        d: Vec3A,
        tmax: f32,
        u: &mut impl FnMut() -> f32,
    ) -> Vec3A {
        let Some((o_l, d_l, t0, t1)) = self.local_span(o, d, tmax) else {
            return Vec3A::ONE;
        };
        let mut tr = Vec3A::ONE;
        let mut depth = exponential(u);
        for (ta, tb, [min, max]) in self.majorants.walk(o_l, d_l, t0, t1) {
            let (control, mu) = (min * self.scale, max * self.scale);
            if !(mu > 0.0) {
                continue;
            }
            if control > 0.0 {
                tr *= (-control * (tb - ta)).exp();
                if !roulette(&mut tr, u) {
                    return Vec3A::ZERO;
                }
            }
            let residual = mu - control;
            if !(residual > 0.0) {
                continue;
            }
            let mut t = ta;
            while next_collision(&mut t, tb, residual, &mut depth, u) {
                let sigma_t = self.sigma_t(o_l + d_l * t, mu);
                tr *= (Vec3A::splat(mu) - sigma_t) / residual;
                if !roulette(&mut tr, u) {
                    return Vec3A::ZERO;
                }
            }
        }
        tr
    }
}

/// Moves `t` to the next tentative collision at `rate` (per unit length) before the cell's end
/// `tb`, spending the exponential optical `depth` carried across cells and drawing the next one:
/// false when the cell ends first (its share of the depth spent).
#[inline(always)]
fn next_collision(
    t: &mut f32,
    tb: f32,
    rate: f32,
    depth: &mut f32,
    u: &mut impl FnMut() -> f32,
) -> bool {
    let to_collision = *depth / rate;
    if !(*t + to_collision < tb) {
        *depth = (*depth - rate * (tb - *t)).max(0.0);
        return false;
    }
    *t += to_collision;
    *depth = exponential(u);
    true
}

/// An exponentially distributed optical depth (mean 1): the depth to a tentative collision.
#[inline(always)]
fn exponential(u: &mut impl FnMut() -> f32) -> f32 {
    -(1.0 - u()).ln()
}

/// Russian roulette on a transmittance weight below [`ROULETTE_BELOW`]: it survives with
/// probability 1/2, doubled. Returns whether it survived (a zero weight does not).
#[inline(always)]
fn roulette(tr: &mut Vec3A, u: &mut impl FnMut() -> f32) -> bool {
    let m = tr.max_element();
    if m < ROULETTE_BELOW {
        if !(m > 0.0) || u() < 0.5 {
            return false;
        }
        *tr *= 2.0;
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use torrey_parser as desc;
    use torrey_testkit::Rng;

    /// A chromatic 12×9×10 grid, dense (values 1 to 8) but for an empty slab, scaled by 0.4.
    fn cloud() -> GridDensity {
        let size = [12u32, 9, 10];
        let mut rng = Rng::new(17);
        let mut data = Vec::new();
        for _z in 0..size[2] {
            for _y in 0..size[1] {
                for x in 0..size[0] {
                    for _c in 0..3 {
                        data.push(if (4..6).contains(&x) {
                            0.0
                        } else {
                            1.0 + 7.0 * rng.f32()
                        });
                    }
                }
            }
        }
        let grid = Grid::from_desc(&desc::GridVolume {
            size,
            channels: 3,
            data,
            to_local: glam::Mat4::IDENTITY,
            nearest: false,
            max: 8.0,
        });
        GridDensity::new(grid, 0.4)
    }

    /// exp(−∫σt) along `o + t d`, t in [0, `tmax`], by the midpoint rule on 20000 steps.
    fn exact_transmittance(g: &GridDensity, o: Vec3A, d: Vec3A, tmax: f32) -> [f64; 3] {
        let Some((t0, t1)) = unit_cube_span(o, d) else {
            return [1.0; 3];
        };
        let (t0, t1) = (t0.max(0.0) as f64, t1.min(tmax) as f64);
        let steps = 20_000;
        let h = (t1 - t0).max(0.0) / steps as f64;
        let mut tau = [0.0f64; 3];
        for i in 0..steps {
            let t = t0 + (i as f64 + 0.5) * h;
            let s = g.grid.eval_local(o + d * t as f32) * g.scale;
            for c in 0..3 {
                tau[c] += s[c] as f64 * h;
            }
        }
        tau.map(|x| (-x).exp())
    }

    /// The mean of residual ratio tracking's estimates (and of the weight of free flights that
    /// pass) is exp(−∫σt) per channel, within 5 standard errors (from the estimates' own
    /// variance), on rays that cross the grid's dense and empty cells, end inside it or start
    /// outside it.
    #[test]
    fn transmittance_is_unbiased_per_channel() {
        let g = cloud();
        assert!(
            g.majorants.values_min_positive(),
            "the test needs cells with a positive minorant"
        );
        let rays = [
            (Vec3A::new(-0.5, 0.3, 0.4), Vec3A::new(1.0, 0.2, 0.1), 10.0),
            (Vec3A::new(0.1, 0.9, 0.2), Vec3A::new(0.6, -0.7, 0.5), 0.8),
            (Vec3A::new(0.5, 0.5, -1.0), Vec3A::new(0.05, 0.0, 1.0), 1.6),
            (Vec3A::new(0.95, 0.2, 0.7), Vec3A::new(-1.0, 0.3, -0.2), 0.5),
        ];
        let n = 200_000;
        let mut rng = Rng::new(23);
        for (k, (o, d, tmax)) in rays.into_iter().enumerate() {
            let d = d.normalize();
            let exact = exact_transmittance(&g, o, d, tmax);
            let (mut sum, mut sq) = ([0.0f64; 3], [0.0f64; 3]);
            let (mut pass, mut pass_sq) = ([0.0f64; 3], [0.0f64; 3]);
            for _ in 0..n {
                let tr = g.transmittance(o, d, tmax, &mut || rng.f32());
                let mut w = Vec3A::ONE;
                let albedo = Field::Constant(Vec3A::ONE);
                let flight = g.sample(o, d, tmax, &albedo, &mut w, &mut || rng.f32());
                let w = match flight {
                    Flight::Pass => w,
                    Flight::Scatter(_) => Vec3A::ZERO,
                };
                for c in 0..3 {
                    sum[c] += tr[c] as f64;
                    sq[c] += (tr[c] as f64).powi(2);
                    pass[c] += w[c] as f64;
                    pass_sq[c] += (w[c] as f64).powi(2);
                }
            }
            for c in 0..3 {
                for (what, s, q) in [("ratio", sum, sq), ("flight", pass, pass_sq)] {
                    let mean = s[c] / n as f64;
                    let var = (q[c] / n as f64 - mean * mean).max(0.0);
                    let err = 5.0 * (var / n as f64).sqrt() + 1e-4 * exact[c];
                    assert!(
                        (mean - exact[c]).abs() <= err,
                        "ray {k} channel {c} {what}: {mean} vs {} (tolerance {err})",
                        exact[c]
                    );
                }
            }
        }
    }
}
