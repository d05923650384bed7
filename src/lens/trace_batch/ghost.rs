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
    CONIC, LaneRay, POLYNOMIAL, RaySlices, SPHERE, SurfaceConstants, ghost_step_at,
    normalise_direction,
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
    /// Traced, each ray's throughput (`tr`) becomes the share of its light the path passes.
    rays: RayBatch,
    nm: Vec<f32>,
    /// Each ray's pair (a, b), a < b, front = 0.
    pair: Vec<[u32; 2]>,
}

impl GhostBatch {
    /// Empties the batch, with room for `rays` ghost samples: how many a batch has varies
    /// from pass to pass, and arrays grown to each new largest count would reallocate now and
    /// then for many passes.
    pub fn clear_with_room(&mut self, rays: usize) {
        self.rays.clear();
        self.rays.reserve(rays);
        self.nm.clear();
        self.nm.reserve(rays);
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
        let mut start = 0;
        while start < n {
            let end = (start + BLOCK).min(n);
            let mut block = Block::default();
            block.load(self, start..end, lens);
            let survivors = block.trace(lens);
            block.store(self, start..end, survivors);
            start = end;
        }
    }

    /// Ray `k`'s (in the order pushed) ray leaving the front of the lens (lens frame, unit
    /// direction) and the share of its light the path passed; `None` where it was blocked.
    pub fn traced(&self, k: usize) -> Option<([f32; 3], [f32; 3], f32)> {
        self.rays.alive[k].then(|| (self.rays.origin(k), self.rays.direction(k), self.rays.tr[k]))
    }
}

/// At most [`BLOCK`] ghost rays in the working order: the first `len` lanes are those still
/// traced (blocked ones are dropped from time to time, so that a path blocked early stops
/// costing anything), each with its ray's index in the batch.
struct Block {
    len: usize,
    ray: [u32; BLOCK],
    ox: [f32; BLOCK],
    oy: [f32; BLOCK],
    oz: [f32; BLOCK],
    dx: [f32; BLOCK],
    dy: [f32; BLOCK],
    dz: [f32; BLOCK],
    alive: [bool; BLOCK],
    transmission: [f32; BLOCK],
    pair: [[u32; 2]; BLOCK],
    /// The reflectance table's wavelength row, and with dispersion the index table's cell
    /// and fraction.
    row: [(usize, f32); BLOCK],
    cell: [u32; BLOCK],
    fraction: [f32; BLOCK],
}

impl Default for Block {
    fn default() -> Self {
        Block {
            len: 0,
            ray: [0; BLOCK],
            ox: [0.0; BLOCK],
            oy: [0.0; BLOCK],
            oz: [0.0; BLOCK],
            dx: [0.0; BLOCK],
            dy: [0.0; BLOCK],
            dz: [0.0; BLOCK],
            alive: [false; BLOCK],
            transmission: [1.0; BLOCK],
            pair: [[0; 2]; BLOCK],
            row: [(0, 0.0); BLOCK],
            cell: [0; BLOCK],
            fraction: [0.0; BLOCK],
        }
    }
}

impl Block {
    /// The batch's rays `range` (at most [`BLOCK`]), with their places in the tables.
    #[inline(always)]
    fn load(&mut self, batch: &GhostBatch, range: std::ops::Range<usize>, lens: &GhostLens) {
        let r = &batch.rays;
        self.len = range.len();
        for (lane, k) in range.enumerate() {
            self.ray[lane] = k as u32;
            [self.ox[lane], self.oy[lane], self.oz[lane]] = r.origin(k);
            [self.dx[lane], self.dy[lane], self.dz[lane]] = r.direction(k);
            self.alive[lane] = r.alive[k];
            self.transmission[lane] = r.tr[k];
            self.pair[lane] = batch.pair[k];
            let nm = batch.nm[k];
            self.row[lane] = lens.reflectance.position(nm);
            if let Some(table) = lens.dispersion {
                let (i, t) = table.position(nm);
                (self.cell[lane], self.fraction[lane]) = (i as u32, t);
            }
        }
    }

    /// Writes the `survivors` back to the batch's rays `range`; every other ray is blocked.
    #[inline(always)]
    fn store(&self, batch: &mut GhostBatch, range: std::ops::Range<usize>, survivors: bool) {
        batch.rays.alive[range].fill(false);
        if !survivors {
            return;
        }
        let r = &mut batch.rays;
        for lane in 0..self.len {
            let k = self.ray[lane] as usize;
            [r.ox[k], r.oy[k], r.oz[k]] = [self.ox[lane], self.oy[lane], self.oz[lane]];
            [r.dx[k], r.dy[k], r.dz[k]] = [self.dx[lane], self.dy[lane], self.dz[lane]];
            r.alive[k] = self.alive[lane];
            r.tr[k] = self.transmission[lane];
        }
    }

