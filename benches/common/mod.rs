//! What the benchmarks share: the test scenes in `../shared/scenes`, the camera poses (the same
//! ones the peer comparison in `benches/peers/` uses), renderers set up for whole frames, and
//! rays for BVH traversal.
//!
//! Each bench target compiles this module on its own and uses part of it.
#![allow(dead_code)]

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

use glam::{Mat4, Vec3};
use realcam::accel::SceneAccel;
use realcam::lens::aperture::ApertureSetting;
use realcam::lens::elements::FocusSetting;
use realcam::lens::focus::FocusMode;
use realcam::lens::io::bundled::load_lens;
use realcam::lens::pupil::PupilSampling;
use realcam::pipeline::{RenderSettings, Renderer, SceneSource};
use realcam::scene::{LoadedScene, load_gltf, look_at};
use realcam::shade::Environment;

/// DamagedHelmet: 15k triangles, textured.
pub const HELMET: &str = "DamagedHelmet";
/// MetalRoughSpheresNoTextures: about 1M triangles (the BVH stress case).
pub const SPHERES: &str = "MetalRoughSpheresNoTextures";
pub const SCENES: &[&str] = &[HELMET, SPHERES];

/// The scene file of a shared scene, relative to the shared scenes folder.
fn scene_file(name: &str) -> String {
    match name {
        HELMET => format!("{name}/{name}.glb"),
        _ => format!("{name}/{name}.gltf"),
    }
}

/// The lens of the whole-frame and peer benchmarks, its stop (mm) and the film diagonal (mm).
pub const FRAME_LENS: &str = "dgauss.50mm";
pub const FRAME_STOP_MM: f64 = 8.0;
pub const FILM_DIAGONAL_MM: f64 = 35.0;

/// Where the helmet is seen from in the whole-frame and peer benchmarks (world, metres):
/// 4.5 m in front (+z), looking at its centre, focused there.
pub const HELMET_EYE: [f32; 3] = [0.0, 0.0, 4.5];
pub const HELMET_TARGET: [f32; 3] = [0.0, 0.0, 0.0];

/// The shared data folder: `$REALCAM_SHARED` if set (a worktree checked out elsewhere),
/// else `../shared` beside the repository.
pub fn shared_dir() -> PathBuf {
    std::env::var_os("REALCAM_SHARED")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared"))
}

/// The file of shared scene `name`, or `None` (with a note) when it is not there.
pub fn shared_scene(name: &str) -> Option<PathBuf> {
    let path = shared_dir().join("scenes").join(scene_file(name));
    if path.exists() {
        Some(path)
    } else {
        eprintln!(
            "note: {} not found; its benchmarks are skipped",
            path.display()
        );
        None
    }
}

/// A loaded scene, kept for the whole run (the 1M-triangle one takes seconds to load).
pub fn loaded_scene(name: &str) -> Option<&'static LoadedScene> {
    static CACHE: OnceLock<Mutex<HashMap<String, &'static LoadedScene>>> = OnceLock::new();
    let path = shared_scene(name)?;
    let mut cache = CACHE.get_or_init(Default::default).lock().unwrap();
    let scene = cache.entry(name.to_string()).or_insert_with(|| {
        Box::leak(Box::new(
            load_gltf(&path).unwrap_or_else(|e| panic!("{}: {e:#}", path.display())),
        ))
    });
    Some(*scene)
}

/// The BVH of a scene, built once for the whole run.
pub fn scene_accel(name: &str) -> Option<&'static SceneAccel> {
    static CACHE: OnceLock<Mutex<HashMap<String, &'static SceneAccel>>> = OnceLock::new();
    let scene = loaded_scene(name)?;
    let mut cache = CACHE.get_or_init(Default::default).lock().unwrap();
    let accel = cache.entry(name.to_string()).or_insert_with(|| {
        Box::leak(Box::new(
            SceneAccel::build(&scene.instances, &scene.materials).expect("BVH builds"),
        ))
    });
    Some(*accel)
}

/// A rayon pool of `threads` workers: the pipeline's and the BVH builder's parallel loops run
/// on the pool they are called from (`pool.install(…)`).
pub fn thread_pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .expect("thread pool starts")
}

/// A scene the whole-frame benchmark renders.
#[derive(Clone, Copy, Debug)]
pub enum FrameScene {
    /// The bundled "dof dragons" scene from its own camera.
    Default,
    /// DamagedHelmet from [`HELMET_EYE`] under a white sky.
    Helmet,
}

