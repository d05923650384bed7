//! Lens ray tracing, one thread: the scalar per-ray path (the reference tracer in f32, array of
//! structs) against SoA batches of 64 … 4096 rays with both kernels (auto-vectorised, on each
//! instruction set, and explicit 8-lane `wide`), for every bundled lens; and the exit-pupil
//! bounds of every lens; and whole camera-ray generation (sample patterns, exit pupil, lens,
//! world frame) for one tile.
//! The rays are film → scene camera rays as the renderer makes them (see
//! `realcam::lens::workload::LensWorkload`, which `realcam bench` measures too).

use divan::{Bencher, black_box};
use glam::Mat4;
use realcam::batch::RayBatch;
use realcam::lens::camera::{CameraRays, FilmGeometry, LensCamera};
use realcam::lens::coating::CoatingModel;
use realcam::lens::io::bundled::BUNDLED;
use realcam::lens::pupil::{ExitPupil, PupilSampling};
use realcam::lens::reflectance::SurfaceReflectance;
use realcam::lens::trace_batch::{Isa, Kernel};
use realcam::lens::workload::LensWorkload;

const RAYS: usize = 4096;

fn main() {
    divan::main();
}

fn lenses() -> impl Iterator<Item = &'static str> {
    BUNDLED.iter().map(|b| b.name)
}

fn workload(lens: &str) -> LensWorkload {
    LensWorkload::new(lens, RAYS).expect("bundled lens sets up")
}

/// One ray at a time through the generic reference tracer, in f32.
#[divan::bench(args = lenses(), sample_count = 40)]
fn scalar_per_ray(bencher: Bencher, lens: &str) {
    let w = workload(lens);
    let mut out = Vec::with_capacity(RAYS);
    bencher
        .counter(divan::counter::ItemsCount::new(RAYS))
        .bench_local(|| black_box(&w).trace_scalar(&mut out));
}

/// The same rays as SoA batches of `BATCH`, explicit `wide::f32x8` kernel.
#[divan::bench(args = lenses(), consts = [64, 256, 1024, 4096], sample_count = 40)]
fn soa_simd<const BATCH: usize>(bencher: Bencher, lens: &str) {
    soa(bencher, lens, BATCH, Kernel::Simd, Isa::detect());
}

/// The same rays as SoA batches of `BATCH`, plain loop auto-vectorised for the widest
/// instruction set of this CPU (the renderer's kernel: AVX-512 here).
#[divan::bench(args = lenses(), consts = [64, 256, 1024, 4096], sample_count = 40)]
fn soa_autovec<const BATCH: usize>(bencher: Bencher, lens: &str) {
    soa(bencher, lens, BATCH, Kernel::AutoVectorised, Isa::detect());
}

/// The plain loop compiled for AVX2 (8 lanes), if this CPU has it.
#[divan::bench(args = lenses(), consts = [64, 1024], sample_count = 40)]
fn soa_autovec_avx2<const BATCH: usize>(bencher: Bencher, lens: &str) {
    soa(bencher, lens, BATCH, Kernel::AutoVectorised, Isa::Avx2);
}

/// The plain loop as the portable build compiles it (x86-64: SSE2, 4 lanes).
#[divan::bench(args = lenses(), consts = [64, 1024], sample_count = 40)]
fn soa_autovec_baseline<const BATCH: usize>(bencher: Bencher, lens: &str) {
    soa(bencher, lens, BATCH, Kernel::AutoVectorised, Isa::Baseline);
}

fn soa(bencher: Bencher, lens: &str, batch: usize, kernel: Kernel, isa: Isa) {
    let w = workload(lens);
    let mut work = RayBatch::with_capacity(batch);
    bencher
        .counter(divan::counter::ItemsCount::new(RAYS))
        .bench_local(|| black_box(&w).trace_soa(batch, kernel, isa, &mut work));
}

/// The plain loop through single-coated surfaces (every survivor's losses looked up at each
/// crossing, at the lens's own indices), 1024-ray batches, on each instruction set: what the
/// reflectance look-ups cost on each instruction set.
#[divan::bench(args = ["dgauss.50mm", "fisheye.10mm"], sample_count = 40)]
fn soa_coated_baseline(bencher: Bencher, lens: &str) {
    soa_coated(bencher, lens, Isa::Baseline);
}

#[divan::bench(args = ["dgauss.50mm", "fisheye.10mm"], sample_count = 40)]
fn soa_coated_avx2(bencher: Bencher, lens: &str) {
    soa_coated(bencher, lens, Isa::Avx2);
}

#[divan::bench(args = ["dgauss.50mm", "fisheye.10mm"], sample_count = 40)]
fn soa_coated_widest(bencher: Bencher, lens: &str) {
    soa_coated(bencher, lens, Isa::detect());
}

fn soa_coated(bencher: Bencher, lens: &str, isa: Isa) {
    let mut w = workload(lens);
    let reflectance =
        SurfaceReflectance::with_model(&w.system.rows, |_| None, CoatingModel::Single);
    w.system = w.system.clone().with_reflectance(reflectance);
    let mut work = RayBatch::with_capacity(1024);
    bencher
        .counter(divan::counter::ItemsCount::new(RAYS))
        .bench_local(|| black_box(&w).trace_soa(1024, Kernel::AutoVectorised, isa, &mut work));
}

