//! The surfaces' losses for a block of lanes: each survivor of a surface keeps 1 − R of its
//! light, R looked up in the lens's reflectance table ([`crate::lens::reflectance`]) at the
//! lane's angle and wavelength. A table lookup per lane: LLVM leaves the loop scalar, so on
//! x86-64 with AVX-512 or AVX2 it runs 16 or 8 lanes at a time, each lane's cell one 16-byte
//! load and the cells transposed into corners ([`attenuate_lanes`]; gathers of the same bytes
//! cost more), the same operations in the same order, without fused multiply-adds,
//! as the scalar loop ([`attenuate_scalar`], the reference and the tail), so every path gives
//! the same bits. Both kernels call the same function, and so agree bit for bit too.

use super::{BLOCK, Isa};
use crate::glass::FRAUNHOFER_D_NM;
use crate::lens::reflectance::{COSINE_STEPS, SurfaceReflectance};
use crate::lens::trace::Travel;

/// What the kernels need to apply the losses.
pub(super) struct Losses<'a> {
    pub table: &'a SurfaceReflectance,
    /// The direction of travel, so the surface (front = 0) met at each step.
    pub travel: Travel,
    /// Each ray's wavelength (a spectral batch), or `None`: every ray at the lens's own
    /// indices, n_d, so its losses are those at the d line.
    pub nm: Option<&'a [f32]>,
}

impl Losses<'_> {
    /// Each lane's table wavelength for the block starting at ray `start` (`n` lanes): the
    /// offset of its wavelength interval's cells within a surface's, and the fraction toward
    /// the next wavelength.
    #[inline(always)]
    pub fn block_positions(&self, start: usize, n: usize, scratch: &mut LossScratch) {
        let mut put = |lane: usize, (w, t): (usize, f32)| {
            scratch.row[lane] = (w * COSINE_STEPS) as u32;
            scratch.fraction[lane] = t;
        };
        match self.nm {
            Some(nm) => {
                for (lane, &nm) in nm[start..start + n].iter().enumerate() {
                    put(lane, self.table.position(nm));
                }
            }
            None => {
                let at = self.table.position(FRAUNHOFER_D_NM as f32);
                for lane in 0..n {
                    put(lane, at);
                }
            }
        }
        scratch.transmission[..n].fill(1.0);
    }

    /// Multiplies the transmission of every lane that `survived` step `step` by 1 − R at its
    /// `cosine` and table wavelength: [`SurfaceReflectance::lookup`] (the same arithmetic on
    /// the same entries), one cell load per lane, with the vector unit of `isa` (the kernel's,
    /// supported by this CPU).
    #[inline(always)]
    pub fn attenuate(
        &self,
        step: usize,
        cosines: &[f32],
        survived: &[bool],
        scratch: &mut LossScratch,
        isa: Isa,
    ) {
        let n = survived.len();
        let intervals = self.table.wavelength_entries() - 1;
        let surface = self
            .travel
            .surface_of_step(step, self.table.surface_count())
            * intervals
            * COSINE_STEPS;
        let lanes = LossLanes {
            cells: &self.table.cells()[surface..surface + intervals * COSINE_STEPS],
            cosines: &cosines[..n],
            survived,
            rows: &scratch.row[..n],
            fractions: &scratch.fraction[..n],
        };
        attenuate_lanes(&lanes, &mut scratch.transmission[..n], isa);
    }
}

/// One surface's losses over a block: the surface's cells (its wavelength intervals × cosine
/// steps, four corners each), and per lane its cosine, whether it survived, its wavelength
/// interval's first cell and its fraction toward the next wavelength.
pub(super) struct LossLanes<'a> {
    pub cells: &'a [[f32; 4]],
    pub cosines: &'a [f32],
    pub survived: &'a [bool],
    pub rows: &'a [u32],
    pub fractions: &'a [f32],
}

/// Multiplies `transmission` by each surviving lane's 1 − R: with `isa`'s vectors
/// (16 or 8 lanes at a time; `isa` must be one this CPU supports), the rest by
/// [`attenuate_scalar`].
#[inline(always)]
pub(super) fn attenuate_lanes(lanes: &LossLanes, transmission: &mut [f32], isa: Isa) {
    let done = super::on_isa!(isa,
        baseline: 0,
        avx2: vectors::attenuate_avx2(lanes, transmission),
        avx512: vectors::attenuate_avx512(lanes, transmission),
    );
    attenuate_scalar(lanes, transmission, done);
}

