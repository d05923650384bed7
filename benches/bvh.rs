//! BVH build (triangles/s) and traversal (rays/s, one thread) on DamagedHelmet (15k triangles)
//! and MetalRoughSpheresNoTextures (1M triangles) from `../shared/scenes`.
//!
//! Traversal compares, for closest-hit primary and bounce rays and any-hit shadow rays: rays
//! one at a time in the order they were made (`per_ray`), the renderer's batch call
//! (`batch`, `SceneAccel::intersect_batch` on a one-thread pool), and the rays sorted for
//! coherence first, sort included (`sorted`). The batch call traces 8-ray packets where the
//! CPU has AVX2 (over the wide tree), which pays only when consecutive rays are coherent (see
//! `closest_primary_tiles`); the per-ray traversals gain from sorting through the cache alone.
//!
//! `closest_primary_tiles` feeds primary rays the way the renderer does: per 32×32 film tile,
//! row-major within the tile, so that 8 consecutive rays are neighbouring pixels; from a
//! pinhole, and from points spread over a lens aperture focused on the scene (`lens`). It
//! compares the batch call (8-ray packets where the CPU has AVX2) with both single-ray
//! traversals on the same rays.
//!
//! The per-ray benchmarks run every traversal this CPU has (`SceneAccel::intersect_with`):
//! obvhs's own, the reference, obvhs's loop with an AVX2 node test (`avx2`), and realcam's own
//! float 8-wide traversal the renderer uses (`wide`), in the same run so that
//! their ratio is measured on the same machine state. The other benchmarks use the renderer's
//! default (the fastest).
//!
//! `anchor` puts Embree 3 (a yardstick, opened at run time when `libembree3.so.3` is
//! installed; see `common/embree.rs`) beside realcam's single-ray traversal, its packets, and the
//! renderer's batch (packets where they run full enough to pay, single rays elsewhere): the
//! same world triangles, the same ray sets (camera rays in tile order, first diffuse bounces),
//! closest hit, one thread. `build_embree` times Embree's own BVH build (one thread).

mod common;
#[path = "common/embree.rs"]
mod embree;

use common::{HELMET, SCENES, TraversalRays, WorldRays, coherent_order, scene_accel, thread_pool};
use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};
use std::time::Duration;

use divan::{Bencher, black_box};
use glam::{Vec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::ray::{Ray, RayHit};
use realcam::accel::{BatchParallelism, PacketUse, SceneAccel, Traversal};
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
fn trace_each(scene: &SceneAccel, traversal: Traversal, rays: &WorldRays, kind: Kind) -> usize {
    let mut found = 0;
    for i in 0..rays.len() {
        let (o, d, t) = (rays.origin[i], rays.direction[i], rays.t_max[i]);
        found += usize::from(match kind {
            Kind::Shadow => scene.occluded_with(traversal, o, d, t),
            _ => scene.intersect_with(traversal, o, d, t).is_some(),
        });
    }
    found
}

/// A scene and a traversal to trace it with, named "scene, traversal" in divan's output.
#[derive(Clone, Copy)]
struct Case {
    scene: &'static str,
    traversal: Traversal,
}

impl std::fmt::Display for Case {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}, {}", self.scene, self.traversal.name())
    }
}

/// Every scene with every traversal this CPU runs, the reference (obvhs) first.
fn cases() -> Vec<Case> {
    SCENES
        .iter()
        .flat_map(|&scene| {
            Traversal::available()
                .into_iter()
                .map(move |traversal| Case { scene, traversal })
        })
        .collect()
}

fn traversal(bencher: Bencher, scene: &str, traversal: Traversal, kind: Kind, sorted: bool) {
    let Some(accel) = scene_accel(scene) else {
        return;
    };
    let rays = rays(accel, kind);
    bencher
        .counter(divan::counter::ItemsCount::new(rays.len()))
        .bench_local(|| {
            if sorted {
                let order = coherent_order(&rays, accel);
                trace_each(accel, traversal, &rays.permuted(&order), kind)
            } else {
                trace_each(accel, traversal, black_box(&rays), kind)
            }
        });
}

#[divan::bench(args = cases(), sample_count = 10)]
fn closest_primary_per_ray(bencher: Bencher, case: Case) {
    traversal(bencher, case.scene, case.traversal, Kind::Primary, false);
}

