//! The explicit 8-lane kernel ([`Kernel::Simd`](super::Kernel::Simd)): `wide::f32x8`, each
//! block copied once into 8-lane arrays (alive as lane masks) and every surface run over them.

use wide::f32x8;

use super::clip::inside_blades;
use super::losses::LossScratch;
use super::refract::{
    CONIC, LaneRay, POLYNOMIAL, SPHERE, SurfaceConstants, normalise_direction, refract_at,
};
use super::{BLOCK, Plan, skip_dead_block};
use crate::batch::RayBatch;
use crate::lens::diaphragm::StopClip;

const LANES: usize = 8;
const CHUNKS: usize = BLOCK / LANES;

/// One block of rays as 8-lane vectors; lanes past the batch's end are dead.
struct SimdBlock {
    rays: [LaneRay<f32x8>; CHUNKS],
    alive: [f32x8; CHUNKS],
}

/// The explicit 8-lane kernel: each block is copied into 8-lane arrays once, traced through
/// every surface, and copied back.
#[inline(always)]
pub(super) fn trace_simd(full_plan: &Plan, rays: &mut RayBatch, etas: &mut Vec<f32>) {
    let plan: Vec<SurfaceConstants<f32x8>> = full_plan.surfaces.iter().map(|s| s.splat()).collect();
    full_plan.size_etas(etas);
    let mut block = SimdBlock {
        rays: [LaneRay {
            origin: [f32x8::ZERO; 3],
            direction: [f32x8::ZERO; 3],
        }; CHUNKS],
        alive: [f32x8::ZERO; CHUNKS],
    };
    let mut cosines = [0.0f32; BLOCK];
    let mut survived = [false; BLOCK];
    let mut scratch = LossScratch::new();
    let len = rays.len();
    let mut start = 0;
    while start < len {
        let end = (start + BLOCK).min(len);
        if skip_dead_block(&rays.alive[start..end]) {
            start = end;
            continue;
        }
        let chunks = (end - start).div_ceil(LANES);
        let spectral = full_plan.block_etas(start, end - start, etas);
        load_block(rays, start, end, &mut block);
        let n = end - start;
        if let Some(losses) = &full_plan.losses {
            losses.block_positions(start, n, &mut scratch);
        }
        let mut transmission = None;
        for (step, surface) in plan.iter().enumerate() {
            let eta = spectral.then(|| &etas[step * BLOCK..(step + 1) * BLOCK]);
            let any_alive = match surface.shape {
                SPHERE => simd_surface::<SPHERE>(surface, &mut block, chunks, eta, &mut cosines),
                CONIC => simd_surface::<CONIC>(surface, &mut block, chunks, eta, &mut cosines),
                _ => simd_surface::<POLYNOMIAL>(surface, &mut block, chunks, eta, &mut cosines),
            };
            if let Some((clip_step, clip)) = full_plan.clip
                && clip_step == step
            {
                transmission = simd_clip(clip, &mut block, chunks);
            }
            if let Some(losses) = &full_plan.losses {
                for (c, alive) in block.alive[..chunks].iter().enumerate() {
                    let mask = alive.to_bitmask();
                    for lane in 0..LANES {
                        survived[c * LANES + lane] = mask & (1 << lane) != 0;
                    }
                }
                losses.attenuate(
                    step,
                    &cosines[..n],
                    &survived[..n],
                    &mut scratch,
                    full_plan.isa,
                );
            }
            if !any_alive {
                break;
            }
        }
        for (ray, &alive) in block.rays[..chunks].iter_mut().zip(&block.alive[..chunks]) {
            normalise_direction(ray, alive);
        }
        store_block(&block, start, end, rays);
        if let Some(transmission) = transmission {
            for (i, &t) in (start..end).zip(&transmission) {
                rays.tr[i] *= t;
                rays.tg[i] *= t;
                rays.tb[i] *= t;
            }
        }
        if full_plan.losses.is_some() {
            for (i, &t) in (start..end).zip(&scratch.transmission[..n]) {
                if rays.alive[i] {
                    rays.tr[i] *= t;
                    rays.tg[i] *= t;
                    rays.tb[i] *= t;
                }
            }
        }
        start = end;
    }
}