/// The reference: lanes `from..` one at a time. R is bilinear in the cell: along the cosine
/// within each wavelength row, then between the rows.
#[inline(always)]
pub(super) fn attenuate_scalar(lanes: &LossLanes, transmission: &mut [f32], from: usize) {
    let steps = COSINE_STEPS as f32;
    for (lane, transmission) in transmission.iter_mut().enumerate().skip(from) {
        let x = (lanes.cosines[lane] * steps).clamp(0.0, steps);
        let c = (x as u32).min(COSINE_STEPS as u32 - 1);
        let u = x - c as f32;
        let [a, b, c0, d] = lanes.cells[(lanes.rows[lane] + c) as usize];
        let r0 = a + u * (b - a);
        let r1 = c0 + u * (d - c0);
        let r = r0 + lanes.fractions[lane] * (r1 - r0);
        *transmission *= if lanes.survived[lane] { 1.0 - r } else { 1.0 };
    }
}

/// [`attenuate_scalar`]'s arithmetic, many lanes at a time. A dead lane's cosine may be
/// anything (NaN included): its index is forced to cell 0 and its factor to 1, as the scalar
/// loop's `survived` test does.
#[cfg(target_arch = "x86_64")]
mod vectors {
    use std::arch::x86_64::*;

    use super::{COSINE_STEPS, LossLanes};

    /// The four corners of 16 lanes' cells (`cell`: each lane's index into `cells`), corner
    /// by corner: each cell is one 16-byte load, and the loads are put four lanes to a
    /// register so that a 4 × 4 transpose within each 128-bit lane leaves every corner's 16
    /// values in lane order. Plain loads cost less than gathers of the same bytes here, and
    /// read the same floats.
    ///
    /// # Safety
    /// Every lane's cell is in `cells` (`base` is its start).
    #[inline]
    #[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq")]
    unsafe fn corners_avx512(base: *const [f32; 4], cell: __m512i) -> [__m512; 4] {
        let mut index = [0u32; 16];
        // SAFETY: `index` holds 16 u32s; every cell read is in the table (the caller's).
        unsafe {
            _mm512_storeu_si512(index.as_mut_ptr() as *mut _, cell);
            let load = |lane: usize| _mm_loadu_ps(base.add(index[lane] as usize) as *const f32);
            // Register e holds lanes e, e + 4, e + 8, e + 12 (one per 128-bit lane).
            let quad = |e: usize| {
                let v = _mm512_castps128_ps512(load(e));
                let v = _mm512_insertf32x4::<1>(v, load(e + 4));
                let v = _mm512_insertf32x4::<2>(v, load(e + 8));
                _mm512_insertf32x4::<3>(v, load(e + 12))
            };
            transpose_lanes_avx512([quad(0), quad(1), quad(2), quad(3)])
        }
    }

    /// The 4 × 4 transpose within each 128-bit lane of four registers.
    #[inline]
    #[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq")]
    fn transpose_lanes_avx512([q0, q1, q2, q3]: [__m512; 4]) -> [__m512; 4] {
        let (t0, t1) = (_mm512_unpacklo_ps(q0, q1), _mm512_unpackhi_ps(q0, q1));
        let (t2, t3) = (_mm512_unpacklo_ps(q2, q3), _mm512_unpackhi_ps(q2, q3));
        let pd = _mm512_castps_pd;
        let ps = _mm512_castpd_ps;
        [
            ps(_mm512_unpacklo_pd(pd(t0), pd(t2))),
            ps(_mm512_unpackhi_pd(pd(t0), pd(t2))),
            ps(_mm512_unpacklo_pd(pd(t1), pd(t3))),
            ps(_mm512_unpackhi_pd(pd(t1), pd(t3))),
        ]
    }

