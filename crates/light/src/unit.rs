//! The unit interval [0, 1) that samplers map their random numbers from.

/// The largest f32 below one: sample values are clamped to it so that `u * n` never reaches `n`.
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
