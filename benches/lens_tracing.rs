//! Lens ray tracing: the scalar per-ray path (array of structs) against SoA batches, and the
//! exit-pupil bounds, for every bundled lens. Rays run film → scene, as when rendering.

use divan::{Bencher, black_box};
use realcam::batch::RayBatch;
use realcam::lens::LensSystem;
use realcam::lens::bundled::load_lens;
use realcam::lens::first_order::FirstOrder;
use realcam::lens::focus::paraxial_film_distance;
use realcam::lens::pupil::{ExitPupil, PupilSampling};
use realcam::lens::trace::{Ray, Travel, trace};
use realcam::lens::trace_batch::{Kernel, trace_batch_with};
use realcam::sampling::Rng;

const LENSES: &[&str] = &[
    "dgauss.50mm",
    "wide.22mm",
    "telephoto.250mm",
    "fisheye.10mm",
];
const RAYS: usize = 4096;

fn main() {
    divan::main();
}

struct Setup {
    system: LensSystem,
    film_distance: f64,
    rays: Vec<Ray<f32>>,
}

fn setup(name: &str) -> Setup {
    let p = load_lens(name, None).unwrap();
    let system = LensSystem::new(&p.rows, None);
    let fo = FirstOrder::compute(&system).unwrap();
    let film_distance = paraxial_film_distance(&system, &fo, 5000.0).unwrap();
    let pupil = ExitPupil::compute(&system, film_distance, 35.0, PupilSampling::Bounds);
    let film_z = (system.rear_z() + film_distance) as f32;
    let mut rng = Rng::new(1, 2);
    let mut rays = Vec::with_capacity(RAYS);
    while rays.len() < RAYS {
        let (x, y) = ((rng.next_f32() - 0.5) * 24.0, (rng.next_f32() - 0.5) * 24.0);
        if let Some(s) = pupil.sample(x, y, rng.next_2d()) {
            let d = [s.point[0] - x, s.point[1] - y, s.point[2] - film_z];
            let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            rays.push(Ray {
                origin: [x, y, film_z],
                direction: [d[0] / n, d[1] / n, d[2] / n],
            });
        }
    }
    Setup {
        system,
        film_distance,
        rays,
    }
}

/// One ray at a time through the generic reference tracer, in f32.
#[divan::bench(args = LENSES)]
fn scalar_per_ray(bencher: Bencher, lens: &str) {
    let s = setup(lens);
    bencher
        .counter(divan::counter::ItemsCount::new(RAYS))
        .bench_local(|| {
            let mut passed = 0;
            for ray in &s.rays {
                passed += usize::from(
                    trace(&s.system.f32s, black_box(*ray), Travel::FilmToScene).is_ok(),
                );
            }
            passed
        });
}

/// The same rays as SoA batches of `BATCH` rays, explicit 8-lane SIMD kernel.
#[divan::bench(args = LENSES, consts = [64, 256, 1024, 4096])]
fn soa_batch_simd<const BATCH: usize>(bencher: Bencher, lens: &str) {
    soa_batch(bencher, lens, BATCH, Kernel::Simd);
}

/// The same rays as SoA batches of `BATCH` rays, plain loop left to the auto-vectoriser.
#[divan::bench(args = LENSES, consts = [64, 1024])]
fn soa_batch_autovec<const BATCH: usize>(bencher: Bencher, lens: &str) {
    soa_batch(bencher, lens, BATCH, Kernel::AutoVectorised);
}

fn soa_batch(bencher: Bencher, lens: &str, batch: usize, kernel: Kernel) {
    let s = setup(lens);
    let mut template = RayBatch::with_capacity(RAYS);
    for r in &s.rays {
        template.push(r.origin, r.direction, 0, 0);
    }
    let mut work = RayBatch::with_capacity(batch);
    bencher
        .counter(divan::counter::ItemsCount::new(RAYS))
        .bench_local(|| {
            let mut passed = 0;
            for start in (0..RAYS).step_by(batch) {
                work.clear();
                for i in start..start + batch {
                    work.push(template.origin(i), template.direction(i), 0, 0);
                }
                trace_batch_with(
                    &s.system.f32s,
                    black_box(&mut work),
                    Travel::FilmToScene,
                    kernel,
                );
                passed += work.alive_count();
            }
            passed
        });
}

/// Exit-pupil bounds of a lens (all segments, in parallel).
#[divan::bench(args = LENSES, sample_count = 10)]
fn exit_pupil_bounds(bencher: Bencher, lens: &str) {
    let s = setup(lens);
    bencher.bench_local(|| {
        ExitPupil::compute(&s.system, s.film_distance, 35.0, PupilSampling::Bounds)
    });
}
