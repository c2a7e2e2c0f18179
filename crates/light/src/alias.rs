//! Alias tables (Walker 1977, built with Vose's method): sampling a discrete distribution with
//! one table read and no search, which is what environment-map sampling needs on its hot path.
//!
//! A table of `n` slots is read at slot `k = floor(u n)`; the fraction of `u n` left over decides
//! between the slot's own index (below the slot's threshold `q`) and its alias, and is then
//! rescaled to a fresh uniform number in [0, 1) for the caller's continuous use (the position
//! inside the chosen cell).
//!
//! The thresholds are stored in f32, which moves each probability by up to an f32 rounding; so the
//! probabilities the table reports are recomputed from the stored slots themselves, and sampling
//! and pdf agree exactly, not just to a rounding.
//!
//! Compared with an inverse-cdf search (a binary search over a cdf) the mapping from `u` to an index
//! is not monotonic: a stratified `u` stays stratified over slots, but neighbouring `u` may pick
//! far-apart cells. In exchange a 2D table over an environment map costs one dependent memory
//! read per level instead of a guide read and a cdf read.

/// One slot of an alias table: the slot's own index is chosen below `q`, `alias` above it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct AliasSlot {
    /// Probability of keeping the slot's own index, in [0, 1].
    pub q: f32,
    /// The index chosen when the slot's own index is not.
    pub alias: u32,
}

/// Builds the slots for `weights` and appends them to `slots` (so that several tables can share one
/// allocation); returns each index's probability as the appended slots realise it.
///
/// Negative, NaN and infinite weights count as 0; all-zero (or empty) weights give the uniform
/// distribution. Zero-weight indices are never chosen by a table with positive weights.
pub fn build_slots(weights: &[f32], slots: &mut Vec<AliasSlot>) -> Vec<f64> {
    let w: Vec<f64> = weights.iter().map(|&x| x as f64).collect();
    build_slots_f64(&w, slots)
}

/// [`build_slots`] for f64 weights (sums of many f32 weights, which may exceed f32's range).
pub fn build_slots_f64(weights: &[f64], slots: &mut Vec<AliasSlot>) -> Vec<f64> {
    let n = weights.len().max(1);
    let w: Vec<f64> = (0..n)
        .map(|i| match weights.get(i) {
            Some(&x) if x.is_finite() && x > 0.0 => x,
            _ => 0.0,
        })
        .collect();
    let sum: f64 = w.iter().sum();
    let start = slots.len();
    slots.extend((0..n).map(|i| AliasSlot {
        q: 1.0,
        alias: i as u32,
    }));
    let table = &mut slots[start..];
    if sum > 0.0 {
        // Vose: pair each under-full slot with an over-full index that tops it up.
        let mut scaled: Vec<f64> = w.iter().map(|&x| x * n as f64 / sum).collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) =
            (0..n).partition(|&i| scaled[i] < 1.0);
        while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
            small.pop();
            table[s] = AliasSlot {
                q: scaled[s] as f32,
                alias: l as u32,
            };
            scaled[l] -= 1.0 - scaled[s];
            if scaled[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        // What is left is full up to rounding and keeps q = 1, except that a zero-weight index
        // must never be chosen: should rounding leave one over, its slot goes to the heaviest
        // index. (Zero-weight slots paired above already have q = 0.)
        let heaviest = (0..n).fold(0, |best, i| if w[i] > w[best] { i } else { best });
        for (i, slot) in table.iter_mut().enumerate() {
            if w[i] == 0.0 && slot.q > 0.0 {
                *slot = AliasSlot {
                    q: 0.0,
                    alias: heaviest as u32,
                };
            }
        }
    }
    // The probabilities the stored (f32) slots realise.
    let mut p = vec![0.0f64; n];
    for (i, slot) in table.iter().enumerate() {
        let q = (slot.q as f64).clamp(0.0, 1.0);
        p[i] += q / n as f64;
        p[slot.alias as usize] += (1.0 - q) / n as f64;
    }
    p
}

/// Picks from `slots` (non-empty) with `u` in [0, 1): the chosen index and a fresh uniform number
/// in [0, 1) from the part of `u` the choice did not use.
///
/// The choice between a slot's own index and its alias depends on random data, so it is made with
/// selects rather than a branch, which would mispredict often.
#[inline(always)]
pub fn pick(slots: &[AliasSlot], u: f32) -> (usize, f32) {
    // Tables hold far fewer than 2^32 slots; u32 converts to f32 in one instruction, usize not.
    let n = slots.len() as u32;
    let t = u * n as f32;
    // u in [0, 1), so t >= 0 and truncation is floor. Keeping frac below 1 guarantees q > frac
    // for a full slot (q = 1), so the alias branch below never divides by 1 - q = 0.
    let k = (t as u32).min(n - 1);
    let frac = (t - k as f32).min(crate::unit::ONE_MINUS_EPSILON);
    let slot = slots[k as usize];
    let own = frac < slot.q;
    let index = std::hint::select_unpredictable(own, k, slot.alias) as usize;
    // own: frac / q; alias: (frac - q) / (1 - q); both in [0, 1] (q > 0 when own, q < 1 when not).
    // A vector select: LLVM turns a scalar float select (even of bit patterns) into a branch.
    let v = glam::Vec4::select(
        glam::BVec4A::splat(own),
        glam::Vec4::new(0.0, slot.q, 0.0, 0.0),
        glam::Vec4::new(slot.q, 1.0 - slot.q, 0.0, 0.0),
    );
    let (lo, width) = (v.x, v.y);
    let rest = ((frac - lo) / width).clamp(0.0, crate::unit::ONE_MINUS_EPSILON);
    (index, rest)
}

