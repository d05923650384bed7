//! Exact ray tracing through the lens for a whole batch at once (structure of arrays, f32).
//!
//! The surface step (`refract::refract_at`) is written once, generically over the lane type,
//! and run by two kernels that give bit-identical rays:
//!
//! * [`Kernel::AutoVectorised`]: a plain loop over one `f32` ray at a time, surface by surface
//!   over a block of rays, left to the compiler's auto-vectoriser;
//! * [`Kernel::Simd`]: explicit 8-lane `wide::f32x8`, the block copied once into 8-lane arrays
//!   (alive as lane masks) and every surface run over them.
//!
//! Rays go through in blocks of [`BLOCK`] so a block's state stays in L1 while all surfaces run
//! over it, and a block stops early once none of its rays is alive. On x86-64 both kernels are
//! also compiled for AVX2 and AVX-512 and the widest the CPU has is chosen at run time ([`Isa`]),
//! so a portable build still runs the plain loop 8 or 16 lanes wide; the explicit kernel's
//! `wide` types use AVX only when the whole build targets it (see BENCHMARKS.md).

mod clip;
mod lanes;
mod refract;

use wide::f32x8;

use self::clip::{clip_plain, inside_blades};
use self::refract::{
    CONIC, LaneRay, NEWTON_STEPS, Newton, POLYNOMIAL, SPHERE, SurfaceConstants,
    normalise_direction, refract_at, refract_from_hit,
};
use super::diaphragm::StopClip;
use super::dispersion::DispersionTable;
use super::system::SurfaceArrays;
use super::trace::Travel;
use crate::batch::RayBatch;

/// Which implementation of the batch kernel to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    /// Explicit 8-lane SIMD (`wide::f32x8`: AVX where the build targets it, SSE pairs otherwise).
    Simd,
    /// A plain loop left to the compiler's auto-vectoriser.
    AutoVectorised,
}

/// Rays traced together through all surfaces: their state (6 × 256 f32 and the flags, ~6 KiB;
/// 7 KiB as 8-lane masks) stays well inside L1.
pub const BLOCK: usize = 256;

/// Traces every alive ray of `rays` (lens frame, mm, unit directions) through all surfaces in
/// the order of `travel`, in place: survivors end on the last surface crossed with their
/// refracted direction; blocked rays get `alive = false` and keep the state they had when
/// blocked. A diaphragm at the stop ([`SurfaceArrays::stop_clip`]) blocks the rays its blades
/// stop, and multiplies the throughput (`tr`, `tg`, `tb`) of those crossing a mask by its grey
/// level there.
pub fn trace_batch(surfaces: &SurfaceArrays<f32>, rays: &mut RayBatch, travel: Travel) {
    trace_batch_with(surfaces, rays, travel, DEFAULT_KERNEL)
}

/// The kernel [`trace_batch`] runs: the faster one where the build does not target AVX (the
/// plain loop gets 8 or 16 lanes from run-time dispatch, `wide` stays at 2 × 4; see
/// BENCHMARKS.md).
pub const DEFAULT_KERNEL: Kernel = Kernel::AutoVectorised;

/// [`trace_batch`] with a chosen kernel (for benchmarks and cross-checks), on the widest
/// instruction set this CPU has.
pub fn trace_batch_with(
    surfaces: &SurfaceArrays<f32>,
    rays: &mut RayBatch,
    travel: Travel,
    kernel: Kernel,
) {
    trace_batch_on(surfaces, rays, travel, kernel, Isa::detect())
}

/// The instruction sets the kernels are compiled for, narrowest first. All give bit-identical
/// rays: they differ only in how many lanes one instruction works on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Isa {
    /// What the build targets (x86-64: SSE2, 4 lanes; AArch64: NEON).
    Baseline,
    /// x86-64 AVX2: 8 lanes.
    Avx2,
    /// x86-64 AVX-512 (F, VL, BW, DQ): 16 lanes.
    Avx512,
}

