//! A batch's wavelength draws: each camera sample's set
//! ([`crate::spectral::draw_wavelength_set`]) and its members' wavelengths
//! ([`super::hero_wavelengths::wavelength_of_set`]), eight or sixteen rays at a time.
//!
//! Every draw interpolates between two neighbouring knots of a table (the sets' 4 KB, the
//! wavelengths' 16 KB) at a place that differs from ray to ray, so LLVM leaves the loop scalar.
//! On x86-64 with AVX-512 or AVX2 each lane's two knots are one 8-byte load
//! ([`pairs_avx512`](super::trace_batch::pairs::pairs_avx512)), and the arithmetic is the
//! scalar draw's, operation for operation and without fused multiply-adds, so every
//! instruction set gives the same bits. The scalar loop is the reference, and does the tail.

use super::hero_wavelengths::wavelength_of_set_from;
use super::trace_batch::{Isa, on_isa};
use crate::glass::FRAUNHOFER_D_NM;
use crate::spectral::{
    SetKnots, WavelengthKnots, WavelengthSet, draw_wavelength_set_from, set_knots, wavelength_knots,
};

/// A batch of `n` rays' draws, `count` wavelengths each.
pub(crate) struct WavelengthDraws<'a> {
    /// In: each ray's uniform number for its set. Out: its set's ([`WavelengthSet::u`]).
    pub u: &'a mut [f32],
    /// Out: each ray's set's inverse density ([`WavelengthSet::inverse_density`]).
    pub inverse_density: &'a mut [f32],
    /// Whether the ray carries light: a ray blocked before the lens gets the d line and a
    /// factor of 0 at every wavelength.
    pub needs: &'a [bool],
    /// Out, wavelength-major (`count` blocks of `n`, the heroes first): each member's
    /// wavelength (nm) and 1/p (the set's inverse density included).
    pub nm: &'a mut [f32],
    pub inverse_pdf: &'a mut [f32],
}

/// The tables the draws interpolate, looked up once per batch.
struct Knots {
    wavelengths: &'static WavelengthKnots,
    /// `None` for a set of one: its wavelength is drawn directly.
    sets: Option<&'static SetKnots>,
}

/// Draws every ray's set of `count` wavelengths (1 ..= [`super::hero_wavelengths::MAX_WAVELENGTHS`])
/// with the vector unit of `isa` (one this CPU supports).
pub(crate) fn draw_wavelengths(mut draws: WavelengthDraws, count: usize, isa: Isa) {
    let n = draws.needs.len();
    assert!(
        draws.u.len() >= n && draws.inverse_density.len() >= n,
        "a set's arrays hold a number per ray"
    );
    assert!(
        draws.nm.len() >= count * n && draws.inverse_pdf.len() >= count * n,
        "the wavelength arrays hold {count} per ray"
    );
    let knots = Knots {
        wavelengths: wavelength_knots(),
        sets: (count > 1).then(|| set_knots(count as u32)),
    };
    let done = on_isa!(isa,
        baseline: 0,
        avx2: vectors::draw_avx2(&knots, &mut draws, count),
        avx512: vectors::draw_avx512(&knots, &mut draws, count),
    );
    draw_scalar(&knots, &mut draws, count, done);
}

