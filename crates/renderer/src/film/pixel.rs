//! One pixel's running estimate: a plain mean of unit-weight samples (importance-sampled
//! filters), or weighted sums of splats (splatted filters). Both accumulate in f64, where the
//! squares of any f32 sample stay finite, and a finished pixel's mean and variance are clamped to
//! f32's range ([`PixelValue::clamped`] says when): no image torrey writes holds an infinite
//! value, whatever finite samples it received (a texture near f32::MAX, `reflectance = 1e30`).

use glam::{DVec3, Vec3A};

/// A finished pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelValue {
    /// The estimate: the mean of the samples, or sum(w L) / sum(w) of the splats.
    pub mean: Vec3A,
    /// Variance of `mean` (its noise level).
    pub variance: Vec3A,
    /// Samples that reached the pixel (splats of non-zero weight).
    pub count: u32,
    /// Sum of the weights: `count` for unit weights. Merging sample ranges weighs by it.
    pub weight: f32,
    /// The mean or the variance exceeded f32's range and was clamped to ±f32::MAX.
    pub clamped: bool,
}

/// `v` as f32, each component clamped to ±f32::MAX; `clamped` is set when one was.
#[inline]
fn to_f32_clamped(v: DVec3, clamped: &mut bool) -> Vec3A {
    let limit = f32::MAX as f64;
    let c = v.clamp(DVec3::splat(-limit), DVec3::splat(limit));
    // NaN cannot come from finite samples; should one appear, it is written as 0.
    let c = DVec3::select(c.cmpeq(c), c, DVec3::ZERO);
    *clamped |= c != v;
    c.as_vec3a()
}

/// Welford's running mean and variance of unit-weight samples, in f64.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PixelMean {
    n: u32,
    mean: DVec3,
    m2: DVec3,
}

impl PixelMean {
    #[inline]
    pub(crate) fn add(&mut self, l: Vec3A) {
        let l = l.as_dvec3();
        self.n += 1;
        let delta = l - self.mean;
        self.mean += delta / self.n as f64;
        self.m2 += delta * (l - self.mean);
    }

    /// The mean and the variance of the mean (sample variance / n; an overestimate for
    /// correlated low-discrepancy samples).
    pub(crate) fn finish(&self) -> PixelValue {
        let n = self.n;
        let mut clamped = false;
        let mean = to_f32_clamped(self.mean, &mut clamped);
        let variance = if n > 1 {
            to_f32_clamped(self.m2 / ((n - 1) as f64 * n as f64), &mut clamped)
        } else {
            Vec3A::ZERO
        };
        PixelValue {
            mean,
            variance,
            count: n,
            weight: n as f32,
            clamped,
        }
    }
}

/// Sums of a pixel's weighted splats, in f64 (weights of either sign cancel):
/// sum w, sum w L, sum w^2, sum w^2 L, sum w^2 L^2.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct SplatSum {
    n: u32,
    w: f64,
    wl: [f64; 3],
    w2: f64,
    w2l: [f64; 3],
    w2l2: [f64; 3],
}

impl SplatSum {
    #[inline]
    pub(crate) fn add(&mut self, w: f32, l: Vec3A) {
        let w = w as f64;
        let w2 = w * w;
        self.n += 1;
        self.w += w;
        self.w2 += w2;
        for c in 0..3 {
            let v = l[c] as f64;
            self.wl[c] += w * v;
            self.w2l[c] += w2 * v;
            self.w2l2[c] += w2 * v * v;
        }
    }

    /// Adds another block's sums for the same pixel.
    pub(crate) fn merge(&mut self, o: &SplatSum) {
        self.n += o.n;
        self.w += o.w;
        self.w2 += o.w2;
        for c in 0..3 {
            self.wl[c] += o.wl[c];
            self.w2l[c] += o.w2l[c];
            self.w2l2[c] += o.w2l2[c];
        }
    }

