//! Mitsuba 3's reconstruction filters (`src/rfilters/*.cpp`): their radii, their separable 1D
//! profiles, and where a pixel's sample lands on the film.
//!
//! Filters without negative lobes (box, tent, gaussian) are drawn by filter importance sampling:
//! the sample's offset from the pixel centre follows the filter exactly, so it counts with weight
//! one in its own pixel. Filters with negative lobes (mitchell, catmullrom, lanczos) are splatted
//! as Mitsuba splats them: the sample lands uniformly in its pixel and adds `f(dx) f(dy)` times
//! its value to every pixel whose centre lies within the radius (docs/conventions.md says why).

use glam::Vec2;
use torrey_fastmath::{ln, sin_cos_2pi};
use torrey_parser::PixelFilter;

/// A reconstruction filter, ready to place samples and weigh splats.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Filter {
    kind: PixelFilter,
    radius: f32,
}

impl Filter {
    pub fn new(kind: PixelFilter) -> Self {
        let radius = match kind {
            PixelFilter::Box => 0.5,
            PixelFilter::Tent { radius } => radius,
            PixelFilter::Gaussian { stddev } => 4.0 * stddev,
            PixelFilter::Mitchell { .. } | PixelFilter::CatmullRom => 2.0,
            PixelFilter::Lanczos { lobes } => lobes as f32,
        };
        Self { kind, radius }
    }

    /// Mitsuba's radius in pixels: the filter is zero beyond it.
    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// Whether samples are splatted across neighbouring pixels with weights (filters with
    /// negative lobes) rather than drawn from the filter with weight one.
    pub fn splats(&self) -> bool {
        matches!(
            self.kind,
            PixelFilter::Mitchell { .. } | PixelFilter::CatmullRom | PixelFilter::Lanczos { .. }
        )
    }

    /// Pixels a splat reaches on either side of the pixel its sample lies in: Mitsuba's
    /// `border_size`, ceil(radius - 0.5); 0 for filters drawn by importance sampling.
    pub fn border(&self) -> u32 {
        if self.splats() {
            (self.radius - 0.5).ceil().max(0.0) as u32
        } else {
            0
        }
    }

    /// The sample's offset from its pixel's centre for the sampler's draw `u`: drawn from the
    /// filter for importance-sampled filters, uniform over the pixel for splatted ones.
    #[inline]
    pub fn offset(&self, u: Vec2) -> Vec2 {
        match self.kind {
            PixelFilter::Box
            | PixelFilter::Mitchell { .. }
            | PixelFilter::CatmullRom
            | PixelFilter::Lanczos { .. } => u - Vec2::splat(0.5),
            PixelFilter::Tent { radius } => Vec2::new(sample_tent(u.x), sample_tent(u.y)) * radius,
            PixelFilter::Gaussian { stddev } => {
                // Box-Muller, truncated at Mitsuba's radius of 4 standard deviations.
                let r = (-2.0 * ln((1.0 - u.x).max(1e-12))).sqrt().min(4.0);
                let (sin_phi, cos_phi) = sin_cos_2pi(u.y);
                Vec2::new(cos_phi, sin_phi) * (r * stddev)
            }
        }
    }

    /// The 1D profile at `x` pixels from the centre, as Mitsuba's `eval` (the filter is the
    /// product of the profiles along x and y). Not normalised: splat weights are divided by their
    /// per-pixel sum.
    #[inline]
    pub fn eval(&self, x: f32) -> f32 {
        let x = x.abs();
        match self.kind {
            PixelFilter::Box => {
                if x <= 0.5 {
                    1.0
                } else {
                    0.0
                }
            }
            PixelFilter::Tent { radius } => (1.0 - x / radius).max(0.0),
            PixelFilter::Gaussian { stddev } => {
                if x <= self.radius {
                    (-0.5 * x * x / (stddev * stddev)).exp()
                } else {
                    0.0
                }
            }
            PixelFilter::Mitchell { b, c } => mitchell_netravali(x, b, c),
            PixelFilter::CatmullRom => mitchell_netravali(x, 0.0, 0.5),
            PixelFilter::Lanczos { .. } => {
                if x < f32::EPSILON {
                    1.0
                } else if x > self.radius {
                    0.0
                } else {
                    let x1 = std::f32::consts::PI * x;
                    let x2 = x1 / self.radius;
                    (x1.sin() * x2.sin()) / (x1 * x2)
                }
            }
        }
    }
}