impl FrameScene {
    pub const ALL: [FrameScene; 2] = [FrameScene::Default, FrameScene::Helmet];
}

impl std::fmt::Display for FrameScene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            FrameScene::Default => "dof-dragons",
            FrameScene::Helmet => "DamagedHelmet",
        })
    }
}

/// A renderer with the scene loaded, its BVH built and the lens derived (by rendering one
/// sample once), so that timing `render` measures the sample passes alone. The default scene
/// uses its camera's own settings (film, stop, focus: what `realcam render` does with it); the
/// helmet the peer comparison's.
pub fn frame_renderer(
    scene: FrameScene,
    width: u32,
    height: u32,
    max_depth: u32,
) -> Option<Renderer> {
    let mut renderer = Renderer::new();
    let (pose, focus, stop, film_diagonal) = match scene {
        FrameScene::Default => {
            renderer.set_scene(SceneSource {
                path: PathBuf::from(realcam::scene::default_scene::DEFAULT_SCENE_PATH),
                embedded: Some(realcam::scene::default_scene::DEFAULT_SCENE_GLB),
            });
            renderer.update().expect("the default scene loads");
            let camera = renderer.scene_cameras().into_iter().next()?;
            let hints = camera.hints;
            let focus = match (hints.film_distance_mm, hints.focus_distance_m) {
                (Some(mm), _) => FocusSetting::FilmDistance(mm),
                (None, metres) => FocusSetting::Distance {
                    metres: metres.unwrap_or(5.0),
                    mode: FocusMode::Paraxial,
                },
            };
            renderer.set_environment(Environment::Uniform(Vec3::ZERO));
            let stop = hints
                .aperture_mm
                .map_or(ApertureSetting::Full, ApertureSetting::Diameter);
            let film = hints.film_diagonal_mm.unwrap_or(FILM_DIAGONAL_MM);
            (camera.world_from_camera, focus, stop, film)
        }
        FrameScene::Helmet => {
            renderer
                .load_scene(shared_scene(HELMET)?)
                .expect("DamagedHelmet loads");
            renderer.set_environment(Environment::Uniform(Vec3::ONE));
            let (eye, target) = (Vec3::from(HELMET_EYE), Vec3::from(HELMET_TARGET));
            let focus = FocusSetting::Distance {
                metres: (eye - target).length() as f64,
                mode: FocusMode::Paraxial,
            };
            let stop = ApertureSetting::Diameter(FRAME_STOP_MM);
            (look_at(eye, target, Vec3::Y), focus, stop, FILM_DIAGONAL_MM)
        }
    };
    renderer.set_camera(pose);
    renderer.set_film(film_diagonal, PupilSampling::Bounds);
    renderer.set_settings(RenderSettings {
        width,
        height,
        seed: 1,
        max_depth,
        tile_size: 32,
        ..RenderSettings::default()
    });
    let lens = renderer.add_lens(
        &load_lens(FRAME_LENS, None).expect("bundled lens"),
        focus,
        stop,
    );
    renderer.set_active_lens(lens);
    renderer.render(1, |_, _| true).expect("renders");
    Some(renderer)
}

/// A pinhole view from +z that fits `bounds` (for BVH rays; the lens plays no part there).
pub fn framing_camera(scene: &SceneAccel) -> Mat4 {
    let bounds = scene.bounds();
    let centre = bounds.center();
    let distance = bounds.diagonal() * 1.2;
    look_at(centre + Vec3::Z * distance, centre, Vec3::Y)
}

/// Rays in the world frame, as structs (origin, unit direction, maximum distance).
#[derive(Clone, Debug, Default)]
pub struct WorldRays {
    pub origin: Vec<Vec3>,
    pub direction: Vec<Vec3>,
    pub t_max: Vec<f32>,
}

impl WorldRays {
    pub fn len(&self) -> usize {
        self.origin.len()
    }

    fn push(&mut self, origin: Vec3, direction: Vec3, t_max: f32) {
        self.origin.push(origin);
        self.direction.push(direction);
        self.t_max.push(t_max);
    }

    /// The same rays reordered by `order`.
    pub fn permuted(&self, order: &[u32]) -> WorldRays {
        let mut out = WorldRays::default();
        for &i in order {
            let i = i as usize;
            out.push(self.origin[i], self.direction[i], self.t_max[i]);
        }
        out
    }
}

