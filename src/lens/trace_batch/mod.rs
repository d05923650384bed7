//! Exact ray tracing through the lens for a whole batch at once (structure of arrays, f32).
//!
//! The surface step (`refract::refract_at`) is written once, generically over the lane type,
//! and run by two kernels that give bit-identical rays:
//!
//! * [`Kernel::AutoVectorised`] (`plain.rs`): a plain loop over one `f32` ray at a time,
//!   surface by surface over a block of rays, left to the compiler's auto-vectoriser;
//! * [`Kernel::Simd`] (`simd.rs`): explicit 8-lane `wide::f32x8`, the block copied once into
//!   8-lane arrays (alive as lane masks) and every surface run over them.
//!
//! This file holds the API and the plan both kernels run (the surfaces in travel order, the
//! spectral index ratios, the diaphragm's step); `tests.rs` checks both against the per-ray
//! reference.
//!
//! Rays go through in blocks of [`BLOCK`] so a block's state stays in L1 while all surfaces run
//! over it, and a block stops early once none of its rays is alive. On x86-64 both kernels are
//! also compiled for AVX2 and AVX-512 and the widest the CPU has is chosen at run time ([`Isa`]),
//! so a portable build still runs the plain loop 8 or 16 lanes wide; the explicit kernel's
//! `wide` types use AVX only when the whole build targets it (see BENCHMARKS.md).

mod clip;
pub(crate) mod ghost;
mod losses;
pub(crate) mod pairs;
mod plain;
mod refract;
mod simd;
#[cfg(test)]
mod tests;

use self::losses::Losses;
use self::plain::trace_plain;
pub(crate) use self::refract::{CONIC, POLYNOMIAL, SPHERE, SurfaceConstants};
use self::simd::trace_simd;
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

/// Whether a block's rays are all blocked before the first surface (film points no ray leaves,
/// such as a fisheye's frame outside its image circle): the kernels leave a blocked lane as it
/// is, so such a block needs no work at all, not even its index and loss look-ups.
#[inline(always)]
fn skip_dead_block(alive: &[bool]) -> bool {
    !alive.contains(&true)
}

/// Traces every alive ray of `rays` (lens frame, mm, unit directions) through all surfaces in
/// the order of `travel`, in place: survivors end on the last surface crossed with their
/// refracted direction; blocked rays get `alive = false` and keep the state they had when
/// blocked. A diaphragm at the stop ([`SurfaceArrays::stop_clip`]) blocks the rays its blades
/// stop, and multiplies the throughput (`tr`, `tg`, `tb`) of those crossing a mask by its grey
/// level there; a lens with losses ([`SurfaceArrays::reflectance`]) multiplies the survivors'
/// throughput by what every surface transmits (here at the d line: the rays have the lens's
/// own indices, n_d).
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

