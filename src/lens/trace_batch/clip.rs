//! The diaphragm's test where rays cross the stop, for a group of lanes: the f32 form of
//! [`StopClip::transmission`] (equations in [`crate::lens::diaphragm`]). The blade test is
//! written once against [`Lanes`], so both kernels give the same bits; a mask's grey level is
//! looked up one lane at a time (a gather), by the same scalar code in both.

use crate::lanes::Lanes;
use crate::lens::diaphragm::StopClip;

/// Which lanes at stop-plane points (`x`, `y`) lie on the open side of every blade (all of
/// them when the diaphragm has no blades).
#[inline(always)]
pub fn inside_blades<L: Lanes>(clip: &StopClip, x: L, y: L) -> L::Mask {
    let apex = L::splat(clip.apex_f32);
    let kappa = L::splat(clip.kappa_f32);
    let mut inside = apex.le(apex);
    for &[nx, ny] in &clip.normals_f32 {
        let (nx, ny) = (L::splat(nx), L::splat(ny));
        let along = x * nx + y * ny;
        let ex = x - apex * nx;
        let ey = y - apex * ny;
        inside = inside & (along + kappa * (ex * ex + ey * ey)).le(apex);
    }
    inside
}

/// The plain kernel's clip at the stop: rays on the closed side of a blade, or where the mask
/// is black, stop being alive; survivors' throughput (`tr`, `tg`, `tb`, or a ghost path's
/// one transmission) is multiplied by the mask's grey level.
#[inline(always)]
pub fn clip_plain<const N: usize>(
    clip: &StopClip,
    x: &[f32],
    y: &[f32],
    alive: &mut [bool],
    mut throughput: [&mut [f32]; N],
) {
    let n = alive.len();
    let (x, y) = (&x[..n], &y[..n]);
    for i in 0..n {
        alive[i] &= inside_blades::<f32>(clip, x[i], y[i]);
    }
    if clip.has_mask() {
        for i in 0..n {
            if alive[i] {
                let t = clip.mask_transmission_f32(x[i], y[i]);
                alive[i] = t > 0.0;
                if alive[i] {
                    for channel in throughput.iter_mut() {
                        channel[i] *= t;
                    }
                }
            }
        }
    }
}