/// The three kinds of rays a frame traces: primary rays from the camera (coherent), diffuse
/// bounce rays from their hits and shadow rays from their hits toward random sky directions
/// (both incoherent, the shadow rays with an any-hit query).
pub struct TraversalRays {
    pub primary: WorldRays,
    pub bounce: WorldRays,
    pub shadow: WorldRays,
}

/// `side` × `side` primary rays of a pinhole camera with a 40° field, and the bounce and shadow
/// rays from the points they hit.
pub fn traversal_rays(scene: &SceneAccel, side: u32) -> TraversalRays {
    let camera = framing_camera(scene);
    let eye = camera.transform_point3(Vec3::ZERO);
    let half = (20f32).to_radians().tan();
    let mut rng = realcam::sampling::Rng::new(5, 6);
    let mut primary = WorldRays::default();
    for y in 0..side {
        for x in 0..side {
            let [jx, jy] = rng.next_2d();
            let u = ((x as f32 + jx) / side as f32 * 2.0 - 1.0) * half;
            let v = (1.0 - (y as f32 + jy) / side as f32 * 2.0) * half;
            let d = camera.transform_vector3(Vec3::new(u, v, -1.0)).normalize();
            primary.push(eye, d, f32::INFINITY);
        }
    }
    let mut bounce = WorldRays::default();
    let mut shadow = WorldRays::default();
    for i in 0..primary.len() {
        let (o, d) = (primary.origin[i], primary.direction[i]);
        let Some(hit) = scene.intersect(o, d, f32::INFINITY) else {
            continue;
        };
        let point = scene.surface(&hit, d);
        let n = point.geometric_normal;
        for rays in [&mut bounce, &mut shadow] {
            let local = cosine_hemisphere(rng.next_2d());
            let (t, b) = n.any_orthonormal_pair();
            let w = (t * local.x + b * local.y + n * local.z).normalize();
            rays.push(point.spawn_origin(w), w, f32::INFINITY);
        }
    }
    TraversalRays {
        primary,
        bounce,
        shadow,
    }
}

fn cosine_hemisphere(u: [f32; 2]) -> Vec3 {
    let r = u[0].sqrt();
    let phi = std::f32::consts::TAU * u[1];
    Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u[0]).max(0.0).sqrt())
}

/// An order that makes consecutive rays similar: by direction octant, then by the Morton code
/// of the origin within `scene`'s bounds (the ray sorting of Pharr et al. / Moon et al., in its
/// simplest form). Sorting costs a pass and an O(n log n) sort, so it pays only if traversal
/// gains more from the coherence than that.
pub fn coherent_order(rays: &WorldRays, scene: &SceneAccel) -> Vec<u32> {
    let bounds = scene.bounds();
    let extent = (bounds.max - bounds.min).max(Vec3::splat(1e-6));
    let mut keyed: Vec<(u64, u32)> = (0..rays.len())
        .map(|i| {
            let d = rays.direction[i];
            let octant =
                u64::from(d.x < 0.0) | u64::from(d.y < 0.0) << 1 | u64::from(d.z < 0.0) << 2;
            let p = ((rays.origin[i] - bounds.min) / extent).clamp(Vec3::ZERO, Vec3::ONE) * 1023.0;
            let morton = spread_bits(p.x as u64)
                | spread_bits(p.y as u64) << 1
                | spread_bits(p.z as u64) << 2;
            (octant << 30 | morton, i as u32)
        })
        .collect();
    keyed.sort_unstable_by_key(|&(key, _)| key);
    keyed.into_iter().map(|(_, i)| i).collect()
}

/// The 10 low bits of `v` spread to every third bit.
fn spread_bits(v: u64) -> u64 {
    let mut x = v & 0x3ff;
    x = (x | x << 16) & 0x0300_00ff;
    x = (x | x << 8) & 0x0300_f00f;
    x = (x | x << 4) & 0x030c_30c3;
    x = (x | x << 2) & 0x0924_9249;
    x
}

/// The scene's world triangles in obvhs form (world space: traversal speed does not depend on
/// the power-of-two scale `SceneAccel` applies).
pub fn world_triangles(scene: &LoadedScene) -> Vec<obvhs::triangle::Triangle> {
    let mut triangles = Vec::with_capacity(scene.triangle_count());
    for instance in &scene.instances {
        let m = instance.world_from_local;
        let p = |i: u32| glam::Vec3A::from(m.transform_point3(instance.mesh.positions[i as usize]));
        for &[a, b, c] in &instance.mesh.triangles {
            triangles.push(obvhs::triangle::Triangle {
                v0: p(a),
                v1: p(b),
                v2: p(c),
            });
        }
    }
    triangles
}
