//! Refractive indices over wavelength, for tracing many wavelengths at once.
//!
//! A camera ray's wavelength sets the index of every glass it crosses. The batch kernels look
//! each medium's index up in a table over the rendered wavelengths (1 nm steps, linear in
//! between: glass dispersion curves bend by less than 1e-6 over a nanometre), so a wavelength
//! costs a lookup per medium instead of a Sellmeier evaluation.

use super::prescription::SurfaceRow;
use super::trace_batch::{Isa, on_isa};
use crate::spectral::{LAMBDA_MAX, LAMBDA_MIN};

/// Table entries per nanometre.
const PER_NM: f32 = 1.0;

/// The index of the medium after each surface over [`LAMBDA_MIN`]..=[`LAMBDA_MAX`].
#[derive(Clone, Debug, PartialEq)]
pub struct DispersionTable {
    /// Per surface (front to back), its index after the surface at each table wavelength; a
    /// surface without glass data has its fixed index at every entry.
    after: Vec<Vec<f32>>,
    /// Per surface, its index when that is the same at every entry (air, a glass without
    /// data): the lanes' look-ups are then that one value, with no gather.
    constant: Vec<Option<f32>>,
}

impl DispersionTable {
    /// The table of `rows`, or `None` when no row has glass data (every index is fixed).
    pub fn new(rows: &[SurfaceRow]) -> Option<DispersionTable> {
        if rows.iter().all(|r| r.glass.is_none()) {
            return None;
        }
        let count = ((LAMBDA_MAX - LAMBDA_MIN) as f32 * PER_NM) as usize + 1;
        let after = rows
            .iter()
            .map(|row| {
                (0..count)
                    .map(|i| row.index_at(LAMBDA_MIN + i as f64 / PER_NM as f64) as f32)
                    .collect()
            })
            .collect::<Vec<Vec<f32>>>();
        let constant = after
            .iter()
            .map(|entries| {
                let first = entries[0];
                entries.iter().all(|&n| n == first).then_some(first)
            })
            .collect();
        Some(DispersionTable { after, constant })
    }

    /// The table coordinate of `wavelength_nm`: entry `i` and the fraction `t` toward `i + 1`.
    #[inline(always)]
    pub fn position(&self, wavelength_nm: f32) -> (usize, f32) {
        let last = self.after.first().map_or(1, |t| t.len() - 1);
        let x = ((wavelength_nm - LAMBDA_MIN as f32) * PER_NM).clamp(0.0, last as f32);
        let i = (x as usize).min(last - 1);
        (i, x - i as f32)
    }

    /// The index after surface `surface` at table position (`i`, `t`).
    #[inline(always)]
    pub fn index_after(&self, surface: usize, (i, t): (usize, f32)) -> f32 {
        self.curve(surface).at(i, t)
    }

    /// The index after surface `surface` over wavelength, for looking many rays up at once.
    #[inline(always)]
    pub fn curve(&self, surface: usize) -> IndexCurve<'_> {
        IndexCurve {
            entries: &self.after[surface],
            constant: self.constant[surface],
        }
    }

    /// The index before surface `surface` (air in front of the first).
    #[inline(always)]
    pub fn index_before(&self, surface: usize, position: (usize, f32)) -> f32 {
        if surface == 0 {
            1.0
        } else {
            self.index_after(surface - 1, position)
        }
    }

    /// The index after surface `surface` at every table wavelength (1 nm steps from
    /// [`LAMBDA_MIN`]): what the GPU backend uploads.
    pub fn entries(&self, surface: usize) -> &[f32] {
        &self.after[surface]
    }

    pub fn surface_count(&self) -> usize {
        self.after.len()
    }
}

/// One medium's index at every table wavelength.
#[derive(Clone, Copy, Debug)]
pub struct IndexCurve<'a> {
    entries: &'a [f32],
    constant: Option<f32>,
}

impl IndexCurve<'_> {
    /// The index at table position (`i`, `t`) from [`DispersionTable::position`]: linear
    /// between entries `i` and `i + 1`.
    #[inline(always)]
    pub fn at(self, i: usize, t: f32) -> f32 {
        let (a, b) = (self.entries[i], self.entries[i + 1]);
        a + t * (b - a)
    }

    /// [`Self::at`] for many lanes, `out[lane]` at (`cells[lane]`, `fractions[lane]`), with
    /// `isa`'s vectors (one this CPU supports): LLVM leaves a loop of table lookups scalar.
    /// The same arithmetic, so the same bits; a constant curve needs no look-up (a + t·(a − a)
    /// is a for every fraction t in [0, 1]).
    #[inline(always)]
    pub fn at_lanes(self, cells: &[u32], fractions: &[f32], out: &mut [f32], isa: Isa) {
        if let Some(index) = self.constant {
            out.fill(index);
            return;
        }
        let n = out.len();
        let (cells, fractions) = (&cells[..n], &fractions[..n]);
        let last_cell = self.entries.len().saturating_sub(2);
        // Every gathered cell is clamped to the last whole cell (a no-op for a position's
        // cell) so both its entries are in the table.
        let done = on_isa!(isa,
            baseline: 0,
            avx2: gathered::at_lanes_avx2(self.entries, last_cell, cells, fractions, out),
            avx512: gathered::at_lanes_avx512(self.entries, last_cell, cells, fractions, out),
        );
        for lane in done..n {
            out[lane] = self.at(cells[lane] as usize, fractions[lane]);
        }
    }
}

