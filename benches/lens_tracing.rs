//! Lens ray tracing, one thread: the scalar per-ray path (the reference tracer in f32, array of
//! structs) against SoA batches of 64 … 4096 rays with both kernels (auto-vectorised and
//! explicit 8-lane `wide`), for every bundled lens; and the exit-pupil bounds of every lens.
//! The rays are film → scene camera rays as the renderer makes them (see
//! `realcam::cli::bench::LensWorkload`, which `realcam bench` measures too).

use divan::{Bencher, black_box};
use realcam::batch::RayBatch;
use realcam::cli::bench::LensWorkload;
use realcam::lens::bundled::BUNDLED;
use realcam::lens::pupil::{ExitPupil, PupilSampling};
use realcam::lens::trace_batch::Kernel;

const RAYS: usize = 4096;

fn main() {
    divan::main();
}

fn lenses() -> impl Iterator<Item = &'static str> {
    BUNDLED.iter().map(|(name, _)| *name)
}

fn workload(lens: &str) -> LensWorkload {
    LensWorkload::new(lens, RAYS).expect("bundled lens sets up")
}

/// One ray at a time through the generic reference tracer, in f32.
#[divan::bench(args = lenses())]
fn scalar_per_ray(bencher: Bencher, lens: &str) {
    let w = workload(lens);
    let mut out = Vec::with_capacity(RAYS);
    bencher
        .counter(divan::counter::ItemsCount::new(RAYS))
        .bench_local(|| black_box(&w).trace_scalar(&mut out));
}

/// The same rays as SoA batches of `BATCH`, explicit 8-lane SIMD kernel.
#[divan::bench(args = lenses(), consts = [64, 256, 1024, 4096])]
fn soa_simd<const BATCH: usize>(bencher: Bencher, lens: &str) {
    soa(bencher, lens, BATCH, Kernel::Simd);
}

/// The same rays as SoA batches of `BATCH`, plain loop left to the auto-vectoriser (the
/// renderer's default kernel).
#[divan::bench(args = lenses(), consts = [64, 256, 1024, 4096])]
fn soa_autovec<const BATCH: usize>(bencher: Bencher, lens: &str) {
    soa(bencher, lens, BATCH, Kernel::AutoVectorised);
}

fn soa(bencher: Bencher, lens: &str, batch: usize, kernel: Kernel) {
    let w = workload(lens);
    let mut work = RayBatch::with_capacity(batch);
    bencher
        .counter(divan::counter::ItemsCount::new(RAYS))
        .bench_local(|| black_box(&w).trace_soa(batch, Some(kernel), &mut work));
}

/// Exit-pupil bounds of a lens (64 film segments, in parallel on all cores).
#[divan::bench(args = lenses(), sample_count = 10)]
fn exit_pupil_bounds(bencher: Bencher, lens: &str) {
    let w = workload(lens);
    bencher.bench_local(|| {
        ExitPupil::compute(
            &w.system,
            w.film_distance,
            LensWorkload::FILM_DIAGONAL_MM,
            PupilSampling::Bounds,
        )
    });
}