impl Isa {
    /// The widest instruction set this CPU supports.
    pub fn detect() -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            if has!("avx512f") && has!("avx512vl") && has!("avx512bw") && has!("avx512dq") {
                return Isa::Avx512;
            }
            if has!("avx2") {
                return Isa::Avx2;
            }
        }
        Isa::Baseline
    }

    /// Every instruction set this CPU supports, narrowest first.
    pub fn available() -> Vec<Isa> {
        [Isa::Baseline, Isa::Avx2, Isa::Avx512]
            .into_iter()
            .filter(|&isa| isa <= Isa::detect())
            .collect()
    }

    pub fn name(self) -> &'static str {
        match self {
            Isa::Baseline => "baseline",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
        }
    }
}

/// [`trace_batch_with`] compiled for `isa` (capped at what this CPU supports), to compare
/// instruction sets.
pub fn trace_batch_on(
    surfaces: &SurfaceArrays<f32>,
    rays: &mut RayBatch,
    travel: Travel,
    kernel: Kernel,
    isa: Isa,
) {
    run(surfaces, None, rays, travel, kernel, isa)
}

/// Each ray at its own wavelength: the rays' wavelengths (nm, one per ray of `rays`), and the
/// lens's indices over wavelength.
#[derive(Clone, Copy, Debug)]
pub struct Wavelengths<'a> {
    pub table: &'a DispersionTable,
    pub nm: &'a [f32],
}

/// [`trace_batch`] with every ray refracted at its own wavelength (`surfaces` gives the shapes
/// and apertures; the indices come from `wavelengths.table`).
pub fn trace_batch_spectral(
    surfaces: &SurfaceArrays<f32>,
    wavelengths: Wavelengths,
    rays: &mut RayBatch,
    travel: Travel,
) {
    trace_batch_spectral_on(
        surfaces,
        wavelengths,
        rays,
        travel,
        DEFAULT_KERNEL,
        Isa::detect(),
    )
}

/// [`trace_batch_spectral`] with a chosen kernel and instruction set.
pub fn trace_batch_spectral_on(
    surfaces: &SurfaceArrays<f32>,
    wavelengths: Wavelengths,
    rays: &mut RayBatch,
    travel: Travel,
    kernel: Kernel,
    isa: Isa,
) {
    assert_eq!(wavelengths.nm.len(), rays.len(), "one wavelength per ray");
    assert_eq!(wavelengths.table.surface_count(), surfaces.len());
    run(surfaces, Some(wavelengths), rays, travel, kernel, isa)
}

fn run(
    surfaces: &SurfaceArrays<f32>,
    wavelengths: Option<Wavelengths>,
    rays: &mut RayBatch,
    travel: Travel,
    kernel: Kernel,
    isa: Isa,
) {
    if travel == Travel::SceneToFilm {
        advance_to_front(surfaces, rays);
    }
    let n = surfaces.len();
    let plan = Plan {
        surfaces: SurfaceConstants::in_travel_order(surfaces, travel),
        spectral: wavelengths.map(|w| (w, travel)),
        clip: surfaces.stop_clip.as_deref().map(|clip| {
            let step = match travel {
                Travel::SceneToFilm => clip.surface,
                Travel::FilmToScene => n - 1 - clip.surface,
            };
            (step, clip)
        }),
    };
    match isa.min(Isa::detect()) {
        Isa::Baseline => run_kernel(kernel, &plan, rays),
        // SAFETY (both): `Isa::detect` found the instructions on this CPU.
        #[cfg(target_arch = "x86_64")]
        Isa::Avx2 => unsafe { run_kernel_avx2(kernel, &plan, rays) },
        #[cfg(target_arch = "x86_64")]
        Isa::Avx512 => unsafe { run_kernel_avx512(kernel, &plan, rays) },
        #[cfg(not(target_arch = "x86_64"))]
        _ => unreachable!("Isa::detect finds only the baseline here"),
    }
}

