//! Two neighbouring floats of a table per lane, gathered as one 64-bit element.
//!
//! The index curves ([`crate::lens::dispersion`]) are read with linear interpolation: a lane
//! needs entries i and i + 1.
//! A gather's cost grows with its elements, so one 64-bit element per lane (a gather of 8
//! lanes' pairs at a time) costs about half of two 32-bit gathers; the pairs are then parted
//! into the first and the second floats, lane order kept. The same floats, so interpolating
//! them gives the same bits as two loads would.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

/// For 16 lanes, the floats at byte offsets `bytes` and `bytes + 4` from `base`, as (firsts,
/// seconds). Lanes outside `mask` read nothing and give 0.
///
/// # Safety
/// The CPU has AVX-512 (F, VL, BW, DQ), and for every lane in `mask` the 8 bytes at
/// `base + bytes` are readable floats.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq")]
pub(crate) unsafe fn pairs_avx512(
    base: *const f32,
    bytes: __m512i,
    mask: __mmask16,
) -> (__m512, __m512) {
    let base = base as *const i64;
    // SAFETY: the caller's: every gathered lane's 8 bytes are readable.
    let (low, high) = unsafe {
        (
            _mm512_mask_i32gather_epi64::<1>(
                _mm512_setzero_si512(),
                mask as u8,
                _mm512_castsi512_si256(bytes),
                base,
            ),
            _mm512_mask_i32gather_epi64::<1>(
                _mm512_setzero_si512(),
                (mask >> 8) as u8,
                _mm512_extracti64x4_epi64::<1>(bytes),
                base,
            ),
        )
    };
    let (low, high) = (_mm512_castsi512_ps(low), _mm512_castsi512_ps(high));
    let firsts = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
    let seconds = _mm512_setr_epi32(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31);
    (
        _mm512_permutex2var_ps(low, firsts, high),
        _mm512_permutex2var_ps(low, seconds, high),
    )
}

/// For 8 lanes, the floats at byte offsets `bytes` and `bytes + 4` from `base`, as (firsts,
/// seconds). Lanes whose `mask` is not all ones read nothing and give 0.
///
/// # Safety
/// The CPU has AVX2, and for every lane in `mask` the 8 bytes at `base + bytes` are readable
/// floats.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn pairs_avx2(
    base: *const f32,
    bytes: __m256i,
    mask: __m256i,
) -> (__m256, __m256) {
    let base = base as *const i64;
    let widen = _mm256_cvtepi32_epi64;
    // SAFETY: the caller's: every gathered lane's 8 bytes are readable.
    let (low, high) = unsafe {
        (
            _mm256_mask_i32gather_epi64::<1>(
                _mm256_setzero_si256(),
                base,
                _mm256_castsi256_si128(bytes),
                widen(_mm256_castsi256_si128(mask)),
            ),
            _mm256_mask_i32gather_epi64::<1>(
                _mm256_setzero_si256(),
                base,
                _mm256_extracti128_si256::<1>(bytes),
                widen(_mm256_extracti128_si256::<1>(mask)),
            ),
        )
    };
    let (low, high) = (_mm256_castsi256_ps(low), _mm256_castsi256_ps(high));
    // (x0 y0 x1 y1 | x2 y2 x3 y3) and the next four lanes' pairs → x0…x7, y0…y7: parted
    // within 128-bit halves, then the halves put in order.
    let firsts = _mm256_shuffle_ps::<0b10_00_10_00>(low, high);
    let seconds = _mm256_shuffle_ps::<0b11_01_11_01>(low, high);
    let order =
        |v: __m256| _mm256_castpd_ps(_mm256_permute4x64_pd::<0b11_01_10_00>(_mm256_castps_pd(v)));
    (order(firsts), order(seconds))
}
