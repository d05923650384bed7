//! The pass stages on a GPU: GenerateRays → Trace → Shade → Weight → WriteFilm as one kernel
//! (`gpu::film`; it lands a sample's companion wavelengths as it generates the sample's rays, so
//! LandCompanions has no GPU system), fed by uploads that follow the ECS's change detection:
//!
//! - the scene's geometry and textures (BVH, triangles, texels) go up once per scene; its
//!   shading data (materials, lights, environment, path depth, seed) again only when one of
//!   those changes, not for a new film size;
//! - the active lens, as the lens systems derived it, goes up when any of its derived components,
//!   the camera pose, the film or the settings change: a lens swap, a focus pull or a new stop
//!   rewrites that one small buffer;
//! - the film's sums stay on the GPU between passes and come back to the film tiles when an
//!   image is asked for ([`read_film_back`]); tiles cleared or loaded on the CPU (a new render,
//!   a resumed checkpoint) go up before the next pass.

use bevy_ecs::change_detection::DetectChanges;
use bevy_ecs::query::With;
use bevy_ecs::resource::Resource;
use bevy_ecs::schedule::{IntoScheduleConfigs, Schedule, SystemCondition};
use bevy_ecs::system::{Commands, Query, Res, ResMut};
use bevy_ecs::world::World;
use rayon::prelude::*;

use super::Stage;
use super::device::GpuBackend;
use super::pass::{ActiveLensQuery, lens_camera, pass_pending};
use super::resources::{
    PassCancel, PassState, PipelineFault, RenderSettings, RenderStats, SceneEnvironment,
};
use crate::accel::SceneAccel;
use crate::film::samples::SampleSequence;
use crate::film::{FilmTile, Image};
use crate::gpu::film::{GpuFilm, pass_source};
use crate::gpu::lens::GpuLens;
use crate::gpu::scene::GpuScene;
use crate::gpu::shading::GpuShading;
use crate::lens::camera::CameraPose;
use crate::lens::elements::{ActiveLens, FilmFormat};
use crate::scene::MaterialLibrary;
use crate::shade::{Environment, LightSet};

/// The scene's geometry and textures on the GPU, once uploaded.
#[derive(Resource, Default)]
pub struct GpuSceneData(Option<GpuScene>);

/// The scene's shading data on the GPU, once uploaded, with the path depth and seed it was
/// uploaded for (the only settings it holds: a new film size leaves it as it is).
#[derive(Resource, Default)]
pub struct GpuShadingData(Option<(GpuShading, u32, u64)>);

/// The active lens on the GPU, once uploaded.
#[derive(Resource, Default)]
pub struct GpuLensData(Option<GpuLens>);

/// The film on the GPU, and which side holds the newer sums.
#[derive(Resource, Default)]
pub struct GpuFilmData {
    film: Option<GpuFilm>,
    /// The GPU rendered passes the tiles do not have yet.
    gpu_newer: bool,
}

/// Makes the (empty) GPU resources the systems fill in.
pub(super) fn init_resources(world: &mut World) {
    world.init_resource::<GpuSceneData>();
    world.init_resource::<GpuShadingData>();
    world.init_resource::<GpuLensData>();
    world.init_resource::<GpuFilmData>();
}

/// Adds the GPU pass systems: they run instead of the CPU's while a [`GpuBackend`] is present.
pub(super) fn add_systems(schedule: &mut Schedule) {
    schedule.add_systems(
        (
            upload_scene,
            upload_shading,
            upload_lens,
            render_pass_on_gpu,
        )
            .chain()
            .in_set(Stage::Shade)
            .run_if(pass_pending.and_then(on_gpu)),
    );
}

/// The passes render on a GPU.
pub(super) fn on_gpu(backend: Option<Res<GpuBackend>>) -> bool {
    backend.is_some()
}

/// Uploads the scene's geometry and textures when there are none yet or they changed (a new
/// scene: the BVH, triangles and texels, the large part, go up once per scene).
fn upload_scene(
    mut commands: Commands,
    backend: Res<GpuBackend>,
    mut uploaded: ResMut<GpuSceneData>,
    accel: Option<Res<SceneAccel>>,
    materials: Option<Res<MaterialLibrary>>,
) {
    let (Some(accel), Some(materials)) = (accel, materials) else {
        return;
    };
    if uploaded.0.is_some() && !accel.is_changed() && !materials.is_changed() {
        return;
    }
    match GpuScene::upload(&backend.0, &accel, &materials) {
        Ok(scene) => uploaded.0 = Some(scene),
        Err(why) => commands.insert_resource(PipelineFault(format!("GPU: {why}"))),
    }
}

