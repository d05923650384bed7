//! Whole frames: camera samples per second of the sample passes (scene load, BVH build and
//! lens set-up excluded, done before timing) for the bundled default scene and DamagedHelmet
//! through dgauss.50mm at an 8 mm stop, on 1 and 2 threads (the scaling).

mod common;

use common::{FrameScene, frame_renderer, thread_pool};
use divan::Bencher;

const WIDTH: u32 = 160;
const HEIGHT: u32 = 160;
/// Samples per pixel per timed render.
const SPP: u32 = 4;
/// Path length as in the peer comparison.
const MAX_DEPTH: u32 = 5;

fn main() {
    divan::main();
}

#[divan::bench(args = FrameScene::ALL, consts = [1, 2], sample_count = 5, sample_size = 1)]
fn camera_samples<const THREADS: usize>(bencher: Bencher, scene: FrameScene) {
    let pool = thread_pool(THREADS);
    let Some(mut renderer) = pool.install(|| frame_renderer(scene, WIDTH, HEIGHT, MAX_DEPTH))
    else {
        return;
    };
    bencher
        .counter(divan::counter::ItemsCount::new(
            (WIDTH * HEIGHT * SPP) as usize,
        ))
        .bench_local(|| pool.install(|| renderer.render(SPP, |_, _| true).expect("renders")));
}