#[divan::bench(args = SCENES, sample_count = 10)]
fn closest_primary_sorted(bencher: Bencher, scene: &str) {
    traversal(bencher, scene, Traversal::detect(), Kind::Primary, true);
}

#[divan::bench(args = cases(), sample_count = 10)]
fn closest_bounce_per_ray(bencher: Bencher, case: Case) {
    traversal(bencher, case.scene, case.traversal, Kind::Bounce, false);
}

#[divan::bench(args = SCENES, sample_count = 10)]
fn closest_bounce_sorted(bencher: Bencher, scene: &str) {
    traversal(bencher, scene, Traversal::detect(), Kind::Bounce, true);
}

#[divan::bench(args = cases(), sample_count = 10)]
fn shadow_any_hit_per_ray(bencher: Bencher, case: Case) {
    traversal(bencher, case.scene, case.traversal, Kind::Shadow, false);
}

#[divan::bench(args = SCENES, sample_count = 10)]
fn shadow_any_hit_sorted(bencher: Bencher, scene: &str) {
    traversal(bencher, scene, Traversal::detect(), Kind::Shadow, true);
}

/// The rays as the renderer's SoA batch (all alive).
fn ray_batch(rays: &WorldRays) -> RayBatch {
    let mut batch = RayBatch::with_capacity(rays.len());
    for i in 0..rays.len() {
        batch.push(rays.origin[i].into(), rays.direction[i].into(), 0, 0);
    }
    batch
}

/// Bounce rays through the batch call (8-ray packets where a packet's rays share a direction
/// octant): in image order, and sorted by octant and origin first (sort included), which makes
/// nearly every packet one octant with neighbouring origins.
#[divan::bench(args = SCENES, consts = [false, true], sample_count = 10)]
fn closest_bounce_batch<const SORTED: bool>(bencher: Bencher, scene: &str) {
    let Some(accel) = scene_accel(scene) else {
        return;
    };
    let rays = rays(accel, Kind::Bounce);
    let unsorted = ray_batch(&rays);
    let mut hits = HitBatch::default();
    let pool = thread_pool(1);
    bencher
        .counter(divan::counter::ItemsCount::new(rays.len()))
        .bench_local(|| {
            pool.install(|| {
                if SORTED {
                    let order = coherent_order(&rays, accel);
                    accel.intersect_batch(&ray_batch(&rays.permuted(&order)), &mut hits)
                } else {
                    accel.intersect_batch(black_box(&unsorted), &mut hits)
                }
            })
        });
}

/// Primary rays through the renderer's batch call (SoA in, SoA hits out) on one thread.
#[divan::bench(args = SCENES, sample_count = 10)]
fn closest_primary_batch(bencher: Bencher, scene: &str) {
    let Some(accel) = scene_accel(scene) else {
        return;
    };
    let rays = rays(accel, Kind::Primary);
    let batch = ray_batch(&rays);
    let mut hits = HitBatch::default();
    let pool = thread_pool(1);
    bencher
        .counter(divan::counter::ItemsCount::new(rays.len()))
        .bench_local(|| pool.install(|| accel.intersect_batch(black_box(&batch), &mut hits)));
}

/// Film tile side, as the renderer's (see `render::tile`).
const TILE: u32 = 32;

/// How `closest_primary_tiles` traces: the batch call or one ray at a time.
#[derive(Clone, Copy)]
enum Method {
    Batch,
    PerRay(Traversal),
}

/// Primary rays from a pinhole or a lens, traced by one method, on the helmet.
#[derive(Clone, Copy)]
struct TileCase {
    lens: bool,
    method: Method,
}

impl std::fmt::Display for TileCase {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let camera = if self.lens { "lens" } else { "pinhole" };
        match self.method {
            Method::Batch => write!(f, "{camera}, batch (packets)"),
            Method::PerRay(t) => write!(f, "{camera}, per ray {}", t.name()),
        }
    }
}

fn tile_cases() -> Vec<TileCase> {
    let methods = Traversal::available()
        .into_iter()
        .map(Method::PerRay)
        .chain([Method::Batch]);
    methods
        .flat_map(|method| [false, true].map(|lens| TileCase { lens, method }))
        .collect()
}

