//! Exponentials and logarithms: exp, exp2, expm1, ln, log2 and powf, with Cody-Waite argument
//! reduction and minimax polynomials fitted for this crate (in exact arithmetic the exponential
//! core is 3e-9 and the logarithm core 6e-9 off, relative: the f32 rounding of the evaluation
//! dominates). Plain multiply-adds, no FMA needed; no lookup tables; the only branches are the
//! cold ones of the logarithm's special inputs (zero, negative, subnormal, infinite, NaN).

/// 1.5 * 2^23: adding and subtracting it rounds an f32 of magnitude below 2^22 to the nearest
/// integer, and the sum's low mantissa bits hold that integer.
const ROUND_MAGIC: f32 = 12_582_912.0;
/// ln 2 split in two: the high part has 15 significant bits, so n * LN2_HI is exact for the
/// |n| <= 256 that the reductions meet.
const LN2_HI: f32 = 0.693_145_75;
const LN2_LO: f32 = 1.428_606_8e-6;
const LN2: f32 = std::f32::consts::LN_2;
const LOG2_E: f32 = std::f32::consts::LOG2_E;

/// e^r - 1 - r for |r| <= ln(2)/2: r^2 (1/2 + r/6 + ...), a degree-4 minimax fit of the bracket.
#[inline(always)]
fn expm1_tail(r: f32) -> f32 {
    let r2 = r * r;
    let a = 0.166_665_2 * r + 0.499_999_94;
    let b = 0.008_368_71 * r + 0.041_668_387;
    let q = (b * r2 + a) + 0.001_381_461_3 * r2 * r2;
    r2 * q
}

/// 2^n for an integer n in [-300, 300], as the product of two powers of two that are each
/// representable: so 2^128 times a mantissa below 1 still comes out finite, and n below -126
/// gives the subnormal (or zero) that the product rounds to.
#[inline(always)]
fn pow2i(n: i32) -> (f32, f32) {
    let h = n >> 1;
    (
        f32::from_bits(((h + 127) << 23) as u32),
        f32::from_bits(((n - h + 127) << 23) as u32),
    )
}

/// The nearest integer to `y` (|y| < 2^22), as f32 and as i32.
#[inline(always)]
fn round_int(y: f32) -> (f32, i32) {
    let t = y + ROUND_MAGIC;
    let n = t - ROUND_MAGIC;
    (n, t.to_bits() as i32 - ROUND_MAGIC.to_bits() as i32)
}

/// `x.exp()`: relative error at most 2.5e-7 (about 2 ULP; tested) for results in f32's normal
/// range (x in [-87.3, 88.7]); below it the result is the subnormal or zero the scaling rounds to,
/// above it infinity. NaN in, NaN out.
#[inline]
pub fn exp(x: f32) -> f32 {
    // `clamp` keeps NaN, and NaN stays NaN through the arithmetic below.
    let x = x.clamp(-104.0, 89.0);
    let (nf, n) = round_int(x * LOG2_E);
    let r = x - nf * LN2_HI - nf * LN2_LO;
    let (s1, s2) = pow2i(n);
    ((1.0 + r) + expm1_tail(r)) * s1 * s2
}

/// `x.exp2()`: relative error at most 2.5e-7 (tested) for x in [-126, 128); below, the subnormal
/// or zero, above, infinity. NaN in, NaN out.
#[inline]
pub fn exp2(x: f32) -> f32 {
    let x = x.clamp(-151.0, 129.0);
    let (nf, n) = round_int(x);
    // x - n is exact; its product with ln 2 adds one rounding, a relative 6e-8 of r <= 0.35.
    let r = (x - nf) * LN2;
    let (s1, s2) = pow2i(n);
    ((1.0 + r) + expm1_tail(r)) * s1 * s2
}

/// `x.exp_m1()`: e^x - 1 without the cancellation near 0. Relative error at most 2.5e-7 (tested)
/// for x in [-87, 88.7]; -1 below (as std), infinity above. NaN in, NaN out.
#[inline]
pub fn expm1(x: f32) -> f32 {
    let x = x.clamp(-104.0, 89.0);
    let (nf, n) = round_int(x * LOG2_E);
    // n = 0 (|x| <= ln(2)/2) leaves r = x exactly, and the result is r + tail(r): no cancellation.
    let r = x - nf * LN2_HI - nf * LN2_LO;
    let em1 = r + expm1_tail(r);
    let (s1, s2) = pow2i(n);
    let s = s1 * s2;
    // 2^n (e^r - 1) + (2^n - 1): exact at n = 0, and 2^n - 1 is exact for every n that matters.
    let small = s * em1 + (s - 1.0);
    // Past 2^24 the -1 no longer counts, and 2^n alone may overflow (n = 128) where the result
    // does not.
    let large = (1.0 + em1) * s1 * s2;
    if n > 24 {
        large
    } else {
        small
    }
}