/// What the kernels run: the surfaces in the order of travel, for a spectral batch the rays'
/// wavelengths, and the diaphragm with the step (in travel order) of the stop it sits at.
struct Plan<'a> {
    surfaces: Vec<SurfaceConstants<f32>>,
    spectral: Option<(Wavelengths<'a>, Travel)>,
    clip: Option<(usize, &'a StopClip)>,
}

impl Plan<'_> {
    /// For a spectral batch, fills `etas` with every lane's index ratio at every surface of the
    /// block `start..start + n` (surface-major, [`BLOCK`] lanes per surface); returns whether it
    /// did.
    #[inline(always)]
    fn block_etas(&self, start: usize, n: usize, etas: &mut [f32]) -> bool {
        let Some((wavelengths, travel)) = self.spectral else {
            return false;
        };
        let table = wavelengths.table;
        let count = self.surfaces.len();
        let mut cell = [0usize; BLOCK];
        let mut fraction = [0.0f32; BLOCK];
        for lane in 0..n {
            (cell[lane], fraction[lane]) = table.position(wavelengths.nm[start + lane]);
        }
        // Each medium's index is looked up once per ray: the index after one surface is the
        // index before the next.
        let index_after =
            |surface: usize, lane: usize| table.index_after(surface, (cell[lane], fraction[lane]));
        let mut carried = [1.0f32; BLOCK];
        match travel {
            Travel::SceneToFilm => {
                for step in 0..count {
                    let eta = &mut etas[step * BLOCK..step * BLOCK + n];
                    for lane in 0..n {
                        let after = index_after(step, lane);
                        eta[lane] = carried[lane] / after;
                        carried[lane] = after;
                    }
                }
            }
            Travel::FilmToScene => {
                for (lane, index) in carried[..n].iter_mut().enumerate() {
                    *index = index_after(count - 1, lane);
                }
                for step in 0..count {
                    let surface = count - 1 - step;
                    let eta = &mut etas[step * BLOCK..step * BLOCK + n];
                    for lane in 0..n {
                        let before = if surface == 0 {
                            1.0
                        } else {
                            index_after(surface - 1, lane)
                        };
                        eta[lane] = carried[lane] / before;
                        carried[lane] = before;
                    }
                }
            }
        }
        true
    }
}

/// Moves rays that start far in front of the lens along themselves to just in front of it.
///
/// The line is the same, but the quadratic for the first surface is then solved with numbers of
/// the lens's size: from 1 m away, f32 loses ~0.01 mm in the hit point on a small lens (the
/// discriminant cancels two terms of ~(distance/radius)²). Camera rays start at the film and
/// never need this.
fn advance_to_front(surfaces: &SurfaceArrays<f32>, rays: &mut RayBatch) {
    let Some(&first_z) = surfaces.vertex_z.first() else {
        return;
    };
    // In front of every point of the front surface: its sag is at most its semi-aperture.
    let plane = first_z - surfaces.semi_aperture_sq[0].sqrt().min(1e4) - 1.0;
    for i in 0..rays.len() {
        let (oz, dz) = (rays.oz[i], rays.dz[i]);
        if rays.alive[i] && oz < plane && dz > 0.0 {
            let t = (plane - oz) / dz;
            rays.ox[i] += t * rays.dx[i];
            rays.oy[i] += t * rays.dy[i];
            rays.oz[i] = plane;
        }
    }
}

#[inline(always)]
fn run_kernel(kernel: Kernel, plan: &Plan, rays: &mut RayBatch) {
    match kernel {
        Kernel::Simd => trace_simd(plan, rays),
        Kernel::AutoVectorised => trace_plain(plan, rays),
    }
}

/// The kernels compiled again for AVX2: the plain loop vectorises 8 lanes wide. (`wide`'s
/// types keep the layout chosen when the crate was compiled: 2 × 128-bit unless the whole
/// build targets AVX.)
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn run_kernel_avx2(kernel: Kernel, plan: &Plan, rays: &mut RayBatch) {
    run_kernel(kernel, plan, rays)
}

/// The kernels compiled again for AVX-512: the plain loop vectorises 16 lanes wide.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq")]
fn run_kernel_avx512(kernel: Kernel, plan: &Plan, rays: &mut RayBatch) {
    run_kernel(kernel, plan, rays)
}

