//! What a render job is asked to do, as plain library data: the scene, the lenses and their
//! settings, the view, the film, the samples and the outputs. The command line builds one from
//! `realcam render`'s options; the live lab keeps one and edits it; [`Job`](super::Job) and
//! [`Session`](crate::live::session::Session) take nothing else.
//!
//! Its checks and messages name the command-line options (`--spp`, `--out`), the names users
//! know the settings by in every front end (the live lab's settings are those options too).

use crate::pipeline::RenderDevice;
use std::fmt;
use std::path::{Path, PathBuf};

use glam::Vec3;

use super::plan::{Shard, StopSweep, Sweep};
use crate::film::DEFAULT_IMAGE_SIDE;
use crate::film::filter::Filter;
use crate::lens::elements::{Dispersion, Flare};
use crate::lens::movements::FilmMovements;
use crate::lens::settings::LensSettings;

/// A render job's whole request.
#[derive(Clone, Debug)]
pub struct JobSpec {
    /// The glTF scene; `None`: the built-in scene.
    pub scene: Option<PathBuf>,
    /// Lens files or bundled lens names, one sequence of frames each; empty: the scene
    /// camera's hint, else the default lens.
    pub lenses: Vec<String>,
    /// Focus, stop, diaphragm and film format, for every lens of the job.
    pub lens: LensSettings,
    /// Where the camera stands and looks.
    pub view: ViewSpec,
    /// The light around the scene; `None`: chosen from the scene's own lights.
    pub environment: Option<EnvironmentSpec>,
    /// Samples per pixel.
    pub spp: u32,
    /// Image size in pixels; `None`: the scene camera's, else [`DEFAULT_IMAGE_SIDE`].
    pub width: Option<u32>,
    pub height: Option<u32>,
    /// The seed of every sample sequence.
    pub seed: u64,
    /// Worker threads; `None`: all cores.
    pub threads: Option<usize>,
    /// Where the passes render: the CPU's cores or a GPU.
    pub device: RenderDevice,
    /// Path length (1: direct lighting only).
    pub max_depth: u32,
    /// Whether camera rays carry wavelengths through the lens's glass.
    pub dispersion: Dispersion,
    /// Whether renders trace the lens's ghosts.
    pub flare: Flare,
    /// Wavelengths per camera sample when they do (1 ..= 8; see
    /// [`crate::lens::hero_wavelengths`]).
    pub wavelengths: u32,
    /// The film's reconstruction filter.
    pub filter: Filter,
    /// Focus on what this pixel sees (x, y from the top left).
    pub focus_on: Option<[u32; 2]>,
    /// Shift and tilt of the film.
    pub movements: FilmMovements,
    /// Render every zoom position of each zoom lens, one frame each (`--zoom-sweep`).
    pub zoom_sweep: bool,
    /// A rack focus: frames from near to far.
    pub focus_sweep: Option<Sweep>,
    /// A stop sweep: frames from one stop to another, by diameter or by f-number.
    pub stop_sweep: Option<StopSweep>,
    /// What is written, and where.
    pub output: OutputSpec,
}

/// Where the camera is: a scene camera, or a position and a point to look at.
#[derive(Clone, Debug)]
pub struct ViewSpec {
    /// A glTF camera by name or index; `None`: the first, else a view of the whole scene.
    pub camera: Option<String>,
    /// Camera position and the point it looks at (world, metres); both or neither.
    pub look_from: Option<Vec3>,
    pub look_at: Option<Vec3>,
    /// Up direction for `look_from`/`look_at`.
    pub up: Vec3,
}

impl Default for ViewSpec {
    fn default() -> ViewSpec {
        ViewSpec {
            camera: None,
            look_from: None,
            look_at: None,
            up: Vec3::Y,
        }
    }
}

/// The environment light.
#[derive(Clone, Debug, PartialEq)]
pub enum EnvironmentSpec {
    /// A uniform sky of this radiance (linear RGB, nits).
    Uniform(Vec3),
    /// An equirectangular `.exr`/`.hdr` image.
    Image(PathBuf),
}

impl fmt::Display for EnvironmentSpec {
    /// As `--env` takes it: `R,G,B` or the image's path.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EnvironmentSpec::Uniform(rgb) => write!(f, "{},{},{}", rgb.x, rgb.y, rgb.z),
            EnvironmentSpec::Image(path) => write!(f, "{}", path.display()),
        }
    }
}

/// A job's outputs and how 8-bit images are made.
#[derive(Clone, Debug)]
pub struct OutputSpec {
    /// The image (its extension sets the format; `-`: a PNG on standard output).
    pub out: PathBuf,
    /// The linear film (.exr or .hdr).
    pub exr: Option<PathBuf>,
    /// Exposure of the 8-bit outputs in stops; `None`: automatic.
    pub exposure: Option<f32>,
    /// JPEG quality, 1–100.
    pub quality: Option<u8>,
    /// Render statistics as JSON.
    pub stats: Option<PathBuf>,
    /// One labelled grid of every frame of the run.
    pub contact_sheet: Option<PathBuf>,
    /// Where interruptions and periodic saves write the render so far.
    pub checkpoint: Option<PathBuf>,
    /// Save a checkpoint every so many seconds of rendering.
    pub checkpoint_every: Option<f64>,
    /// Continue the render saved in this checkpoint.
    pub resume: Option<PathBuf>,
    /// Render only this shard of the samples, to a partial.
    pub shard: Option<Shard>,
    /// Where a shard's partial goes.
    pub partial: Option<PathBuf>,
}

impl OutputSpec {
    /// The output files with the options that name them (frames of sweeps and lens runs are
    /// suffixed copies of these).
    pub fn files(&self) -> Vec<(&'static str, &Path)> {
        [
            ("--out", Some(self.out.as_path())),
            ("--exr", self.exr.as_deref()),
            ("--stats", self.stats.as_deref()),
            ("--contact-sheet", self.contact_sheet.as_deref()),
            ("--checkpoint", self.checkpoint.as_deref()),
            ("--partial", self.partial.as_deref()),
        ]
        .into_iter()
        .filter_map(|(option, path)| Some((option, path?)))
        .collect()
    }
}

impl JobSpec {
    /// Wavelengths per camera sample whose arrays the CPU's pass batches hold (what the
    /// memory estimate counts): with dispersion on, `wavelengths` (a lens without glass data
    /// renders without, so this is an upper bound); 0 with it off, and 0 on the GPU, whose
    /// own buffers are checked against its limits.
    pub fn camera_wavelengths(&self) -> u32 {
        match (self.dispersion, self.device) {
            (Dispersion::On, RenderDevice::Cpu) => self.wavelengths,
            _ => 0,
        }
    }

    /// The image size the spec gives, each side [`DEFAULT_IMAGE_SIDE`] where it gives none.
    pub fn size_or_default(&self) -> (u32, u32) {
        (
            self.width.unwrap_or(DEFAULT_IMAGE_SIDE),
            self.height.unwrap_or(DEFAULT_IMAGE_SIDE),
        )
    }

    /// The film movements, `None` when there are none.
    pub fn movements(&self) -> Option<FilmMovements> {
        (!self.movements.is_none()).then_some(self.movements)
    }
}
