//! The render schedule: one bevy_ecs [`Schedule`] whose stages are named [`SystemSet`]s.
//!
//! ```text
//! LoadScene → BuildBvh → DeriveLens → GenerateRays → Trace → Shade → Weight → WriteFilm
//! └─ once per scene ─┘   └ on change ┘ └──────────── once per sample pass ─────────────┘
//! ```
//!
//! Every run of the schedule is cheap when nothing changed: LoadScene acts only on a new
//! [`SceneSource`], BuildBvh only on new mesh instances, the lens systems only on changed lens
//! entities (change detection), and the pass stages only while a pass is pending. The pass
//! stages work tile by tile in parallel (rayon); rays travel between them as SoA batches in
//! each tile's [`TileBatch`]. See ARCHITECTURE.md for what each stage reads and writes.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use bevy_ecs::change_detection::DetectChanges;
use bevy_ecs::component::Component;
use bevy_ecs::entity::Entity;
use bevy_ecs::query::{Added, With};
use bevy_ecs::resource::Resource;
use bevy_ecs::schedule::{IntoScheduleConfigs, Schedule, ScheduleLabel, SystemSet};
use bevy_ecs::system::{Commands, Query, Res, ResMut};
use bevy_ecs::world::{Mut, Ref, World};
use glam::Mat4;
use rayon::prelude::*;

use crate::accel::SceneAccel;
use crate::batch::HitBatch;
use crate::film::samples::SampleSequence;
use crate::film::{FilmTile, Image, tiles};
use crate::lens::Prescription;
use crate::lens::aperture::ApertureSetting;
use crate::lens::camera::{CameraRays, FilmGeometry, LensCamera};
use crate::lens::diaphragm::Diaphragm;
use crate::lens::elements::{
    ActiveLens, Dispersion, FilmFormat, FilmPlacement, FocusSetting, LensDerivation,
    LensDerivationStats, LensFault, LensGeometry, activate_lens, add_lens_systems, set_diaphragm,
    spawn_lens,
};
use crate::lens::movements::FilmMovements;
use crate::lens::pupil::{ExitPupil, PupilSampling};
use crate::scene::{
    Bounds, LoadedScene, MaterialLibrary, MeshInstance, PunctualLight, SceneCamera,
};
use crate::shade::{Environment, LightSet, RadianceBatch, ShadeStats, Shader};

/// The schedule's label.
#[derive(ScheduleLabel, Clone, Debug, PartialEq, Eq, Hash)]
pub struct RenderSchedule;

/// The stages, in the order they run.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stage {
    LoadScene,
    BuildBvh,
    DeriveLens,
    GenerateRays,
    Trace,
    Shade,
    Weight,
    WriteFilm,
}

impl Stage {
    pub const ALL: [Stage; 8] = [
        Stage::LoadScene,
        Stage::BuildBvh,
        Stage::DeriveLens,
        Stage::GenerateRays,
        Stage::Trace,
        Stage::Shade,
        Stage::Weight,
        Stage::WriteFilm,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Stage::LoadScene => "load_scene",
            Stage::BuildBvh => "build_bvh",
            Stage::DeriveLens => "derive_lens",
            Stage::GenerateRays => "generate_rays",
            Stage::Trace => "trace",
            Stage::Shade => "shade",
            Stage::Weight => "weight",
            Stage::WriteFilm => "write_film",
        }
    }
}

/// Where the scene comes from: a file, or bytes built into the binary.
#[derive(Resource, Clone, Debug)]
pub struct SceneSource {
    pub path: PathBuf,
    pub embedded: Option<&'static [u8]>,
}

/// Settings of the render passes.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub seed: u64,
    pub max_depth: u32,
    pub tile_size: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 512,
            height: 512,
            seed: 0,
            max_depth: 8,
            tile_size: 32,
        }
    }
}

/// Rigid transform from the camera frame (see [`crate::lens::camera`]) to the world.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct CameraPose(pub Mat4);

/// The environment the path tracer sees beyond the scene.
#[derive(Resource, Clone, Debug)]
pub struct SceneEnvironment(pub Environment);

