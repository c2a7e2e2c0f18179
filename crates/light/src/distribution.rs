//! Piecewise-constant 1D and 2D distributions: the building block of environment-map and
//! light-selection importance sampling.
//!
//! Both tolerate bad weights rather than panicking: negative, NaN and infinite weights count as 0,
//! and a distribution whose weights are all zero samples uniformly (with finite, non-NaN pdfs), so
//! callers never have to special-case black inputs to stay NaN-free.

use glam::Vec2;

/// The largest f32 below 1, so that samples stay inside the half-open interval [0, 1).
pub const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// `u` clamped into [0, 1), where the samplers' searches and picks expect it (NaN reads as 0).
#[inline]
pub(crate) fn clamp_unit(u: f32) -> f32 {
    if u.is_nan() {
        0.0
    } else {
        u.clamp(0.0, ONE_MINUS_EPSILON)
    }
}

/// A piecewise-constant density over [0, 1) with `len()` equal-width bins.
///
/// Used for discrete choices (which light, which row) and continuous ones (where in a row), so both
/// views are offered over the same tables.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    /// Sanitised bin weights (never negative or NaN).
    func: Vec<f32>,
    /// Normalised running sum, `len() + 1` entries, `cdf[0] = 0`, `cdf[len()] = 1`.
    cdf: Vec<f32>,
    /// Density of each bin over [0, 1) (what [`Self::bin_density`] computes), precomputed so the
    /// samplers and pdfs read one f32 instead of doing an f64 division.
    density: Vec<f32>,
    /// Guide (cutpoint) table for the inverse-cdf search: `guide[k]` is the bin that `u = k / G`
    /// falls in, for `k` in `0..=G` with `G = guide.len() - 1` a power of two. Since `u * G` is
    /// exact for a power of two, every `u` in `[k / G, (k + 1) / G)` falls in a bin between
    /// `guide[k]` and `guide[k + 1]`, so the search only looks at that (usually tiny) range.
    guide: Vec<u32>,
    /// Integral of `func` over [0, 1): sum of weights divided by the bin count.
    integral: f32,
    /// Sum of the weights (kept in f64 so discrete probabilities of huge maps stay exact).
    sum: f64,
}

impl Distribution1D {
    /// Builds the tables. Negative, NaN and infinite weights are treated as 0; an empty slice is
    /// treated as a single zero-weight bin; an all-zero distribution samples uniformly.
    pub fn new(weights: &[f32]) -> Self {
        let mut func: Vec<f32> = weights
            .iter()
            .map(|&w| if w.is_finite() && w > 0.0 { w } else { 0.0 })
            .collect();
        if func.is_empty() {
            func.push(0.0);
        }
        let n = func.len();
        let sum: f64 = func.iter().map(|&w| w as f64).sum();
        let mut cdf = Vec::with_capacity(n + 1);
        cdf.push(0.0f32);
        if sum > 0.0 {
            let mut acc = 0.0f64;
            for &w in &func {
                acc += w as f64;
                // Zero-weight bins repeat the previous value exactly, and the last positive bin
                // reaches exactly 1 because `acc == sum` there.
                cdf.push((acc / sum) as f32);
            }
        } else {
            for i in 1..=n {
                cdf.push(i as f32 / n as f32);
            }
        }
        *cdf.last_mut().unwrap() = 1.0;
        let density = (0..n)
            .map(|i| {
                if sum > 0.0 {
                    (func[i] as f64 * n as f64 / sum) as f32
                } else {
                    1.0
                }
            })
            .collect();
        Self {
            integral: (sum / n as f64) as f32,
            guide: Self::build_guide(&cdf),
            func,
            cdf,
            density,
            sum,
        }
    }

    /// The guide table for `cdf` (see the field): one entry per `k / G`, `G` the power of two at
    /// or above the bin count, each the bin [`Self::find_slow`] returns for that `u`.
    fn build_guide(cdf: &[f32]) -> Vec<u32> {
        let n = cdf.len() - 1;
        let g = n.next_power_of_two();
        let mut guide = Vec::with_capacity(g + 1);
        let mut i = 0usize;
        for k in 0..=g {
            // Exact: k and g are small integers and g is a power of two.
            let t = k as f32 / g as f32;
            while i + 1 < n && cdf[i + 1] <= t {
                i += 1;
            }
            guide.push(i as u32);
        }
        guide
    }