/// The primary rays of [`TraversalRays`] (a `SIDE`² row-major image) in tile order, each
/// moved, for `lens`, to a point of an aperture and re-aimed at its pixel's point on the focus
/// plane through the scene's centre. The aperture is as wide relative to the focus distance as
/// the renderer's 8 mm at 4.5 m.
fn tile_rays(scene: &SceneAccel, lens: bool) -> WorldRays {
    let rays = rays(scene, Kind::Primary);
    let order: Vec<u32> = (0..SIDE / TILE)
        .flat_map(|ty| (0..SIDE / TILE).map(move |tx| (tx, ty)))
        .flat_map(|(tx, ty)| {
            (0..TILE)
                .flat_map(move |y| (0..TILE).map(move |x| (ty * TILE + y) * SIDE + tx * TILE + x))
        })
        .collect();
    let mut rays = rays.permuted(&order);
    if lens {
        let eye = rays.origin[0];
        let focus = (scene.bounds().center() - eye).length();
        let axis = (scene.bounds().center() - eye) / focus;
        let (right, up) = axis.any_orthonormal_pair();
        let aperture = focus * 0.008 / 4.5;
        let mut rng = realcam::sampling::Rng::new(9, 1);
        for i in 0..rays.len() {
            let d = rays.direction[i];
            let target = eye + d * (focus / d.dot(axis));
            let [a, b] = rng.next_2d();
            let origin: Vec3 = eye + (right * (a - 0.5) + up * (b - 0.5)) * aperture;
            rays.origin[i] = origin;
            rays.direction[i] = (target - origin).normalize();
        }
    }
    rays
}

/// Helmet primary rays in the renderer's tile order: packets against single rays.
#[divan::bench(args = tile_cases(), sample_count = 10)]
fn closest_primary_tiles(bencher: Bencher, case: TileCase) {
    let Some(accel) = scene_accel(HELMET) else {
        return;
    };
    let rays = tile_rays(accel, case.lens);
    let batch = ray_batch(&rays);
    let mut hits = HitBatch::default();
    let pool = thread_pool(1);
    bencher
        .counter(divan::counter::ItemsCount::new(rays.len()))
        .bench_local(|| match case.method {
            Method::Batch => {
                pool.install(|| accel.intersect_batch(black_box(&batch), &mut hits));
                hits.triangle.len()
            }
            Method::PerRay(traversal) => {
                trace_each(accel, traversal, black_box(&rays), Kind::Primary)
            }
        });
}

/// obvhs build presets for realcam's BVH (no spatial splits: realcam needs one leaf entry per
/// triangle), traced with obvhs's own triangle test on the helmet's bounce rays. Tells whether
/// a better-built tree or smaller leaves would speed traversal, and, against
/// `closest_bounce_per_ray`, what realcam's triangle test and alpha check cost on top.
#[divan::bench(args = PRESETS, sample_count = 10)]
fn preset_bounce_obvhs_triangles(bencher: Bencher, preset: &str) {
    let (Some(scene), Some(accel)) = (common::loaded_scene(HELMET), scene_accel(HELMET)) else {
        return;
    };
    let triangles = common::world_triangles(scene);
    let bvh = build_cwbvh_from_tris(&triangles, preset_params(preset), &mut Duration::default());
    let rays = rays(accel, Kind::Bounce);
    bencher
        .counter(divan::counter::ItemsCount::new(rays.len()))
        .bench_local(|| {
            let mut found = 0;
            for i in 0..rays.len() {
                let ray = Ray::new(
                    Vec3A::from(rays.origin[i]),
                    Vec3A::from(rays.direction[i]),
                    0.0,
                    f32::INFINITY,
                );
                let mut hit = RayHit::none();
                found += usize::from(bvh.ray_traverse(ray, &mut hit, |ray, id| {
                    triangles[bvh.primitive_indices[id] as usize].intersect(ray)
                }));
            }
            found
        });
}

const PRESETS: &[&str] = &[
    "medium (realcam's)",
    "slow, no splits",
    "medium, leaves ≤ 4",
    "medium, leaves ≤ 2",
];