/// World bounds of the loaded scene.
#[derive(Resource, Clone, Copy, Debug)]
pub struct SceneBounds(pub Bounds);

/// Every file the loaded scene reads (the glTF, its buffers and images): outputs must not
/// overwrite any of them.
#[derive(Resource, Clone, Debug, Default)]
pub struct SceneInputs(pub Vec<PathBuf>);

/// Warnings collected while loading (shown to the user once).
#[derive(Resource, Clone, Debug, Default)]
pub struct SceneWarnings(pub Vec<String>);

/// Marks every entity spawned from the scene, so a new scene replaces it.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct SceneObject;

/// The sample pass the pass stages are working on.
#[derive(Resource, Clone, Copy, Debug, Default)]
pub struct PassState {
    /// True between a request and WriteFilm.
    pub pending: bool,
    /// Sample index this pass renders into every pixel (the key of its random streams).
    pub sample: u32,
}

/// How many samples each pixel will get in all (a render's target spp). Camera samples
/// 0..count are stratified together (correlated multi-jitter); the plan must stay the same
/// across an interrupted render's resume and across shards, which it does: it is the target.
#[derive(Resource, Clone, Copy, Debug, PartialEq, Eq)]
pub struct SamplePlan {
    pub samples_per_pixel: u32,
}

/// A flag another thread raises to abandon the pass under way (a live session whose settings
/// changed): the pass stages skip their remaining tiles and the film keeps none of the pass.
#[derive(Resource, Clone, Debug, Default)]
pub struct PassCancel(pub Arc<AtomicBool>);