/// Defines a function twice more, compiled for AVX2 and for AVX-512 (x86-64 only): the same
/// parameters and body under the two names given, so that everything the body inlines
/// (`#[inline(always)]` code) vectorises 8 or 16 lanes wide. The same operations, so the same
/// bits; [`on_isa!`] picks the copy for an [`Isa`].
macro_rules! widened {
    ($(#[$meta:meta])* $vis:vis fn $avx2:ident / $avx512:ident ($($params:tt)*) $(-> $ret:ty)? $body:block) => {
        $(#[$meta])*
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2")]
        $vis fn $avx2($($params)*) $(-> $ret)? $body

        $(#[$meta])*
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq")]
        $vis fn $avx512($($params)*) $(-> $ret)? $body
    };
}

/// Evaluates the expression for `isa`: `baseline`, or a call of the AVX2 or AVX-512 copy that
/// [`widened!`] made (the instructions found on this CPU: `isa` at most [`Isa::detect`]'s).
macro_rules! on_isa {
    ($isa:expr, baseline: $baseline:expr, avx2: $avx2:expr, avx512: $avx512:expr $(,)?) => {
        match $isa {
            $crate::lens::trace_batch::Isa::Baseline => $baseline,
            // SAFETY (both): the caller passes an `Isa` this CPU has (`Isa::detect`).
            #[cfg(target_arch = "x86_64")]
            $crate::lens::trace_batch::Isa::Avx2 => unsafe { $avx2 },
            #[cfg(target_arch = "x86_64")]
            $crate::lens::trace_batch::Isa::Avx512 => unsafe { $avx512 },
            #[cfg(not(target_arch = "x86_64"))]
            _ => unreachable!("Isa::detect finds only the baseline here"),
        }
    };
}

pub(crate) use {on_isa, widened};

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
    let isa = isa.min(Isa::detect());
    KERNEL_SCRATCH.with_borrow_mut(|scratch| {
        let KernelScratch {
            surfaces: in_travel_order,
            etas,
        } = scratch;
        in_travel_order.clear();
        in_travel_order.extend(SurfaceConstants::in_travel_order(surfaces, travel));
        let plan = Plan {
            surfaces: in_travel_order,
            spectral: wavelengths.map(|w| (w, travel)),
            clip: surfaces
                .stop_clip
                .as_deref()
                .map(|clip| (travel.surface_of_step(clip.surface, n), clip)),
            isa,
            losses: surfaces.reflectance.as_deref().map(|table| Losses {
                table,
                travel,
                nm: wavelengths.map(|w| w.nm),
            }),
        };
        on_isa!(isa,
            baseline: run_kernel(kernel, &plan, rays, etas),
            avx2: run_kernel_avx2(kernel, &plan, rays, etas),
            avx512: run_kernel_avx512(kernel, &plan, rays, etas),
        )
    })
}

/// What [`run`] works in, kept per thread from call to call (a pass traces a batch per tile,
/// several times): the surfaces in travel order and a spectral block's index ratios.
#[derive(Default)]
struct KernelScratch {
    surfaces: Vec<SurfaceConstants<f32>>,
    etas: Vec<f32>,
}

thread_local! {
    static KERNEL_SCRATCH: std::cell::RefCell<KernelScratch> =
        std::cell::RefCell::new(KernelScratch::default());
}

/// What the kernels run: the surfaces in the order of travel, for a spectral batch the rays'
/// wavelengths, the diaphragm with the step (in travel order) of the stop it sits at, and the
/// surfaces' losses.
struct Plan<'a> {
    surfaces: &'a [SurfaceConstants<f32>],
    spectral: Option<(Wavelengths<'a>, Travel)>,
    clip: Option<(usize, &'a StopClip)>,
    /// The instruction set the kernel runs with (supported by this CPU): the index and loss
    /// look-ups use its gathers.
    isa: Isa,
    losses: Option<Losses<'a>>,
}

impl Plan<'_> {
    /// Makes `etas` the length [`Plan::block_etas`] fills: a block's index ratios at every
    /// surface for a spectral batch, nothing otherwise.
    fn size_etas(&self, etas: &mut Vec<f32>) {
        let len = if self.spectral.is_some() {
            self.surfaces.len() * BLOCK
        } else {
            0
        };
        etas.resize(len, 0.0);
    }

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
        let mut cell = [0u32; BLOCK];
        let mut fraction = [0.0f32; BLOCK];
        for lane in 0..n {
            let (i, t) = table.position(wavelengths.nm[start + lane]);
            (cell[lane], fraction[lane]) = (i as u32, t);
        }
        let (cell, fraction) = (&cell[..n], &fraction[..n]);
        // Each medium's index is looked up once per ray (the index after one surface is the
        // index before the next), a surface at a time over the block so each lookup is a
        // gather. Scene to film the rays start in air; film to scene, in the medium behind
        // the last surface, and crossing surface s leads into the medium after s − 1 (the air
        // in front of the lens after surface 0).
        let mut carried = [1.0f32; BLOCK];
        let carried = &mut carried[..n];
        if travel == Travel::FilmToScene {
            table
                .curve(count - 1)
                .at_lanes(cell, fraction, carried, self.isa);
        }
        let mut index = [1.0f32; BLOCK];
        let index = &mut index[..n];
        for step in 0..count {
            let after = match travel {
                Travel::SceneToFilm => Some(step),
                Travel::FilmToScene => (count - 1 - step).checked_sub(1),
            };
            match after {
                Some(surface) => table
                    .curve(surface)
                    .at_lanes(cell, fraction, index, self.isa),
                None => index.fill(1.0),
            }
            let eta = &mut etas[step * BLOCK..step * BLOCK + n];
            for lane in 0..n {
                eta[lane] = carried[lane] / index[lane];
                carried[lane] = index[lane];
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
fn run_kernel(kernel: Kernel, plan: &Plan, rays: &mut RayBatch, etas: &mut Vec<f32>) {
    match kernel {
        Kernel::Simd => trace_simd(plan, rays, etas),
        Kernel::AutoVectorised => trace_plain(plan, rays, etas),
    }
}

widened! {
    /// The kernels compiled again for AVX2 and AVX-512: the plain loop vectorises 8 and 16
    /// lanes wide. (`wide`'s types keep the layout chosen when the crate was compiled: 2 ×
    /// 128-bit unless the whole build targets AVX.)
    fn run_kernel_avx2 / run_kernel_avx512(
        kernel: Kernel,
        plan: &Plan,
        rays: &mut RayBatch,
        etas: &mut Vec<f32>,
    ) {
        run_kernel(kernel, plan, rays, etas)
    }
}
