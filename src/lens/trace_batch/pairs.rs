//! Two neighbouring floats of a table per lane, read as one 8-byte load each.
//!
//! The index curves ([`crate::lens::dispersion`]) are read with linear interpolation: a lane
//! needs entries i and i + 1. Each lane's pair is one 8-byte load, two lanes to a 128-bit
//! register, and the registers are parted into the first and the second floats, lane order
//! kept: on the CPUs measured, plain loads cost less than gathers of the same bytes. The same
//! floats, so interpolating them gives the same bits as two loads would.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

/// Lanes `2k` and `2k + 1`'s pairs in one register: (first, second) of each, in lane order.
///
/// # Safety
/// The 8 bytes at `base + index[2k]` and at `base + index[2k + 1]` (floats) are readable.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn two_pairs(base: *const f32, index: &[u32], k: usize) -> __m128 {
    // SAFETY: the caller's.
    unsafe {
        let low = _mm_load_sd(base.add(index[2 * k] as usize) as *const f64);
        _mm_castpd_ps(_mm_loadh_pd(
            low,
            base.add(index[2 * k + 1] as usize) as *const f64,
        ))
    }
}

/// For 16 lanes, the floats at `base + index` and `base + index + 1` (`index` in floats), as
/// (firsts, seconds).
///
/// # Safety
/// The CPU has AVX-512 (F, VL, BW, DQ), and for every lane both floats are readable.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq")]
pub(crate) unsafe fn pairs_avx512(base: *const f32, index: __m512i) -> (__m512, __m512) {
    let mut lanes = [0u32; 16];
    // SAFETY: `lanes` holds 16 u32s; every pair read is readable (the caller's).
    let (low, high) = unsafe {
        _mm512_storeu_si512(lanes.as_mut_ptr() as *mut _, index);
        let quad = |first: usize| {
            let v = _mm512_castps128_ps512(two_pairs(base, &lanes, first));
            let v = _mm512_insertf32x4::<1>(v, two_pairs(base, &lanes, first + 1));
            let v = _mm512_insertf32x4::<2>(v, two_pairs(base, &lanes, first + 2));
            _mm512_insertf32x4::<3>(v, two_pairs(base, &lanes, first + 3))
        };
        (quad(0), quad(4))
    };
    let firsts = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
    let seconds = _mm512_setr_epi32(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31);
    (
        _mm512_permutex2var_ps(low, firsts, high),
        _mm512_permutex2var_ps(low, seconds, high),
    )
}

/// For 8 lanes, the floats at `base + index` and `base + index + 1` (`index` in floats), as
/// (firsts, seconds).
///
/// # Safety
/// The CPU has AVX2, and for every lane both floats are readable.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn pairs_avx2(base: *const f32, index: __m256i) -> (__m256, __m256) {
    let mut lanes = [0u32; 8];
    // SAFETY: `lanes` holds 8 u32s; every pair read is readable (the caller's).
    let (low, high) = unsafe {
        _mm256_storeu_si256(lanes.as_mut_ptr() as *mut __m256i, index);
        let half = |first: usize| {
            _mm256_set_m128(
                two_pairs(base, &lanes, first + 1),
                two_pairs(base, &lanes, first),
            )
        };
        (half(0), half(2))
    };
    // (x0 y0 x1 y1 | x2 y2 x3 y3) and the next four lanes' pairs → x0…x7, y0…y7: parted
    // within 128-bit halves, then the halves put in order.
    let firsts = _mm256_shuffle_ps::<0b10_00_10_00>(low, high);
    let seconds = _mm256_shuffle_ps::<0b11_01_11_01>(low, high);
    let order =
        |v: __m256| _mm256_castpd_ps(_mm256_permute4x64_pd::<0b11_01_10_00>(_mm256_castps_pd(v)));
    (order(firsts), order(seconds))
}
