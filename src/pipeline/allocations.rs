//! A pass in the steady state allocates next to nothing: every tile keeps its batches from
//! pass to pass (`TileBatch`), and Shade, the lens kernel and the packet traversal keep their
//! working memory per thread. This test counts the allocations the passes make, with a counting
//! allocator installed in the library's test binary that counts only on threads that asked to
//! be counted (so that tests running beside it do not).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::Vec3;

use super::{RenderSettings, Renderer, SceneSource};
use crate::lens::aperture::ApertureSetting;
use crate::lens::elements::FocusSetting;
use crate::lens::focus::FocusMode;
use crate::lens::io::bundled::load_lens;
use crate::lens::pupil::PupilSampling;
use crate::scene::default_scene::{DEFAULT_SCENE_GLB, DEFAULT_SCENE_PATH};
use crate::scene::look_at;
use crate::shade::Environment;

struct CountingAllocator;

static COUNTED: AtomicU64 = AtomicU64::new(0);

thread_local! {
    static COUNTING: Cell<bool> = const { Cell::new(false) };
}

// SAFETY: every call goes to the system allocator unchanged; counting touches only an atomic
// and a const-initialised thread-local without a destructor (neither allocates).
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if COUNTING.with(Cell::get) {
            COUNTED.fetch_add(1, Ordering::Relaxed);
        }
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if COUNTING.with(Cell::get) {
            COUNTED.fetch_add(1, Ordering::Relaxed);
        }
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: CountingAllocator = CountingAllocator;

/// Allocations a pass of the default scene may make once every tile has rendered a few: the
/// stages' lists of tiles and of their results (11 on 2026-11-27, 13 on 2026-11-28, 10 once
/// each stage kept its tiles and their results in one list; at any number of tiles).
/// Before the tiles and threads kept their working memory, a pass made about 27 a tile (1,729
/// at 256², 64 tiles) and reallocated some arrays for many passes.
const STEADY_STATE_PER_PASS: u64 = 16;

#[test]
fn a_pass_in_the_steady_state_allocates_only_its_stage_lists() {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .start_handler(|_| COUNTING.with(|c| c.set(true)))
        .build()
        .unwrap();
    pool.install(|| {
        COUNTING.with(|c| c.set(true));
        let mut renderer = Renderer::new();
        renderer.set_scene(SceneSource {
            path: DEFAULT_SCENE_PATH.into(),
            embedded: Some(DEFAULT_SCENE_GLB),
        });
        renderer.set_environment(Environment::Uniform(Vec3::splat(0.5)));
        renderer.set_camera(look_at(
            Vec3::new(0.0, 1.0, 4.0),
            Vec3::new(0.0, 0.8, 0.0),
            Vec3::Y,
        ));
        renderer.set_film(35.0, PupilSampling::Bounds);
        // 4 × 4 tiles on 2 threads: each tile's rays stay on one thread, as in any frame of
        // useful size.
        renderer.set_settings(RenderSettings {
            width: 128,
            height: 128,
            ..RenderSettings::default()
        });
        let focus = FocusSetting::Distance {
            metres: 4.0,
            mode: FocusMode::Paraxial,
        };
        let lens = renderer.add_lens(
            &load_lens("dgauss.50mm", None).unwrap(),
            focus,
            ApertureSetting::Full,
        );
        renderer.set_active_lens(lens);
        renderer.begin_film(None).unwrap();
        for sample in 0..4 {
            renderer.render_pass(sample).unwrap();
        }
        // Counted pass by pass, and judged by the median pass: a thread's scratch grows the
        // first time that thread meets a tile that needs more (the first tile with ghost
        // samples, about 20 allocations), and which thread meets which tile when is the
        // scheduler's choice, so on a busy machine that can fall in any pass. An allocation
        // made in every pass shows in the median; a one-off growth does not.
        let mut per_pass: Vec<u64> = (4..20)
            .map(|sample| {
                let before = COUNTED.load(Ordering::Relaxed);
                renderer.render_pass(sample).unwrap();
                COUNTED.load(Ordering::Relaxed) - before
            })
            .collect();
        per_pass.sort_unstable();
        let median = per_pass[per_pass.len() / 2];
        assert!(
            median <= STEADY_STATE_PER_PASS,
            "the median pass made {median} allocations, more than {STEADY_STATE_PER_PASS} \
             (each pass's, sorted: {per_pass:?})"
        );
        let image = renderer.image().unwrap();
        assert!(
            image.sums.iter().any(|s| s[0] > 0.0),
            "the passes rendered light"
        );
    });
}