    /// [`corners_avx512`] for 8 lanes: register e holds lanes e and e + 4.
    ///
    /// # Safety
    /// Every lane's cell is in `cells` (`base` is its start).
    #[inline]
    #[target_feature(enable = "avx2")]
    unsafe fn corners_avx2(base: *const [f32; 4], cell: __m256i) -> [__m256; 4] {
        let mut index = [0u32; 8];
        // SAFETY: `index` holds 8 u32s; every cell read is in the table (the caller's).
        unsafe {
            _mm256_storeu_si256(index.as_mut_ptr() as *mut __m256i, cell);
            let load = |lane: usize| _mm_loadu_ps(base.add(index[lane] as usize) as *const f32);
            let pair = |e: usize| _mm256_set_m128(load(e + 4), load(e));
            let [q0, q1, q2, q3] = [pair(0), pair(1), pair(2), pair(3)];
            let (t0, t1) = (_mm256_unpacklo_ps(q0, q1), _mm256_unpackhi_ps(q0, q1));
            let (t2, t3) = (_mm256_unpacklo_ps(q2, q3), _mm256_unpackhi_ps(q2, q3));
            let pd = _mm256_castps_pd;
            let ps = _mm256_castpd_ps;
            [
                ps(_mm256_unpacklo_pd(pd(t0), pd(t2))),
                ps(_mm256_unpackhi_pd(pd(t0), pd(t2))),
                ps(_mm256_unpacklo_pd(pd(t1), pd(t3))),
                ps(_mm256_unpackhi_pd(pd(t1), pd(t3))),
            ]
        }
    }

    /// Whole groups of 16 lanes; returns how many lanes it did.
    #[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq")]
    pub(super) fn attenuate_avx512(lanes: &LossLanes, transmission: &mut [f32]) -> usize {
        const W: usize = 16;
        let groups = transmission.len() / W;
        let steps = _mm512_set1_ps(COSINE_STEPS as f32);
        let zero = _mm512_setzero_ps();
        let one = _mm512_set1_ps(1.0);
        let last = _mm512_set1_epi32(COSINE_STEPS as i32 - 1);
        let base = lanes.cells.as_ptr();
        for g in 0..groups {
            let at = g * W;
            // SAFETY: `at + W <= len` for every slice read here (all are `len` long).
            unsafe {
                // 16 `bool`s are 16 bytes, each 0 or 1.
                let flags = _mm_loadu_si128(lanes.survived.as_ptr().add(at) as *const __m128i);
                let alive = _mm_test_epi8_mask(flags, flags);
                let cosine = _mm512_loadu_ps(lanes.cosines.as_ptr().add(at));
                // clamp(x, 0, steps) as f32::clamp: a NaN (only in dead lanes) stays NaN and
                // is masked off below.
                let x = _mm512_mul_ps(cosine, steps);
                let x = _mm512_mask_blend_ps(_mm512_cmp_ps_mask::<_CMP_LT_OQ>(x, zero), x, zero);
                let x = _mm512_mask_blend_ps(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(x, steps), x, steps);
                let c = _mm512_min_epu32(_mm512_cvttps_epu32(x), last);
                let u = _mm512_sub_ps(x, _mm512_cvtepu32_ps(c));
                let rows = _mm512_loadu_si512(lanes.rows.as_ptr().add(at) as *const _);
                let cell = _mm512_mask_blend_epi32(
                    alive,
                    _mm512_setzero_si512(),
                    _mm512_add_epi32(rows, c),
                );
                let [a, b, c0, d] = corners_avx512(base, cell);
                let r0 = _mm512_add_ps(a, _mm512_mul_ps(u, _mm512_sub_ps(b, a)));
                let r1 = _mm512_add_ps(c0, _mm512_mul_ps(u, _mm512_sub_ps(d, c0)));
                let fraction = _mm512_loadu_ps(lanes.fractions.as_ptr().add(at));
                let r = _mm512_add_ps(r0, _mm512_mul_ps(fraction, _mm512_sub_ps(r1, r0)));
                let factor = _mm512_mask_blend_ps(alive, one, _mm512_sub_ps(one, r));
                let out = transmission.as_mut_ptr().add(at);
                _mm512_storeu_ps(out, _mm512_mul_ps(_mm512_loadu_ps(out), factor));
            }
        }
        groups * W
    }

