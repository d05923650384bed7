//! What a lens's kind costs a frame: the same frame through an aspheric lens and through its
//! spherical twin (the same surfaces without their conic and polynomial terms), and through a
//! lens with glass data rendered spectrally (each camera ray its own wavelength) and at the
//! lens file's indices (`--dispersion off`). Camera samples per second of the sample passes,
//! the default scene from its camera, 160², 4 spp per timed render, depth 5, 2 threads.
//!
//! `cargo bench --bench lens_variants`; compare the pairs' rates in one run (BENCHMARKS.md).
//! After divan's tables, `frame_pairs` measures the pairs the targets name round by round
//! (`cargo bench --bench lens_variants -- frame_pairs` runs it alone).

mod common;

use common::thread_pool;
use divan::Bencher;
use realcam::lens::aperture::ApertureSetting;
use realcam::lens::elements::{Dispersion, FocusSetting};
use realcam::lens::focus::FocusMode;
use realcam::lens::io::bundled::load_lens;
use realcam::lens::pupil::PupilSampling;
use realcam::lens::{Asphere, Prescription};
use realcam::pipeline::{RenderSettings, Renderer, SceneSource};
use realcam::shade::Environment;

const WIDTH: u32 = 160;
const HEIGHT: u32 = 160;
const SPP: u32 = 4;
const MAX_DEPTH: u32 = 5;

fn main() {
    divan::main();
    // Divan takes name filters as plain arguments; the pairs run unless filtered out.
    let filters: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    if filters.is_empty() || filters.iter().any(|f| "frame_pairs".contains(f.as_str())) {
        frame_pairs();
    }
}

/// The frame pairs whose ratio the targets name: (numerator, denominator).
const PAIRS: [(&str, &str); 3] = [
    ("rf16-aspheric", "rf16-spherical-twin"),
    ("dgauss50-spectral", "dgauss50-fixed-index"),
    ("ef35-spectral", "ef35-fixed-index"),
];
const PAIR_ROUNDS: usize = 25;

/// Each pair's cost ratio, measured round by round: a render of one, then of the other (the
/// order alternating), so a change in the machine's speed (another process, the clock) falls on
/// both halves of a round alike and the ratio of the round stays true. Prints the median ratio
/// and its quartiles over the rounds.
fn frame_pairs() {
    let pool = thread_pool(2);
    println!(
        "\nframe_pairs: {PAIR_ROUNDS} rounds of one {WIDTH}×{HEIGHT}, {SPP}-spp render each, order alternating"
    );
    println!(
        "{:<44} {:>9} {:>9} {:>9}   {:>9} {:>9}",
        "pair (a / b)", "q1", "median", "q3", "a median", "b median"
    );
    for (a, b) in PAIRS {
        let mut renderers = [a, b].map(|name| pool.install(|| renderer(name)));
        let mut time = |which: usize| {
            let renderer = &mut renderers[which];
            let start = std::time::Instant::now();
            pool.install(|| renderer.render(SPP, |_, _| true).expect("renders"));
            start.elapsed().as_secs_f64()
        };
        let mut ratios = Vec::with_capacity(PAIR_ROUNDS);
        let mut times = [Vec::new(), Vec::new()];
        for round in 0..PAIR_ROUNDS {
            let (ta, tb) = if round % 2 == 0 {
                let ta = time(0);
                (ta, time(1))
            } else {
                let tb = time(1);
                (time(0), tb)
            };
            ratios.push(ta / tb);
            times[0].push(ta);
            times[1].push(tb);
        }
        let quantile = |values: &mut Vec<f64>, q: f64| {
            values.sort_by(f64::total_cmp);
            values[((values.len() - 1) as f64 * q).round() as usize]
        };
        println!(
            "{:<44} {:>8.3}× {:>8.3}× {:>8.3}×   {:>6.2} ms {:>6.2} ms",
            format!("{a} / {b}"),
            quantile(&mut ratios, 0.25),
            quantile(&mut ratios, 0.5),
            quantile(&mut ratios, 0.75),
            quantile(&mut times[0], 0.5) * 1e3,
            quantile(&mut times[1], 0.5) * 1e3,
        );
    }
}

/// (bench name, bundled lens, spherical twin?, dispersion)
const VARIANTS: [(&str, &str, bool, Dispersion); 6] = [
    (
        "rf16-aspheric",
        "canon-rf-16mm-f2.8",
        false,
        Dispersion::Off,
    ),
    (
        "rf16-spherical-twin",
        "canon-rf-16mm-f2.8",
        true,
        Dispersion::Off,
    ),
    ("dgauss50-spectral", "dgauss.50mm", false, Dispersion::On),
    (
        "dgauss50-fixed-index",
        "dgauss.50mm",
        false,
        Dispersion::Off,
    ),
    ("ef35-spectral", "canon-ef-35mm-f2", false, Dispersion::On),
    (
        "ef35-fixed-index",
        "canon-ef-35mm-f2",
        false,
        Dispersion::Off,
    ),
];

const NAMES: [&str; 6] = [
    VARIANTS[0].0,
    VARIANTS[1].0,
    VARIANTS[2].0,
    VARIANTS[3].0,
    VARIANTS[4].0,
    VARIANTS[5].0,
];

