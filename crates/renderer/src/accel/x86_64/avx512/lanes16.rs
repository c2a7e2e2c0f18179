//! Sixteen f32 lanes in an AVX-512 register: [`Lanes`] for the sixteen-ray shadow packets.

use crate::accel::x86_64::shadow_packet::{Lanes, MAX_LANES};
use std::arch::x86_64::*;

/// Sixteen lanes, one `__m512`. Only used inside kernels compiled with AVX-512F.
pub(crate) struct Lanes16;

impl Lanes for Lanes16 {
    const N: usize = 16;
    type F = __m512;

    #[inline(always)]
    unsafe fn splat(x: f32) -> __m512 {
        // SAFETY: the CPU has AVX-512 F (the caller's contract, see `Lanes`).
        unsafe { _mm512_set1_ps(x) }
    }
    #[inline(always)]
    unsafe fn load(a: &[f32; MAX_LANES]) -> __m512 {
        // SAFETY: all sixteen values.
        unsafe { _mm512_loadu_ps(a.as_ptr()) }
    }
    #[inline(always)]
    unsafe fn add(a: __m512, b: __m512) -> __m512 {
        // SAFETY: the CPU has AVX-512 F (the caller's contract, see `Lanes`).
        unsafe { _mm512_add_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn sub(a: __m512, b: __m512) -> __m512 {
        // SAFETY: the CPU has AVX-512 F (the caller's contract, see `Lanes`).
        unsafe { _mm512_sub_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn mul(a: __m512, b: __m512) -> __m512 {
        // SAFETY: the CPU has AVX-512 F (the caller's contract, see `Lanes`).
        unsafe { _mm512_mul_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn fmsub(a: __m512, b: __m512, c: __m512) -> __m512 {
        // SAFETY: the CPU has AVX-512 F (the caller's contract, see `Lanes`).
        unsafe { _mm512_fmsub_ps(a, b, c) }
    }
    #[inline(always)]
    unsafe fn min(a: __m512, b: __m512) -> __m512 {
        // SAFETY: the CPU has AVX-512 F (the caller's contract, see `Lanes`).
        unsafe { _mm512_min_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn max(a: __m512, b: __m512) -> __m512 {
        // SAFETY: the CPU has AVX-512 F (the caller's contract, see `Lanes`).
        unsafe { _mm512_max_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn xor(a: __m512, b: __m512) -> __m512 {
        // SAFETY: the CPU has AVX-512 F (the caller's contract, see `Lanes`).
        unsafe {
            _mm512_castsi512_ps(_mm512_xor_si512(
                _mm512_castps_si512(a),
                _mm512_castps_si512(b),
            ))
        }
    }
    #[inline(always)]
    unsafe fn or(a: __m512, b: __m512) -> __m512 {
        // SAFETY: the CPU has AVX-512 F (the caller's contract, see `Lanes`).
        unsafe {
            _mm512_castsi512_ps(_mm512_or_si512(
                _mm512_castps_si512(a),
                _mm512_castps_si512(b),
            ))
        }
    }
    #[inline(always)]
    unsafe fn flip_sign_by(a: __m512, s: __m512) -> __m512 {
        // SAFETY: the CPU has AVX-512 F (the caller's contract, see `Lanes`).
        unsafe {
            let sign = _mm512_and_si512(_mm512_castps_si512(s), _mm512_set1_epi32(i32::MIN));
            _mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(a), sign))
        }
    }
    #[inline(always)]
    unsafe fn abs(a: __m512) -> __m512 {
        // SAFETY: the CPU has AVX-512 F (the caller's contract, see `Lanes`).
        unsafe { _mm512_abs_ps(a) }
    }
    #[inline(always)]
    unsafe fn le(a: __m512, b: __m512) -> u32 {
        // SAFETY: the CPU has AVX-512 F (the caller's contract, see `Lanes`).
        unsafe { _mm512_cmp_ps_mask::<_CMP_LE_OQ>(a, b) as u32 }
    }
    #[inline(always)]
    unsafe fn lt(a: __m512, b: __m512) -> u32 {
        // SAFETY: the CPU has AVX-512 F (the caller's contract, see `Lanes`).
        unsafe { _mm512_cmp_ps_mask::<_CMP_LT_OQ>(a, b) as u32 }
    }
    #[inline(always)]
    unsafe fn gt(a: __m512, b: __m512) -> u32 {
        // SAFETY: the CPU has AVX-512 F (the caller's contract, see `Lanes`).
        unsafe { _mm512_cmp_ps_mask::<_CMP_GT_OQ>(a, b) as u32 }
    }
    #[inline(always)]
    unsafe fn eq(a: __m512, b: __m512) -> u32 {
        // SAFETY: the CPU has AVX-512 F (the caller's contract, see `Lanes`).
        unsafe { _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(a, b) as u32 }
    }
    #[inline(always)]
    unsafe fn negative(a: __m512) -> u32 {
        // SAFETY: the CPU has AVX-512 F (the caller's contract, see `Lanes`).
        unsafe { _mm512_cmplt_epi32_mask(_mm512_castps_si512(a), _mm512_setzero_si512()) as u32 }
    }
}
