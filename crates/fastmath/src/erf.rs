//! The error function and its inverse, for the Beckmann microfacet distribution (its exact Smith
//! masking and the sampling of its visible normals).

use crate::explog::{exp, ln};
use std::f32::consts::FRAC_2_SQRT_PI;

/// erf(x) for |x| < 0.9: x P(x^2), P a degree-5 minimax fit (relative 1.2e-8 in exact
/// arithmetic), summed as x c0 + x (s Q(s)) so that only the last addition rounds at full size.
#[inline(always)]
fn erf_small(x: f32) -> f32 {
    let s = x * x;
    let s2 = s * s;
    let a = 0.112_821_41 * s - 0.376_125_23;
    let b = 0.005_011_971_4 * s - 0.026_778_916;
    let q = (b * s2 + a) - 0.000_609_039_8 * s2 * s2;
    // c0 = 2/sqrt(pi) in two parts: its f32 rounding alone would be a relative 6e-8.
    FRAC_2_SQRT_PI * x + x * (s * q - 7.194_669e-8)
}

/// ln erfc(a) for a in [0.9, 3.93]: a degree-7 minimax fit (relative 3.5e-7 of erfc in exact
/// arithmetic).
#[inline(always)]
fn ln_erfc_large(a: f32) -> f32 {
    let a2 = a * a;
    let a4 = a2 * a2;
    let p0 = -1.127_045_8 * a - 0.000_431_194_54;
    let p1 = -0.104_527_25 * a - 0.637_504_3;
    let p2 = -0.003_573_503 * a + 0.023_154_88;
    let p3 = -1.440_056_1e-5 * a + 0.000_336_475_6;
    (p1 * a2 + p0) + (p3 * a2 + p2) * a4
}

/// The error function: absolute error at most 1.6e-7 and, for |x| < 0.9, relative error at most
/// 2.5e-7 (tested). Odd (erf(-x) = -erf(x)), ±1 beyond |x| = 3.93 where f32 rounds it to that;
/// NaN in, NaN out.
#[inline]
pub fn erf(x: f32) -> f32 {
    let a = x.abs();
    if a < 0.9 {
        return erf_small(x);
    }
    // Beyond 3.93, erfc < 1.4e-8 rounds away against 1: the fit's end value does too.
    let r = 1.0 - exp(ln_erfc_large(a.min(3.93)));
    // NaN fails `a < 0.9` and `min` would turn it into a number: keep it NaN.
    if a.is_nan() {
        return x;
    }
    r.copysign(x)
}

/// The inverse error function on (-1, 1), Giles' single-precision approximation ("Approximating
/// the erfinv function", GPU Computing Gems Jade, 2011): a polynomial in w = -ln(1 - x^2) (or in
/// its square root near ±1), here with this crate's [`ln`]. Relative error at most 5e-7 (tested)
/// for |x| <= 0.9999999; arguments beyond that are clamped to it (|result| <= 3.77), NaN in, NaN
/// out.
#[inline]
pub fn erfinv(x: f32) -> f32 {
    let x = x.clamp(-0.999_999_9, 0.999_999_9);
    // (1 - x)(1 + x) keeps the precision of 1 - x near ±1 (each factor is exact there).
    let w = -ln((1.0 - x) * (1.0 + x));
    // Giles' polynomials (coefficients c0..c8 as published), by Estrin's scheme: four dependent
    // multiply-add levels instead of eight, because the Beckmann sampler's Newton steps wait
    // for this value.
    let p = if w < 5.0 {
        let w = w - 2.5;
        let (w2, w4) = (w * w, w * w * (w * w));
        let q0 = 0.246_640_73 * w + 1.501_409_4;
        let q1 = -0.001_253_725 * w - 0.004_177_681_6;
        let q2 = -4.391_506_5e-6 * w + 0.000_218_580_87;
        let q3 = 3.432_739_4e-7 * w - 3.523_387_7e-6;
        (q1 * w2 + q0) + ((q3 * w2 + q2) + 2.810_226_4e-8 * w4) * w4
    } else {
        let w = w.sqrt() - 3.0;
        let (w2, w4) = (w * w, w * w * (w * w));
        let q0 = 1.001_674 * w + 2.832_976_8;
        let q1 = -0.007_622_461_3 * w + 0.009_438_870_5;
        let q2 = -0.003_673_428_4 * w + 0.005_739_507_7;
        let q3 = 0.000_100_950_56 * w + 0.001_349_343_2;
        (q1 * w2 + q0) + ((q3 * w2 + q2) - 0.000_200_214_26 * w4) * w4
    };
    p * x
}

