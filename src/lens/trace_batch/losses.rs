//! The surfaces' losses for a block of lanes: each survivor of a surface keeps 1 − R of its
//! light, R looked up in the lens's reflectance table ([`crate::lens::reflectance`]) at the
//! lane's angle and wavelength. A table lookup is a gather, so it runs one lane at a time, by
//! the same scalar code in both kernels (which therefore give the same bits).

use super::BLOCK;
use crate::glass::FRAUNHOFER_D_NM;
use crate::lens::reflectance::SurfaceReflectance;

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
    /// Each lane's table wavelength for the block starting at ray `start` (`n` lanes).
    #[inline(always)]
    pub fn block_positions(&self, start: usize, n: usize, positions: &mut [(usize, f32)]) {
        match self.nm {
            Some(nm) => {
                for (position, &nm) in positions[..n].iter_mut().zip(&nm[start..start + n]) {
                    *position = self.table.position(nm);
                }
            }
            None => positions[..n].fill(self.table.position(FRAUNHOFER_D_NM as f32)),
        }
    }

    /// Multiplies the `transmission` of every lane that `survived` step `step` by 1 − R at its
    /// `cosine` and table wavelength.
    #[inline(always)]
    pub fn attenuate(
        &self,
        step: usize,
        cosines: &[f32],
        survived: impl Fn(usize) -> bool,
        positions: &[(usize, f32)],
        transmission: &mut [f32],
    ) {
        let surface = self.surface_of_step[step];
        for (lane, t) in transmission.iter_mut().enumerate() {
            if survived(lane) {
                *t *= 1.0 - self.table.lookup(surface, cosines[lane], positions[lane]);
            }
        }
    }
}

/// A block's scratch for the losses: every lane's table wavelength and its transmission so far.
pub(super) struct LossScratch {
    pub positions: [(usize, f32); BLOCK],
    pub transmission: [f32; BLOCK],
}

impl LossScratch {
    pub fn new() -> Self {
        LossScratch {
            positions: [(0, 0.0); BLOCK],
            transmission: [1.0; BLOCK],
        }
    }
}