    /// Whole groups of 8 lanes; returns how many lanes it did.
    #[target_feature(enable = "avx2")]
    pub(super) fn attenuate_avx2(lanes: &LossLanes, transmission: &mut [f32]) -> usize {
        const W: usize = 8;
        let groups = transmission.len() / W;
        let steps = _mm256_set1_ps(COSINE_STEPS as f32);
        let zero = _mm256_setzero_ps();
        let one = _mm256_set1_ps(1.0);
        let last = _mm256_set1_epi32(COSINE_STEPS as i32 - 1);
        let base = lanes.cells.as_ptr();
        for g in 0..groups {
            let at = g * W;
            // SAFETY: `at + W <= len` for every slice read here (all are `len` long).
            unsafe {
                let mut flags = [0i32; W];
                for (flag, &survived) in flags.iter_mut().zip(&lanes.survived[at..at + W]) {
                    *flag = -(survived as i32);
                }
                let alive = _mm256_loadu_si256(flags.as_ptr() as *const __m256i);
                let alive_ps = _mm256_castsi256_ps(alive);
                let cosine = _mm256_loadu_ps(lanes.cosines.as_ptr().add(at));
                let x = _mm256_mul_ps(cosine, steps);
                let x = _mm256_blendv_ps(x, zero, _mm256_cmp_ps::<_CMP_LT_OQ>(x, zero));
                let x = _mm256_blendv_ps(x, steps, _mm256_cmp_ps::<_CMP_GT_OQ>(x, steps));
                // x is in [0, 32] in live lanes, so the signed conversion is exact; the max
                // keeps a NaN's conversion (i32::MIN) inside the table all the same.
                let c = _mm256_min_epi32(
                    _mm256_max_epi32(_mm256_cvttps_epi32(x), _mm256_setzero_si256()),
                    last,
                );
                let u = _mm256_sub_ps(x, _mm256_cvtepi32_ps(c));
                let rows = _mm256_loadu_si256(lanes.rows.as_ptr().add(at) as *const __m256i);
                let cell = _mm256_and_si256(alive, _mm256_add_epi32(rows, c));
                let [a, b, c0, d] = corners_avx2(base, cell);
                let r0 = _mm256_add_ps(a, _mm256_mul_ps(u, _mm256_sub_ps(b, a)));
                let r1 = _mm256_add_ps(c0, _mm256_mul_ps(u, _mm256_sub_ps(d, c0)));
                let fraction = _mm256_loadu_ps(lanes.fractions.as_ptr().add(at));
                let r = _mm256_add_ps(r0, _mm256_mul_ps(fraction, _mm256_sub_ps(r1, r0)));
                let factor = _mm256_blendv_ps(one, _mm256_sub_ps(one, r), alive_ps);
                let out = transmission.as_mut_ptr().add(at);
                _mm256_storeu_ps(out, _mm256_mul_ps(_mm256_loadu_ps(out), factor));
            }
        }
        groups * W
    }
}

/// A block's scratch for the losses: every lane's table wavelength (its row's offset and the
/// fraction toward the next) and its transmission so far.
pub(super) struct LossScratch {
    pub row: [u32; BLOCK],
    pub fraction: [f32; BLOCK],
    pub transmission: [f32; BLOCK],
}

impl LossScratch {
    pub fn new() -> Self {
        LossScratch {
            row: [0; BLOCK],
            fraction: [0.0; BLOCK],
            transmission: [1.0; BLOCK],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The vector paths give the scalar loop's bits on every lane: live lanes with cosines
    /// inside and outside [0, 1] (clamped), dead lanes with NaN cosines, any wavelength row, and
    /// a tail shorter than a group.
    #[test]
    fn vector_lanes_give_the_scalar_bits() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let intervals = 7;
        let cells: Vec<[f32; 4]> = (0..intervals * COSINE_STEPS)
            .map(|_| [next(), next(), next(), next()])
            .collect();
        for n in [256, 253, 7] {
            let survived: Vec<bool> = (0..n).map(|_| next() < 0.8).collect();
            let cosines: Vec<f32> = (0..n)
                .map(|i| {
                    if !survived[i] && next() < 0.5 {
                        f32::NAN
                    } else {
                        next() * 1.2 - 0.1
                    }
                })
                .collect();
            let rows: Vec<u32> = (0..n)
                .map(|_| ((next() * intervals as f32) as usize * COSINE_STEPS) as u32)
                .collect();
            let fractions: Vec<f32> = (0..n).map(|_| next()).collect();
            let start: Vec<f32> = (0..n).map(|_| next()).collect();
            let lanes = LossLanes {
                cells: &cells,
                cosines: &cosines,
                survived: &survived,
                rows: &rows,
                fractions: &fractions,
            };
            let mut reference = start.clone();
            attenuate_scalar(&lanes, &mut reference, 0);
            let bits = |t: &[f32]| t.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
            for isa in Isa::available() {
                let mut t = start.clone();
                attenuate_lanes(&lanes, &mut t, isa);
                assert_eq!(bits(&t), bits(&reference), "{n} lanes, {}", isa.name());
            }
        }
    }
}