#[cfg(test)]
mod tests {
    use super::*;

    extern "C" {
        /// The C library's double-precision erf (glibc: under 1 ULP of f64): the reference.
        #[link_name = "erf"]
        fn libm_erf(x: f64) -> f64;
    }

    fn erf64(x: f64) -> f64 {
        // SAFETY: a pure C function of one double, linked with std's libm on every unix target.
        unsafe { libm_erf(x) }
    }

    /// erf^-1(y) in f64 by Newton steps on the f64 erf from a bisection start.
    fn erfinv64(y: f64) -> f64 {
        let (mut lo, mut hi) = (-6.0f64, 6.0f64);
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if erf64(mid) < y {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let mut x = 0.5 * (lo + hi);
        for _ in 0..3 {
            let d = 2.0 / std::f64::consts::PI.sqrt() * (-x * x).exp();
            if d > 0.0 {
                x -= (erf64(x) - y) / d;
            }
        }
        x
    }

    #[test]
    fn erf_matches_f64_over_dense_sweep() {
        let (mut max_abs, mut max_rel_small) = (0.0f64, 0.0f64);
        let n = 8_000_000;
        for k in 0..=n {
            let x = -5.0 + 10.0 * k as f32 / n as f32;
            let want = erf64(x as f64);
            let err = (erf(x) as f64 - want).abs();
            max_abs = max_abs.max(err);
            if x.abs() < 0.9 && want != 0.0 {
                max_rel_small = max_rel_small.max(err / want.abs());
            }
        }
        for k in 0..200 {
            let x = 1e-30f32 * 1.4f32.powi(k);
            if x < 0.9 {
                let err = (erf(x) as f64 - erf64(x as f64)).abs() / erf64(x as f64);
                max_rel_small = max_rel_small.max(err);
            }
        }
        assert!(max_abs <= 1.6e-7, "max erf error {max_abs:e}");
        assert!(
            max_rel_small <= 2.5e-7,
            "max relative erf error {max_rel_small:e}"
        );
        assert_eq!(erf(0.0), 0.0);
        assert_eq!(erf(10.0), 1.0);
        assert_eq!(erf(-10.0), -1.0);
        assert_eq!(erf(f32::INFINITY), 1.0);
        assert!(erf(f32::NAN).is_nan());
        assert!(erf(-0.3) == -erf(0.3) && erf(-2.0) == -erf(2.0));
    }

    #[test]
    fn erfinv_matches_f64_over_dense_sweep() {
        let mut max_rel = 0.0f64;
        let mut ys: Vec<f32> = (0..=2_000_000)
            .map(|k| -1.0 + 2.0 * k as f32 / 2_000_000.0)
            .collect();
        // Near ±1, the tail branch, down to the clamp.
        for k in 1..=100_000 {
            let d = k as f32 * 1e-7;
            ys.extend([1.0 - d, -1.0 + d]);
        }
        ys.extend([0.0, 1e-30, -1e-20, 0.999_999_9]);
        for y in ys {
            let y = y.clamp(-0.999_999_9, 0.999_999_9);
            let want = erfinv64(y as f64);
            if want == 0.0 {
                assert_eq!(erfinv(y), 0.0);
                continue;
            }
            max_rel = max_rel.max((erfinv(y) as f64 - want).abs() / want.abs());
        }
        assert!(max_rel <= 5e-7, "max erfinv error {max_rel:e}");
        // Round trips through erf.
        // (Up to |x| = 2: beyond, the f32 rounding of erf(x) itself moves the inverse by more.)
        for k in -200..=200 {
            let x = k as f32 * 0.01;
            assert!((erfinv(erf(x)) - x).abs() <= 2e-6 * (1.0 + x.abs()), "{x}");
        }
        assert!(erfinv(f32::NAN).is_nan());
        assert_eq!(erfinv(2.0), erfinv(0.999_999_9));
    }
}
