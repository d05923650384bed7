//! BVH build (triangles/s) and traversal (rays/s, one thread) on DamagedHelmet (15k triangles)
//! and MetalRoughSpheresNoTextures (1M triangles) from `../shared/scenes`.
//!
//! Traversal compares, for closest-hit primary and bounce rays and any-hit shadow rays: rays
//! one at a time in the order they were made (`per_ray`), the renderer's batch call
//! (`batch`, `SceneAccel::intersect_batch` on a one-thread pool), and the rays sorted for
//! coherence first, sort included (`sorted`). obvhs traverses one ray at a time (no packets),
//! so sorting is the batching that can help.

mod common;

use common::{SCENES, TraversalRays, WorldRays, coherent_order, scene_accel, thread_pool};
use divan::{Bencher, black_box};
use realcam::accel::SceneAccel;
use realcam::batch::{HitBatch, RayBatch};

/// Primary rays per side of the image: 256² = 65,536 primary rays.
const SIDE: u32 = 256;

fn main() {
    divan::main();
}

/// The BVH build from world triangles (flatten, PLOC build, reorder), on 1 and 2 threads.
#[divan::bench(args = SCENES, consts = [1, 2], sample_count = 5)]
fn build<const THREADS: usize>(bencher: Bencher, scene: &str) {
    let Some(loaded) = common::loaded_scene(scene) else {
        return;
    };
    let triangles = loaded.triangle_count();
    let pool = thread_pool(THREADS);
    bencher
        .counter(divan::counter::ItemsCount::new(triangles))
        .bench_local(|| {
            pool.install(|| {
                SceneAccel::build(&loaded.instances, &loaded.materials).expect("builds")
            })
        });
}

/// Which rays of [`TraversalRays`] a benchmark traces.
#[derive(Clone, Copy, Debug)]
enum Kind {
    Primary,
    Bounce,
    Shadow,
}

fn rays(scene: &SceneAccel, kind: Kind) -> WorldRays {
    let TraversalRays {
        primary,
        bounce,
        shadow,
    } = common::traversal_rays(scene, SIDE);
    match kind {
        Kind::Primary => primary,
        Kind::Bounce => bounce,
        Kind::Shadow => shadow,
    }
}

/// Traces `rays` one at a time: closest hits, or any hit for shadow rays. Returns hits found.
fn trace_each(scene: &SceneAccel, rays: &WorldRays, kind: Kind) -> usize {
    let mut found = 0;
    for i in 0..rays.len() {
        let (o, d, t) = (rays.origin[i], rays.direction[i], rays.t_max[i]);
        found += usize::from(match kind {
            Kind::Shadow => scene.occluded(o, d, t),
            _ => scene.intersect(o, d, t).is_some(),
        });
    }
    found
}

fn traversal(bencher: Bencher, scene: &str, kind: Kind, sorted: bool) {
    let Some(accel) = scene_accel(scene) else {
        return;
    };
    let rays = rays(accel, kind);
    bencher
        .counter(divan::counter::ItemsCount::new(rays.len()))
        .bench_local(|| {
            if sorted {
                let order = coherent_order(&rays, accel);
                trace_each(accel, &rays.permuted(&order), kind)
            } else {
                trace_each(accel, black_box(&rays), kind)
            }
        });
}

#[divan::bench(args = SCENES, sample_count = 10)]
fn closest_primary_per_ray(bencher: Bencher, scene: &str) {
    traversal(bencher, scene, Kind::Primary, false);
}

#[divan::bench(args = SCENES, sample_count = 10)]
fn closest_primary_sorted(bencher: Bencher, scene: &str) {
    traversal(bencher, scene, Kind::Primary, true);
}

#[divan::bench(args = SCENES, sample_count = 10)]
fn closest_bounce_per_ray(bencher: Bencher, scene: &str) {
    traversal(bencher, scene, Kind::Bounce, false);
}

#[divan::bench(args = SCENES, sample_count = 10)]
fn closest_bounce_sorted(bencher: Bencher, scene: &str) {
    traversal(bencher, scene, Kind::Bounce, true);
}

#[divan::bench(args = SCENES, sample_count = 10)]
fn shadow_any_hit_per_ray(bencher: Bencher, scene: &str) {
    traversal(bencher, scene, Kind::Shadow, false);
}

#[divan::bench(args = SCENES, sample_count = 10)]
fn shadow_any_hit_sorted(bencher: Bencher, scene: &str) {
    traversal(bencher, scene, Kind::Shadow, true);
}

/// Primary rays through the renderer's batch call (SoA in, SoA hits out) on one thread.
#[divan::bench(args = SCENES, sample_count = 10)]
fn closest_primary_batch(bencher: Bencher, scene: &str) {
    let Some(accel) = scene_accel(scene) else {
        return;
    };
    let rays = rays(accel, Kind::Primary);
    let mut batch = RayBatch::with_capacity(rays.len());
    for i in 0..rays.len() {
        batch.push(rays.origin[i].into(), rays.direction[i].into(), 0, 0);
    }
    let mut hits = HitBatch::default();
    let pool = thread_pool(1);
    bencher
        .counter(divan::counter::ItemsCount::new(rays.len()))
        .bench_local(|| pool.install(|| accel.intersect_batch(black_box(&batch), &mut hits)));
}
