//! The pass stages: GenerateRays → Trace → Shade → LandCompanions → Weight → WriteFilm, one
//! module each, run while a pass is pending. Each works tile by tile in parallel through
//! [`run_on_tiles`]; rays travel between them in each tile's [`TileBatch`](super::TileBatch).

mod companions;
mod film;
mod rays;
mod shade;
mod trace;
mod weight;

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

use bevy_ecs::schedule::common_conditions::not;
use bevy_ecs::schedule::{IntoScheduleConfigs, Schedule, SystemCondition};
use bevy_ecs::system::Res;
use rayon::prelude::*;

use super::Stage;
use super::gpu::on_gpu;
use super::resources::{PassCancel, PassState, RenderStats};
use crate::accel::BatchParallelism;

pub use companions::land_companions;
pub use film::write_film;
pub use rays::generate_rays;
pub(crate) use rays::{ActiveLensQuery, LensChanged, lens_camera};
pub use shade::shade;
pub use trace::trace_rays;
pub use weight::weight;

/// Adds the six pass systems to `schedule`, each in its stage and only while a pass is
/// pending and the passes render on the CPU (see `pipeline::gpu` for the GPU's).
pub(super) fn add_systems(schedule: &mut Schedule) {
    let on_cpu = || pass_pending.and_then(not(on_gpu));
    schedule.add_systems((
        generate_rays.in_set(Stage::GenerateRays).run_if(on_cpu()),
        trace_rays.in_set(Stage::Trace).run_if(on_cpu()),
        shade.in_set(Stage::Shade).run_if(on_cpu()),
        land_companions
            .in_set(Stage::LandCompanions)
            .run_if(on_cpu()),
        weight.in_set(Stage::Weight).run_if(on_cpu()),
        write_film.in_set(Stage::WriteFilm).run_if(on_cpu()),
    ));
}

/// A pass is requested and not abandoned: a cancelled pass never reaches Weight or WriteFilm.
pub(super) fn pass_pending(pass: Res<PassState>, cancel: Option<Res<PassCancel>>) -> bool {
    pass.pending && !PassCancel::raised(cancel.as_deref())
}

/// With at least this many tiles per worker thread, the tiles alone keep every thread busy
/// to the end of a stage, and each tile's rays stay on one thread (Trace, Shade): splitting
/// them again made the 640² peer frames 2–5 % slower on 16 cores (BENCHMARKS.md, "The GPU
/// machine, 2026-11-27").
const TILES_PER_THREAD: usize = 4;

/// How Trace and Shade share a tile's rays among the threads, for a pass of `tiles` tiles:
/// spread over them only when the tiles are too few to keep every thread busy (a small frame).
pub(super) fn tile_parallelism(tiles: usize) -> BatchParallelism {
    if tiles >= TILES_PER_THREAD * rayon::current_num_threads() {
        BatchParallelism::OneThread
    } else {
        BatchParallelism::Spread
    }
}

/// What every pass system does around its per-tile work: runs `work` on each of `tiles` in
/// parallel (rayon) and adds the wall time to `stage`'s in `stats`, and the time inside `work` summed
/// over the tiles to its busy time. Once `cancel` is raised
/// the tiles not yet started are skipped; Weight and WriteFilm pass no flag, since their run
/// condition already kept the pass for the film, which takes all of a pass or none of it.
/// Returns the results of the tiles that ran, in tile order.
pub(super) fn run_on_tiles<T: Send, R: Send>(
    stage: Stage,
    tiles: impl IntoIterator<Item = T>,
    cancel: Option<&PassCancel>,
    stats: &mut RenderStats,
    work: impl Fn(T) -> R + Sync + Send,
) -> impl Iterator<Item = R> {
    let start = Instant::now();
    let tiles: Vec<T> = tiles.into_iter().collect();
    let busy_nanos = AtomicU64::new(0);
    // Written in place, one slot per tile: no list of per-task vectors to allocate and join.
    let mut results = Vec::with_capacity(tiles.len());
    tiles
        .into_par_iter()
        .map(|tile| {
            (!PassCancel::raised(cancel)).then(|| {
                let tile_start = Instant::now();
                let result = work(tile);
                let nanos = tile_start.elapsed().as_nanos() as u64;
                busy_nanos.fetch_add(nanos, Ordering::Relaxed);
                result
            })
        })
        .collect_into_vec(&mut results);
    stats.add_time(stage, start);
    stats.add_busy(stage, Duration::from_nanos(busy_nanos.into_inner()));
    results.into_iter().flatten()
}