fn preset_params(name: &str) -> BvhBuildParams {
    let medium = BvhBuildParams::medium_build();
    match name {
        "slow, no splits" => BvhBuildParams {
            pre_split: false,
            ..BvhBuildParams::slow_build()
        },
        "medium, leaves ≤ 4" => BvhBuildParams {
            max_prims_per_leaf: 4,
            ..medium
        },
        "medium, leaves ≤ 2" => BvhBuildParams {
            max_prims_per_leaf: 2,
            ..medium
        },
        _ => medium,
    }
}

/// The ray sets of the traversal anchor.
#[derive(Clone, Copy, Debug, PartialEq)]
enum AnchorRays {
    /// Pinhole camera rays per 32 × 32 tile, row-major within the tile (as the renderer).
    CameraTiles,
    /// The first diffuse bounce from every camera-ray hit, in image order.
    Bounce,
}

/// Who traces the anchor's rays.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Tracer {
    /// realcam, one ray at a time (the renderer's single-ray traversal, AVX2 where present).
    RealcamSingle,
    /// realcam's batch call with every packet walking as one (8-ray packets where a packet's
    /// rays share an octant).
    RealcamPackets,
    /// realcam's batch call as the renderer makes it: packets where they run full enough to
    /// pay, single rays elsewhere (`realcam::accel::PacketUse::WherePaying`).
    RealcamBatch,
    /// Embree 3, `rtcIntersect1`.
    Embree1,
    /// Embree 3, `rtcIntersect8` on 8 consecutive rays.
    Embree8,
}

#[derive(Clone, Copy)]
struct AnchorCase {
    scene: &'static str,
    rays: AnchorRays,
    tracer: Tracer,
}

impl std::fmt::Display for AnchorCase {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let rays = match self.rays {
            AnchorRays::CameraTiles => "camera tiles",
            AnchorRays::Bounce => "bounce",
        };
        let tracer = match self.tracer {
            Tracer::RealcamSingle => "realcam single",
            Tracer::RealcamPackets => "realcam packets",
            Tracer::RealcamBatch => "realcam batch (packets where they pay)",
            Tracer::Embree1 => "embree rtcIntersect1",
            Tracer::Embree8 => "embree rtcIntersect8",
        };
        write!(f, "{}, {rays}, {tracer}", self.scene)
    }
}

fn anchor_cases() -> Vec<AnchorCase> {
    let mut cases = Vec::new();
    for &scene in SCENES {
        for rays in [AnchorRays::CameraTiles, AnchorRays::Bounce] {
            for tracer in [
                Tracer::RealcamSingle,
                Tracer::RealcamPackets,
                Tracer::RealcamBatch,
                Tracer::Embree1,
                Tracer::Embree8,
            ] {
                cases.push(AnchorCase {
                    scene,
                    rays,
                    tracer,
                });
            }
        }
    }
    cases
}

/// The process's Embree device, opened once (`None` without the library).
fn embree() -> Option<&'static embree::Embree> {
    static EMBREE: OnceLock<Option<&'static embree::Embree>> = OnceLock::new();
    *EMBREE.get_or_init(|| embree::Embree::open().map(|e| &*Box::leak(Box::new(e))))
}

/// Embree's BVH over a scene's world triangles, built once for the run.
fn embree_scene(name: &str) -> Option<&'static embree::EmbreeScene<'static>> {
    type Scenes = HashMap<String, &'static embree::EmbreeScene<'static>>;
    static CACHE: OnceLock<Mutex<Scenes>> = OnceLock::new();
    let device = embree()?;
    let loaded = common::loaded_scene(name)?;
    let mut cache = CACHE.get_or_init(Default::default).lock().unwrap();
    let scene = cache
        .entry(name.to_string())
        .or_insert_with(|| Box::leak(Box::new(device.scene(&triangle_corners(loaded)))));
    Some(*scene)
}

fn triangle_corners(scene: &realcam::scene::LoadedScene) -> Vec<[Vec3; 3]> {
    common::world_triangles(scene)
        .iter()
        .map(|t| [t.v0, t.v1, t.v2].map(Vec3::from))
        .collect()
}

fn anchor_rays(accel: &SceneAccel, rays: AnchorRays) -> WorldRays {
    match rays {
        AnchorRays::CameraTiles => tile_rays(accel, false),
        AnchorRays::Bounce => self::rays(accel, Kind::Bounce),
    }
}