    /// Integral of the (unnormalised) step function over [0, 1): the average weight. Zero means
    /// "nothing to sample" even though sampling still works (uniformly).
    pub fn integral(&self) -> f32 {
        self.integral
    }

    /// Number of bins (at least 1).
    pub fn len(&self) -> usize {
        self.func.len()
    }

    /// Always false: an empty weight slice becomes one zero-weight bin. Present for API symmetry.
    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    /// The sanitised weight of bin `i` (0 outside the range), for callers that need the raw value.
    pub fn weight(&self, i: usize) -> f32 {
        self.func.get(i).copied().unwrap_or(0.0)
    }

    /// Finds the bin whose cdf interval contains `u` (in [0, 1), as [`clamp_unit`] returns),
    /// skipping zero-width bins: the largest `i` in `[0, len() - 1]` with `cdf[i] <= u`. Since
    /// `cdf[len()] = 1 > u`, bin `i` has positive width. Uses the guide table to narrow the search
    /// to the bins that `u`'s guide cell spans; gives exactly [`Self::find_slow`]'s answer.
    #[inline]
    fn find(&self, u: f32) -> usize {
        let n = self.func.len();
        if n <= 8 {
            // A few bins (a light's triangles): scanning the cdf beats reading the guide first.
            // The cdf is non-decreasing, so counting every entry <= u equals counting the leading
            // ones, and the full count has no data-dependent exit to mispredict.
            return self.cdf[1..n].iter().filter(|&&c| c <= u).count();
        }
        find_in(&self.cdf, |c| c, &self.guide, u)
    }

    /// Plain binary search over the whole cdf: the reference for [`Self::find`].
    #[cfg(test)]
    fn find_slow(&self, u: f32) -> usize {
        let n = self.func.len();
        self.cdf[..n].partition_point(|&c| c <= u).saturating_sub(1)
    }

    /// Density of bin `i` over [0, 1) (1 for an all-zero distribution, which samples uniformly).
    #[inline]
    fn bin_density(&self, i: usize) -> f32 {
        self.density[i]
    }

    /// Continuous sample in [0,1): returns (x, pdf(x) density over [0,1), bin index).
    #[inline]
    pub fn sample_continuous(&self, u: f32) -> (f32, f32, usize) {
        let u = clamp_unit(u);
        let i = self.find(u);
        let x = warp_in(&self.cdf, |c| c, i, u);
        (x, self.bin_density(i), i)
    }

    /// Discrete: (index, probability, u remapped to [0,1) within the chosen bin).
    #[inline]
    pub fn sample_discrete(&self, u: f32) -> (usize, f32, f32) {
        let u = clamp_unit(u);
        let i = self.find(u);
        let lo = self.cdf[i];
        let width = self.cdf[i + 1] - lo;
        let remapped = if width > 0.0 {
            ((u - lo) / width).clamp(0.0, ONE_MINUS_EPSILON)
        } else {
            0.0
        };
        (i, self.pdf_discrete(i), remapped)
    }

    /// Probability of choosing bin `i` with [`Self::sample_discrete`] (0 outside the range).
    #[inline]
    pub fn pdf_discrete(&self, i: usize) -> f32 {
        if i >= self.func.len() {
            0.0
        } else if self.sum > 0.0 {
            (self.func[i] as f64 / self.sum) as f32
        } else {
            1.0 / self.func.len() as f32
        }
    }

    /// Density at `x` of [`Self::sample_continuous`] (0 outside [0, 1]; x = 1 counts as the last bin).
    #[inline]
    pub fn pdf_continuous(&self, x: f32) -> f32 {
        if !(0.0..=1.0).contains(&x) {
            return 0.0;
        }
        let n = self.func.len();
        let i = ((x * n as f32) as usize).min(n - 1);
        self.bin_density(i)
    }

