//! The auto-vectorised kernel ([`Kernel::AutoVectorised`](super::Kernel::AutoVectorised)): a
//! plain loop over one `f32` ray at a time, surface by surface over a block of rays, left to
//! the compiler's vectoriser (8 or 16 lanes wide in the AVX2 and AVX-512 copies).

use super::clip::clip_plain;
use super::losses::LossScratch;
use super::refract::{
    CONIC, LaneRay, NEWTON_STEPS, Newton, POLYNOMIAL, RaySlices, SPHERE, SurfaceConstants,
    normalise_direction, refract_at, refract_from_hit,
};
use super::{BLOCK, Plan, skip_dead_block};
use crate::batch::RayBatch;
use crate::lanes::{Pair, PairMask};

/// The auto-vectorised kernel: in place on the batch's arrays, block by block.
#[inline(always)]
pub(super) fn trace_plain(plan: &Plan, rays: &mut RayBatch, etas: &mut Vec<f32>) {
    let len = rays.len();
    plan.size_etas(etas);
    let mut cosines = [0.0f32; BLOCK];
    let mut scratch = LossScratch::new();
    let mut start = 0;
    while start < len {
        let end = (start + BLOCK).min(len);
        if skip_dead_block(&rays.alive[start..end]) {
            start = end;
            continue;
        }
        let n = end - start;
        let spectral = plan.block_etas(start, n, etas);
        if let Some(losses) = &plan.losses {
            losses.block_positions(start, n, &mut scratch);
        }
        let ox = &mut rays.ox[start..end];
        let oy = &mut rays.oy[start..end];
        let oz = &mut rays.oz[start..end];
        let dx = &mut rays.dx[start..end];
        let dy = &mut rays.dy[start..end];
        let dz = &mut rays.dz[start..end];
        let alive = &mut rays.alive[start..end];
        for (step, surface) in plan.surfaces.iter().enumerate() {
            let lanes = Lanes {
                rays: RaySlices {
                    ox: &mut *ox,
                    oy: &mut *oy,
                    oz: &mut *oz,
                    dx: &mut *dx,
                    dy: &mut *dy,
                    dz: &mut *dz,
                    alive: &mut *alive,
                },
                cosines: &mut cosines,
            };
            // The shape (and whether indices vary per ray) picks the kernel once per surface and
            // block, never per ray.
            let any_alive = if spectral {
                let eta = &etas[step * BLOCK..step * BLOCK + n];
                match surface.shape {
                    SPHERE => plain_surface::<SPHERE, true>(surface, lanes, eta),
                    CONIC => plain_surface::<CONIC, true>(surface, lanes, eta),
                    _ => plain_surface::<POLYNOMIAL, true>(surface, lanes, eta),
                }
            } else {
                match surface.shape {
                    SPHERE => plain_surface::<SPHERE, false>(surface, lanes, &[]),
                    CONIC => plain_surface::<CONIC, false>(surface, lanes, &[]),
                    _ => plain_surface::<POLYNOMIAL, false>(surface, lanes, &[]),
                }
            };
            if let Some((clip_step, clip)) = plan.clip
                && clip_step == step
            {
                let throughput = [
                    &mut rays.tr[start..end],
                    &mut rays.tg[start..end],
                    &mut rays.tb[start..end],
                ];
                clip_plain(clip, ox, oy, alive, throughput);
            }
            if let Some(losses) = &plan.losses {
                losses.attenuate(step, &cosines[..n], alive, &mut scratch, plan.isa);
            }
            if !any_alive {
                break;
            }
        }
        if plan.losses.is_some() {
            for (i, &t) in scratch.transmission[..n].iter().enumerate() {
                if alive[i] {
                    rays.tr[start + i] *= t;
                    rays.tg[start + i] *= t;
                    rays.tb[start + i] *= t;
                }
            }
        }
        for i in 0..n {
            let mut ray = LaneRay {
                origin: [ox[i], oy[i], oz[i]],
                direction: [dx[i], dy[i], dz[i]],
            };
            normalise_direction(&mut ray, alive[i]);
            [dx[i], dy[i], dz[i]] = ray.direction;
        }
        start = end;
    }
}