/// The Mitchell-Netravali cubic with parameters B and C at |x| (radius 2).
#[inline]
fn mitchell_netravali(x: f32, b: f32, c: f32) -> f32 {
    let (x2, x3) = (x * x, x * x * x);
    let v = if x < 1.0 {
        (12.0 - 9.0 * b - 6.0 * c) * x3 + (-18.0 + 12.0 * b + 6.0 * c) * x2 + (6.0 - 2.0 * b)
    } else {
        (-b - 6.0 * c) * x3
            + (6.0 * b + 30.0 * c) * x2
            + (-12.0 * b - 48.0 * c) * x
            + (8.0 * b + 24.0 * c)
    };
    if x < 2.0 {
        v / 6.0
    } else {
        0.0
    }
}

/// Inverse CDF of the unit tent on [-1, 1].
#[inline]
pub(crate) fn sample_tent(u: f32) -> f32 {
    if u < 0.5 {
        (2.0 * u).sqrt() - 1.0
    } else {
        1.0 - (2.0 - 2.0 * u).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::{PcgSampler, Sampler};

    #[test]
    fn tent_samples_match_the_tent() {
        let mut s = PcgSampler::new(1, 1);
        let mut bins = [0u32; 8];
        let n = 80_000;
        for _ in 0..n {
            let x = sample_tent(s.next_1d());
            assert!((-1.0..=1.0).contains(&x));
            bins[((x + 1.0) * 4.0).min(7.999) as usize] += 1;
        }
        // Expected mass of bin [a, b] under the tent: integral of 1 - |x|.
        let cdf = |x: f64| {
            if x < 0.0 {
                0.5 * (1.0 + x).powi(2)
            } else {
                1.0 - 0.5 * (1.0 - x).powi(2)
            }
        };
        let chi2: f64 = (0..8)
            .map(|i| {
                let (a, b) = (-1.0 + i as f64 * 0.25, -1.0 + (i + 1) as f64 * 0.25);
                let e = (cdf(b) - cdf(a)) * n as f64;
                (bins[i] as f64 - e).powi(2) / e
            })
            .sum();
        assert!(chi2 < 24.3, "chi2 = {chi2}"); // 7 dof, 0.999 quantile
    }

    /// Radii, borders and the profiles' known values: Mitchell-Netravali's cubic is (6 - 2B)/6 at
    /// 0 and B/6 at 1 and 0 from 2 on (Catmull-Rom: 1, 0, 0; interpolating), Lanczos is 1 at 0
    /// and 0 at every integer and beyond its lobes; Catmull-Rom and Lanczos dip below zero.
    #[test]
    fn profiles_and_radii_are_mitsubas() {
        let m = Filter::new(PixelFilter::Mitchell {
            b: 1.0 / 3.0,
            c: 1.0 / 3.0,
        });
        assert_eq!((m.radius(), m.border(), m.splats()), (2.0, 2, true));
        assert!((m.eval(0.0) - 16.0 / 18.0).abs() < 1e-6);
        assert!((m.eval(1.0) - 1.0 / 18.0).abs() < 1e-6);
        assert!((m.eval(-1.0) - 1.0 / 18.0).abs() < 1e-6);
        assert_eq!(m.eval(2.0), 0.0);
        let cr = Filter::new(PixelFilter::CatmullRom);
        assert!((cr.eval(0.0) - 1.0).abs() < 1e-6 && cr.eval(1.0).abs() < 1e-6);
        assert!(cr.eval(1.5) < -0.05);
        let l = Filter::new(PixelFilter::Lanczos { lobes: 3 });
        assert_eq!((l.radius(), l.border()), (3.0, 3));
        assert_eq!(l.eval(0.0), 1.0);
        for k in 1..=3 {
            assert!(l.eval(k as f32).abs() < 1e-6, "{k}");
        }
        assert_eq!(l.eval(3.5), 0.0);
        assert!(l.eval(1.5) < -0.1);
        let g = Filter::new(PixelFilter::Gaussian { stddev: 0.5 });
        assert_eq!((g.radius(), g.border(), g.splats()), (2.0, 0, false));
        // Each profile integrates to about one (Lanczos 3: 0.997), so weights are comparable.
        for f in [m, cr, l] {
            let n = 20_000;
            let r = f.radius();
            let sum: f32 = (0..n)
                .map(|i| f.eval(-r + (i as f32 + 0.5) * 2.0 * r / n as f32))
                .sum::<f32>()
                * 2.0
                * r
                / n as f32;
            assert!((sum - 1.0).abs() < 4e-3, "{f:?}: {sum}");
        }
    }
}