/// ln(1 + f) - f + f^2 / 2 for f in [sqrt(1/2) - 1, sqrt(2) - 1]: f^3 P(f), P a degree-7 minimax
/// fit (relative 6e-9 of ln(1 + f) in exact arithmetic).
#[inline(always)]
fn ln1p_tail(f: f32) -> f32 {
    let f2 = f * f;
    let f4 = f2 * f2;
    let a = -0.250_008_2 * f + 0.333_333_3;
    let b = -0.166_233_57 * f + 0.200_012_27;
    let c = -0.131_601_83 * f + 0.142_017_58;
    let d = -0.076_344_93 * f + 0.127_615_76;
    let p = (b * f2 + a) + (d * f2 + c) * f4;
    p * f2 * f
}

/// x = 2^e m with m in [sqrt(1/2), sqrt(2)), for normal positive finite x: (e, m - 1).
#[inline(always)]
fn split_sqrt2(x: f32) -> (f32, f32) {
    const SQRT_HALF_BITS: i32 = 0x3f35_04f3;
    let bits = x.to_bits() as i32;
    let e = (bits - SQRT_HALF_BITS) >> 23;
    let m = f32::from_bits((bits - (e << 23)) as u32);
    (e as f32, m - 1.0)
}

/// Whether x is a positive, normal, finite f32: the logarithms' fast path.
#[inline(always)]
fn log_fast_path(x: f32) -> bool {
    (f32::MIN_POSITIVE..f32::INFINITY).contains(&x)
}

/// `x.ln()`: absolute error at most 1.2e-7 for x in [0.5, 2], relative error at most 1.2e-7
/// elsewhere (tested). Zero, negative, subnormal, infinite and NaN inputs take std's answer
/// (a cold branch).
#[inline]
pub fn ln(x: f32) -> f32 {
    if !log_fast_path(x) {
        return ln_cold(x);
    }
    let (e, f) = split_sqrt2(x);
    // The small terms first: e ln2_lo + tail, then f - f^2/2, then e ln2_hi (exact).
    (e * LN2_LO + ln1p_tail(f) + (f - 0.5 * f * f)) + e * LN2_HI
}

#[cold]
#[inline(never)]
fn ln_cold(x: f32) -> f32 {
    x.ln()
}

#[cold]
#[inline(never)]
fn log2_cold(x: f32) -> f32 {
    x.log2()
}

/// `x.log2()`: absolute error at most 2e-7 for x in [0.5, 2], relative error at most 1.2e-7
/// elsewhere (tested); std's answer for zero, negative, subnormal, infinite and NaN inputs.
#[inline]
pub fn log2(x: f32) -> f32 {
    if !log_fast_path(x) {
        return log2_cold(x);
    }
    let (e, f) = split_sqrt2(x);
    (ln1p_tail(f) + (f - 0.5 * f * f)) * LOG2_E + e
}