/// One block's rays, and each lane's cosine in the less dense medium at the surface just
/// crossed.
struct Lanes<'a> {
    rays: RaySlices<'a>,
    cosines: &'a mut [f32; BLOCK],
}

impl<'a> Lanes<'a> {
    /// The block's rays and cosines, every slice cut to the block's length: in a loop over
    /// `0..alive.len()` the compiler then knows every index is in bounds, checks none, and
    /// vectorises.
    #[inline(always)]
    fn cut(self) -> (RaySlices<'a>, &'a mut [f32]) {
        let n = self.rays.alive.len();
        self.cut_to(n)
    }

    /// [`Self::cut`] to `n` rays, a constant where the caller knows the block is whole.
    #[inline(always)]
    fn cut_to(self, n: usize) -> (RaySlices<'a>, &'a mut [f32]) {
        let RaySlices {
            ox,
            oy,
            oz,
            dx,
            dy,
            dz,
            alive,
        } = self.rays;
        let rays = RaySlices {
            ox: &mut ox[..n],
            oy: &mut oy[..n],
            oz: &mut oz[..n],
            dx: &mut dx[..n],
            dy: &mut dy[..n],
            dz: &mut dz[..n],
            alive: &mut alive[..n],
        };
        (rays, &mut self.cosines[..n])
    }
}

/// One surface over a block of rays in the plain kernel (each ray's index ratio from `etas`
/// when `SPECTRAL`); returns whether any ray is alive.
#[inline(always)]
fn plain_surface<const SHAPE: u8, const SPECTRAL: bool>(
    surface: &SurfaceConstants<f32>,
    lanes: Lanes,
    etas: &[f32],
) -> bool {
    if SHAPE == POLYNOMIAL {
        return plain_polynomial_surface::<SPECTRAL>(surface, lanes, etas);
    }
    if lanes.rays.alive.len() == BLOCK {
        return paired_surface::<SHAPE, SPECTRAL>(surface, lanes, etas);
    }
    let (mut rays, cosines) = lanes.cut();
    let n = rays.alive.len();
    let etas = if SPECTRAL { &etas[..n] } else { etas };
    let mut any_alive = false;
    for i in 0..n {
        let mut ray = rays.ray(i);
        let eta = if SPECTRAL { etas[i] } else { surface.eta };
        let crossing = refract_at::<f32, SHAPE>(surface, &mut ray, rays.alive[i], eta);
        rays.set_ray(i, &ray);
        rays.alive[i] = crossing.survives;
        cosines[i] = crossing.cosine;
        any_alive |= crossing.survives;
    }
    any_alive
}

/// [`plain_surface`] for a whole block: ray i goes beside ray i + BLOCK/2 as one [`Pair`], so
/// the vectorised loop runs two independent vectors through the surface step's long chain of
/// dependent operations (square roots and a division among them) instead of leaving the core
/// waiting on one. Half a block apart, a pair's rays never share a vector, which the compiler
/// sees from the constant distance. Each ray sees the same operations as alone.
#[inline(always)]
fn paired_surface<const SHAPE: u8, const SPECTRAL: bool>(
    surface: &SurfaceConstants<f32>,
    lanes: Lanes,
    etas: &[f32],
) -> bool {
    const HALF: usize = BLOCK / 2;
    let (mut rays, cosines) = lanes.cut_to(BLOCK);
    let etas = if SPECTRAL { &etas[..BLOCK] } else { etas };
    let paired = surface.splat::<Pair>();
    let mut any_alive = false;
    for i in 0..HALF {
        let j = i + HALF;
        let mut ray = side_by_side(&rays.ray(i), &rays.ray(j));
        let eta = if SPECTRAL {
            Pair(etas[i], etas[j])
        } else {
            paired.eta
        };
        let alive = PairMask(rays.alive[i], rays.alive[j]);
        let crossing = refract_at::<Pair, SHAPE>(&paired, &mut ray, alive, eta);
        let (ray_i, ray_j) = apart(&ray);
        rays.set_ray(i, &ray_i);
        rays.set_ray(j, &ray_j);
        let PairMask(survives_i, survives_j) = crossing.survives;
        (rays.alive[i], rays.alive[j]) = (survives_i, survives_j);
        (cosines[i], cosines[j]) = (crossing.cosine.0, crossing.cosine.1);
        any_alive |= survives_i | survives_j;
    }
    any_alive
}