impl PassCancel {
    pub fn requested(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

fn cancelled(cancel: &Option<Res<PassCancel>>) -> bool {
    cancel.as_ref().is_some_and(|c| c.requested())
}

/// A stage that could not do its work; the driver turns it into an error.
#[derive(Resource, Clone, Debug)]
pub struct PipelineFault(pub String);

/// Counters and wall times for `--stats`.
#[derive(Resource, Clone, Debug, Default)]
pub struct RenderStats {
    pub stage_time: [Duration; 8],
    pub scene_loads: u64,
    pub bvh_builds: u64,
    pub triangles: u64,
    pub bvh_nodes: u64,
    pub camera_samples: u64,
    pub lens_rays_passed: u64,
    pub rays_traced: u64,
    pub rejected_samples: u64,
    /// What shading met: escaped rays, emitters, light samples and their fate (its rays are
    /// also counted in `rays_traced`).
    pub shading: ShadeStats,
}

impl RenderStats {
    fn add_time(&mut self, stage: Stage, start: Instant) {
        self.stage_time[stage as usize] += start.elapsed();
    }

    /// The sample counters since `earlier` (an earlier copy): what one frame did.
    pub fn since(&self, earlier: &RenderStats) -> RenderStats {
        RenderStats {
            camera_samples: self.camera_samples - earlier.camera_samples,
            lens_rays_passed: self.lens_rays_passed - earlier.lens_rays_passed,
            rays_traced: self.rays_traced - earlier.rays_traced,
            rejected_samples: self.rejected_samples - earlier.rejected_samples,
            shading: self.shading.since(&earlier.shading),
            ..self.clone()
        }
    }
}

/// One tile's rays between stages, as structure-of-arrays batches.
#[derive(Component, Clone, Debug, Default)]
pub struct TileBatch {
    pub camera: CameraRays,
    pub hits: HitBatch,
    pub radiance: RadianceBatch,
}

/// Builds the schedule with every stage.
pub fn render_schedule() -> Schedule {
    let mut schedule = Schedule::new(RenderSchedule);
    // Stage::ALL is the order: each stage runs before the next.
    for pair in Stage::ALL.windows(2) {
        schedule.configure_sets(pair[0].before(pair[1]));
    }
    add_lens_systems(&mut schedule);
    schedule.configure_sets(
        (
            LensDerivation::Geometry,
            LensDerivation::Placement,
            LensDerivation::Pupil,
        )
            .in_set(Stage::DeriveLens),
    );
    schedule.add_systems((
        load_scene.in_set(Stage::LoadScene),
        (build_bvh, build_lights).chain().in_set(Stage::BuildBvh),
        generate_rays
            .in_set(Stage::GenerateRays)
            .run_if(pass_pending),
        trace_rays.in_set(Stage::Trace).run_if(pass_pending),
        shade.in_set(Stage::Shade).run_if(pass_pending),
        weight.in_set(Stage::Weight).run_if(pass_pending),
        write_film.in_set(Stage::WriteFilm).run_if(pass_pending),
    ));
    schedule
}

/// A pass is requested and not abandoned: a cancelled pass never reaches Weight or WriteFilm.
fn pass_pending(pass: Res<PassState>, cancel: Option<Res<PassCancel>>) -> bool {
    pass.pending && !cancelled(&cancel)
}

/// LoadScene: reads the glTF named by a new [`SceneSource`] and spawns its objects.
pub fn load_scene(
    mut commands: Commands,
    source: Option<Res<SceneSource>>,
    old: Query<Entity, With<SceneObject>>,
    mut stats: ResMut<RenderStats>,
) {
    let Some(source) = source else { return };
    if !source.is_changed() {
        return;
    }
    let start = Instant::now();
    let loaded = match source.embedded {
        Some(bytes) => crate::scene::load_gltf_bytes(bytes, None, &source.path),
        None => crate::scene::load_gltf(&source.path),
    };
    match loaded {
        Ok(scene) => {
            for entity in &old {
                commands.entity(entity).despawn();
            }
            spawn_scene(&mut commands, scene);
            stats.scene_loads += 1;
        }
        Err(e) => commands.insert_resource(PipelineFault(format!("{e:#}"))),
    }
    stats.add_time(Stage::LoadScene, start);
}

fn spawn_scene(commands: &mut Commands, scene: LoadedScene) {
    for instance in scene.instances {
        commands.spawn((instance, SceneObject));
    }
    for light in scene.lights {
        commands.spawn((light, SceneObject));
    }
    for camera in scene.cameras {
        commands.spawn((camera, SceneObject));
    }
    commands.insert_resource(scene.materials);
    commands.insert_resource(SceneBounds(scene.bounds));
    commands.insert_resource(SceneWarnings(scene.warnings));
    commands.insert_resource(SceneInputs(scene.inputs));
}

/// BuildBvh: builds the BVH when mesh instances were added.
pub fn build_bvh(
    mut commands: Commands,
    added: Query<(), Added<MeshInstance>>,
    instances: Query<&MeshInstance>,
    materials: Option<Res<MaterialLibrary>>,
    mut stats: ResMut<RenderStats>,
) {
    let Some(materials) = materials else { return };
    if added.is_empty() && !materials.is_changed() {
        return;
    }
    let start = Instant::now();
    match SceneAccel::build(instances.iter(), &materials) {
        Ok(accel) => {
            stats.bvh_builds += 1;
            stats.triangles = accel.triangle_count() as u64;
            stats.bvh_nodes = accel.node_count() as u64;
            commands.insert_resource(accel);
        }
        Err(e) => commands.insert_resource(PipelineFault(format!("{e:#}"))),
    }
    stats.add_time(Stage::BuildBvh, start);
}

/// BuildBvh (after the BVH): the light set, rebuilt when the BVH, lights or environment change.
pub fn build_lights(
    mut commands: Commands,
    accel: Option<Res<SceneAccel>>,
    materials: Option<Res<MaterialLibrary>>,
    environment: Option<Res<SceneEnvironment>>,
    lights: Query<Ref<PunctualLight>>,
    mut stats: ResMut<RenderStats>,
) {
    let (Some(accel), Some(materials)) = (accel, materials) else {
        return;
    };
    let environment_changed = environment.as_ref().is_some_and(|e| e.is_changed());
    let lights_changed = lights.iter().any(|l| l.is_changed());
    if !(accel.is_changed() || environment_changed || lights_changed) {
        return;
    }
    let start = Instant::now();
    let punctual: Vec<PunctualLight> = lights.iter().map(|l| (*l).clone()).collect();
    let black = Environment::Uniform(glam::Vec3::ZERO);
    let environment = environment.as_deref().map_or(&black, |e| &e.0);
    commands.insert_resource(LightSet::build(&punctual, &accel, &materials, environment));
    stats.add_time(Stage::BuildBvh, start);
}

type ActiveLensQuery<'w, 's> = Query<
    'w,
    's,
    (
        &'static LensGeometry,
        &'static FilmPlacement,
        &'static ExitPupil,
        Option<&'static Dispersion>,
        Option<&'static FilmMovements>,
    ),
    With<ActiveLens>,
>;

/// GenerateRays: camera rays of this pass for every tile, traced through the active lens.
// A system's parameters are its explicit queries and resources (bevy style), not a bundle.
#[allow(clippy::too_many_arguments)]
pub fn generate_rays(
    mut commands: Commands,
    lens: ActiveLensQuery,
    pose: Option<Res<CameraPose>>,
    settings: Res<RenderSettings>,
    film_format: Res<FilmFormat>,
    pass: Res<PassState>,
    plan: Option<Res<SamplePlan>>,
    cancel: Option<Res<PassCancel>>,
    mut tiles: Query<(&FilmTile, &mut TileBatch)>,
    mut stats: ResMut<RenderStats>,
) {
    let start = Instant::now();
    let (Ok((geometry, _placement, pupil, dispersion, movements)), Some(pose)) =
        (lens.single(), pose)
    else {
        commands.insert_resource(PipelineFault(
            "no active lens with a valid focus, or no camera pose".into(),
        ));
        return;
    };
    let camera = LensCamera {
        system: &geometry.system,
        pupil,
        film: FilmGeometry::new(settings.width, settings.height, film_format.diagonal_mm)
            .moved(movements.copied().unwrap_or_default()),
        world_from_camera: pose.0,
        samples_per_pixel: plan.map_or(0, |p| p.samples_per_pixel),
        dispersion: geometry
            .system
            .dispersion
            .as_deref()
            .filter(|_| Dispersion::is_spectral(dispersion, geometry)),
    };
    let mut work: Vec<(&FilmTile, Mut<TileBatch>)> = tiles.iter_mut().collect();
    let passed: u64 = work
        .par_iter_mut()
        .map(|(tile, batch)| {
            if cancelled(&cancel) {
                return 0;
            }
            camera.generate(tile.pixels(), pass.sample, settings.seed, &mut batch.camera);
            batch.camera.rays.alive_count() as u64
        })
        .sum();
    stats.camera_samples += (settings.width * settings.height) as u64;
    stats.lens_rays_passed += passed;
    stats.add_time(Stage::GenerateRays, start);
}

/// Trace: closest hits of every tile's camera rays.
pub fn trace_rays(
    accel: Option<Res<SceneAccel>>,
    cancel: Option<Res<PassCancel>>,
    mut tiles: Query<&mut TileBatch>,
    mut stats: ResMut<RenderStats>,
) {
    let start = Instant::now();
    let Some(accel) = accel else { return };
    let mut work: Vec<Mut<TileBatch>> = tiles.iter_mut().collect();
    let traced: u64 = work
        .par_iter_mut()
        .map(|batch| {
            if cancelled(&cancel) {
                return 0;
            }
            let batch = &mut **batch;
            accel.intersect_batch(&batch.camera.rays, &mut batch.hits);
            batch.camera.rays.alive_count() as u64
        })
        .sum();
    stats.rays_traced += traced;
    stats.add_time(Stage::Trace, start);
}

/// Shade: path-traced radiance arriving along every camera ray.
#[allow(clippy::too_many_arguments)]
pub fn shade(
    accel: Option<Res<SceneAccel>>,
    materials: Option<Res<MaterialLibrary>>,
    lights: Option<Res<LightSet>>,
    environment: Option<Res<SceneEnvironment>>,
    settings: Res<RenderSettings>,
    cancel: Option<Res<PassCancel>>,
    mut tiles: Query<&mut TileBatch>,
    mut stats: ResMut<RenderStats>,
) {
    let start = Instant::now();
    let (Some(accel), Some(materials), Some(lights)) = (accel, materials, lights) else {
        return;
    };
    let default_env = SceneEnvironment(Environment::Uniform(glam::Vec3::ZERO));
    let environment = environment.as_deref().unwrap_or(&default_env);
    let shader = Shader {
        accel: &accel,
        materials: &materials,
        lights: &lights,
        environment: &environment.0,
        max_depth: settings.max_depth,
        seed: settings.seed,
    };
    let mut work: Vec<Mut<TileBatch>> = tiles.iter_mut().collect();
    let shading: ShadeStats = work
        .par_iter_mut()
        .map(|batch| {
            let mut tile_stats = ShadeStats::default();
            if cancelled(&cancel) {
                return tile_stats;
            }
            let batch = &mut **batch;
            shader.shade_batch(
                &batch.camera.rays,
                &batch.hits,
                &mut batch.radiance,
                &mut tile_stats,
            );
            tile_stats
        })
        .sum();
    stats.rays_traced += shading.rays_traced;
    stats.shading += shading;
    stats.add_time(Stage::Shade, start);
}

/// Weight: multiplies radiance by the lens weight (and in a spectral render turns it into what
/// its wavelength adds to the film, see [`crate::spectral`]); non-finite samples never reach
/// the film.
pub fn weight(mut tiles: Query<&mut TileBatch>, mut stats: ResMut<RenderStats>) {
    let start = Instant::now();
    let mut work: Vec<Mut<TileBatch>> = tiles.iter_mut().collect();
    let film = crate::spectral::spectral_film();
    let rejected: u64 = work
        .par_iter_mut()
        .map(|batch| {
            let TileBatch {
                camera, radiance, ..
            } = &mut **batch;
            let mut rejected = 0;
            let spectral = !camera.wavelength.is_empty();
            for i in 0..camera.weight.len() {
                let w = camera.weight[i];
                let (r, g, b) = (radiance.r[i] * w, radiance.g[i] * w, radiance.b[i] * w);
                let [r, g, b] = if spectral {
                    film.film_rgb(camera.wavelength[i], camera.wavelength_weight[i], [r, g, b])
                } else {
                    [r, g, b]
                };
                let finite = r.is_finite() && g.is_finite() && b.is_finite();
                rejected += u64::from(!finite);
                radiance.r[i] = if finite { r } else { 0.0 };
                radiance.g[i] = if finite { g } else { 0.0 };
                radiance.b[i] = if finite { b } else { 0.0 };
            }
            rejected
        })
        .sum();
    stats.rejected_samples += rejected;
    stats.add_time(Stage::Weight, start);
}

/// WriteFilm: adds the pass's weighted samples to each tile's sums.
pub fn write_film(
    mut tiles: Query<(&mut FilmTile, &TileBatch)>,
    mut pass: ResMut<PassState>,
    mut stats: ResMut<RenderStats>,
) {
    let start = Instant::now();
    let mut work: Vec<(Mut<FilmTile>, &TileBatch)> = tiles.iter_mut().collect();
    work.par_iter_mut().for_each(|(tile, batch)| {
        let tile = &mut **tile;
        // Camera rays were generated in `FilmTile::pixels` order: index i is local pixel i.
        for i in 0..tile.sum_r.len() {
            tile.sum_r[i] += batch.radiance.r[i];
            tile.sum_g[i] += batch.radiance.g[i];
            tile.sum_b[i] += batch.radiance.b[i];
        }
        tile.samples += 1;
    });
    pass.pending = false;
    stats.add_time(Stage::WriteFilm, start);
}

/// Owns the world and the schedule: the library's entry point for rendering.
pub struct Renderer {
    pub world: World,
    schedule: Schedule,
}

impl Default for Renderer {
    fn default() -> Self {
        Renderer::new()
    }
}

impl Renderer {
    pub fn new() -> Renderer {
        let mut world = World::new();
        world.init_resource::<RenderStats>();
        world.init_resource::<LensDerivationStats>();
        world.init_resource::<FilmFormat>();
        world.init_resource::<PassState>();
        world.init_resource::<RenderSettings>();
        Renderer {
            world,
            schedule: render_schedule(),
        }
    }

    /// Runs the schedule once; returns the fault a stage reported, if any.
    pub fn update(&mut self) -> anyhow::Result<()> {
        self.schedule.run(&mut self.world);
        if let Some(fault) = self.world.remove_resource::<PipelineFault>() {
            anyhow::bail!(fault.0);
        }
        Ok(())
    }

    /// Sets the scene; it loads (and its BVH builds) on the next update.
    pub fn set_scene(&mut self, source: SceneSource) {
        self.world.insert_resource(source);
    }

    /// Loads a glTF file now (scene and BVH), reporting any error.
    pub fn load_scene(&mut self, path: impl Into<PathBuf>) -> anyhow::Result<()> {
        self.set_scene(SceneSource {
            path: path.into(),
            embedded: None,
        });
        self.update()
    }

    /// Adds a lens (one entity per surface, under a lens entity) without activating it.
    pub fn add_lens(
        &mut self,
        prescription: &Prescription,
        focus: FocusSetting,
        aperture: ApertureSetting,
    ) -> Entity {
        spawn_lens(&mut self.world, prescription, focus, aperture)
    }

    /// Puts `diaphragm` (blades, a mask) on the stop of `lens`; `None`: the stop's circle.
    pub fn set_diaphragm(&mut self, lens: Entity, diaphragm: Option<Diaphragm>) {
        set_diaphragm(&mut self.world, lens, diaphragm);
    }

    /// Puts `movements` on `lens`, or takes them off (`None`), touching the component only
    /// when it changes.
    pub fn set_movements(&mut self, lens: Entity, movements: Option<FilmMovements>) {
        let mut entity = self.world.entity_mut(lens);
        match movements {
            Some(movements) if entity.get::<FilmMovements>() != Some(&movements) => {
                entity.insert(movements);
            }
            None if entity.contains::<FilmMovements>() => {
                entity.remove::<FilmMovements>();
            }
            _ => {}
        }
    }

    /// Makes `lens` the lens the next render uses.
    pub fn set_active_lens(&mut self, lens: Entity) {
        activate_lens(&mut self.world, lens);
    }

    /// Declares the render's target samples per pixel, over which camera samples are
    /// stratified (see [`SamplePlan`]).
    pub fn set_sample_plan(&mut self, samples_per_pixel: u32) {
        self.world.insert_resource(SamplePlan { samples_per_pixel });
    }

    /// Places the camera: `world_from_camera` is rigid, the camera looks down its −Z.
    pub fn set_camera(&mut self, world_from_camera: Mat4) {
        self.world.insert_resource(CameraPose(world_from_camera));
    }

    /// Sets the film diagonal (mm) and how camera rays sample the pupil.
    pub fn set_film(&mut self, diagonal_mm: f64, pupil_sampling: PupilSampling) {
        let film = FilmFormat {
            diagonal_mm,
            pupil_sampling,
        };
        if *self.world.resource::<FilmFormat>() != film {
            self.world.insert_resource(film);
        }
    }

    pub fn set_environment(&mut self, environment: Environment) {
        self.world.insert_resource(SceneEnvironment(environment));
    }

    /// Sets resolution, seed, depth; respawns the film tiles when the image size changed.
    pub fn set_settings(&mut self, settings: RenderSettings) {
        let resize = *self.world.resource::<RenderSettings>() != settings
            || self
                .world
                .query::<&FilmTile>()
                .iter(&self.world)
                .next()
                .is_none();
        if resize {
            let old: Vec<Entity> = self
                .world
                .query_filtered::<Entity, With<FilmTile>>()
                .iter(&self.world)
                .collect();
            for e in old {
                self.world.despawn(e);
            }
            for tile in tiles(settings.width, settings.height, settings.tile_size) {
                self.world.spawn((tile, TileBatch::default()));
            }
        }
        self.world.insert_resource(settings);
    }

    /// Errors if the active lens cannot be used (bad edit, impossible focus).
    pub fn check_active_lens(&mut self) -> anyhow::Result<()> {
        let mut faults = self.world.query_filtered::<&LensFault, With<ActiveLens>>();
        if let Some(fault) = faults.iter(&self.world).next() {
            anyhow::bail!(fault.0.clone());
        }
        let mut active = self.world.query_filtered::<Entity, With<ActiveLens>>();
        if active.iter(&self.world).next().is_none() {
            anyhow::bail!("no active lens");
        }
        Ok(())
    }

    /// Clears the film and renders samples 0..`spp`, calling `progress(done, total)` after each
    /// pass; stops early (keeping what was rendered) when `progress` returns false.
    pub fn render(
        &mut self,
        spp: u32,
        progress: impl FnMut(u32, u32) -> bool,
    ) -> anyhow::Result<Image> {
        self.render_sequence(None, SampleSequence::all(spp).iter(), progress)
    }

    /// Renders one pass per sample index in `samples`, in order, onto the film cleared or, with
    /// `start`, holding `start`'s sums (a resumed checkpoint). Each sample index keys its own
    /// random streams, so any split of the indices (shards, interruptions) sums to the same
    /// image. Stops early, keeping what was rendered, when `progress(done, total)` says false.
    pub fn render_samples(
        &mut self,
        start: Option<&Image>,
        samples: &[u32],
        progress: impl FnMut(u32, u32) -> bool,
    ) -> anyhow::Result<Image> {
        self.render_sequence(start, samples.iter().copied(), progress)
    }

    /// [`Renderer::render_samples`] over any sequence of sample indices (e.g. a
    /// [`SampleSequence`]), without listing them.
    pub fn render_sequence(
        &mut self,
        start: Option<&Image>,
        samples: impl ExactSizeIterator<Item = u32>,
        mut progress: impl FnMut(u32, u32) -> bool,
    ) -> anyhow::Result<Image> {
        self.begin_film(start)?;
        let total = samples.len() as u32;
        for (done, sample) in samples.enumerate() {
            self.render_pass(sample)?;
            if !progress(done as u32 + 1, total) {
                break;
            }
        }
        Ok(self.image())
    }

    /// Prepares a render: brings everything up to date, checks the active lens, and clears the
    /// film (or loads `start`'s sums into it).
    pub fn begin_film(&mut self, start: Option<&Image>) -> anyhow::Result<()> {
        self.update()?;
        self.check_active_lens()?;
        let (width, height) = {
            let settings = self.world.resource::<RenderSettings>();
            (settings.width, settings.height)
        };
        if let Some(image) = start
            && (image.width, image.height) != (width, height)
        {
            anyhow::bail!(
                "film of {}×{} cannot continue an image of {}×{}",
                width,
                height,
                image.width,
                image.height
            );
        }
        for mut tile in self
            .world
            .query::<&mut FilmTile>()
            .iter_mut(&mut self.world)
        {
            tile.clear();
            if let Some(image) = start {
                tile.load(image);
            }
        }
        Ok(())
    }

    /// Renders sample index `sample` into every pixel: one run of the pass stages.
    pub fn render_pass(&mut self, sample: u32) -> anyhow::Result<()> {
        self.world.insert_resource(PassState {
            pending: true,
            sample,
        });
        self.update()
    }

    /// [`Renderer::render_pass`] that a raised [`PassCancel`] flag may abandon: true when the
    /// pass reached the film, false when it was cancelled (the film holds none of it).
    pub fn render_pass_unless_cancelled(&mut self, sample: u32) -> anyhow::Result<bool> {
        self.render_pass(sample)?;
        let mut pass = self.world.resource_mut::<PassState>();
        let finished = !pass.pending;
        pass.pending = false;
        Ok(finished)
    }

    /// The film's current contents.
    pub fn image(&mut self) -> Image {
        let settings = self.world.resource::<RenderSettings>().clone();
        let mut query = self.world.query::<&FilmTile>();
        Image::from_tiles(settings.width, settings.height, query.iter(&self.world))
    }

    pub fn scene_cameras(&mut self) -> Vec<SceneCamera> {
        let mut cameras: Vec<SceneCamera> = self
            .world
            .query::<&SceneCamera>()
            .iter(&self.world)
            .cloned()
            .collect();
        cameras.sort_by_key(|c| c.index);
        cameras
    }
}