/// [`IndexCurve::at`]'s arithmetic, 16 or 8 lanes at a time, each lane's two entries read as
/// one pair ([`crate::lens::trace_batch::pairs`]).
#[cfg(target_arch = "x86_64")]
mod gathered {
    use std::arch::x86_64::*;

    use crate::lens::trace_batch::pairs::{pairs_avx2, pairs_avx512};

    /// Whole groups of 16 lanes; returns how many lanes it did.
    #[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq")]
    pub(super) fn at_lanes_avx512(
        entries: &[f32],
        last_cell: usize,
        cells: &[u32],
        fractions: &[f32],
        out: &mut [f32],
    ) -> usize {
        const W: usize = 16;
        if entries.len() < 2 {
            return 0;
        }
        let groups = out.len() / W;
        let last = _mm512_set1_epi32(last_cell as i32);
        for g in 0..groups {
            let at = g * W;
            // SAFETY: `at + W <= len` for the three slices (`cells` and `fractions` are
            // `out`'s length), and every gathered pair starts at most at `last_cell`, so both
            // its entries are in the table.
            unsafe {
                let cell = _mm512_loadu_si512(cells.as_ptr().add(at) as *const _);
                let cell = _mm512_min_epu32(cell, last);
                let (a, b) = pairs_avx512(entries.as_ptr(), cell);
                let t = _mm512_loadu_ps(fractions.as_ptr().add(at));
                let index = _mm512_add_ps(a, _mm512_mul_ps(t, _mm512_sub_ps(b, a)));
                _mm512_storeu_ps(out.as_mut_ptr().add(at), index);
            }
        }
        groups * W
    }

    /// Whole groups of 8 lanes; returns how many lanes it did.
    #[target_feature(enable = "avx2")]
    pub(super) fn at_lanes_avx2(
        entries: &[f32],
        last_cell: usize,
        cells: &[u32],
        fractions: &[f32],
        out: &mut [f32],
    ) -> usize {
        const W: usize = 8;
        if entries.len() < 2 {
            return 0;
        }
        let groups = out.len() / W;
        let last = _mm256_set1_epi32(last_cell as i32);
        for g in 0..groups {
            let at = g * W;
            // SAFETY: as in `at_lanes_avx512`.
            unsafe {
                let cell = _mm256_loadu_si256(cells.as_ptr().add(at) as *const __m256i);
                let cell = _mm256_min_epu32(cell, last);
                let (a, b) = pairs_avx2(entries.as_ptr(), cell);
                let t = _mm256_loadu_ps(fractions.as_ptr().add(at));
                let index = _mm256_add_ps(a, _mm256_mul_ps(t, _mm256_sub_ps(b, a)));
                _mm256_storeu_ps(out.as_mut_ptr().add(at), index);
            }
        }
        groups * W
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::LensSystem;

    /// The gathered look-ups give exactly the scalar one's bits, at every instruction set, for
    /// wavelengths across the table, on its ends and beyond them, and for block lengths that
    /// leave a scalar tail.
    #[test]
    fn index_lookups_for_many_lanes_match_one_at_a_time() {
        let lens = crate::lens::io::bundled::load_lens("dgauss.50mm", None).unwrap();
        let system = LensSystem::new(&lens.rows, None);
        let table = system.dispersion.as_deref().expect("dgauss has glass data");
        let nm: Vec<f32> = (0..203)
            .map(|i| LAMBDA_MIN as f32 - 3.0 + i as f32 * 2.037)
            .chain([LAMBDA_MIN as f32, LAMBDA_MAX as f32, 1e4, -5.0])
            .collect();
        let (cells, fractions): (Vec<u32>, Vec<f32>) = nm
            .iter()
            .map(|&nm| {
                let (i, t) = table.position(nm);
                (i as u32, t)
            })
            .unzip();
        for surface in 0..table.surface_count() {
            let curve = table.curve(surface);
            let one_at_a_time: Vec<f32> = (0..nm.len())
                .map(|lane| curve.at(cells[lane] as usize, fractions[lane]))
                .collect();
            for isa in Isa::available() {
                for len in [nm.len(), 16, 9, 0] {
                    let mut out = vec![f32::NAN; len];
                    curve.at_lanes(&cells[..len], &fractions[..len], &mut out, isa);
                    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&out), bits(&one_at_a_time[..len]), "{isa:?} {len}");
                }
            }
        }
    }
}
