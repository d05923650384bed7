//! Refractive indices over wavelength, for tracing many wavelengths at once.
//!
//! A camera ray's wavelength sets the index of every glass it crosses. The batch kernels look
//! each medium's index up in a table over the rendered wavelengths (1 nm steps, linear in
//! between: glass dispersion curves bend by less than 1e-6 over a nanometre), so a wavelength
//! costs a lookup per medium instead of a Sellmeier evaluation.

use super::prescription::SurfaceRow;
use crate::spectral::{LAMBDA_MAX, LAMBDA_MIN};

/// Table entries per nanometre.
const PER_NM: f32 = 1.0;

/// The index of the medium after each surface over [`LAMBDA_MIN`]..=[`LAMBDA_MAX`].
#[derive(Clone, Debug, PartialEq)]
pub struct DispersionTable {
    /// Per surface (front to back), its index after the surface at each table wavelength; a
    /// surface without glass data has its fixed index at every entry.
    after: Vec<Vec<f32>>,
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
            .collect();
        Some(DispersionTable { after })
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
        let table = &self.after[surface];
        table[i] + t * (table[i + 1] - table[i])
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