/// The auto-vectorised kernel: in place on the batch's arrays, block by block.
#[inline(always)]
fn trace_plain(plan: &Plan, rays: &mut RayBatch) {
    let len = rays.len();
    let mut etas = vec![
        0.0f32;
        if plan.spectral.is_some() {
            plan.surfaces.len() * BLOCK
        } else {
            0
        }
    ];
    let mut start = 0;
    while start < len {
        let end = (start + BLOCK).min(len);
        let n = end - start;
        let spectral = plan.block_etas(start, n, &mut etas);
        let ox = &mut rays.ox[start..end];
        let oy = &mut rays.oy[start..end];
        let oz = &mut rays.oz[start..end];
        let dx = &mut rays.dx[start..end];
        let dy = &mut rays.dy[start..end];
        let dz = &mut rays.dz[start..end];
        let alive = &mut rays.alive[start..end];
        for (step, surface) in plan.surfaces.iter().enumerate() {
            let lanes = Lanes {
                ox: &mut *ox,
                oy: &mut *oy,
                oz: &mut *oz,
                dx: &mut *dx,
                dy: &mut *dy,
                dz: &mut *dz,
                alive: &mut *alive,
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
            if !any_alive {
                break;
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

/// One block's rays, structure of arrays.
struct Lanes<'a> {
    ox: &'a mut [f32],
    oy: &'a mut [f32],
    oz: &'a mut [f32],
    dx: &'a mut [f32],
    dy: &'a mut [f32],
    dz: &'a mut [f32],
    alive: &'a mut [bool],
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
    let n = lanes.alive.len();
    let (ox, oy, oz) = (&mut lanes.ox[..n], &mut lanes.oy[..n], &mut lanes.oz[..n]);
    let (dx, dy, dz) = (&mut lanes.dx[..n], &mut lanes.dy[..n], &mut lanes.dz[..n]);
    let alive = &mut lanes.alive[..n];
    let etas = if SPECTRAL { &etas[..n] } else { etas };
    let mut any_alive = false;
    for i in 0..n {
        let mut ray = LaneRay {
            origin: [ox[i], oy[i], oz[i]],
            direction: [dx[i], dy[i], dz[i]],
        };
        let eta = if SPECTRAL { etas[i] } else { surface.eta };
        let survives = refract_at::<f32, SHAPE>(surface, &mut ray, alive[i], eta);
        [ox[i], oy[i], oz[i]] = ray.origin;
        [dx[i], dy[i], dz[i]] = ray.direction;
        alive[i] = survives;
        any_alive |= survives;
    }
    any_alive
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
    let n = lanes.alive.len();
    let (ox, oy, oz) = (&mut lanes.ox[..n], &mut lanes.oy[..n], &mut lanes.oz[..n]);
    let (dx, dy, dz) = (&mut lanes.dx[..n], &mut lanes.dy[..n], &mut lanes.dz[..n]);
    let alive = &mut lanes.alive[..n];
    let ray_at = |i: usize| LaneRay {
        origin: [ox[i], oy[i], oz[i]],
        direction: [dx[i], dy[i], dz[i]],
    };
    // The iteration state as arrays (structure of arrays, so the step loop vectorises).
    let mut t = [0.0f32; BLOCK];
    let mut searching = [false; BLOCK];
    let mut converged = [false; BLOCK];
    let (t, searching, converged) = (&mut t[..n], &mut searching[..n], &mut converged[..n]);
    for i in 0..n {
        let start = Newton::start(surface, &ray_at(i), alive[i]);
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
            state.step(surface, &ray_at(i));
            (t[i], searching[i], converged[i]) = (state.t, state.searching, state.converged);
            any_searching |= state.searching;
        }
        if !any_searching {
            break;
        }
    }
    let mut any_alive = false;
    for i in 0..n {
        let mut ray = LaneRay {
            origin: [ox[i], oy[i], oz[i]],
            direction: [dx[i], dy[i], dz[i]],
        };
        let eta = if SPECTRAL { etas[i] } else { surface.eta };
        let (t, hit) = Newton {
            t: t[i],
            searching: searching[i],
            converged: converged[i],
        }
        .hit();
        let survives =
            refract_from_hit::<f32, POLYNOMIAL>(surface, &mut ray, alive[i], eta, t, hit);
        [ox[i], oy[i], oz[i]] = ray.origin;
        [dx[i], dy[i], dz[i]] = ray.direction;
        alive[i] = survives;
        any_alive |= survives;
    }
    any_alive
}

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
fn trace_simd(full_plan: &Plan, rays: &mut RayBatch) {
    let plan: Vec<SurfaceConstants<f32x8>> = full_plan.surfaces.iter().map(|s| s.splat()).collect();
    let mut etas = vec![
        0.0f32;
        if full_plan.spectral.is_some() {
            plan.len() * BLOCK
        } else {
            0
        }
    ];
    let mut block = SimdBlock {
        rays: [LaneRay {
            origin: [f32x8::ZERO; 3],
            direction: [f32x8::ZERO; 3],
        }; CHUNKS],
        alive: [f32x8::ZERO; CHUNKS],
    };
    let len = rays.len();
    let mut start = 0;
    while start < len {
        let end = (start + BLOCK).min(len);
        let chunks = (end - start).div_ceil(LANES);
        let spectral = full_plan.block_etas(start, end - start, &mut etas);
        load_block(rays, start, end, &mut block);
        let mut transmission = None;
        for (step, surface) in plan.iter().enumerate() {
            let eta = spectral.then(|| &etas[step * BLOCK..(step + 1) * BLOCK]);
            let any_alive = match surface.shape {
                SPHERE => simd_surface::<SPHERE>(surface, &mut block, chunks, eta),
                CONIC => simd_surface::<CONIC>(surface, &mut block, chunks, eta),
                _ => simd_surface::<POLYNOMIAL>(surface, &mut block, chunks, eta),
            };
            if let Some((clip_step, clip)) = full_plan.clip
                && clip_step == step
            {
                transmission = simd_clip(clip, &mut block, chunks);
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
        start = end;
    }
}

/// One surface over the first `chunks` chunks of a block (each lane's index ratio from `etas`
/// when given: [`BLOCK`] lanes); returns whether any lane is alive.
#[inline(always)]
fn simd_surface<const SHAPE: u8>(
    surface: &SurfaceConstants<f32x8>,
    block: &mut SimdBlock,
    chunks: usize,
    etas: Option<&[f32]>,
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
        *alive = refract_at::<f32x8, SHAPE>(surface, ray, *alive, eta);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::LensSystem;
    use crate::lens::trace::{Ray, trace};
    use crate::sampling::Rng;

    fn bundled(name: &str) -> LensSystem {
        let p = crate::lens::io::bundled::load_lens(name, None).unwrap();
        LensSystem::new(&p.rows, None)
    }

    /// Every bundled lens, and Zemax designs from the test data (with a conic and aspheric
    /// surface among them).
    fn test_lenses() -> Vec<(String, LensSystem)> {
        let zemax = [
            "US08427765-1-S-TIM28.zmx",
            "lens1.zmx",
            "US00583336-2-scaled.zmx",
        ];
        let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/zmx");
        crate::lens::io::bundled::BUNDLED
            .iter()
            .map(|b| (b.name.to_string(), bundled(b.name)))
            .chain(zemax.iter().map(|file| {
                let p = crate::lens::Prescription::load(&data.join(file), None).unwrap();
                (file.to_string(), LensSystem::new(&p.rows, None))
            }))
            .collect()
    }

    /// Random rays from the film plane toward the rear element: the render path's rays.
    /// Random rays from the film plane toward the rear element: the render path's rays. Every
    /// other one is aimed within the exit-pupil bounds, as the renderer aims (so lenses with a
    /// small pupil still pass many), the rest anywhere over the rear element (so many are
    /// blocked, at every surface).
    fn film_rays(system: &LensSystem, film_distance: f64, count: usize) -> Vec<Ray<f64>> {
        let mut rng = Rng::new(42, 7);
        let rear = system.rear_semi_aperture() * 1.1;
        // A film about the lens's size (±15 mm for a camera lens, less for a phone's).
        let film = 30.0f64.min(4.0 * system.rear_semi_aperture());
        let film_z = system.rear_z() + film_distance;
        let pupil = crate::lens::pupil::ExitPupil::compute(
            system,
            film_distance,
            film * std::f64::consts::SQRT_2,
            crate::lens::pupil::PupilSampling::Bounds,
        );
        (0..count)
            .map(|i| {
                let film = [
                    (rng.next_f64() - 0.5) * film,
                    (rng.next_f64() - 0.5) * film,
                    film_z,
                ];
                let u = [rng.next_f64(), rng.next_f64()];
                let in_bounds = pupil.sample(film[0] as f32, film[1] as f32, u.map(|v| v as f32));
                let target = match in_bounds {
                    Some(sample) if i % 2 == 0 => sample.point.map(f64::from),
                    _ => [
                        (u[0] - 0.5) * 2.0 * rear,
                        (u[1] - 0.5) * 2.0 * rear,
                        system.rear_z(),
                    ],
                };
                let d = crate::lens::trace::normalize([
                    target[0] - film[0],
                    target[1] - film[1],
                    target[2] - film[2],
                ]);
                Ray {
                    origin: film,
                    direction: d,
                }
            })
            .collect()
    }

    fn assert_bit_identical(a: &RayBatch, b: &RayBatch, name: &str) {
        assert_eq!(a.alive, b.alive, "{name}: kernels disagree");
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for (x, y) in [
            (&a.ox, &b.ox),
            (&a.oy, &b.oy),
            (&a.oz, &b.oz),
            (&a.dx, &b.dx),
            (&a.dy, &b.dy),
            (&a.dz, &b.dz),
        ] {
            assert_eq!(bits(x), bits(y), "{name}: kernels disagree");
        }
    }

    /// Both kernels on every instruction set this CPU has give exactly `expected`.
    fn assert_every_kernel_agrees(
        system: &LensSystem,
        input: &RayBatch,
        expected: &RayBatch,
        travel: Travel,
        name: &str,
    ) {
        for isa in Isa::available() {
            for kernel in [Kernel::AutoVectorised, Kernel::Simd] {
                let mut rays = input.clone();
                trace_batch_on(&system.f32s, &mut rays, travel, kernel, isa);
                assert_bit_identical(expected, &rays, &format!("{name} {kernel:?} {isa:?}"));
            }
        }
    }

    #[test]
    fn batch_agrees_with_scalar_reference_on_every_bundled_lens() {
        for (name, system) in test_lenses() {
            let name = name.as_str();
            // Not a multiple of the lane count or the block: exercises the padded last chunk.
            // The film near focus, where the render's rays come from.
            let film_distance = crate::lens::first_order::FirstOrder::compute(&system)
                .map_or(system.rear_z() * 0.6, |fo| fo.back_focal_length);
            let rays = film_rays(&system, film_distance, 4003);
            let mut batch = RayBatch::with_capacity(rays.len());
            for r in &rays {
                let f = |a: [f64; 3]| [a[0] as f32, a[1] as f32, a[2] as f32];
                batch.push(f(r.origin), f(r.direction), 0, 0);
            }
            let input = batch.clone();
            trace_batch(&system.f32s, &mut batch, Travel::FilmToScene);
            assert_every_kernel_agrees(&system, &input, &batch, Travel::FilmToScene, name);
            let mut passed = 0;
            let mut disagreements = 0;
            for (i, r) in rays.iter().enumerate() {
                match trace(&system.f64s, *r, Travel::FilmToScene) {
                    Ok(out) => {
                        if !batch.alive[i] {
                            disagreements += 1;
                            continue;
                        }
                        passed += 1;
                        let p = batch.origin(i);
                        let d = batch.direction(i);
                        for k in 0..3 {
                            assert!(
                                (p[k] as f64 - out.origin[k]).abs() < 2e-3,
                                "{name}: point {k}: {} vs {}",
                                p[k],
                                out.origin[k]
                            );
                            assert!(
                                (d[k] as f64 - out.direction[k]).abs() < 2e-4,
                                "{name}: direction {k}"
                            );
                        }
                    }
                    Err(_) => disagreements += usize::from(batch.alive[i]),
                }
            }
            // f32 vs f64 may only differ for rays grazing an aperture edge.
            assert!(
                disagreements <= rays.len() / 500,
                "{name}: {disagreements} disagreements"
            );
            assert!(passed > 100, "{name}: only {passed} rays passed");
        }
    }

    /// Scene→film rays aimed from 1 m in front at points of the front element, parallel-ish
    /// bundles and strongly oblique ones alike; both kernels give the same rays and agree with
    /// the reference, and blocked rays keep finite state.
    #[test]
    fn scene_to_film_agrees_and_blocked_rays_stay_finite() {
        for (name, system) in test_lenses() {
            let name = name.as_str();
            let mut rng = Rng::new(3, 9);
            let front = system.front_semi_aperture() * 1.2;
            let rays: Vec<Ray<f64>> = (0..1001)
                .map(|_| {
                    let origin = [
                        (rng.next_f64() - 0.5) * 400.0,
                        (rng.next_f64() - 0.5) * 400.0,
                        -1000.0,
                    ];
                    let target = [
                        (rng.next_f64() - 0.5) * 2.0 * front,
                        (rng.next_f64() - 0.5) * 2.0 * front,
                        0.0,
                    ];
                    let d = crate::lens::trace::normalize([
                        target[0] - origin[0],
                        target[1] - origin[1],
                        target[2] - origin[2],
                    ]);
                    Ray {
                        origin,
                        direction: d,
                    }
                })
                .collect();
            let mut batch = RayBatch::with_capacity(rays.len());
            for r in &rays {
                let f = |a: [f64; 3]| a.map(|x| x as f32);
                batch.push(f(r.origin), f(r.direction), 0, 0);
            }
            let input = batch.clone();
            trace_batch(&system.f32s, &mut batch, Travel::SceneToFilm);
            assert_every_kernel_agrees(&system, &input, &batch, Travel::SceneToFilm, name);
            let mut disagreements = 0;
            for (i, r) in rays.iter().enumerate() {
                assert!(
                    batch
                        .origin(i)
                        .iter()
                        .chain(&batch.direction(i))
                        .all(|v| v.is_finite()),
                    "{name}: ray {i} has non-finite state"
                );
                let reference = trace(&system.f64s, *r, Travel::SceneToFilm);
                disagreements += usize::from(reference.is_ok() != batch.alive[i]);
                if let (Ok(out), true) = (reference, batch.alive[i]) {
                    let d = batch.direction(i);
                    for k in 0..3 {
                        assert!(
                            (d[k] as f64 - out.direction[k]).abs() < 2e-4,
                            "{name}: {i} {k} {:?} {:?} {:?}",
                            d,
                            out.direction,
                            batch.origin(i)
                        );
                    }
                }
            }
            assert!(disagreements <= 2, "{name}: {disagreements} disagreements");
        }
    }

    /// A diaphragm (curved blades, turned, and a graded mask) clips the same rays in every
    /// kernel, bit for bit, throughput included, and as the f64 reference does: the reference
    /// blocks the same rays (but for those grazing an edge) and passes the same light.
    #[test]
    fn diaphragm_clips_alike_in_every_kernel_and_the_reference() {
        use crate::lens::diaphragm::{ApertureMask, Blades, Diaphragm};
        use crate::lens::trace::trace_transmitted;
        // A 16×16 mask: a radial ramp with an opaque notch, so rays see every grey level.
        let values: Vec<f32> = (0..256)
            .map(|i| {
                let (x, y) = ((i % 16) as f32 - 7.5, (i / 16) as f32 - 7.5);
                if x > 2.0 && y.abs() < 1.5 {
                    0.0
                } else {
                    (1.0 - (x * x + y * y).sqrt() / 12.0).clamp(0.0, 1.0)
                }
            })
            .collect();
        let mask = ApertureMask::from_values(std::path::Path::new("ramp"), 16, 16, values).unwrap();
        let diaphragms = [
            Diaphragm {
                blades: Some(Blades::new(5, 0.0, 0.0).unwrap()),
                mask: None,
            },
            Diaphragm {
                blades: Some(Blades::new(7, 11.0, 0.4).unwrap()),
                mask: Some(std::sync::Arc::new(mask)),
            },
        ];
        for (name, plain) in test_lenses().into_iter().take(4) {
            for diaphragm in &diaphragms {
                let system = plain.clone().with_diaphragm(Some(diaphragm));
                let film_distance = crate::lens::first_order::FirstOrder::compute(&system)
                    .map_or(system.rear_z() * 0.6, |fo| fo.back_focal_length);
                let rays = film_rays(&system, film_distance, 4003);
                let mut batch = RayBatch::with_capacity(rays.len());
                for r in &rays {
                    batch.push(
                        r.origin.map(|v| v as f32),
                        r.direction.map(|v| v as f32),
                        0,
                        0,
                    );
                }
                let input = batch.clone();
                let name = format!("{name} {}", diaphragm.describe());
                for isa in Isa::available() {
                    for kernel in [Kernel::AutoVectorised, Kernel::Simd] {
                        let mut other = input.clone();
                        trace_batch_on(&system.f32s, &mut other, Travel::FilmToScene, kernel, isa);
                        if kernel == Kernel::AutoVectorised && isa == Isa::Baseline {
                            batch = other.clone();
                        }
                        assert_bit_identical(&batch, &other, &format!("{name} {kernel:?} {isa:?}"));
                        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                        assert_eq!(bits(&batch.tr), bits(&other.tr), "{name}: throughput");
                    }
                }
                let (mut passed, mut clipped, mut disagreements) = (0, 0, 0);
                for (i, r) in rays.iter().enumerate() {
                    let unclipped = trace(&plain.f64s, *r, Travel::FilmToScene).is_ok();
                    match trace_transmitted(&system.f64s, *r, Travel::FilmToScene, true, |_, _| {})
                    {
                        Ok((_, t)) if batch.alive[i] => {
                            passed += 1;
                            assert!(
                                (batch.tr[i] as f64 - t).abs() < 0.02,
                                "{name}: ray {i} passes {} vs reference {t}",
                                batch.tr[i]
                            );
                        }
                        Err(_) if !batch.alive[i] => clipped += usize::from(unclipped),
                        _ => disagreements += 1,
                    }
                }
                assert!(disagreements <= rays.len() / 200, "{name}: {disagreements}");
                assert!(
                    passed > 100 && clipped > 20,
                    "{name}: {passed} passed, {clipped} clipped"
                );
            }
        }
    }

    /// Rays of many wavelengths in one batch, each refracted with its own indices, agree with
    /// the f64 reference traced at that wavelength; every kernel gives the same bits.
    #[test]
    fn spectral_batch_agrees_with_the_reference_at_each_wavelength() {
        let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/zmx");
        for file in ["lens1.zmx", "US08427765-1-S-TIM28.zmx"] {
            let p = crate::lens::Prescription::load(&data.join(file), None).unwrap();
            let system = LensSystem::new(&p.rows, None);
            let table = system.dispersion.as_deref().expect("catalogue glasses");
            let rays = film_rays(&system, system.rear_z() * 0.6, 8003);
            let lambdas = [
                380.0f32, 430.0, 486.1327, 550.0, 587.5618, 656.2725, 720.0, 780.0,
            ];
            let nm: Vec<f32> = (0..rays.len())
                .map(|i| lambdas[i % lambdas.len()])
                .collect();
            let mut batch = RayBatch::with_capacity(rays.len());
            for r in &rays {
                batch.push(
                    r.origin.map(|v| v as f32),
                    r.direction.map(|v| v as f32),
                    0,
                    0,
                );
            }
            let input = batch.clone();
            let wavelengths = Wavelengths { table, nm: &nm };
            trace_batch_spectral(&system.f32s, wavelengths, &mut batch, Travel::FilmToScene);
            for isa in Isa::available() {
                for kernel in [Kernel::AutoVectorised, Kernel::Simd] {
                    let mut other = input.clone();
                    trace_batch_spectral_on(
                        &system.f32s,
                        wavelengths,
                        &mut other,
                        Travel::FilmToScene,
                        kernel,
                        isa,
                    );
                    assert_bit_identical(&batch, &other, &format!("{file} {kernel:?} {isa:?}"));
                }
            }
            let references: Vec<LensSystem> = lambdas
                .iter()
                .map(|&l| system.at_wavelength(l as f64))
                .collect();
            let (mut passed, mut disagreements) = (0, 0);
            for (i, r) in rays.iter().enumerate() {
                let reference = &references[i % lambdas.len()];
                match (
                    trace(&reference.f64s, *r, Travel::FilmToScene),
                    batch.alive[i],
                ) {
                    (Ok(out), true) => {
                        passed += 1;
                        let d = batch.direction(i);
                        for k in 0..3 {
                            assert!(
                                (d[k] as f64 - out.direction[k]).abs() < 2e-4,
                                "{file} at {} nm: {d:?} vs {:?}",
                                nm[i],
                                out.direction
                            );
                        }
                    }
                    (Ok(_), false) | (Err(_), true) => disagreements += 1,
                    (Err(_), false) => {}
                }
            }
            assert!(disagreements <= rays.len() / 500, "{file}: {disagreements}");
            assert!(passed > 100, "{file}: only {passed} rays passed");
        }
    }
}
