//! Trigonometry: atan2, acos and sin/cos of a fraction of a turn. Each is accurate to a few ULP
//! of f32 (bounds below, checked by the tests over dense sweeps against f64). The environment map
//! relies on them staying far below its texel-edge margin, so that the uv of a sampled direction
//! still lands in the texel it was sampled from.

use std::f32::consts::{FRAC_PI_2, PI};

/// atan(s) for s in [-1, 1]: SLEEF's degree-17 odd minimax polynomial (`atan2kf`), evaluated
/// with plain multiply-adds (no FMA needed). Max error 1e-7 rad over [0, 1]. Estrin's scheme
/// rather than Horner's: three dependent multiply-add levels instead of eight, which matters
/// because an environment-map lookup waits for this value.
#[inline(always)]
fn atan_unit(s: f32) -> f32 {
    let t = s * s;
    let t2 = t * t;
    let t4 = t2 * t2;
    let a = 0.199_926_96 * t - 0.333_331_02;
    let b = 0.106_347_93 * t - 0.142_027_36;
    let c = 0.042_504_99 * t - 0.074_890_09;
    let d = 0.002_823_639 * t - 0.015_956_903;
    let p = (b * t2 + a) + (d * t2 + c) * t4;
    p * t * s + s
}

/// `y.atan2(x)` without libm. Absolute error at most 4e-7 rad (under 2 ULP of pi) for finite
/// inputs; the result is in [-pi, pi] with std's quadrant and signed-zero conventions
/// (`atan2(+0, -0) = pi`, `atan2(-0, -0) = -pi`, `atan2(0, 0) = 0`). NaN in, NaN out. Both inputs
/// infinite gives NaN (std gives a multiple of pi/4); the callers only pass finite components.
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    atan2_inline(y, x)
}

/// [`atan2`], always inlined: for loops over SIMD lanes, which a call would keep scalar.
#[inline(always)]
pub fn atan2_inline(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = if ay > ax { (ax, ay) } else { (ay, ax) };
    // 0 / 0 reads as 0 (the angle of a zero vector, as std); otherwise lo / hi is in [0, 1]
    // (or NaN for a NaN input).
    let s = if hi == 0.0 { 0.0 } else { lo / hi };
    let mut a = atan_unit(s);
    if ay > ax {
        a = FRAC_PI_2 - a;
    }
    if x.is_sign_negative() {
        a = PI - a;
    }
    if y.is_sign_negative() {
        -a
    } else {
        a
    }
}

/// `(x.sin(), x.cos())` for |x| <= pi/4 (at most an eighth of a turn) by Cephes' sinf/cosf
/// polynomials, to within about 1 ULP of 1; the core of [`sin_cos_2pi`], and of the renderer's
/// concentric disk map, whose angles already lie in that range.
#[inline(always)]
pub fn sin_cos_eighth(x: f32) -> (f32, f32) {
    let z = x * x;
    let s = ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1) * z * x + x;
    let c = ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z - 0.5 * z + 1.0;
    (s, c)
}

/// `(b, a)` when `swap`, else `(a, b)`, without a branch: for choices made by random numbers,
/// where a branch mispredicts half the time. A vector select on purpose: LLVM turns a scalar
/// float select like this one back into a branch.
#[inline(always)]
pub fn swap_if(swap: bool, a: f32, b: f32) -> (f32, f32) {
    let v = glam::Vec4::select(
        glam::BVec4A::splat(swap),
        glam::Vec4::new(b, a, 0.0, 0.0),
        glam::Vec4::new(a, b, 0.0, 0.0),
    );
    (v.x, v.y)
}

/// `((2 pi t).sin(), (2 pi t).cos())` for `t` in [0, 1] without libm, to within 1.2e-7 absolute
/// (about 1 ULP of 1). Exact reduction: `t` minus the nearest quarter turn is exact in f32 on
/// [0, 1], so unlike `(2.0 * PI * t).sin_cos()` no argument rounding is added near t = 1. The
/// remainder (at most an eighth of a turn) goes through Cephes' sinf/cosf polynomials. Outside
/// [0, 1] (or NaN) it falls back to std.
#[inline]
pub fn sin_cos_2pi(t: f32) -> (f32, f32) {
    if !(0.0..=1.0).contains(&t) {
        return (2.0 * PI * t).sin_cos();
    }
    // The nearest quarter turn (0..=4); the remainder is at most an eighth of a turn.
    // SAFETY: t is in [0, 1] (checked above, which NaN fails), so 4 t + 1/2 is finite and in
    // [0.5, 4.5]: its truncation fits an i32 (the unchecked conversion is one instruction, the
    // saturating `as` half a dozen).
    let q = unsafe { (4.0 * t + 0.5).to_int_unchecked::<i32>() };
    let (s, c) = sin_cos_eighth((t - q as f32 * 0.25) * (2.0 * PI));
    let q = q as u32;
    // Rotate by q quarter turns without branches: odd q swaps sin and cos, and the signs follow
    // (s, c), (c, -s), (-s, -c), (-c, s).
    let (a, b) = swap_if(q & 1 != 0, s, c);
    let sin_sign = (q & 2) << 30;
    let cos_sign = ((q + 1) & 2) << 30;
    (
        f32::from_bits(a.to_bits() ^ sin_sign),
        f32::from_bits(b.to_bits() ^ cos_sign),
    )
}