/// A renderer of the default scene through the variant's lens, derived and warmed up.
fn renderer(name: &str) -> Renderer {
    let &(_, lens, twin, dispersion) = VARIANTS.iter().find(|v| v.0 == name).expect("a variant");
    let mut prescription: Prescription = load_lens(lens, None).expect("bundled lens");
    if twin {
        for row in &mut prescription.rows {
            row.asphere = Asphere::NONE;
        }
    }
    let mut renderer = Renderer::new();
    renderer.set_scene(SceneSource {
        path: realcam::scene::default_scene::DEFAULT_SCENE_PATH.into(),
        embedded: Some(realcam::scene::default_scene::DEFAULT_SCENE_GLB),
    });
    renderer.update().expect("the default scene loads");
    let camera = renderer
        .scene_cameras()
        .into_iter()
        .next()
        .expect("a camera");
    renderer.set_environment(Environment::Uniform(glam::Vec3::ZERO));
    renderer.set_camera(camera.world_from_camera);
    let film = prescription.info.film_diagonal_mm.unwrap_or(43.27);
    renderer.set_film(film, PupilSampling::Bounds);
    renderer.set_settings(RenderSettings {
        width: WIDTH,
        height: HEIGHT,
        seed: 1,
        max_depth: MAX_DEPTH,
        tile_size: 32,
        ..RenderSettings::default()
    });
    let focus = FocusSetting::Distance {
        metres: camera.hints.focus_distance_m.unwrap_or(3.0),
        mode: FocusMode::Paraxial,
    };
    let entity = renderer.add_lens(&prescription, focus, ApertureSetting::Full);
    renderer.world.entity_mut(entity).insert(dispersion);
    renderer.set_active_lens(entity);
    renderer.render(1, |_, _| true).expect("renders");
    renderer
}

#[divan::bench(args = NAMES, sample_count = 7, sample_size = 1)]
fn camera_samples(bencher: Bencher, name: &str) {
    let pool = thread_pool(2);
    let mut renderer = pool.install(|| renderer(name));
    bencher
        .counter(divan::counter::ItemsCount::new(
            (WIDTH * HEIGHT * SPP) as usize,
        ))
        .bench_local(|| pool.install(|| renderer.render(SPP, |_, _| true).expect("renders")));
}

/// (bench name, bundled lens, spherical twin?, spectral?, diaphragm blades)
type KernelVariant = (&'static str, &'static str, bool, bool, Option<u32>);
const KERNELS: [KernelVariant; 7] = [
    (
        "phone80-aspheric",
        "deeplens-phone-80deg",
        false,
        false,
        None,
    ),
    (
        "phone80-spherical-twin",
        "deeplens-phone-80deg",
        true,
        false,
        None,
    ),
    ("rf16-aspheric", "canon-rf-16mm-f2.8", false, false, None),
    (
        "rf16-spherical-twin",
        "canon-rf-16mm-f2.8",
        true,
        false,
        None,
    ),
    ("dgauss50-spectral", "dgauss.50mm", false, true, None),
    ("dgauss50-fixed-index", "dgauss.50mm", false, false, None),
    ("dgauss50-six-blades", "dgauss.50mm", false, false, Some(6)),
];

const KERNEL_NAMES: [&str; 7] = [
    KERNELS[0].0,
    KERNELS[1].0,
    KERNELS[2].0,
    KERNELS[3].0,
    KERNELS[4].0,
    KERNELS[5].0,
    KERNELS[6].0,
];

/// The lens alone: 4096 camera rays (film → scene, as the renderer aims them) through the SoA
/// kernel, one thread. A twin traces the same rays through the same surfaces made spherical;
/// a spectral run gives each ray its own wavelength (380–780 nm); a bladed one clips them at
/// the stop with a six-bladed diaphragm.
#[divan::bench(args = KERNEL_NAMES, sample_count = 40)]
fn lens_kernel(bencher: Bencher, name: &str) {
    use realcam::batch::RayBatch;
    use realcam::lens::LensSystem;
    use realcam::lens::trace::Travel;
    use realcam::lens::trace_batch::{Wavelengths, trace_batch, trace_batch_spectral};
    use realcam::lens::workload::LensWorkload;
    let &(_, lens, twin, spectral, blades) =
        KERNELS.iter().find(|k| k.0 == name).expect("a kernel");
    let workload = LensWorkload::new(lens, 4096).expect("lens sets up");
    let system = if twin {
        let mut rows = workload.system.rows.clone();
        for row in &mut rows {
            row.asphere = Asphere::NONE;
        }
        LensSystem::new(&rows, None)
    } else {
        workload.system.clone()
    };
    let diaphragm = blades.map(|count| realcam::lens::diaphragm::Diaphragm {
        blades: Some(realcam::lens::diaphragm::Blades::new(count, 0.0, 0.0).expect("blades")),
        mask: None,
    });
    let system = system.with_diaphragm(diaphragm.as_ref());
    let nm: Vec<f32> = (0..workload.batch.len())
        .map(|i| 380.0 + 400.0 * ((i as f32 * 0.618_034) % 1.0))
        .collect();
    let mut batch = RayBatch::default();
    bencher
        .counter(divan::counter::ItemsCount::new(workload.batch.len()))
        .bench_local(|| {
            batch.clone_from(&workload.batch);
            match (spectral, system.dispersion.as_deref()) {
                (true, Some(table)) => trace_batch_spectral(
                    &system.f32s,
                    Wavelengths { table, nm: &nm },
                    &mut batch,
                    Travel::FilmToScene,
                ),
                _ => trace_batch(&system.f32s, &mut batch, Travel::FilmToScene),
            }
            divan::black_box(&batch);
        });
}