/// One surface over the first `chunks` chunks of a block (each lane's index ratio from `etas`
/// when given: [`BLOCK`] lanes), leaving each lane's cosine in the less dense medium in
/// `cosines`; returns whether any lane is alive.
#[inline(always)]
fn simd_surface<const SHAPE: u8>(
    surface: &SurfaceConstants<f32x8>,
    block: &mut SimdBlock,
    chunks: usize,
    etas: Option<&[f32]>,
    cosines: &mut [f32; BLOCK],
) -> bool {
    let mut any_alive = f32x8::ZERO;
    for (c, (ray, alive)) in block.rays[..chunks]
        .iter_mut()
        .zip(&mut block.alive[..chunks])
        .enumerate()
    {
        let eta = match etas {
            Some(etas) => {
                let mut lanes = [1.0f32; LANES];
                lanes.copy_from_slice(&etas[c * LANES..(c + 1) * LANES]);
                f32x8::from(lanes)
            }
            None => surface.eta,
        };
        let crossing = refract_at::<f32x8, SHAPE>(surface, ray, *alive, eta);
        *alive = crossing.survives;
        cosines[c * LANES..(c + 1) * LANES].copy_from_slice(&crossing.cosine.to_array());
        any_alive |= *alive;
    }
    any_alive.any()
}

/// The diaphragm's clip at the stop over the first `chunks` chunks of a block, as
/// [`clip_plain`]: returns, with a mask, each lane's grey level (1 where it did not survive the
/// stop, so multiplying by it changes nothing there).
#[inline(always)]
fn simd_clip(clip: &StopClip, block: &mut SimdBlock, chunks: usize) -> Option<[f32; BLOCK]> {
    for (ray, alive) in block.rays[..chunks].iter().zip(&mut block.alive[..chunks]) {
        *alive &= inside_blades::<f32x8>(clip, ray.origin[0], ray.origin[1]);
    }
    if !clip.has_mask() {
        return None;
    }
    let mut transmission = [1.0f32; BLOCK];
    for (c, (ray, alive)) in block.rays[..chunks]
        .iter()
        .zip(&mut block.alive[..chunks])
        .enumerate()
    {
        let (x, y) = (ray.origin[0].to_array(), ray.origin[1].to_array());
        let mask = alive.to_bitmask();
        let mut passes = [0.0f32; LANES];
        for lane in 0..LANES {
            if mask & (1 << lane) != 0 {
                let t = clip.mask_transmission_f32(x[lane], y[lane]);
                if t > 0.0 {
                    transmission[c * LANES + lane] = t;
                    passes[lane] = f32::from_bits(u32::MAX);
                }
            }
        }
        *alive = f32x8::from(passes);
    }
    Some(transmission)
}

/// Lanes `start..end` of the batch into `block` (the last chunk padded with dead lanes).
#[inline(always)]
fn load_block(rays: &RayBatch, start: usize, end: usize, block: &mut SimdBlock) {
    let lanes = |v: &[f32], at: usize| {
        let mut a = [0.0f32; LANES];
        let n = (end - at).min(LANES);
        a[..n].copy_from_slice(&v[at..at + n]);
        f32x8::from(a)
    };
    for (c, at) in (start..end).step_by(LANES).enumerate() {
        block.rays[c] = LaneRay {
            origin: [
                lanes(&rays.ox, at),
                lanes(&rays.oy, at),
                lanes(&rays.oz, at),
            ],
            direction: [
                lanes(&rays.dx, at),
                lanes(&rays.dy, at),
                lanes(&rays.dz, at),
            ],
        };
        let mut mask = [0.0f32; LANES];
        for (m, &a) in mask.iter_mut().zip(&rays.alive[at..end.min(at + LANES)]) {
            // All-ones bits: a true lane mask.
            *m = f32::from_bits(if a { u32::MAX } else { 0 });
        }
        block.alive[c] = f32x8::from(mask);
    }
}

/// The block's lanes back into `start..end` of the batch.
#[inline(always)]
fn store_block(block: &SimdBlock, start: usize, end: usize, rays: &mut RayBatch) {
    for (c, at) in (start..end).step_by(LANES).enumerate() {
        let n = (end - at).min(LANES);
        let put =
            |v: &mut [f32], lanes: f32x8| v[at..at + n].copy_from_slice(&lanes.to_array()[..n]);
        let ray = &block.rays[c];
        put(&mut rays.ox, ray.origin[0]);
        put(&mut rays.oy, ray.origin[1]);
        put(&mut rays.oz, ray.origin[2]);
        put(&mut rays.dx, ray.direction[0]);
        put(&mut rays.dy, ray.direction[1]);
        put(&mut rays.dz, ray.direction[2]);
        let mask = block.alive[c].to_bitmask();
        for (lane, a) in rays.alive[at..at + n].iter_mut().enumerate() {
            *a = mask & (1 << lane) != 0;
        }
    }
}