    /// The ratio estimate sum(w L) / sum(w) and its variance by the delta method,
    /// sum w^2 (L - mean)^2 / (sum w)^2, scaled by n_eff / (n_eff - 1) with Kish's effective
    /// sample count n_eff = (sum w)^2 / sum w^2 (for unit weights: the sample variance / n).
    pub(crate) fn finish(&self) -> PixelValue {
        if self.w == 0.0 {
            return PixelValue {
                count: self.n,
                ..PixelValue::default()
            };
        }
        let mut mean = DVec3::ZERO;
        let mut var = DVec3::ZERO;
        let w_sq = self.w * self.w;
        let n_eff = w_sq / self.w2;
        let correction = if n_eff > 1.0 {
            n_eff / (n_eff - 1.0)
        } else {
            1.0
        };
        for c in 0..3 {
            let m = self.wl[c] / self.w;
            let q = self.w2l2[c] - 2.0 * m * self.w2l[c] + m * m * self.w2;
            mean[c] = m;
            var[c] = q.max(0.0) / w_sq * correction;
        }
        let mut clamped = false;
        PixelValue {
            mean: to_f32_clamped(mean, &mut clamped),
            variance: to_f32_clamped(var, &mut clamped),
            count: self.n,
            weight: self.w as f32,
            clamped,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Unit-weight splats give Welford's mean and variance of the mean.
    #[test]
    fn unit_splats_match_the_plain_mean() {
        let values = [0.5f32, 2.0, 1.25, 3.5, 0.0];
        let (mut a, mut b) = (PixelMean::default(), SplatSum::default());
        for v in values {
            a.add(Vec3A::splat(v));
            b.add(1.0, Vec3A::splat(v));
        }
        let (a, b) = (a.finish(), b.finish());
        assert!((a.mean - b.mean).abs().max_element() < 1e-6);
        assert!((a.variance - b.variance).abs().max_element() < 1e-6);
        assert_eq!((a.count, a.weight), (b.count, b.weight));
    }

    /// Finite samples near f32::MAX: the mean is theirs (sums in f64 do not overflow) and the
    /// variance, beyond f32's range, is clamped to f32::MAX and flagged; in f32 the sum of
    /// squares was infinite. Ordinary samples are not flagged.
    #[test]
    fn huge_samples_give_finite_clamped_pixels() {
        let values = [3.0e38f32, 1.0, 3.4e38, 0.0, 2.5e38];
        let mut p = PixelMean::default();
        for v in values {
            p.add(Vec3A::new(v, 1.0, -v));
        }
        let v = p.finish();
        let mean = values.iter().map(|&x| x as f64).sum::<f64>() / values.len() as f64;
        assert!(((v.mean.x as f64) - mean).abs() <= 1e-6 * mean, "{v:?}");
        assert_eq!(v.mean.y, 1.0);
        assert!(((v.mean.z as f64) + mean).abs() <= 1e-6 * mean, "{v:?}");
        assert_eq!(v.variance, Vec3A::new(f32::MAX, 0.0, f32::MAX));
        assert!(v.clamped);
        let mut ordinary = PixelMean::default();
        ordinary.add(Vec3A::splat(1e18));
        ordinary.add(Vec3A::splat(2e18));
        let o = ordinary.finish();
        assert!(
            !o.clamped && o.variance.is_finite() && o.variance.x > 0.0,
            "{o:?}"
        );

        // Splats: a negative lobe on one side makes sum(w L) / sum(w) exceed f32::MAX.
        let mut s = SplatSum::default();
        s.add(1.0, Vec3A::splat(3.4e38));
        s.add(-0.5, Vec3A::splat(0.0));
        let v = s.finish();
        assert_eq!(v.mean, Vec3A::splat(f32::MAX));
        assert!(v.variance.is_finite() && v.clamped, "{v:?}");
    }

    /// Signed weights: the estimate is sum(w L) / sum(w); split sums merge to the same pixel.
    #[test]
    fn signed_weights_and_merging() {
        let splats = [(1.0f32, 2.0f32), (-0.25, 8.0), (0.5, 1.0), (0.75, 4.0)];
        let mut all = SplatSum::default();
        let (mut a, mut b) = (SplatSum::default(), SplatSum::default());
        for (i, &(w, l)) in splats.iter().enumerate() {
            all.add(w, Vec3A::splat(l));
            if i < 2 { &mut a } else { &mut b }.add(w, Vec3A::splat(l));
        }
        a.merge(&b);
        let (x, y) = (all.finish(), a.finish());
        let expected = (2.0 - 2.0 + 0.5 + 3.0) / 2.0;
        assert!((x.mean.x - expected).abs() < 1e-6, "{x:?}");
        assert_eq!(x, y);
        assert_eq!((x.count, x.weight), (4, 2.0));
    }
}