/// Rays `a` and `b` side by side as one [`Pair`] ray.
#[inline(always)]
fn side_by_side(a: &LaneRay<f32>, b: &LaneRay<f32>) -> LaneRay<Pair> {
    let (ao, ad, bo, bd) = (a.origin, a.direction, b.origin, b.direction);
    LaneRay {
        origin: [Pair(ao[0], bo[0]), Pair(ao[1], bo[1]), Pair(ao[2], bo[2])],
        direction: [Pair(ad[0], bd[0]), Pair(ad[1], bd[1]), Pair(ad[2], bd[2])],
    }
}

/// A [`Pair`] ray's two rays.
#[inline(always)]
fn apart(ray: &LaneRay<Pair>) -> (LaneRay<f32>, LaneRay<f32>) {
    let ([ox, oy, oz], [dx, dy, dz]) = (ray.origin, ray.direction);
    (
        LaneRay {
            origin: [ox.0, oy.0, oz.0],
            direction: [dx.0, dy.0, dz.0],
        },
        LaneRay {
            origin: [ox.1, oy.1, oz.1],
            direction: [dx.1, dy.1, dz.1],
        },
    )
}

/// [`plain_surface`] for a polynomial asphere: the Newton iterations run as steps over the whole
/// block (each step a plain loop over the rays, which vectorises; a ray's own iteration loop,
/// with its data-dependent exit, would not), until no ray is still searching. Bit-identical to
/// [`refract_at`] ray by ray: each ray sees the same operations in the same order.
#[inline(always)]
fn plain_polynomial_surface<const SPECTRAL: bool>(
    surface: &SurfaceConstants<f32>,
    lanes: Lanes,
    etas: &[f32],
) -> bool {
    let (mut rays, cosines) = lanes.cut();
    let n = rays.alive.len();
    // The iteration state as arrays (structure of arrays, so the step loop vectorises).
    let mut t = [0.0f32; BLOCK];
    let mut searching = [false; BLOCK];
    let mut converged = [false; BLOCK];
    let (t, searching, converged) = (&mut t[..n], &mut searching[..n], &mut converged[..n]);
    for i in 0..n {
        let start = Newton::start(surface, &rays.ray(i), rays.alive[i]);
        (t[i], searching[i], converged[i]) = (start.t, start.searching, start.converged);
    }
    for _ in 0..NEWTON_STEPS {
        let mut any_searching = false;
        for i in 0..n {
            let mut state = Newton {
                t: t[i],
                searching: searching[i],
                converged: converged[i],
            };
            state.step(surface, &rays.ray(i));
            (t[i], searching[i], converged[i]) = (state.t, state.searching, state.converged);
            any_searching |= state.searching;
        }
        if !any_searching {
            break;
        }
    }
    let mut any_alive = false;
    for i in 0..n {
        let mut ray = rays.ray(i);
        let eta = if SPECTRAL { etas[i] } else { surface.eta };
        let (t, hit) = Newton {
            t: t[i],
            searching: searching[i],
            converged: converged[i],
        }
        .hit();
        let crossing =
            refract_from_hit::<f32, POLYNOMIAL>(surface, &mut ray, rays.alive[i], eta, t, hit);
        rays.set_ray(i, &ray);
        rays.alive[i] = crossing.survives;
        cosines[i] = crossing.cosine;
        any_alive |= crossing.survives;
    }
    any_alive
}
