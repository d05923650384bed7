//! Ghost paths ([`crate::lens::ghost`]) for a batch of rays at once, each along its own pair.
//!
//! A pass's ghost samples are few (one in [`GHOST_EVERY`](crate::lens::ghost::GHOST_EVERY):
//! 64 of a 32 × 32 tile's rays) and spread over many pairs (45 on a double Gauss), so they are
//! not grouped by pair. Instead every path of pair (a, b) is three sweeps over the surfaces,
//! the same three for every pair:
//!
//! ```text
//! toward the scene  n−1 … 0   the lanes with i ≥ a meet surface i: refract, reflect at a
//! toward the film   0 … n−1   the lanes with a < i ≤ b: refract, reflect at b
//! toward the scene  n−1 … 0   the lanes with i < b: refract
//! ```
//!
//! so at each step all lanes face the same surface (one shape, one set of constants) and
//! differ only in whether they meet it and how: masks, as blocked lanes are in the batch
//! kernels, and the step ([`ghost_step_at`]) vectorises. The physics is
//! [`crate::lens::ghost::trace_ghost_path`]'s, which stays the per-ray reference (tested
//! against it: f32 arithmetic in another order, so equal within rounding, not bit for bit).

use super::clip::clip_plain;
use super::refract::{
    CONIC, LaneRay, POLYNOMIAL, SPHERE, SurfaceConstants, ghost_step_at, normalise_direction,
};
use super::{BLOCK, Isa};
use crate::batch::RayBatch;
use crate::lens::dispersion::DispersionTable;
use crate::lens::reflectance::SurfaceReflectance;
use crate::lens::system::SurfaceArrays;

/// What ghost paths are traced through: the lens, its reflectances, and its indices over
/// wavelength (`None`: every ray at the lens's own indices).
#[derive(Clone, Copy, Debug)]
pub(crate) struct GhostLens<'a> {
    pub surfaces: &'a SurfaceArrays<f32>,
    pub reflectance: &'a SurfaceReflectance,
    pub dispersion: Option<&'a DispersionTable>,
}

/// A batch's ghost samples: rays leaving the film (lens frame), each with its wavelength and
/// pair. Kept between batches so that its arrays keep their capacity.
#[derive(Clone, Debug, Default)]
pub(crate) struct GhostBatch {
    rays: RayBatch,
    nm: Vec<f32>,
    /// Each ray's pair (a, b), a < b, front = 0.
    pair: Vec<[u32; 2]>,
    /// The share of each ray's light its path passes.
    transmission: Vec<f32>,
    /// A block's indices of every medium, per lane (see [`trace_block`]).
    media: Vec<f32>,
}

impl GhostBatch {
    /// Empties the batch, with room for `rays` ghost samples: how many a batch has varies
    /// from pass to pass, and arrays grown to each new largest count would reallocate now and
    /// then for many passes.
    pub fn clear_with_room(&mut self, rays: usize) {
        self.rays.clear();
        self.rays.reserve(rays);
        for v in [&mut self.nm, &mut self.transmission] {
            v.clear();
            v.reserve(rays);
        }
        self.pair.clear();
        self.pair.reserve(rays);
    }

    /// Adds a ghost sample: a ray leaving the film (lens frame, unit direction) at wavelength
    /// `nm` (the d line without dispersion), to reflect at the surfaces `pair`.
    pub fn push(&mut self, origin: [f32; 3], direction: [f32; 3], nm: f32, pair: [usize; 2]) {
        self.rays.push(origin, direction, 0, 0);
        self.nm.push(nm);
        self.pair.push(pair.map(|s| s as u32));
    }

    /// Traces every ray along its ghost path.
    #[inline(always)]
    pub fn trace(&mut self, lens: &GhostLens) {
        let n = self.pair.len();
        self.transmission.clear();
        self.transmission.resize(n, 1.0);
        let mut start = 0;
        while start < n {
            let end = (start + BLOCK).min(n);
            let r = &mut self.rays;
            let lanes = GhostLanes {
                ox: &mut r.ox[start..end],
                oy: &mut r.oy[start..end],
                oz: &mut r.oz[start..end],
                dx: &mut r.dx[start..end],
                dy: &mut r.dy[start..end],
                dz: &mut r.dz[start..end],
                alive: &mut r.alive[start..end],
                transmission: &mut self.transmission[start..end],
                nm: &self.nm[start..end],
                pair: &self.pair[start..end],
            };
            trace_block(lens, lanes, &mut self.media);
            start = end;
        }
    }