/// Checks once per scene and ray set that Embree and realcam find the same closest hits
/// (distance within 1e-4 relative; a few rays grazing shared edges may differ), so that the
/// comparison is between traversals doing the same work.
fn check_agreement(
    case: AnchorCase,
    accel: &SceneAccel,
    scene: &embree::EmbreeScene,
    rays: &WorldRays,
) {
    static CHECKED: OnceLock<Mutex<Vec<String>>> = OnceLock::new();
    let key = format!("{}, {:?}", case.scene, case.rays);
    let mut checked = CHECKED.get_or_init(Default::default).lock().unwrap();
    if checked.contains(&key) {
        return;
    }
    checked.push(key.clone());
    let mut embree_rays: Vec<_> = (0..rays.len())
        .map(|i| embree::RayHit1::new(rays.origin[i], rays.direction[i]))
        .collect();
    scene.intersect1(&mut embree_rays, false);
    let disagree = (0..rays.len())
        .filter(|&i| {
            let ours = accel.intersect(rays.origin[i], rays.direction[i], f32::INFINITY);
            let theirs = &embree_rays[i];
            match ours {
                None => theirs.geom_id != embree::INVALID_GEOMETRY_ID,
                Some(hit) => (hit.t - theirs.tfar).abs() > 1e-4 * hit.t.max(1e-3),
            }
        })
        .count();
    eprintln!(
        "note: {key}: Embree and realcam disagree on {disagree} of {} closest hits",
        rays.len()
    );
    assert!(
        disagree * 1000 <= rays.len(),
        "{key}: Embree and realcam disagree on {disagree} rays: not the same scene"
    );
}

/// The traversal anchor: realcam's traversals beside Embree's on the same rays, one thread.
#[divan::bench(args = anchor_cases(), sample_count = 10)]
fn anchor(bencher: Bencher, case: AnchorCase) {
    let Some(accel) = scene_accel(case.scene) else {
        return;
    };
    let rays = anchor_rays(accel, case.rays);
    let counter = divan::counter::ItemsCount::new(rays.len());
    let coherent = case.rays == AnchorRays::CameraTiles;
    match case.tracer {
        Tracer::RealcamSingle => {
            let traversal = Traversal::detect();
            bencher
                .counter(counter)
                .bench_local(|| trace_each(accel, traversal, black_box(&rays), Kind::Primary));
        }
        Tracer::RealcamPackets | Tracer::RealcamBatch => {
            let batch = ray_batch(&rays);
            let mut hits = HitBatch::default();
            let pool = thread_pool(1);
            // The batch as the renderer traces a tile's: on the thread that holds it.
            let (parallelism, packets) = if case.tracer == Tracer::RealcamPackets {
                (BatchParallelism::Spread, PacketUse::Always)
            } else {
                (BatchParallelism::OneThread, PacketUse::WherePaying)
            };
            bencher.counter(counter).bench_local(|| {
                pool.install(|| {
                    accel.intersect_batch_using(black_box(&batch), &mut hits, parallelism, packets)
                });
                hits.triangle.len()
            });
        }
        Tracer::Embree1 | Tracer::Embree8 => {
            let Some(scene) = embree_scene(case.scene) else {
                return;
            };
            check_agreement(case, accel, scene, &rays);
            if case.tracer == Tracer::Embree1 {
                let mut embree_rays: Vec<_> = (0..rays.len())
                    .map(|i| embree::RayHit1::new(rays.origin[i], rays.direction[i]))
                    .collect();
                bencher
                    .counter(counter)
                    .bench_local(|| scene.intersect1(black_box(&mut embree_rays), coherent));
            } else {
                let mut packets = embree::packets8(&rays.origin, &rays.direction);
                bencher
                    .counter(counter)
                    .bench_local(|| scene.intersect8(black_box(&mut packets), coherent));
            }
        }
    }
}

/// Embree's BVH build over the same world triangles (medium quality, one thread), for
/// comparison with `build`.
#[divan::bench(args = SCENES, sample_count = 5)]
fn build_embree(bencher: Bencher, scene: &str) {
    let (Some(device), Some(loaded)) = (embree(), common::loaded_scene(scene)) else {
        return;
    };
    let triangles = triangle_corners(loaded);
    bencher
        .counter(divan::counter::ItemsCount::new(triangles.len()))
        .bench_local(|| device.scene(black_box(&triangles)));
}
