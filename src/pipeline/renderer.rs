//! The [`Renderer`]: the world and the render schedule, and the calls through which a front
//! end sets a scene, lenses, camera and film and renders passes.

use std::path::PathBuf;

use bevy_ecs::entity::Entity;
use bevy_ecs::query::With;
use bevy_ecs::schedule::Schedule;
use bevy_ecs::world::World;
use glam::Mat4;

use super::device::{GpuBackend, RenderDevice};
use super::render_schedule;
use super::resources::{
    PassState, PipelineFault, RenderSettings, RenderStats, SceneEnvironment, SceneSource, TileBatch,
};
use crate::film::samples::SampleSequence;
use crate::film::{FilmTile, Image, tiles};
use crate::gpu::GpuContext;
use crate::gpu::film::GpuFilm;
use crate::lens::Prescription;
use crate::lens::aperture::ApertureSetting;
use crate::lens::camera::CameraPose;
use crate::lens::diaphragm::Diaphragm;
use crate::lens::elements::{
    ActiveLens, CoatingChoice, FilmFormat, FocusSetting, LensDerivationStats, LensFault,
    activate_lens, set_coating_choice, set_diaphragm, set_zoom_position, spawn_lens,
};
use crate::lens::focus_probe::LensesSettling;
use crate::lens::movements::FilmMovements;
use crate::lens::pupil::PupilSampling;
use crate::scene::SceneCamera;
use crate::shade::Environment;

/// Schedule runs one update makes at most while a lens settles its focus groups on a pixel
/// ([`LensesSettling`]); each round moves them by far less than the last.
const SETTLING_ROUNDS: usize = 8;

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
        let settings = RenderSettings::default();
        world.insert_resource(settings.film_resolution());
        world.insert_resource(settings);
        Renderer {
            world,
            schedule: render_schedule(),
        }
    }

    /// Chooses where the passes render. A GPU is opened here (once per process, see
    /// [`GpuContext::shared`]): a machine without one is an error that says so.
    pub fn set_device(&mut self, device: RenderDevice) -> anyhow::Result<()> {
        match device {
            RenderDevice::Cpu => {
                // Passes the GPU rendered come back to the tiles before it stands aside.
                super::gpu::read_film_back(&mut self.world)?;
                self.world.remove_resource::<GpuBackend>();
            }
            RenderDevice::Gpu => {
                let context =
                    GpuContext::shared().map_err(|why| anyhow::anyhow!("--device gpu: {why}"))?;
                self.world.insert_resource(GpuBackend(context));
                super::gpu::init_resources(&mut self.world);
            }
        }
        Ok(())
    }

    /// Where the passes render.
    pub fn device(&self) -> RenderDevice {
        if self.world.contains_resource::<GpuBackend>() {
            RenderDevice::Gpu
        } else {
            RenderDevice::Cpu
        }
    }

    /// Runs the schedule once; returns the fault a stage reported, if any.
    pub fn update(&mut self) -> anyhow::Result<()> {
        // A lens focusing on a pixel with its focus groups moves them and probes again through
        // the re-derived lens (see `lens::focus_probe`); a few rounds settle it.
        for _ in 0..SETTLING_ROUNDS {
            self.schedule.run(&mut self.world);
            if self.world.remove_resource::<LensesSettling>().is_none() {
                break;
            }
        }
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

    /// Sets the zoom position `lens` renders at (0-based; `None`: as its surfaces are written).
    pub fn set_zoom_position(&mut self, lens: Entity, position: Option<usize>) {
        set_zoom_position(&mut self.world, lens, position);
    }

    /// Sets how the surfaces of `lens` are coated.
    pub fn set_coating_choice(&mut self, lens: Entity, choice: CoatingChoice) {
        set_coating_choice(&mut self.world, lens, choice);
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
        // The lens systems see the film's size through its own resource (the lens does not
        // read the pipeline's settings); written with the settings, so it changes with them.
        self.world.insert_resource(settings.film_resolution());
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

    /// Clears the film and renders samples 0..`spp` in the device's batches
    /// ([`Renderer::passes_per_update`]), calling `progress(done, total)` after each; stops
    /// early (keeping what was rendered) when `progress` returns false.
    pub fn render(
        &mut self,
        spp: u32,
        mut progress: impl FnMut(u32, u32) -> bool,
    ) -> anyhow::Result<Image> {
        self.begin_film(None)?;
        let samples = SampleSequence::all(spp);
        let per_update = self.passes_per_update();
        let mut done = 0;
        while done < spp {
            let batch = samples.after(done).first_n(per_update);
            self.render_passes(batch)?;
            done += batch.count;
            if !progress(done, spp) {
                break;
            }
        }
        self.image()
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
        self.image()
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
        super::gpu::film_cleared(&mut self.world);
        Ok(())
    }

    /// Renders sample index `sample` into every pixel: one run of the pass stages.
    pub fn render_pass(&mut self, sample: u32) -> anyhow::Result<()> {
        self.world.insert_resource(PassState {
            pending: true,
            sample,
            step: 1,
            count: 1,
        });
        self.update()
    }

    /// How many passes one update should render: one on the CPU (its passes are long and
    /// parallel inside); on a GPU enough for about sixteen million samples a dispatch, so that
    /// the CPU's share of a pass (the schedule, the submission) does not leave the GPU idle.
    pub fn passes_per_update(&self) -> u32 {
        if !self.world.contains_resource::<GpuBackend>() {
            return 1;
        }
        let settings = self.world.resource::<RenderSettings>();
        GpuFilm::samples_per_pixel_per_dispatch(settings.width as u64 * settings.height as u64)
    }

    /// Renders the sample indices of `samples`: in one update on a GPU (see
    /// [`Renderer::passes_per_update`] for how many to ask for), one pass per index on the CPU.
    /// The film is the same either way.
    pub fn render_passes(&mut self, samples: SampleSequence) -> anyhow::Result<()> {
        if samples.is_empty() {
            return Ok(());
        }
        if !self.world.contains_resource::<GpuBackend>() {
            for sample in samples.iter() {
                self.render_pass(sample)?;
            }
            return Ok(());
        }
        self.world.insert_resource(PassState {
            pending: true,
            sample: samples.first,
            step: samples.step,
            count: samples.count,
        });
        self.update()
    }

    /// [`Renderer::render_pass`] that a raised [`PassCancel`](super::PassCancel) flag may abandon: true when the
    /// pass reached the film, false when it was cancelled (the film holds none of it).
    pub fn render_pass_unless_cancelled(&mut self, sample: u32) -> anyhow::Result<bool> {
        self.render_pass(sample)?;
        let mut pass = self.world.resource_mut::<PassState>();
        let finished = !pass.pending;
        pass.pending = false;
        Ok(finished)
    }

    /// The film's current contents (on a GPU, read back from it first).
    pub fn image(&mut self) -> anyhow::Result<Image> {
        super::gpu::read_film_back(&mut self.world)?;
        let settings = self.world.resource::<RenderSettings>().clone();
        let mut query = self.world.query::<&FilmTile>();
        Ok(Image::from_tiles(
            settings.width,
            settings.height,
            query.iter(&self.world),
        ))
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