/// Uploads the shading data (materials, lights, environment, path depth and seed) when there
/// is none yet or any of it changed.
fn upload_shading(
    mut commands: Commands,
    backend: Res<GpuBackend>,
    mut uploaded: ResMut<GpuShadingData>,
    materials: Option<Res<MaterialLibrary>>,
    lights: Option<Res<LightSet>>,
    environment: Option<Res<SceneEnvironment>>,
    settings: Res<RenderSettings>,
) {
    let (Some(materials), Some(lights)) = (materials, lights) else {
        return;
    };
    let wanted = (settings.max_depth, settings.seed);
    let current = uploaded
        .0
        .as_ref()
        .is_some_and(|(_, depth, seed)| (*depth, *seed) == wanted);
    let changed = !current
        || materials.is_changed()
        || lights.is_changed()
        || environment.as_ref().is_some_and(|e| e.is_changed());
    if !changed {
        return;
    }
    let black = Environment::Uniform(glam::Vec3::ZERO);
    let environment = environment.as_deref().map_or(&black, |e| &e.0);
    match GpuShading::upload(
        &backend.0,
        &materials,
        &lights,
        environment,
        wanted.0,
        wanted.1,
    ) {
        Ok(shading) => uploaded.0 = Some((shading, wanted.0, wanted.1)),
        Err(why) => commands.insert_resource(PipelineFault(format!("GPU: {why}"))),
    }
}

/// Uploads the active lens (with the camera pose and film it renders for) when it changed.
#[allow(clippy::too_many_arguments)]
fn upload_lens(
    mut commands: Commands,
    backend: Res<GpuBackend>,
    mut uploaded: ResMut<GpuLensData>,
    lens: ActiveLensQuery,
    changed_lens: Query<(), (With<ActiveLens>, super::pass::LensChanged)>,
    pose: Option<Res<CameraPose>>,
    settings: Res<RenderSettings>,
    film_format: Res<FilmFormat>,
) {
    let Some(pose) = pose else {
        return;
    };
    let Ok(active) = lens.single() else {
        return;
    };
    let changed = uploaded.0.is_none()
        || !changed_lens.is_empty()
        || pose.is_changed()
        || settings.is_changed()
        || film_format.is_changed();
    if !changed {
        return;
    }
    let camera = lens_camera(active, &pose, &settings, &film_format);
    let context = &backend.0;
    let result = match uploaded.0.as_mut() {
        Some(gpu) => gpu.update(context, &camera, settings.seed),
        None => GpuLens::upload(context, &camera, settings.seed).map(|gpu| {
            uploaded.0 = Some(gpu);
        }),
    };
    if let Err(why) = result {
        commands.insert_resource(PipelineFault(format!("GPU: {why}")));
    }
}

