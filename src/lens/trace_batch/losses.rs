//! The surfaces' losses for a block of lanes: each survivor of a surface keeps 1 − R of its
//! light, R looked up in the lens's reflectance table ([`crate::lens::reflectance`]) at the
//! lane's angle and wavelength. A table lookup is a gather, so it runs one lane at a time, by
//! the same scalar code in both kernels (which therefore give the same bits).

use super::BLOCK;
use crate::glass::FRAUNHOFER_D_NM;
use crate::lens::reflectance::{COSINE_STEPS, SurfaceReflectance};

/// What the kernels need to apply the losses.
pub(super) struct Losses<'a> {
    pub table: &'a SurfaceReflectance,
    /// The surface (front = 0) met at each step of the travel.
    pub surface_of_step: Vec<usize>,
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
    /// the same entries), one cell load per lane.
    #[inline(always)]
    pub fn attenuate(
        &self,
        step: usize,
        cosines: &[f32],
        survived: &[bool],
        scratch: &mut LossScratch,
    ) {
        let n = survived.len();
        let intervals = self.table.wavelength_entries() - 1;
        let surface = self.surface_of_step[step] * intervals * COSINE_STEPS;
        let cells = &self.table.cells()[surface..surface + intervals * COSINE_STEPS];
        let steps = COSINE_STEPS as f32;
        let (cosines, rows, fractions) = (&cosines[..n], &scratch.row[..n], &scratch.fraction[..n]);
        let transmission = &mut scratch.transmission[..n];
        for lane in 0..n {
            let x = (cosines[lane] * steps).clamp(0.0, steps);
            let c = (x as u32).min(COSINE_STEPS as u32 - 1);
            let u = x - c as f32;
            let [a, b, c0, d] = cells[(rows[lane] + c) as usize];
            let r0 = a + u * (b - a);
            let r1 = c0 + u * (d - c0);
            let r = r0 + fractions[lane] * (r1 - r0);
            transmission[lane] *= if survived[lane] { 1.0 - r } else { 1.0 };
        }
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