    /// The first `len` lanes, as the step sees them.
    #[inline(always)]
    fn lanes(&mut self) -> RaySlices<'_> {
        let n = self.len;
        RaySlices {
            ox: &mut self.ox[..n],
            oy: &mut self.oy[..n],
            oz: &mut self.oz[..n],
            dx: &mut self.dx[..n],
            dy: &mut self.dy[..n],
            dz: &mut self.dz[..n],
            alive: &mut self.alive[..n],
        }
    }

    /// Drops the blocked lanes, keeping the others in order.
    #[inline(always)]
    fn compact(&mut self) {
        let mut kept = 0;
        for lane in 0..self.len {
            if self.alive[lane] {
                self.ray[kept] = self.ray[lane];
                self.ox[kept] = self.ox[lane];
                self.oy[kept] = self.oy[lane];
                self.oz[kept] = self.oz[lane];
                self.dx[kept] = self.dx[lane];
                self.dy[kept] = self.dy[lane];
                self.dz[kept] = self.dz[lane];
                self.alive[kept] = true;
                self.transmission[kept] = self.transmission[lane];
                self.pair[kept] = self.pair[lane];
                self.row[kept] = self.row[lane];
                self.cell[kept] = self.cell[lane];
                self.fraction[kept] = self.fraction[lane];
                kept += 1;
            }
        }
        self.len = kept;
    }
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

impl Block {
    /// Traces the block's rays along their paths: each surface met keeps 1 − R of the light,
    /// each reflection R (1 beyond the critical angle), the clear apertures and the stop clip
    /// as for any ray. Survivors end leaving the front surface with unit directions, blocked
    /// lanes with `alive = false`; returns whether any survived.
    #[inline(always)]
    fn trace(&mut self, lens: &GhostLens) -> bool {
        let surfaces = lens.surfaces;
        let count = surfaces.len();
        let mut before = [1.0f32; BLOCK];
        let mut after = [1.0f32; BLOCK];
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
                let n = self.len;
                for lane in 0..n {
                    (active[lane], reflect[lane]) = sweep.meets(i as u32, self.pair[lane]);
                }
                // The media's indices in front of surface i and behind it, at each lane's
                // wavelength or the lens's own; the ratio n on the lanes' side over n beyond.
                let (front, back) = (&mut before[..n], &mut after[..n]);
                match lens.dispersion {
                    Some(table) => {
                        let (cell, fraction) = (&self.cell[..n], &self.fraction[..n]);
                        let isa = Isa::detect();
                        table.curve(i).at_lanes(cell, fraction, back, isa);
                        match i.checked_sub(1) {
                            Some(f) => table.curve(f).at_lanes(cell, fraction, front, isa),
                            None => front.fill(1.0),
                        }
                    }
                    None => {
                        front.fill(surfaces.index_front[i]);
                        back.fill(surfaces.index_back[i]);
                    }
                }
                for lane in 0..n {
                    eta[lane] = if toward_film {
                        front[lane] / back[lane]
                    } else {
                        back[lane] / front[lane]
                    };
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
                let alive = match s.shape {
                    SPHERE => step.run::<SPHERE>(&s, &mut self.lanes()),
                    CONIC => step.run::<CONIC>(&s, &mut self.lanes()),
                    _ => step.run::<POLYNOMIAL>(&s, &mut self.lanes()),
                };
                if alive == 0 {
                    return false;
                }
                let (alive_now, transmission) = (&mut self.alive[..n], &mut self.transmission[..n]);
                if let Some(clip) = surfaces.stop_clip.as_deref()
                    && clip.surface == i
                {
                    // Only the lanes that met the stop now are clipped.
                    for lane in 0..n {
                        clipped[lane] = alive_now[lane] && active[lane];
                    }
                    let (x, y) = (&self.ox[..n], &self.oy[..n]);
                    clip_plain(clip, x, y, &mut clipped[..n], [&mut *transmission]);
                    for lane in 0..n {
                        alive_now[lane] &= clipped[lane] || !active[lane];
                    }
                }
                for lane in 0..n {
                    if alive_now[lane] && active[lane] {
                        let r = if total[lane] {
                            1.0
                        } else {
                            lens.reflectance.lookup(i, cosine[lane], self.row[lane])
                        };
                        transmission[lane] *= if reflect[lane] { r } else { 1.0 - r };
                    }
                }
                // Once half the lanes are blocked, the rest move up.
                if 2 * alive <= n {
                    self.compact();
                }
            }
        }
        let lanes = self.lanes();
        for lane in 0..lanes.alive.len() {
            let mut ray = lanes.ray(lane);
            normalise_direction(&mut ray, lanes.alive[lane]);
            [lanes.dx[lane], lanes.dy[lane], lanes.dz[lane]] = ray.direction;
        }
        true
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
    /// Runs [`ghost_step_at`] over the lanes (a plain loop, which vectorises); returns how
    /// many lanes are alive (before the stop clip).
    #[inline(always)]
    fn run<const SHAPE: u8>(self, s: &SurfaceConstants<f32>, lanes: &mut RaySlices) -> usize {
        let n = self.eta.len();
        let (ox, oy, oz) = (&mut lanes.ox[..n], &mut lanes.oy[..n], &mut lanes.oz[..n]);
        let (dx, dy, dz) = (&mut lanes.dx[..n], &mut lanes.dy[..n], &mut lanes.dz[..n]);
        let alive = &mut lanes.alive[..n];
        let (active, reflect) = (&self.active[..n], &self.reflect[..n]);
        let (cosine, total) = (&mut self.cosine[..n], &mut self.total[..n]);
        let mut alive_count = 0;
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
            alive_count += usize::from(crossing.survives);
        }
        alive_count
    }
}