/// One pass on the GPU: the film (re)made and loaded from the tiles when they are newer, then
/// the kernel for this pass's sample index.
#[allow(clippy::too_many_arguments)]
fn render_pass_on_gpu(
    mut commands: Commands,
    backend: Res<GpuBackend>,
    scene: Res<GpuSceneData>,
    shading: Res<GpuShadingData>,
    lens: Res<GpuLensData>,
    mut film: ResMut<GpuFilmData>,
    settings: Res<RenderSettings>,
    cancel: Option<Res<PassCancel>>,
    mut pass: ResMut<PassState>,
    mut tiles: Query<&mut FilmTile>,
    mut stats: ResMut<RenderStats>,
) {
    let (Some(scene), Some((shading, ..)), Some(lens)) = (&scene.0, &shading.0, &lens.0) else {
        commands.insert_resource(PipelineFault(
            "no active lens with a valid focus, or no camera pose".into(),
        ));
        return;
    };
    if PassCancel::raised(cancel.as_deref()) {
        return;
    }
    let context = &backend.0;
    let (width, height) = (settings.width, settings.height);
    let data = &mut *film;
    let wavelengths = lens.wavelengths();
    if data.film.as_ref().is_none_or(|f| {
        (f.width, f.height, f.wavelengths, f.filter)
            != (width, height, wavelengths, settings.filter)
    }) {
        match GpuFilm::new(context, width, height, wavelengths, settings.filter) {
            Ok(made) => data.film = Some(made),
            Err(why) => {
                commands.insert_resource(PipelineFault(format!("GPU: {why}")));
                return;
            }
        }
        data.gpu_newer = false;
    }
    let gpu_film = data.film.as_mut().expect("made above");
    if !data.gpu_newer {
        // The tiles hold the newest sums (a cleared or resumed film, or what the GPU last gave
        // back): the GPU starts from them. A cleared film (every new render) is cleared there
        // too, without assembling and uploading a frame of zeros (milliseconds a render).
        if tiles.iter().all(|tile| tile.is_clear()) {
            gpu_film.clear(context);
        } else {
            gpu_film.load(
                context,
                &Image::from_tiles(width, height, tiles.iter()).sums,
            );
        }
    }
    let upstream = [&lens.bindings, &scene.bindings, &shading.bindings];
    // Compiling the kernel is set-up (like the BVH build), not pass time.
    let compile_start = std::time::Instant::now();
    let result = gpu_film
        .prepare_kernel(context, upstream, || pass_source(wavelengths))
        .and_then(|compiled| {
            if compiled {
                stats.gpu_kernel_time += compile_start.elapsed();
            }
            // Growing the scratch for this update's dispatches is set-up too, as making the
            // film is.
            gpu_film.reserve_samples(context, pass.count.max(1));
            let start = std::time::Instant::now();
            let samples = SampleSequence {
                first: pass.sample,
                step: pass.step.max(1),
                count: pass.count.max(1),
            };
            let result = gpu_film.render_pass(context, upstream, samples);
            stats.add_time(Stage::Shade, start);
            stats.gpu_kernel_busy.clone_from(&gpu_film.kernel_busy);
            result
        });
    if let Err(why) = result {
        commands.insert_resource(PipelineFault(format!("GPU: {why}")));
        return;
    }
    data.gpu_newer = true;
    let passes = pass.count.max(1);
    for mut tile in &mut tiles {
        tile.samples += passes;
    }
    stats.camera_samples += u64::from(width * height) * u64::from(passes);
    pass.pending = false;
}

/// The film tiles were cleared or loaded on the CPU: the GPU takes their sums before its next
/// pass, dropping any passes it had not given back.
pub(super) fn film_cleared(world: &mut World) {
    if let Some(mut data) = world.get_resource_mut::<GpuFilmData>() {
        data.gpu_newer = false;
    }
}

/// Brings the GPU's film sums (and its counts) back into the film tiles, when it has passes
/// they lack. Called before an image is read from the tiles.
pub(super) fn read_film_back(world: &mut World) -> anyhow::Result<()> {
    let Some(backend) = world.get_resource::<GpuBackend>().cloned() else {
        return Ok(());
    };
    let Some(mut data) = world.get_resource_mut::<GpuFilmData>() else {
        return Ok(());
    };
    if !data.gpu_newer {
        return Ok(());
    }
    // Out of the resource while the tiles (in the same world) take its sums.
    let Some(mut film) = data.film.take() else {
        return Ok(());
    };
    // Waiting for the passes still queued is pass time: WriteFilm's, as on the CPU.
    let start = std::time::Instant::now();
    let width = film.width;
    let mut query = world.query::<&mut FilmTile>();
    let samples = query.iter(world).next().map_or(0, |tile| tile.samples);
    let mut tiles: Vec<_> = query.iter_mut(world).collect();
    // Each tile takes its pixels straight from the mapped readback.
    let read = film.read_with(&backend.0, |sums| {
        tiles.par_iter_mut().for_each(|tile| {
            tile.load_from(width, samples, |i| {
                let [r, g, b, _] = sums[i];
                [r, g, b]
            })
        });
    });
    drop(tiles);
    let mut data = world.resource_mut::<GpuFilmData>();
    data.film = Some(film);
    let counts = read.map_err(|why| anyhow::anyhow!("GPU: {why}"))?;
    data.gpu_newer = false;
    let mut stats = world.resource_mut::<RenderStats>();
    stats.add_time(Stage::WriteFilm, start);
    stats.lens_rays_passed += counts.lens_rays_passed;
    stats.rejected_samples += counts.rejected_samples;
    stats.rays_traced += counts.shading.rays_traced;
    stats.shading += counts.shading;
    Ok(())
}