    /// Ray `k`'s (in the order pushed) ray leaving the front of the lens (lens frame, unit
    /// direction) and the share of its light the path passed; `None` where it was blocked.
    pub fn traced(&self, k: usize) -> Option<([f32; 3], [f32; 3], f32)> {
        self.rays.alive[k].then(|| {
            (
                self.rays.origin(k),
                self.rays.direction(k),
                self.transmission[k],
            )
        })
    }
}

/// At most [`BLOCK`] ghost rays, structure of arrays.
struct GhostLanes<'a> {
    ox: &'a mut [f32],
    oy: &'a mut [f32],
    oz: &'a mut [f32],
    dx: &'a mut [f32],
    dy: &'a mut [f32],
    dz: &'a mut [f32],
    alive: &'a mut [bool],
    transmission: &'a mut [f32],
    nm: &'a [f32],
    pair: &'a [[u32; 2]],
}

/// Which way a sweep travels, and which lanes meet surface `i` in it and reflect there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Sweep {
    /// Film to the first reflection, at a.
    In,
    /// The first reflection to the second, at b.
    Back,
    /// The second reflection out into the scene.
    Out,
}

impl Sweep {
    fn toward_film(self) -> bool {
        self == Sweep::Back
    }

    /// Whether a lane of pair `[a, b]` meets surface `i` in this sweep, and whether it
    /// reflects there.
    #[inline(always)]
    fn meets(self, i: u32, [a, b]: [u32; 2]) -> (bool, bool) {
        match self {
            Sweep::In => (i >= a, i == a),
            Sweep::Back => (a < i && i <= b, i == b),
            Sweep::Out => (i < b, false),
        }
    }
}

/// Traces a block of ghost rays along their paths: each surface met keeps 1 − R of the light,
/// each reflection R (1 beyond the critical angle), the clear apertures and the stop clip as
/// for any ray. Survivors end leaving the front surface with unit directions; blocked lanes
/// get `alive = false`. `media` is working memory: with dispersion, every medium's index per
/// lane.
#[inline(always)]
fn trace_block(lens: &GhostLens, mut lanes: GhostLanes, media: &mut Vec<f32>) {
    let n = lanes.alive.len();
    let surfaces = lens.surfaces;
    let count = surfaces.len();
    // Each lane's place in the reflectance table, and with dispersion the index of every
    // medium at its wavelength (medium m lies in front of surface m; medium 0 is air).
    let mut row = [(0usize, 0.0f32); BLOCK];
    for (row, &nm) in row.iter_mut().zip(lanes.nm) {
        *row = lens.reflectance.position(nm);
    }
    media.clear();
    if let Some(table) = lens.dispersion {
        // Room for a whole block, whatever this one's size.
        media.reserve((count + 1) * BLOCK);
        let mut cell = [0u32; BLOCK];
        let mut fraction = [0.0f32; BLOCK];
        for lane in 0..n {
            let (i, t) = table.position(lanes.nm[lane]);
            (cell[lane], fraction[lane]) = (i as u32, t);
        }
        media.resize((count + 1) * n, 1.0);
        for surface in 0..count {
            let after = &mut media[(surface + 1) * n..(surface + 2) * n];
            table
                .curve(surface)
                .at_lanes(&cell[..n], &fraction[..n], after, Isa::detect());
        }
    }
    let mut eta = [1.0f32; BLOCK];
    let mut active = [false; BLOCK];
    let mut reflect = [false; BLOCK];
    let mut cosine = [0.0f32; BLOCK];
    let mut total = [false; BLOCK];
    let mut clipped = [false; BLOCK];
    for sweep in [Sweep::In, Sweep::Back, Sweep::Out] {
        let toward_film = sweep.toward_film();
        let order: &mut dyn Iterator<Item = usize> = if toward_film {
            &mut (0..count)
        } else {
            &mut (0..count).rev()
        };
        for i in order {
            for lane in 0..n {
                (active[lane], reflect[lane]) = sweep.meets(i as u32, lanes.pair[lane]);
            }
            // n on the lanes' side over n beyond: toward the film the medium in front of i
            // over the one behind it.
            match lens.dispersion {
                Some(_) => {
                    let (front, back) = (&media[i * n..(i + 1) * n], &media[(i + 1) * n..]);
                    for lane in 0..n {
                        eta[lane] = if toward_film {
                            front[lane] / back[lane]
                        } else {
                            back[lane] / front[lane]
                        };
                    }
                }
                None => {
                    let (front, back) = (surfaces.index_front[i], surfaces.index_back[i]);
                    eta.fill(if toward_film {
                        front / back
                    } else {
                        back / front
                    });
                }
            }
            let forward_sign = if toward_film { 1.0 } else { -1.0 };
            let s = SurfaceConstants::of(surfaces, i, 1.0, forward_sign);
            let step = Step {
                eta: &eta[..n],
                active: &active[..n],
                reflect: &reflect[..n],
                cosine: &mut cosine[..n],
                total: &mut total[..n],
            };
            let any_alive = match s.shape {
                SPHERE => step.run::<SPHERE>(&s, &mut lanes),
                CONIC => step.run::<CONIC>(&s, &mut lanes),
                _ => step.run::<POLYNOMIAL>(&s, &mut lanes),
            };
            if !any_alive {
                return;
            }
            if let Some(clip) = surfaces.stop_clip.as_deref()
                && clip.surface == i
            {
                // Only the lanes that met the stop now are clipped.
                for lane in 0..n {
                    clipped[lane] = lanes.alive[lane] && active[lane];
                }
                clip_plain(
                    clip,
                    lanes.ox,
                    lanes.oy,
                    &mut clipped[..n],
                    [&mut *lanes.transmission],
                );
                for lane in 0..n {
                    lanes.alive[lane] &= clipped[lane] || !active[lane];
                }
            }
            for lane in 0..n {
                if lanes.alive[lane] && active[lane] {
                    let r = if total[lane] {
                        1.0
                    } else {
                        lens.reflectance.lookup(i, cosine[lane], row[lane])
                    };
                    lanes.transmission[lane] *= if reflect[lane] { r } else { 1.0 - r };
                }
            }
        }
    }
    for lane in 0..n {
        let mut ray = lane_ray(&lanes, lane);
        normalise_direction(&mut ray, lanes.alive[lane]);
        [lanes.dx[lane], lanes.dy[lane], lanes.dz[lane]] = ray.direction;
    }
}