/// `x.powf(y)` for x >= 0 as 2^(y log2 x). Relative error at most 3e-7 + 1.5e-7 |y log2 x|
/// (tested): a few ULP where the result is near 1, growing with the exponent's magnitude, 2e-5
/// when the result is near f32's underflow or overflow (the error of log2 x scaled by y). Exact
/// at y = 0 (1, also for x = 0) and x = 1; 0 and infinity for x = 0 as std. Negative x gives NaN
/// (std gives a real result for integer y); NaN in, NaN out.
#[inline]
pub fn powf(x: f32, y: f32) -> f32 {
    let r = exp2(y * log2(x));
    if y == 0.0 {
        1.0
    } else {
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Relative error of `got` against `want` (absolute where `want` is below `floor`).
    fn rel(got: f32, want: f64, floor: f64) -> f64 {
        (got as f64 - want).abs() / want.abs().max(floor)
    }

    #[test]
    fn exp_matches_f64_over_dense_sweep() {
        let mut max_err = 0.0f64;
        let n = 8_000_000;
        for k in 0..=n {
            let x = -87.3 + (88.7 + 87.3) * k as f32 / n as f32;
            max_err = max_err.max(rel(exp(x), (x as f64).exp(), 0.0));
        }
        // Small arguments, where e^x is near 1.
        for k in -1_000_000..=1_000_000 {
            let x = k as f32 * 1e-6;
            max_err = max_err.max(rel(exp(x), (x as f64).exp(), 0.0));
        }
        assert!(max_err <= 2.5e-7, "max exp error {max_err:e}");
        assert_eq!(exp(0.0), 1.0);
        assert_eq!(exp(-200.0), 0.0);
        assert_eq!(exp(f32::NEG_INFINITY), 0.0);
        assert_eq!(exp(100.0), f32::INFINITY);
        assert_eq!(exp(f32::INFINITY), f32::INFINITY);
        assert!(exp(f32::NAN).is_nan());
        // Just inside the range ends.
        assert!(exp(88.72).is_finite() && exp(88.73).is_infinite());
        assert!(exp(-103.0) < 1e-44 && exp(-103.0) >= 0.0);
    }

    #[test]
    fn exp2_matches_f64_over_dense_sweep() {
        let mut max_err = 0.0f64;
        let n = 8_000_000;
        for k in 0..=n {
            let x = -126.0 + 253.9 * k as f32 / n as f32;
            max_err = max_err.max(rel(exp2(x), (x as f64).exp2(), 0.0));
        }
        assert!(max_err <= 2.5e-7, "max exp2 error {max_err:e}");
        for i in -126..=127 {
            assert_eq!(exp2(i as f32), (i as f32).exp2(), "2^{i}");
        }
        assert_eq!(exp2(-200.0), 0.0);
        assert_eq!(exp2(128.0), f32::INFINITY);
        assert!(exp2(f32::NAN).is_nan());
    }

    #[test]
    fn expm1_matches_f64_over_dense_sweep() {
        let mut max_err = 0.0f64;
        let mut xs: Vec<f32> = (0..=4_000_000)
            .map(|k| -87.0 + 175.7 * k as f32 / 4_000_000.0)
            .collect();
        xs.extend((-1_000_000..=1_000_000).map(|k| k as f32 * 1e-6));
        xs.extend((0..200).flat_map(|k| {
            let x = 1e-30f32 * 1.4f32.powi(k);
            [x, -x]
        }));
        // (1.4^199 1e-30 is 82: within the range where e^x - 1 is a finite f32.)
        for x in xs {
            max_err = max_err.max(rel(expm1(x), (x as f64).exp_m1(), 0.0));
        }
        assert!(max_err <= 2.5e-7, "max expm1 error {max_err:e}");
        assert_eq!(expm1(0.0), 0.0);
        assert_eq!(expm1(-200.0), -1.0);
        assert_eq!(expm1(200.0), f32::INFINITY);
        assert!(expm1(f32::NAN).is_nan());
    }

    #[test]
    fn ln_and_log2_match_f64_over_dense_sweep() {
        let (mut max_ln, mut max_log2) = (0.0f64, 0.0f64);
        let mut check = |x: f32| {
            let (wl, w2) = ((x as f64).ln(), (x as f64).log2());
            // Absolute error near 1 (where the result crosses zero), relative elsewhere.
            let near_one = (0.5..=2.0).contains(&x);
            let floor = if near_one { 1.0 } else { 0.0 };
            max_ln = max_ln.max(rel(ln(x), wl, floor));
            max_log2 = max_log2.max(rel(log2(x), w2, floor) * if near_one { 0.6 } else { 1.0 });
        };
        // Every f32 in [0.5, 2) and a dense sweep of every binade.
        let mut x = 0.5f32;
        while x < 2.0 {
            check(x);
            x = x.next_up();
        }
        for e in -126..=127 {
            for k in 0..4096 {
                check((1.0 + k as f32 / 4096.0) * (e as f32).exp2());
            }
        }
        check(f32::MAX);
        check(f32::MIN_POSITIVE);
        assert!(max_ln <= 1.2e-7, "max ln error {max_ln:e}");
        // log2's near-one bound is 2e-7 absolute (the 0.6 above scales it to the 1.2e-7 check).
        assert!(max_log2 <= 1.2e-7, "max log2 error {max_log2:e}");
        assert_eq!(ln(1.0), 0.0);
        assert_eq!(log2(1.0), 0.0);
        for i in -126..=127 {
            assert_eq!(log2((i as f32).exp2()), i as f32);
        }
        // Special inputs follow std.
        for x in [0.0f32, -0.0, -1.0, 1e-40, f32::INFINITY, f32::NAN] {
            let (a, b) = (ln(x), x.ln());
            assert!(a == b || a.is_nan() && b.is_nan(), "ln({x}) = {a}, std {b}");
            let (a, b) = (log2(x), x.log2());
            assert!(
                a == b || a.is_nan() && b.is_nan(),
                "log2({x}) = {a}, std {b}"
            );
        }
    }

    #[test]
    fn powf_matches_f64_within_its_bound() {
        let mut worst = 0.0f64;
        let xs: Vec<f32> = (1..=20_000).map(|k| k as f32 / 10_000.0).collect();
        let ys: Vec<f32> = (-400..=400)
            .map(|k| k as f32 * 0.25)
            .chain([0.5, 1.0 / 2.4, 2.4, 1000.0, 4000.0])
            .collect();
        for &x in &xs {
            for &y in &ys {
                let want = (x as f64).powf(y as f64);
                if !(want > 1.2e-38 && want < 3.4e38) {
                    continue;
                }
                let t = (y as f64 * (x as f64).log2()).abs();
                let err = rel(powf(x, y), want, 0.0) / (3e-7 + 1.5e-7 * t);
                worst = worst.max(err);
            }
        }
        assert!(worst <= 1.0, "powf error {worst} of its bound");
        assert_eq!(powf(0.0, 0.0), 1.0);
        assert_eq!(powf(0.0, 2.0), 0.0);
        assert_eq!(powf(0.0, -2.0), f32::INFINITY);
        assert_eq!(powf(1.0, 1234.5), 1.0);
        assert_eq!(powf(7.0, 0.0), 1.0);
        assert!(powf(-1.0, 0.5).is_nan());
    }
}
