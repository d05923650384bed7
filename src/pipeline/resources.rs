//! The render world's resources and the components the stages share: what a front end sets
//! (scene, settings, cancel flag), what the scene stages leave behind, and what
//! the pass stages hand each other and count.

use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use bevy_ecs::component::Component;
use bevy_ecs::resource::Resource;

use super::Stage;
use crate::batch::HitBatch;
use crate::film::DEFAULT_IMAGE_SIDE;
use crate::film::filter::Filter;
use crate::lens::camera::{CameraRays, FilmResolution};
use crate::scene::Bounds;
use crate::shade::{Environment, RadianceBatch, ShadeStats};

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
    /// Wavelengths per camera sample in a spectral render (see
    /// [`crate::lens::hero_wavelengths`]).
    pub wavelengths: u32,
    /// How each share of a sample spreads over the pixels around its film point.
    pub filter: Filter,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: DEFAULT_IMAGE_SIDE,
            height: DEFAULT_IMAGE_SIDE,
            seed: 0,
            max_depth: 8,
            tile_size: 32,
            wavelengths: crate::lens::hero_wavelengths::DEFAULT_WAVELENGTHS,
            filter: Filter::default(),
        }
    }
}

impl RenderSettings {
    /// The film's size in pixels, the part of the settings the lens systems read.
    pub fn film_resolution(&self) -> FilmResolution {
        FilmResolution {
            width: self.width,
            height: self.height,
        }
    }
}

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
    /// On a GPU, the passes of one update: `count` sample indices from `sample` in steps of
    /// `step`, in one dispatch (each pixel adds them to its sums in index order, so the film
    /// is the same as after `count` single passes). The CPU renders one pass per update.
    pub step: u32,
    pub count: u32,
}

/// A flag another thread raises to abandon the pass under way (a live session whose settings
/// changed): the pass stages skip their remaining tiles and the film keeps none of the pass.
#[derive(Resource, Clone, Debug, Default)]
pub struct PassCancel(pub Arc<AtomicBool>);

impl PassCancel {
    pub fn requested(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }

    /// Whether `cancel`, a flag the world may not have, is raised.
    pub(super) fn raised(cancel: Option<&PassCancel>) -> bool {
        cancel.is_some_and(PassCancel::requested)
    }
}

/// A stage that could not do its work; the driver turns it into an error.
#[derive(Resource, Clone, Debug)]
pub struct PipelineFault(pub String);

/// Counters and wall times for `--stats`.
#[derive(Resource, Clone, Debug, Default)]
pub struct RenderStats {
    pub stage_time: [Duration; Stage::ALL.len()],
    /// Per stage, the time spent inside its per-tile work summed over the tiles: set against
    /// `stage_time` × threads it says how long the workers sat idle (waiting for the stage's
    /// last tiles) rather than worked. A tile that waits on its own parallel work (the rays'
    /// traversal and shading split again) may run another tile meanwhile, and both count: the
    /// sum can exceed `stage_time` × threads by that overlap, a few per cent at 16 threads.
    pub stage_busy: [Duration; Stage::ALL.len()],
    pub scene_loads: u64,
    pub bvh_builds: u64,
    pub triangles: u64,
    pub bvh_nodes: u64,
    pub camera_samples: u64,
    pub lens_rays_passed: u64,
    pub rays_traced: u64,
    pub rejected_samples: u64,
    /// Compiling the GPU's pass kernel (set-up, once per renderer; not in any stage's time).
    pub gpu_kernel_time: Duration,
    /// Each GPU kernel's own time on the device, by name, when the render timed them
    /// (`REALCAM_GPU_TIMESTAMPS=1`; see [`crate::gpu::compute::StepClock`]).
    pub gpu_kernel_busy: std::collections::BTreeMap<&'static str, Duration>,
    /// What shading met: escaped rays, emitters, light samples and their fate (its rays are
    /// also counted in `rays_traced`).
    pub shading: ShadeStats,
}

impl RenderStats {
    pub(super) fn add_time(&mut self, stage: Stage, start: Instant) {
        self.stage_time[stage as usize] += start.elapsed();
    }

    pub(super) fn add_busy(&mut self, stage: Stage, busy: Duration) {
        self.stage_busy[stage as usize] += busy;
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
    /// Weighted radiance this tile's samples add to other pixels than their own (several
    /// wavelengths per sample), in ray order.
    pub splats: Vec<crate::film::splat::Splat>,
    /// With a filter wider than a pixel, what this tile's samples add around their film points.
    pub spread: crate::film::splat::Spread,
}