#[inline(always)]
fn lane_ray(lanes: &GhostLanes, lane: usize) -> LaneRay<f32> {
    LaneRay {
        origin: [lanes.ox[lane], lanes.oy[lane], lanes.oz[lane]],
        direction: [lanes.dx[lane], lanes.dy[lane], lanes.dz[lane]],
    }
}

/// One surface of a sweep over a block's lanes: what each lane does there, and what it
/// leaves for the losses.
struct Step<'a> {
    eta: &'a [f32],
    active: &'a [bool],
    reflect: &'a [bool],
    cosine: &'a mut [f32],
    total: &'a mut [bool],
}

impl Step<'_> {
    /// Runs [`ghost_step_at`] over the lanes (a plain loop, which vectorises); returns
    /// whether any lane is alive.
    #[inline(always)]
    fn run<const SHAPE: u8>(self, s: &SurfaceConstants<f32>, lanes: &mut GhostLanes) -> bool {
        let n = self.eta.len();
        let (ox, oy, oz) = (&mut lanes.ox[..n], &mut lanes.oy[..n], &mut lanes.oz[..n]);
        let (dx, dy, dz) = (&mut lanes.dx[..n], &mut lanes.dy[..n], &mut lanes.dz[..n]);
        let alive = &mut lanes.alive[..n];
        let (active, reflect) = (&self.active[..n], &self.reflect[..n]);
        let (cosine, total) = (&mut self.cosine[..n], &mut self.total[..n]);
        let mut any_alive = false;
        for lane in 0..n {
            let mut ray = LaneRay {
                origin: [ox[lane], oy[lane], oz[lane]],
                direction: [dx[lane], dy[lane], dz[lane]],
            };
            let crossing = ghost_step_at::<f32, SHAPE>(
                s,
                &mut ray,
                alive[lane],
                active[lane],
                reflect[lane],
                self.eta[lane],
            );
            [ox[lane], oy[lane], oz[lane]] = ray.origin;
            [dx[lane], dy[lane], dz[lane]] = ray.direction;
            alive[lane] = crossing.survives;
            (cosine[lane], total[lane]) = (crossing.cosine, crossing.total);
            any_alive |= crossing.survives;
        }
        any_alive
    }
}