    /// Bin that [`Self::pdf_continuous`] uses for `x` (clamped into range).
    #[inline]
    pub fn bin_of(&self, x: f32) -> usize {
        bin_of_n(x, self.func.len())
    }
}

/// The bin of `x` among `n` equal bins over [0, 1), clamped into range (NaN reads as bin 0).
#[inline(always)]
fn bin_of_n(x: f32, n: usize) -> usize {
    if x.is_nan() || x <= 0.0 {
        0
    } else {
        ((x * n as f32) as usize).min(n - 1)
    }
}

/// The guide-table search of [`Distribution1D::find`] over any table whose entries carry the cdf
/// (`cdf(table[i])`, `n + 1` entries); `guide` as [`Distribution1D`]'s field. `u` in [0, 1).
#[inline(always)]
fn find_in<T: Copy>(table: &[T], cdf: impl Fn(T) -> f32, guide: &[u32], u: f32) -> usize {
    let g = guide.len() - 1;
    // u < 1 and g is a power of two, so u * g is exact and k < g.
    let k = ((u * g as f32) as usize).min(g - 1);
    let (lo, hi) = (guide[k] as usize, guide[k + 1] as usize);
    // cdf[lo] <= k / g <= u, and the answer is at most hi because u < (k + 1) / g.
    let c = &table[lo + 1..hi + 1];
    if c.len() <= 8 {
        lo + c.iter().filter(|&&e| cdf(e) <= u).count()
    } else {
        lo + c.partition_point(|&e| cdf(e) <= u)
    }
}