/// A discrete distribution over `len()` indices, sampled with an alias table.
#[derive(Clone, Debug)]
pub struct AliasTable {
    slots: Vec<AliasSlot>,
    /// Probability of each index, as the slots realise it.
    probability: Vec<f32>,
    /// Sum of the sanitised weights.
    sum: f64,
}

impl AliasTable {
    /// See [`build_slots`] for how bad weights are treated.
    pub fn new(weights: &[f32]) -> Self {
        let mut slots = Vec::with_capacity(weights.len().max(1));
        let probability = build_slots(weights, &mut slots)
            .into_iter()
            .map(|p| p as f32)
            .collect();
        let sum = weights
            .iter()
            .filter(|w| w.is_finite() && **w > 0.0)
            .map(|&w| w as f64)
            .sum();
        Self {
            slots,
            probability,
            sum,
        }
    }

    /// Number of indices (at least 1).
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// Always false (empty weights become one index); present for API symmetry.
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// Sum of the sanitised weights (0: nothing to sample, though sampling still works uniformly).
    pub fn weight_sum(&self) -> f64 {
        self.sum
    }

    /// The chosen index and a fresh uniform number in [0, 1); `u` in [0, 1) (NaN reads as 0).
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32) {
        pick(&self.slots, crate::unit::clamp_unit(u))
    }

    /// Probability of [`Self::sample`] choosing `i` (0 outside the range).
    #[inline]
    pub fn probability(&self, i: usize) -> f32 {
        self.probability.get(i).copied().unwrap_or(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use torrey_testkit::{assert_chi_square, Rng};

    #[test]
    fn probabilities_follow_the_weights_and_sum_to_one() {
        let weights: Vec<f32> = (0..37).map(|i| ((i * 7919) % 11) as f32 * 0.37).collect();
        let total: f64 = weights.iter().map(|&w| w as f64).sum();
        let table = AliasTable::new(&weights);
        let mut sum = 0.0f64;
        for (i, &w) in weights.iter().enumerate() {
            let p = table.probability(i) as f64;
            assert!((p - w as f64 / total).abs() < 1e-6, "index {i}: {p}");
            if w == 0.0 {
                assert_eq!(p, 0.0, "zero weight {i} must never be chosen");
            }
            sum += p;
        }
        assert!((sum - 1.0).abs() < 1e-6);
    }

    #[test]
    fn histogram_matches_probabilities_and_rest_is_uniform() {
        // A spiky distribution: one heavy index, zeros, and many light ones.
        let mut weights: Vec<f32> = (0..50).map(|i| 0.1 + (i % 7) as f32).collect();
        weights[3] = 0.0;
        weights[17] = 400.0;
        weights[40] = 0.0;
        let table = AliasTable::new(&weights);
        let n = 200_000;
        let mut hist = vec![0.0f64; weights.len()];
        // The rest of u, binned within each of three indices (heavy, light, medium).
        let watched = [17usize, 0, 6];
        let mut rest_hist = vec![vec![0.0f64; 8]; watched.len()];
        let mut rng = Rng::new(9);
        for _ in 0..n {
            let (i, rest) = table.sample(rng.f32());
            assert!((0.0..1.0).contains(&rest));
            hist[i] += 1.0;
            if let Some(w) = watched.iter().position(|&x| x == i) {
                rest_hist[w][(rest * 8.0) as usize] += 1.0;
            }
        }
        assert_eq!(hist[3], 0.0);
        assert_eq!(hist[40], 0.0);
        let expected: Vec<f64> = (0..weights.len())
            .map(|i| table.probability(i) as f64 * n as f64)
            .collect();
        assert_chi_square("AliasTable::sample", &hist, &expected);
        for (w, rest) in watched.iter().zip(&rest_hist) {
            let count: f64 = rest.iter().sum();
            let expected = vec![count / 8.0; 8];
            assert_chi_square(&format!("rest of u within index {w}"), rest, &expected);
        }
    }

    #[test]
    fn pick_at_the_top_of_the_unit_interval() {
        // The largest u the samplers produce, on tables of awkward sizes with full slots (q = 1)
        // last: the rest of u must stay a number in [0, 1).
        let top = crate::unit::ONE_MINUS_EPSILON;
        for n in [1usize, 3, 7, 1000, 4097, 65_537] {
            let weights: Vec<f32> = (0..n).map(|i| 1.0 + (i % 3) as f32).collect();
            let mut slots = Vec::new();
            build_slots(&weights, &mut slots);
            for u in [top, top.next_down(), 0.0] {
                let (i, rest) = pick(&slots, u);
                assert!(i < n, "n = {n}, u = {u}: index {i}");
                assert!((0.0..1.0).contains(&rest), "n = {n}, u = {u}: rest {rest}");
            }
        }
    }

    #[test]
    fn bad_and_degenerate_weights() {
        for weights in [vec![], vec![0.0; 5], vec![f32::NAN, -1.0, f32::INFINITY]] {
            let table = AliasTable::new(&weights);
            let n = table.len();
            assert_eq!(n, weights.len().max(1));
            for i in 0..n {
                assert!((table.probability(i) - 1.0 / n as f32).abs() < 1e-6);
            }
            for u in [0.0, 0.3, 0.999_999_9, 1.0, f32::NAN, -2.0] {
                let (i, rest) = table.sample(u);
                assert!(i < n && (0.0..1.0).contains(&rest), "u = {u}");
            }
        }
        // One positive weight among zeros: always chosen.
        let table = AliasTable::new(&[0.0, 0.0, 2.5, 0.0]);
        for k in 0..100 {
            assert_eq!(table.sample(k as f32 / 100.0).0, 2);
        }
        assert_eq!(table.probability(2), 1.0);
    }
}
