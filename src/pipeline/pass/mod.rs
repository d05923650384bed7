//! The pass stages: GenerateRays → Trace → Shade → LandCompanions → Weight → WriteFilm, one
//! module each, run while a pass is pending. Each works tile by tile in parallel through
//! [`run_on_tiles`]; rays travel between them in each tile's [`TileBatch`](super::TileBatch).

mod companions;
mod film;
mod rays;
mod shade;
mod trace;
mod weight;

use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Mutex, PoisonError};
use std::time::{Duration, Instant};

use bevy_ecs::schedule::common_conditions::not;
use bevy_ecs::schedule::{IntoScheduleConfigs, Schedule, SystemCondition};
use bevy_ecs::system::Res;
use rayon::prelude::*;

use super::Stage;
use super::gpu::on_gpu;
use super::resources::{PassCancel, PassState, RenderStats};
use crate::accel::BatchParallelism;
use crate::sync::lock;

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
/// parallel and adds the wall time to `stage`'s in `stats`, and the time inside `work` summed
/// over the tiles to its busy time. Once `cancel` is raised the tiles not yet started are
/// skipped; Weight and WriteFilm pass no flag, since their run condition already kept the pass
/// for the film, which takes all of a pass or none of it. Returns the results of the tiles that
/// ran, in tile order.
///
/// Every worker thread takes the next tile nobody has started (a shared counter) until none is
/// left, so a stage ends within one tile's work of its last tile starting. A parallel iterator
/// over the tiles stops splitting them once each thread has a share, and a share a thread has
/// begun to work through is no longer there to steal: the two workers of a 2-core machine sat
/// idle for 4.5 % of the peer helmet's stages at 320² (busy ÷ (wall × threads) 0.951–0.956
/// against 0.972–0.982 now; BENCHMARKS.md, twentieth session). Which worker runs a tile does
/// not change what it computes: each tile's work reads and writes that tile's batch alone.
pub(super) fn run_on_tiles<T: Send, R: Send>(
    stage: Stage,
    tiles: impl IntoIterator<Item = T>,
    cancel: Option<&PassCancel>,
    stats: &mut RenderStats,
    work: impl Fn(T) -> R + Sync + Send,
) -> impl Iterator<Item = R> {
    let start = Instant::now();
    // Each cell is taken out of (or given its result) by the one worker the counter gave its
    // index to; the locks are held only for that. One list for both, allocated once a stage:
    // a pass in the steady state allocates little else (`super::allocations`).
    let cells: Vec<Mutex<TileCell<T, R>>> = tiles
        .into_iter()
        .map(|tile| Mutex::new(TileCell::Waiting(tile)))
        .collect();
    let next = AtomicUsize::new(0);
    let busy_nanos = AtomicU64::new(0);
    let take_tiles = || {
        while let Some(cell) = cells.get(next.fetch_add(1, Ordering::Relaxed)) {
            if PassCancel::raised(cancel) {
                break;
            }
            let TileCell::Waiting(tile) = std::mem::replace(&mut *lock(cell), TileCell::Running)
            else {
                unreachable!("the counter gives each tile to one worker");
            };
            let tile_start = Instant::now();
            let result = work(tile);
            busy_nanos.fetch_add(tile_start.elapsed().as_nanos() as u64, Ordering::Relaxed);
            *lock(cell) = TileCell::Done(result);
        }
    };
    // One task per worker, handed out as rayon hands out any parallel work (no allocation).
    (0..rayon::current_num_threads())
        .into_par_iter()
        .for_each(|_| take_tiles());
    stats.add_time(stage, start);
    stats.add_busy(stage, Duration::from_nanos(busy_nanos.into_inner()));
    cells.into_iter().filter_map(|cell| {
        match cell.into_inner().unwrap_or_else(PoisonError::into_inner) {
            TileCell::Done(result) => Some(result),
            TileCell::Waiting(_) | TileCell::Running => None,
        }
    })
}

/// A tile of [`run_on_tiles`]: not yet started, being worked on, or its result.
enum TileCell<T, R> {
    Waiting(T),
    Running,
    Done(R),
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;
    use std::sync::atomic::AtomicBool;

    use super::*;

    /// Every tile runs once, on whichever worker takes it, and the results come back in tile
    /// order; the busy time is the tiles' own.
    #[test]
    fn every_tile_runs_once_and_the_results_keep_tile_order() {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap();
        let runs: Vec<AtomicUsize> = (0..103).map(|_| AtomicUsize::new(0)).collect();
        let mut stats = RenderStats::default();
        let results: Vec<usize> = pool.install(|| {
            run_on_tiles(Stage::Trace, 0..runs.len(), None, &mut stats, |tile| {
                runs[tile].fetch_add(1, Ordering::Relaxed);
                // Uneven work, so that the workers finish their tiles out of order.
                std::thread::sleep(Duration::from_micros(50 * (tile % 7) as u64));
                tile * 10
            })
            .collect()
        });
        assert_eq!(results, (0..runs.len()).map(|t| t * 10).collect::<Vec<_>>());
        assert!(runs.iter().all(|r| r.load(Ordering::Relaxed) == 1));
        let busy = stats.stage_busy[Stage::Trace as usize];
        let least: u64 = (0..103).map(|t| 50 * (t % 7) as u64).sum();
        assert!(busy >= Duration::from_micros(least), "busy {busy:?}");
        assert!(stats.stage_time[Stage::Trace as usize] > Duration::ZERO);
    }

    /// Once the pass is cancelled, no tile not yet started runs: the results are those of the
    /// tiles that did, still in tile order.
    #[test]
    fn a_cancelled_pass_starts_no_more_tiles() {
        let cancel = PassCancel(Arc::new(AtomicBool::new(false)));
        let mut stats = RenderStats::default();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap();
        // One worker takes the tiles in order; tile 5 raises the flag.
        let results: Vec<usize> = pool.install(|| {
            run_on_tiles(Stage::Shade, 0..20, Some(&cancel), &mut stats, |tile| {
                if tile == 5 {
                    cancel.0.store(true, Ordering::Relaxed);
                }
                tile
            })
            .collect()
        });
        assert_eq!(results, vec![0, 1, 2, 3, 4, 5]);
    }
}