/// `x.acos()` for x in [-1, 1] as sqrt(1 - |x|) P(|x|), P a degree-7 minimax polynomial (fitted
/// for this crate, 1.3e-8 rad off in exact arithmetic), and pi minus that for negative x. Absolute
/// error at most 5e-7 rad (2 ULP of the results in [2, pi]; tested). Outside [-1, 1] the argument
/// is clamped (std gives NaN); NaN in, NaN out.
#[inline]
pub fn acos(x: f32) -> f32 {
    /// pi - PI in f32: added separately, it halves the error of pi - r.
    const PI_LO: f32 = -8.742_278e-8;
    let t = x.abs();
    // Not `min`: it would turn NaN into 1.
    let t = if t > 1.0 { 1.0 } else { t };
    let t2 = t * t;
    let t4 = t2 * t2;
    let a = 0.088_999_26 * t - 0.214_599_89;
    let b = 0.031_335_47 * t - 0.050_312_784;
    let c = 0.007_245_446 * t - 0.017_808_981;
    let q = (b * t2 + a) + (c - 0.001_441_479_2 * t2) * t4;
    let r = (1.0 - t).sqrt() * (FRAC_PI_2 + t * q);
    if x.is_sign_negative() {
        (PI - r) + PI_LO
    } else {
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atan2_matches_f64_over_dense_sweep() {
        let mut max_err = 0.0f64;
        // Every direction on a fine circle, at several magnitudes (including tiny and huge).
        let n = 1_000_000;
        for k in 0..n {
            let phi = (k as f64 + 0.37) / n as f64 * std::f64::consts::TAU;
            for r in [1e-30f64, 1e-3, 1.0, 7.5, 1e30] {
                let (y, x) = ((r * phi.sin()) as f32, (r * phi.cos()) as f32);
                let want = (y as f64).atan2(x as f64);
                let got = atan2(y, x) as f64;
                max_err = max_err.max((got - want).abs());
            }
        }
        // The reduced argument directly, including ratios near 0 and 1.
        for k in 0..=1_000_000 {
            let s = k as f32 / 1_000_000.0;
            for (y, x) in [(s, 1.0), (1.0, s), (-s, -1.0), (s * 1e-20, 1.0)] {
                let err = (atan2(y, x) as f64 - (y as f64).atan2(x as f64)).abs();
                max_err = max_err.max(err);
            }
        }
        assert!(max_err <= 4e-7, "max atan2 error {max_err:e}");
    }

    #[test]
    fn sin_cos_2pi_matches_f64_over_dense_sweep() {
        let mut max_err = 0.0f64;
        let n = 4_000_000;
        let mut ts: Vec<f32> = (0..=n).map(|k| k as f32 / n as f32).collect();
        // Quarter-turn boundaries and their neighbours.
        for q in 0..=8 {
            let t = q as f32 / 8.0;
            ts.extend([t, t.next_up(), t.next_down()]);
        }
        ts.extend([1e-30, 1e-7, 1.0f32.next_down()]);
        for t in ts {
            if !(0.0..=1.0).contains(&t) {
                continue;
            }
            let (s, c) = sin_cos_2pi(t);
            let (ws, wc) = (std::f64::consts::TAU * t as f64).sin_cos();
            max_err = max_err
                .max((s as f64 - ws).abs())
                .max((c as f64 - wc).abs());
            assert!(s.abs() <= 1.0 && c.abs() <= 1.0);
        }
        assert!(max_err <= 1.2e-7, "max sin/cos error {max_err:e}");
        // Exact at the quarter turns that matter for the map's orientation.
        assert_eq!(sin_cos_2pi(0.0), (0.0, 1.0));
        assert_eq!(sin_cos_2pi(0.25), (1.0, 0.0));
        assert_eq!(sin_cos_2pi(0.5), (0.0, -1.0));
        // Outside [0, 1]: std's answer.
        for t in [-0.3f32, 1.7, f32::NAN] {
            let (s, c) = sin_cos_2pi(t);
            let (ws, wc) = (2.0 * PI * t).sin_cos();
            assert!(s.to_bits() == ws.to_bits() && c.to_bits() == wc.to_bits() || t.is_nan());
        }
    }

    #[test]
    fn atan2_special_values_follow_std() {
        for (y, x) in [
            (0.0f32, 0.0f32),
            (-0.0, 0.0),
            (0.0, -0.0),
            (-0.0, -0.0),
            (0.0, 1.0),
            (-0.0, -1.0),
            (0.0, -1.0),
            (1.0, 0.0),
            (-1.0, 0.0),
            (1.0, -0.0),
            (3.0, 3.0),
            (-2.0, -2.0),
            (f32::MIN_POSITIVE, f32::MAX),
        ] {
            let (got, want) = (atan2(y, x), y.atan2(x));
            assert!(
                (got - want).abs() <= 4e-7 && got.is_sign_negative() == want.is_sign_negative(),
                "atan2({y}, {x}) = {got}, std {want}"
            );
        }
        assert!(atan2(f32::NAN, 1.0).is_nan() && atan2(1.0, f32::NAN).is_nan());
    }

    #[test]
    fn acos_matches_f64_over_dense_sweep() {
        let mut max_err = 0.0f64;
        let n = 4_000_000;
        let mut xs: Vec<f32> = (0..=n).map(|k| -1.0 + 2.0 * k as f32 / n as f32).collect();
        // Near +-1, where acos has its infinite slope.
        for k in 0..100_000 {
            let d = 1e-7f32 * (k as f32 + 1.0);
            xs.extend([1.0 - d, -1.0 + d]);
        }
        xs.extend([1.0f32.next_down(), -1.0f32.next_up(), 0.0, -0.0, 1e-30]);
        for x in xs {
            let err = (acos(x) as f64 - (x as f64).acos()).abs();
            max_err = max_err.max(err);
        }
        assert!(max_err <= 5e-7, "max acos error {max_err:e}");
        assert_eq!(acos(1.0), 0.0);
        assert!(acos(f32::NAN).is_nan());
        assert!((acos(-1.0) - PI).abs() <= 3e-7);
    }
}
