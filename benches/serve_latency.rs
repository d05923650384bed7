//! `realcam serve`'s responsiveness: from a change of settings (a focus pull, a new stop, a lens
//! swap) arriving while a full pass of a 512×512 render is under way, to the first image of the
//! new settings being out. Target (issue 13): under 0.3 s on 2 cores. Also the full pass the
//! coarse first pass stands in for.

use std::sync::Arc;
use std::time::Duration;

use divan::Bencher;
use realcam::cli::render::parse_render_arguments;
use realcam::job::Job;
use realcam::job::outputs::validate;
use realcam::live::LiveLab;
use realcam::live::lenses::LensLibrary;
use realcam::live::session::Session;
use realcam::live::settings::{LiveSettings, SpecParser};
use serde_json::{Value, json};

fn main() {
    // The machine: 2 cores.
    rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build_global()
        .unwrap();
    divan::main();
}

/// A live session on the default scene at 512×512 with a target far off, so it is always
/// in the middle of a full pass when a change comes.
fn lab() -> LiveLab {
    let argv: Vec<String> = ["--width", "512", "--height", "512", "--spp", "100000"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let settings = LiveSettings::from_arguments(&argv);
    let parser: SpecParser = Arc::new(parse_render_arguments);
    let spec = settings.parse(&parser).expect("render arguments");
    let formats = validate(&spec).unwrap();
    let job = Job::prepare(&spec, formats).unwrap();
    let library = LensLibrary::new(Vec::new(), None, Default::default()).unwrap();
    let (flag, cancel) = LiveLab::cancel_flag();
    let session = Session::new(job, settings, parser, library, cancel).unwrap();
    let lab = LiveLab::start(session, flag);
    // Into the steady state: full passes under way.
    let generation = lab.published().generation;
    lab.wait_for_image(generation + 1, Duration::from_secs(60));
    lab
}

/// Applies `changes` and waits for the first image rendered with them.
fn first_image_after(lab: &LiveLab, changes: Value) {
    let state = lab.change(changes).unwrap();
    let generation = state["generation"].as_u64().unwrap();
    let shown = lab.wait_for_image(generation, Duration::from_secs(60));
    assert!(shown > generation, "no image");
}

/// How long the server renders full passes before each timed change, so the change lands in
/// the middle of one (a pass takes some 70 ms here). Not timed: it is the inputs' set-up.
const BETWEEN_CHANGES: Duration = Duration::from_millis(150);

/// Times [`first_image_after`] for each of `changes` in turn, with [`BETWEEN_CHANGES`] of
/// steady rendering before each (outside the timing).
fn bench_changes(bencher: Bencher, changes: &[Value]) {
    let lab = lab();
    let mut next = 0;
    bencher
        .with_inputs(|| {
            std::thread::sleep(BETWEEN_CHANGES);
            next = (next + 1) % changes.len();
            changes[next].clone()
        })
        .bench_local_values(|change| first_image_after(&lab, change));
    lab.stop();
}

#[divan::bench(sample_count = 20, sample_size = 1)]
fn first_image_after_focus_pull(bencher: Bencher) {
    bench_changes(
        bencher,
        &[
            json!({ "focus_distance": 1.5 }),
            json!({ "focus_distance": 6.0 }),
        ],
    );
}

#[divan::bench(sample_count = 20, sample_size = 1)]
fn first_image_after_stop_change(bencher: Bencher) {
    bench_changes(
        bencher,
        &[json!({ "f_number": 2.0 }), json!({ "f_number": 8.0 })],
    );
}

#[divan::bench(sample_count = 20, sample_size = 1)]
fn first_image_after_lens_swap(bencher: Bencher) {
    let lenses = [
        "wide.22mm",
        "telephoto.250mm",
        "dgauss.50mm",
        "fisheye.10mm",
    ];
    let changes: Vec<Value> = lenses.iter().map(|lens| json!({ "lens": lens })).collect();
    bench_changes(bencher, &changes);
}

/// One full-resolution pass (1 spp at 512×512) with no change, image to image: what the
/// coarse first pass saves a client from waiting for.
#[divan::bench(sample_count = 10, sample_size = 1)]
fn full_pass_512(bencher: Bencher) {
    let lab = lab();
    bencher
        .with_inputs(|| {
            // Start the clock as an image comes out.
            let generation = lab.published().generation;
            lab.wait_for_image(generation, Duration::from_secs(60))
        })
        .bench_local_values(|generation| lab.wait_for_image(generation, Duration::from_secs(60)));
    lab.stop();
}
