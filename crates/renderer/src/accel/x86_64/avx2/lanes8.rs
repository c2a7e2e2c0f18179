//! Eight f32 lanes in an AVX2 register: [`Lanes`] for the eight-ray shadow packets.

use crate::accel::x86_64::shadow_packet::{Lanes, MAX_LANES};
use std::arch::x86_64::*;

/// Eight lanes, one `__m256`. Only used inside kernels compiled with AVX2 and FMA.
pub(crate) struct Lanes8;

impl Lanes for Lanes8 {
    const N: usize = 8;
    type F = __m256;

    #[inline(always)]
    unsafe fn splat(x: f32) -> __m256 {
        // SAFETY: the CPU has AVX2 and FMA (the caller's contract, see `Lanes`).
        unsafe { _mm256_set1_ps(x) }
    }
    #[inline(always)]
    unsafe fn load(a: &[f32; MAX_LANES]) -> __m256 {
        // SAFETY: eight of the sixteen values.
        unsafe { _mm256_loadu_ps(a.as_ptr()) }
    }
    #[inline(always)]
    unsafe fn add(a: __m256, b: __m256) -> __m256 {
        // SAFETY: the CPU has AVX2 and FMA (the caller's contract, see `Lanes`).
        unsafe { _mm256_add_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn sub(a: __m256, b: __m256) -> __m256 {
        // SAFETY: the CPU has AVX2 and FMA (the caller's contract, see `Lanes`).
        unsafe { _mm256_sub_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn mul(a: __m256, b: __m256) -> __m256 {
        // SAFETY: the CPU has AVX2 and FMA (the caller's contract, see `Lanes`).
        unsafe { _mm256_mul_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn fmsub(a: __m256, b: __m256, c: __m256) -> __m256 {
        // SAFETY: the CPU has AVX2 and FMA (the caller's contract, see `Lanes`).
        unsafe { _mm256_fmsub_ps(a, b, c) }
    }
    #[inline(always)]
    unsafe fn min(a: __m256, b: __m256) -> __m256 {
        // SAFETY: the CPU has AVX2 and FMA (the caller's contract, see `Lanes`).
        unsafe { _mm256_min_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn max(a: __m256, b: __m256) -> __m256 {
        // SAFETY: the CPU has AVX2 and FMA (the caller's contract, see `Lanes`).
        unsafe { _mm256_max_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn xor(a: __m256, b: __m256) -> __m256 {
        // SAFETY: the CPU has AVX2 and FMA (the caller's contract, see `Lanes`).
        unsafe { _mm256_xor_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn or(a: __m256, b: __m256) -> __m256 {
        // SAFETY: the CPU has AVX2 and FMA (the caller's contract, see `Lanes`).
        unsafe { _mm256_or_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn flip_sign_by(a: __m256, s: __m256) -> __m256 {
        // SAFETY: the CPU has AVX2 and FMA (the caller's contract, see `Lanes`).
        unsafe { _mm256_xor_ps(a, _mm256_and_ps(s, _mm256_set1_ps(-0.0))) }
    }
    #[inline(always)]
    unsafe fn abs(a: __m256) -> __m256 {
        // SAFETY: the CPU has AVX2 and FMA (the caller's contract, see `Lanes`).
        unsafe { _mm256_andnot_ps(_mm256_set1_ps(-0.0), a) }
    }
    #[inline(always)]
    unsafe fn le(a: __m256, b: __m256) -> u32 {
        // SAFETY: the CPU has AVX2 and FMA (the caller's contract, see `Lanes`).
        unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(a, b)) as u32 }
    }
    #[inline(always)]
    unsafe fn lt(a: __m256, b: __m256) -> u32 {
        // SAFETY: the CPU has AVX2 and FMA (the caller's contract, see `Lanes`).
        unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(a, b)) as u32 }
    }
    #[inline(always)]
    unsafe fn gt(a: __m256, b: __m256) -> u32 {
        // SAFETY: the CPU has AVX2 and FMA (the caller's contract, see `Lanes`).
        unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(a, b)) as u32 }
    }
    #[inline(always)]
    unsafe fn eq(a: __m256, b: __m256) -> u32 {
        // SAFETY: the CPU has AVX2 and FMA (the caller's contract, see `Lanes`).
        unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(a, b)) as u32 }
    }
    #[inline(always)]
    unsafe fn negative(a: __m256) -> u32 {
        // SAFETY: the CPU has AVX2 and FMA (the caller's contract, see `Lanes`).
        unsafe { _mm256_movemask_ps(a) as u32 }
    }
}