/// The plain loop with every ray at its own wavelength (a spectral render's camera rays and
/// companions), 1024-ray batches, on each instruction set: what the per-ray indices cost.
#[divan::bench(args = ["dgauss.50mm", "fisheye.10mm"], sample_count = 40)]
fn soa_spectral_baseline(bencher: Bencher, lens: &str) {
    soa_spectral(bencher, lens, Isa::Baseline);
}

#[divan::bench(args = ["dgauss.50mm", "fisheye.10mm"], sample_count = 40)]
fn soa_spectral_avx2(bencher: Bencher, lens: &str) {
    soa_spectral(bencher, lens, Isa::Avx2);
}

#[divan::bench(args = ["dgauss.50mm", "fisheye.10mm"], sample_count = 40)]
fn soa_spectral_widest(bencher: Bencher, lens: &str) {
    soa_spectral(bencher, lens, Isa::detect());
}

fn soa_spectral(bencher: Bencher, lens: &str, isa: Isa) {
    let w = workload(lens);
    let (mut work, mut nm) = (RayBatch::with_capacity(1024), Vec::new());
    bencher
        .counter(divan::counter::ItemsCount::new(RAYS))
        .bench_local(|| black_box(&w).trace_soa_spectral(1024, isa, &mut work, &mut nm));
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

/// Camera rays for a 32 × 32 tile (the renderer's tile) of a 512 × 512 film, one pass of a
/// 32 spp plan (stratified patterns) and one pass past it (independent numbers), one thread.
#[divan::bench(args = ["dgauss.50mm", "fisheye.10mm"], consts = [0, 32], sample_count = 40)]
fn camera_generate<const PASS: u32>(bencher: Bencher, lens: &str) {
    camera_rays(bencher, lens, PASS, CoatingModel::Ideal, false);
}

/// [`camera_generate`] through single-coated surfaces (their losses on every ray), and with
/// the ghosts traced (one sample in 16): what coatings and flare add to ray generation.
#[divan::bench(args = ["dgauss.50mm", "fisheye.10mm"], consts = [0], sample_count = 40)]
fn camera_generate_coated<const PASS: u32>(bencher: Bencher, lens: &str) {
    camera_rays(bencher, lens, PASS, CoatingModel::Single, false);
}

#[divan::bench(args = ["dgauss.50mm", "fisheye.10mm"], consts = [0], sample_count = 40)]
fn camera_generate_coated_with_ghosts<const PASS: u32>(bencher: Bencher, lens: &str) {
    camera_rays(bencher, lens, PASS, CoatingModel::Single, true);
}

/// A spectral render's camera rays as the default makes them (issue 25's cost): single-coated,
/// with ghosts, each sample with its set of `WAVELENGTHS` (1: the hero alone; 3: the default,
/// the hero traced forward and two companions backward to their film points and combined).
#[divan::bench(args = ["dgauss.50mm", "fisheye.10mm"], consts = [1, 3], sample_count = 40)]
fn camera_generate_spectral<const WAVELENGTHS: u32>(bencher: Bencher, lens: &str) {
    camera_rays_with(
        bencher,
        lens,
        0,
        CoatingModel::Single,
        true,
        Some(WAVELENGTHS),
    );
}

fn camera_rays(bencher: Bencher, lens: &str, pass: u32, coating: CoatingModel, ghosts: bool) {
    camera_rays_with(bencher, lens, pass, coating, ghosts, None);
}

/// Camera rays for one tile ([`tile_rays`]) through `lens` coated with `coating`, with or
/// without its ghosts, and with `wavelengths` per sample (`None`: without dispersion).
fn camera_rays_with(
    bencher: Bencher,
    lens: &str,
    pass: u32,
    coating: CoatingModel,
    ghosts: bool,
    wavelengths: Option<u32>,
) {
    let w = workload(lens);
    let reflectance = SurfaceReflectance::with_model(&w.system.rows, |_| None, coating);
    let system = w.system.clone().with_reflectance(reflectance);
    let pupil = ExitPupil::compute(
        &system,
        w.film_distance,
        LensWorkload::FILM_DIAGONAL_MM,
        PupilSampling::Bounds,
    );
    let camera = LensCamera {
        system: &system,
        pupil: &pupil,
        film: FilmGeometry::new(512, 512, LensWorkload::FILM_DIAGONAL_MM),
        world_from_camera: Mat4::IDENTITY,
        dispersion: system
            .dispersion
            .as_deref()
            .filter(|_| wavelengths.is_some()),
        wavelengths: wavelengths.unwrap_or(1),
        ghosts: system.ghosts.as_deref().filter(|_| ghosts),
    };
    tile_rays(bencher, &camera, pass);
}

/// `camera`'s rays for the 32 × 32 tile at (240, 240) of its film, pass `pass`, seed 7.
fn tile_rays(bencher: Bencher, camera: &LensCamera, pass: u32) {
    let pixels: Vec<(u32, u32)> = (0..32)
        .flat_map(|y| (0..32).map(move |x| (240 + x, 240 + y)))
        .collect();
    let mut out = CameraRays::default();
    bencher
        .counter(divan::counter::ItemsCount::new(pixels.len()))
        .bench_local(|| camera.generate(pixels.iter().copied(), pass, 7, black_box(&mut out)));
}