/// The continuous warp of [`Distribution1D::sample_continuous`]: `u` (in [0, 1), inside bin `i`
/// of the cdf carried by `table`'s `n + 1` entries) to x in bin `i` of [0, 1).
#[inline(always)]
fn warp_in<T: Copy>(table: &[T], cdf: impl Fn(T) -> f32, i: usize, u: f32) -> f32 {
    let n = table.len() - 1;
    let lo = cdf(table[i]);
    let width = cdf(table[i + 1]) - lo;
    let du = if width > 0.0 {
        ((u - lo) / width).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let mut x = ((i as f32 + du) / n as f32).min(ONE_MINUS_EPSILON);
    // Rounding can push x across a bin edge (possibly into a zero-density neighbour); nudge it
    // back so that `pdf_continuous(x)` agrees with the returned pdf.
    while bin_of_n(x, n) > i {
        x = f32::from_bits(x.to_bits() - 1);
    }
    while bin_of_n(x, n) < i {
        x = f32::from_bits(x.to_bits() + 1);
    }
    x
}

/// A piecewise-constant density over the unit square on a `width` x `height` grid: a marginal
/// over rows (v) and one conditional per row (u). Used for environment-map sampling, where row 0 is
/// the top of the image (v = 0).
#[derive(Clone, Debug)]
pub struct Distribution2D {
    width: usize,
    height: usize,
    marginal: Distribution1D,
    /// The conditionals, flattened: row `r` owns entries `r * (width + 1) ..` of `width + 1`
    /// pairs (cdf of the row's [`Distribution1D`], density of the cell), where the cell density
    /// is the marginal density of the row times the conditional density of the column (the same
    /// f32 product sampling the two 1D distributions gives). One allocation with the cdf and
    /// the density side by side, so sampling a row touches as few cache lines as possible and
    /// [`Self::pdf`] is one load.
    rows: Vec<[f32; 2]>,
    /// The rows' guide tables, `guide_len` entries per row (see [`Distribution1D`]).
    guides: Vec<u32>,
    guide_len: usize,
}

impl Distribution2D {
    /// Builds from row-major weights (`weights[row * width + col]`). A zero `width`/`height` is
    /// treated as 1, and missing weights (slice too short) as 0, so bad input cannot panic.
    pub fn new(weights: &[f32], width: usize, height: usize) -> Self {
        let width = width.max(1);
        let height = height.max(1);
        let mut row = vec![0.0f32; width];
        let mut conditionals = Vec::with_capacity(height);
        for r in 0..height {
            for (c, w) in row.iter_mut().enumerate() {
                *w = weights.get(r * width + c).copied().unwrap_or(0.0);
            }
            conditionals.push(Distribution1D::new(&row));
        }
        let marginal_weights: Vec<f32> = conditionals.iter().map(|d| d.integral()).collect();
        let marginal = Distribution1D::new(&marginal_weights);
        let guide_len = conditionals[0].guide.len();
        let mut rows = Vec::with_capacity(height * (width + 1));
        let mut guides = Vec::with_capacity(height * guide_len);
        for (r, d) in conditionals.iter().enumerate() {
            let pdf_v = marginal.bin_density(r);
            rows.extend(d.cdf.iter().enumerate().map(|(i, &c)| {
                let pdf_u = d.density.get(i).copied().unwrap_or(0.0);
                [c, pdf_v * pdf_u]
            }));
            guides.extend_from_slice(&d.guide);
        }
        Self {
            width,
            height,
            marginal,
            rows,
            guides,
            guide_len,
        }
    }

    /// Integral of the step function over the unit square (0 for an all-zero map).
    pub fn integral(&self) -> f32 {
        self.marginal.integral()
    }

    /// Grid width (columns, u).
    pub fn width(&self) -> usize {
        self.width
    }

    /// Grid height (rows, v).
    pub fn height(&self) -> usize {
        self.height
    }

    /// Returns (uv in [0,1)^2, density over the unit square).
    #[inline]
    pub fn sample(&self, u: Vec2) -> (Vec2, f32) {
        let (v, _, row) = self.marginal.sample_continuous(u.y);
        let stride = self.width + 1;
        let table = &self.rows[row * stride..(row + 1) * stride];
        let guide = &self.guides[row * self.guide_len..(row + 1) * self.guide_len];
        // Exactly Distribution1D::sample_continuous on the row's conditional.
        let ux = clamp_unit(u.x);
        let i = find_in(table, |e| e[0], guide, ux);
        let x = warp_in(table, |e| e[0], i, ux);
        (Vec2::new(x, v), table[i][1])
    }

    /// Density of [`Self::sample`] at `uv` (0 outside the unit square).
    #[inline]
    pub fn pdf(&self, uv: Vec2) -> f32 {
        if !(0.0..=1.0).contains(&uv.x) || !(0.0..=1.0).contains(&uv.y) {
            return 0.0;
        }
        let row = self.marginal.bin_of(uv.y);
        let col = bin_of_n(uv.x, self.width);
        self.rows[row * (self.width + 1) + col][1]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use torrey_testkit::{assert_chi_square, Rng};

    #[test]
    fn continuous_histogram_matches_pdf() {
        let weights = [1.0, 0.0, 3.0, 0.5, 7.0, 2.0, 0.0, 4.0];
        let d = Distribution1D::new(&weights);
        assert_eq!(d.len(), 8);
        assert!((d.integral() - 17.5 / 8.0).abs() < 1e-6);
        // Histogram on 32 bins (4 per distribution bin): checks the within-bin placement too.
        let bins = 32;
        let n = 100_000;
        let mut hist = vec![0.0f64; bins];
        let mut rng = Rng::new(1);
        for _ in 0..n {
            let (x, pdf, i) = d.sample_continuous(rng.f32());
            assert!((0.0..1.0).contains(&x));
            assert_eq!(i, (x * 8.0) as usize);
            assert_eq!(pdf, d.pdf_continuous(x));
            assert!(pdf > 0.0);
            hist[(x * bins as f32) as usize] += 1.0;
        }
        let expected: Vec<f64> = (0..bins)
            .map(|b| {
                let x = (b as f32 + 0.5) / bins as f32;
                d.pdf_continuous(x) as f64 / bins as f64 * n as f64
            })
            .collect();
        assert_chi_square("Distribution1D::sample_continuous", &hist, &expected);
    }

    #[test]
    fn discrete_histogram_matches_probabilities() {
        let weights: Vec<f32> = (0..40).map(|i| ((i * 7919) % 13) as f32).collect();
        let d = Distribution1D::new(&weights);
        let total: f32 = weights.iter().sum();
        let n = 100_000;
        let mut hist = vec![0.0f64; weights.len()];
        let mut rng = Rng::new(2);
        for _ in 0..n {
            let (i, p, rem) = d.sample_discrete(rng.f32());
            assert!((0.0..1.0).contains(&rem));
            assert!((p - weights[i] / total).abs() < 1e-6);
            assert_eq!(p, d.pdf_discrete(i));
            hist[i] += 1.0;
        }
        let expected: Vec<f64> = (0..weights.len())
            .map(|i| d.pdf_discrete(i) as f64 * n as f64)
            .collect();
        assert_chi_square("Distribution1D::sample_discrete", &hist, &expected);
        // The remapped u of a chosen bin is itself uniform.
        let mut rem_hist = vec![0.0f64; 16];
        for _ in 0..n {
            let (_, _, rem) = d.sample_discrete(rng.f32());
            rem_hist[(rem * 16.0) as usize] += 1.0;
        }
        assert_chi_square("remapped u", &rem_hist, &[n as f64 / 16.0; 16]);
    }

    #[test]
    fn bad_and_zero_weights_give_no_nan() {
        let d = Distribution1D::new(&[0.0, -1.0, f32::NAN, f32::INFINITY]);
        assert_eq!(d.integral(), 0.0);
        for k in 0..100 {
            let u = k as f32 / 100.0;
            let (x, pdf, i) = d.sample_continuous(u);
            assert!(
                (x - u).abs() < 1e-6,
                "all-zero should be uniform: u {u} x {x}"
            );
            assert_eq!(pdf, 1.0);
            assert_eq!(i, (u * 4.0) as usize);
            let (j, p, _) = d.sample_discrete(u);
            assert_eq!(j, (u * 4.0) as usize);
            assert_eq!(p, 0.25);
        }
        // Out-of-range u is clamped, not a panic.
        for u in [-1.0, 1.0, 2.0, f32::NAN, f32::INFINITY] {
            let (x, pdf, _) = d.sample_continuous(u);
            assert!(x.is_finite() && (0.0..1.0).contains(&x) && pdf.is_finite());
        }
        let empty = Distribution1D::new(&[]);
        assert_eq!(empty.len(), 1);
        assert_eq!(empty.sample_continuous(0.3).1, 1.0);
        // Negative weights count as zero: never sampled.
        let d = Distribution1D::new(&[-5.0, 1.0]);
        for k in 0..100 {
            let (x, _, i) = d.sample_continuous(k as f32 / 100.0);
            assert_eq!(i, 1);
            assert!(x >= 0.5);
        }
        assert_eq!(d.pdf_continuous(0.25), 0.0);
        assert_eq!(d.pdf_continuous(0.75), 2.0);
        assert_eq!(d.pdf_continuous(-0.1), 0.0);
        assert_eq!(d.pdf_discrete(7), 0.0);
    }

    #[test]
    fn guide_table_search_matches_binary_search() {
        let mut rng = Rng::new(5);
        // Peaked, sparse, flat, tiny and non-power-of-two sizes, including zero-weight runs.
        let mut cases: Vec<Vec<f32>> = vec![
            vec![1.0],
            vec![0.0, 0.0, 1.0],
            vec![3.0, 1.0],
            vec![0.0; 7],
            (0..513)
                .map(|i| if i == 300 { 1e6 } else { 1e-3 })
                .collect(),
            (0..1000)
                .map(|i| if i % 17 == 0 { 1.0 } else { 0.0 })
                .collect(),
            (0..64).map(|i| (i as f32).powi(6)).collect(),
        ];
        for n in [5usize, 100, 256, 777] {
            cases.push((0..n).map(|_| rng.f32().powi(8)).collect());
        }
        for weights in &cases {
            let d = Distribution1D::new(weights);
            let g = d.guide.len() - 1;
            let mut us: Vec<f32> = (0..20_000).map(|_| rng.f32()).collect();
            // Every cdf value, its neighbours and the guide cell edges: the boundary cases.
            for &c in &d.cdf {
                us.extend([
                    c,
                    f32::from_bits(c.to_bits().saturating_sub(1)),
                    c.next_up(),
                ]);
            }
            us.extend((0..=g).map(|k| k as f32 / g as f32));
            us.extend([0.0, ONE_MINUS_EPSILON]);
            for u in us {
                let u = clamp_unit(u);
                assert_eq!(d.find(u), d.find_slow(u), "u {u} weights {weights:?}");
            }
        }
    }

    #[test]
    fn distribution_2d_histogram_matches_pdf() {
        let (w, h) = (12, 8);
        // Includes a zero row and zero cells.
        let weights: Vec<f32> = (0..w * h)
            .map(|k| {
                let (i, j) = (k % w, k / w);
                if j == 3 {
                    0.0
                } else {
                    ((i * 3 + j * 5) % 7) as f32 + if i == j { 10.0 } else { 0.0 }
                }
            })
            .collect();
        let d = Distribution2D::new(&weights, w, h);
        let total: f32 = weights.iter().sum();
        assert!((d.integral() - total / (w * h) as f32).abs() < 1e-5);
        let n = 200_000;
        let (bw, bh) = (2 * w, 2 * h);
        let mut hist = vec![0.0f64; bw * bh];
        let mut rng = Rng::new(3);
        let conditionals: Vec<Distribution1D> =
            weights.chunks(w).map(Distribution1D::new).collect();
        for _ in 0..n {
            let u = rng.vec2();
            let (uv, pdf) = d.sample(u);
            assert!((0.0..1.0).contains(&uv.x) && (0.0..1.0).contains(&uv.y));
            let rel = (pdf - d.pdf(uv)).abs() / pdf;
            assert!(rel < 1e-6, "pdf mismatch at {uv}: {pdf} vs {}", d.pdf(uv));
            // The flattened rows give exactly what the row's own Distribution1D gives.
            let row = d.marginal.bin_of(uv.y);
            let product = d.marginal.pdf_continuous(uv.y) * conditionals[row].pdf_continuous(uv.x);
            assert_eq!(d.pdf(uv), product);
            assert_eq!(pdf, product);
            assert_eq!(uv.x, conditionals[row].sample_continuous(u.x).0);
            let cell = (uv.y * h as f32) as usize * w + (uv.x * w as f32) as usize;
            assert!(weights[cell] > 0.0, "sampled a zero cell");
            assert!((pdf - weights[cell] * (w * h) as f32 / total).abs() < 1e-4 * pdf);
            hist[(uv.y * bh as f32) as usize * bw + (uv.x * bw as f32) as usize] += 1.0;
        }
        let expected: Vec<f64> = (0..bw * bh)
            .map(|k| {
                let c = Vec2::new(
                    ((k % bw) as f32 + 0.5) / bw as f32,
                    ((k / bw) as f32 + 0.5) / bh as f32,
                );
                d.pdf(c) as f64 / (bw * bh) as f64 * n as f64
            })
            .collect();
        assert_chi_square("Distribution2D::sample", &hist, &expected);
    }

    #[test]
    fn distribution_2d_all_zero_and_bad_sizes() {
        let d = Distribution2D::new(&[0.0; 12], 4, 3);
        assert_eq!(d.integral(), 0.0);
        let mut rng = Rng::new(4);
        for _ in 0..1000 {
            let (uv, pdf) = d.sample(rng.vec2());
            assert!(uv.is_finite());
            assert_eq!(pdf, 1.0);
            assert_eq!(d.pdf(uv), 1.0);
        }
        // Too few weights and zero sizes do not panic.
        let d = Distribution2D::new(&[1.0, 2.0], 4, 0);
        assert_eq!((d.width(), d.height()), (4, 1));
        let (uv, pdf) = d.sample(Vec2::new(0.9, 0.5));
        assert!(uv.x < 0.5 && pdf > 0.0, "{uv} {pdf}");
        assert_eq!(d.pdf(Vec2::new(0.7, 0.5)), 0.0);
        assert_eq!(d.pdf(Vec2::new(1.5, 0.5)), 0.0);
    }
}