/// The reference: rays `from..` one at a time.
fn draw_scalar(knots: &Knots, draws: &mut WavelengthDraws, count: usize, from: usize) {
    let n = draws.needs.len();
    for i in from..n {
        let set = match knots.sets {
            Some(table) => draw_wavelength_set_from(table, draws.u[i], count as u32),
            None => WavelengthSet {
                u: draws.u[i],
                inverse_density: 1.0,
            },
        };
        (draws.u[i], draws.inverse_density[i]) = (set.u, set.inverse_density);
        for k in 0..count {
            let sample = wavelength_of_set_from(knots.wavelengths, set, k as u32, count as u32);
            let j = k * n + i;
            (draws.nm[j], draws.inverse_pdf[j]) = if draws.needs[i] {
                (sample.nm, sample.inverse_pdf)
            } else {
                (FRAUNHOFER_D_NM as f32, 0.0)
            };
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod vectors {
    use std::arch::x86_64::*;

    use super::{Knots, WavelengthDraws};
    use crate::glass::FRAUNHOFER_D_NM;
    use crate::lens::trace_batch::pairs::{pairs_avx2, pairs_avx512};
    use crate::spectral::wavelengths::KnotSteps;

    /// `between_knots` for 16 lanes: clamp as `f32::clamp` (the second operand of `max`
    /// and `min` is the one a NaN passes through, as it does there), the step through i32 as
    /// the scalar code takes it, then the same products and sums.
    #[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq")]
    fn between_knots_avx512(knots: &[f32], u: __m512) -> (__m512, __m512) {
        let KnotSteps {
            steps,
            end,
            last_step,
        } = KnotSteps::of(knots.len());
        let last = last_step as i32;
        let steps_v = _mm512_set1_ps(steps);
        let x = _mm512_mul_ps(u, steps_v);
        let x = _mm512_min_ps(_mm512_set1_ps(end), _mm512_max_ps(_mm512_setzero_ps(), x));
        let k = _mm512_max_epi32(_mm512_cvttps_epi32(x), _mm512_setzero_si512());
        let k = _mm512_min_epi32(k, _mm512_set1_epi32(last));
        // SAFETY: every k is within 0 ..= len − 2, so both knots of each lane are in the table.
        let (a, b) = unsafe { pairs_avx512(knots.as_ptr(), k) };
        let width = _mm512_sub_ps(b, a);
        let within = _mm512_sub_ps(x, _mm512_cvtepi32_ps(k));
        (
            _mm512_add_ps(a, _mm512_mul_ps(within, width)),
            _mm512_mul_ps(steps_v, width),
        )
    }

    /// Whole groups of 16 rays; returns how many rays it did.
    #[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq")]
    pub(super) fn draw_avx512(knots: &Knots, draws: &mut WavelengthDraws, count: usize) -> usize {
        const W: usize = 16;
        let n = draws.needs.len();
        let groups = n / W;
        let count_v = _mm512_set1_ps(count as f32);
        let below_one = _mm512_set1_ps(1.0 - f32::EPSILON / 2.0);
        let one = _mm512_set1_ps(1.0);
        let d_line = _mm512_set1_ps(FRAUNHOFER_D_NM as f32);
        for g in 0..groups {
            let at = g * W;
            // SAFETY (the loads and stores): `at + W <= n`, and `draw_wavelengths` checked
            // that `u` and `inverse_density` hold n floats, `nm` and `inverse_pdf` count·n.
            let u = unsafe { _mm512_loadu_ps(draws.u.as_ptr().add(at)) };
            let (set_u, inverse_density) = match knots.sets {
                Some(table) => {
                    let scaled = _mm512_mul_ps(u, count_v);
                    // `(scaled as u32).min(count − 1)`: scaled is in [0, count).
                    let stratum =
                        _mm512_max_epi32(_mm512_cvttps_epi32(scaled), _mm512_setzero_si512());
                    let stratum = _mm512_min_epi32(stratum, _mm512_set1_epi32(count as i32 - 1));
                    let stratum = _mm512_cvtepi32_ps(stratum);
                    let (warped, inverse_density) =
                        between_knots_avx512(table, _mm512_sub_ps(scaled, stratum));
                    let set_u = _mm512_div_ps(_mm512_add_ps(stratum, warped), count_v);
                    // `f32::min(set_u, below_one)`: a NaN gives `below_one`, as `min` here.
                    (_mm512_min_ps(set_u, below_one), inverse_density)
                }
                None => (u, one),
            };
            // SAFETY: as above; 16 `bool`s are 16 bytes, each 0 or 1.
            let needs = unsafe {
                _mm512_storeu_ps(draws.u.as_mut_ptr().add(at), set_u);
                _mm512_storeu_ps(draws.inverse_density.as_mut_ptr().add(at), inverse_density);
                let flags = _mm_loadu_si128(draws.needs.as_ptr().add(at) as *const __m128i);
                _mm_test_epi8_mask(flags, flags)
            };
            for k in 0..count {
                let shifted = _mm512_add_ps(set_u, _mm512_set1_ps(k as f32 / count as f32));
                let wraps = _mm512_cmp_ps_mask::<_CMP_GE_OQ>(shifted, one);
                let shifted = _mm512_mask_sub_ps(shifted, wraps, shifted, one);
                let (nm, inverse_pdf) = between_knots_avx512(knots.wavelengths, shifted);
                let inverse_pdf = _mm512_mul_ps(inverse_pdf, inverse_density);
                let j = k * n + at;
                // SAFETY: as above.
                unsafe {
                    _mm512_storeu_ps(
                        draws.nm.as_mut_ptr().add(j),
                        _mm512_mask_blend_ps(needs, d_line, nm),
                    );
                    _mm512_storeu_ps(
                        draws.inverse_pdf.as_mut_ptr().add(j),
                        _mm512_maskz_mov_ps(needs, inverse_pdf),
                    );
                }
            }
        }
        groups * W
    }

    /// `between_knots` for 8 lanes, as [`between_knots_avx512`].
    #[target_feature(enable = "avx2")]
    fn between_knots_avx2(knots: &[f32], u: __m256) -> (__m256, __m256) {
        let KnotSteps {
            steps,
            end,
            last_step,
        } = KnotSteps::of(knots.len());
        let last = last_step as i32;
        let steps_v = _mm256_set1_ps(steps);
        let x = _mm256_mul_ps(u, steps_v);
        let x = _mm256_min_ps(_mm256_set1_ps(end), _mm256_max_ps(_mm256_setzero_ps(), x));
        let k = _mm256_max_epi32(_mm256_cvttps_epi32(x), _mm256_setzero_si256());
        let k = _mm256_min_epi32(k, _mm256_set1_epi32(last));
        // SAFETY: every k is within 0 ..= len − 2, so both knots of each lane are in the table.
        let (a, b) = unsafe { pairs_avx2(knots.as_ptr(), k) };
        let width = _mm256_sub_ps(b, a);
        let within = _mm256_sub_ps(x, _mm256_cvtepi32_ps(k));
        (
            _mm256_add_ps(a, _mm256_mul_ps(within, width)),
            _mm256_mul_ps(steps_v, width),
        )
    }

    /// Whole groups of 8 rays; returns how many rays it did.
    #[target_feature(enable = "avx2")]
    pub(super) fn draw_avx2(knots: &Knots, draws: &mut WavelengthDraws, count: usize) -> usize {
        const W: usize = 8;
        let n = draws.needs.len();
        let groups = n / W;
        let count_v = _mm256_set1_ps(count as f32);
        let below_one = _mm256_set1_ps(1.0 - f32::EPSILON / 2.0);
        let one = _mm256_set1_ps(1.0);
        let d_line = _mm256_set1_ps(FRAUNHOFER_D_NM as f32);
        for g in 0..groups {
            let at = g * W;
            // SAFETY (the loads and stores): as in `draw_avx512`.
            let u = unsafe { _mm256_loadu_ps(draws.u.as_ptr().add(at)) };
            let (set_u, inverse_density) = match knots.sets {
                Some(table) => {
                    let scaled = _mm256_mul_ps(u, count_v);
                    let stratum =
                        _mm256_max_epi32(_mm256_cvttps_epi32(scaled), _mm256_setzero_si256());
                    let stratum = _mm256_min_epi32(stratum, _mm256_set1_epi32(count as i32 - 1));
                    let stratum = _mm256_cvtepi32_ps(stratum);
                    let (warped, inverse_density) =
                        between_knots_avx2(table, _mm256_sub_ps(scaled, stratum));
                    let set_u = _mm256_div_ps(_mm256_add_ps(stratum, warped), count_v);
                    (_mm256_min_ps(set_u, below_one), inverse_density)
                }
                None => (u, one),
            };
            // SAFETY: as above; 8 `bool`s are 8 bytes, each 0 or 1.
            let needs = unsafe {
                _mm256_storeu_ps(draws.u.as_mut_ptr().add(at), set_u);
                _mm256_storeu_ps(draws.inverse_density.as_mut_ptr().add(at), inverse_density);
                let flags = _mm_loadl_epi64(draws.needs.as_ptr().add(at) as *const __m128i);
                let flags = _mm256_cvtepu8_epi32(flags);
                _mm256_castsi256_ps(_mm256_cmpgt_epi32(flags, _mm256_setzero_si256()))
            };
            for k in 0..count {
                let shifted = _mm256_add_ps(set_u, _mm256_set1_ps(k as f32 / count as f32));
                let wraps = _mm256_cmp_ps::<_CMP_GE_OQ>(shifted, one);
                let shifted = _mm256_blendv_ps(shifted, _mm256_sub_ps(shifted, one), wraps);
                let (nm, inverse_pdf) = between_knots_avx2(knots.wavelengths, shifted);
                let inverse_pdf = _mm256_mul_ps(inverse_pdf, inverse_density);
                let j = k * n + at;
                // SAFETY: as above.
                unsafe {
                    _mm256_storeu_ps(
                        draws.nm.as_mut_ptr().add(j),
                        _mm256_blendv_ps(d_line, nm, needs),
                    );
                    _mm256_storeu_ps(
                        draws.inverse_pdf.as_mut_ptr().add(j),
                        _mm256_and_ps(needs, inverse_pdf),
                    );
                }
            }
        }
        groups * W
    }
}

#[cfg(not(target_arch = "x86_64"))]
mod vectors {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::hero_wavelengths::{MAX_WAVELENGTHS, wavelength_of_set};
    use crate::sampling::Rng;
    use crate::spectral::draw_wavelength_set;

    /// What one batch's draws give: (set u, inverse density, nm, 1/p) as bits.
    fn drawn(u: &[f32], needs: &[bool], count: usize, isa: Isa) -> Vec<Vec<u32>> {
        let n = needs.len();
        let mut set_u = u.to_vec();
        let mut inverse_density = vec![f32::NAN; n];
        let mut nm = vec![f32::NAN; n * count];
        let mut inverse_pdf = vec![f32::NAN; n * count];
        draw_wavelengths(
            WavelengthDraws {
                u: &mut set_u,
                inverse_density: &mut inverse_density,
                needs,
                nm: &mut nm,
                inverse_pdf: &mut inverse_pdf,
            },
            count,
            isa,
        );
        [set_u, inverse_density, nm, inverse_pdf]
            .iter()
            .map(|v| v.iter().map(|x| x.to_bits()).collect())
            .collect()
    }

    /// Uniform numbers across [0, 1), with the places a draw changes step: 0, the strata's
    /// and the members' boundaries k/count and the floats either side, and the last float
    /// below 1.
    fn uniform_numbers(count: usize, rng: &mut Rng) -> Vec<f32> {
        let mut u: Vec<f32> = (0..180).map(|_| rng.next_f32()).collect();
        for k in 0..=count {
            let edge = k as f32 / count as f32;
            u.extend([edge.next_down(), edge, edge.next_up()]);
        }
        u.extend([0.0, -0.0, 1.0 - f32::EPSILON / 2.0, 1e-30, 0.5]);
        u.retain(|v| (0.0..1.0).contains(v));
        u
    }

    /// Every instruction set draws exactly the scalar reference's bits, for every set size,
    /// for batches with and without a tail and with blocked rays among them; and the
    /// reference is the per-ray functions it stands for.
    #[test]
    fn batched_draws_give_the_bits_of_one_draw_at_a_time() {
        let mut rng = Rng::new(41, 7);
        for count in 1..=MAX_WAVELENGTHS as usize {
            let all = uniform_numbers(count, &mut rng);
            for len in [0, 1, 7, 8, 15, 16, 17, 40, all.len()] {
                let u = &all[..len.min(all.len())];
                let needs: Vec<bool> = (0..u.len()).map(|i| i % 5 != 3).collect();
                let reference = drawn(u, &needs, count, Isa::Baseline);
                for isa in Isa::available() {
                    assert_eq!(
                        drawn(u, &needs, count, isa),
                        reference,
                        "{isa:?}, {count} wavelengths, {} rays",
                        u.len()
                    );
                }
                let n = u.len();
                for (i, (&u, &needs)) in u.iter().zip(&needs).enumerate() {
                    let set = draw_wavelength_set(u, count as u32);
                    assert_eq!(reference[0][i], set.u.to_bits());
                    assert_eq!(reference[1][i], set.inverse_density.to_bits());
                    for k in 0..count {
                        let sample = wavelength_of_set(set, k as u32, count as u32);
                        let (nm, inverse_pdf) = if needs {
                            (sample.nm, sample.inverse_pdf)
                        } else {
                            (FRAUNHOFER_D_NM as f32, 0.0)
                        };
                        assert_eq!(reference[2][k * n + i], nm.to_bits(), "{count} {u} {k}");
                        assert_eq!(reference[3][k * n + i], inverse_pdf.to_bits());
                    }
                }
            }
        }
    }
}
