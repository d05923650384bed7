//! `realcam render`: a glTF scene through one or more lenses, to PNG/EXR; with focus and
//! stop sweeps, contact sheets, checkpoints, resume and render-farm shards. The options; the
//! work is the library's render job ([`crate::job`]).

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};

use super::interrupt::Interrupt;
use super::options::LensOptions;
use super::values::{number, parse_pair, parse_pixel, parse_vec3, whole};
use super::{Cli, Command};
use crate::film::filter::Filter;
use crate::film::{MAX_IMAGE_SIDE, MAX_SPP};
use crate::job::plan::{Shard, StopSweep, Sweep};
use crate::job::spec::{EnvironmentSpec, JobSpec, OutputSpec, ViewSpec};
use crate::job::{Job, Progress, outputs::validate};
use crate::lens::elements::{Dispersion, Flare};
use crate::lens::movements::FilmMovements;
use crate::memory::MAX_THREADS;
use crate::pipeline::RenderDevice;

// The field docs are `--help` text for a terminal: brackets there are clap's "[default: …]"
// and JSON, not rustdoc links.
#[allow(rustdoc::broken_intra_doc_links)]
#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    /// glTF 2.0 scene (.gltf or .glb) [default: the built-in dof-dragons scene].
    pub scene: Option<PathBuf>,
    /// Lens prescription file or bundled lens name; repeat it to render through several lenses
    /// in one run (scene loaded and BVH built once) [default: the scene camera's hint, else
    /// dgauss.50mm].
    #[arg(long, value_name = "FILE")]
    pub lens: Vec<String>,
    /// Samples per pixel (at most 16777216 = 2^24: beyond it the film's f32 sums cannot take
    /// in another sample).
    #[arg(
        long,
        default_value_t = 64,
        value_name = "N",
        allow_hyphen_values = true,
        value_parser = whole::<u32>(1, MAX_SPP)
    )]
    pub spp: u32,
    /// Image width in pixels [default: 512].
    #[arg(long, value_name = "W", allow_hyphen_values = true, value_parser = whole::<u32>(1, MAX_IMAGE_SIDE))]
    pub width: Option<u32>,
    /// Image height in pixels [default: 512].
    #[arg(long, value_name = "H", allow_hyphen_values = true, value_parser = whole::<u32>(1, MAX_IMAGE_SIDE))]
    pub height: Option<u32>,
    #[command(flatten)]
    pub lens_options: LensOptions,
    /// glTF camera to render from, by node/camera name or index [default: the first camera,
    /// else a view of the whole scene from +z].
    #[arg(long, value_name = "NAME|INDEX")]
    pub camera: Option<String>,
    /// Camera position (world, metres); with --look-at, overrides the scene camera.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, requires = "look_at", allow_hyphen_values = true)]
    pub look_from: Option<Vec3>,
    /// Point the camera looks at (and focuses on, unless a focus is given).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, requires = "look_from", allow_hyphen_values = true)]
    pub look_at: Option<Vec3>,
    /// Up direction for --look-from/--look-at.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, default_value = "0,1,0", allow_hyphen_values = true)]
    pub up: Vec3,
    /// Environment: a uniform sky `R,G,B` (nits) or an equirectangular .exr/.hdr image
    /// [default: black if the scene has lights or emitters, else a white sky of 1 nit].
    #[arg(long, value_name = "R,G,B|FILE", allow_hyphen_values = true)]
    pub env: Option<String>,
    /// Random seed; the same seed gives the same image whatever the thread count.
    #[arg(long, default_value_t = 0, value_name = "S", allow_hyphen_values = true, value_parser = whole::<u64>(0, u64::MAX))]
    pub seed: u64,
    /// Worker threads, at most 1024 [default: all cores].
    #[arg(long, value_name = "N", allow_hyphen_values = true, value_parser = whole::<usize>(1, MAX_THREADS))]
    pub threads: Option<usize>,
    /// Where the passes render: `cpu` (all cores, or --threads) or `gpu` (the best adapter
    /// `realcam devices` lists; the same image, within noise).
    #[arg(long, value_name = "cpu|gpu", default_value = "cpu")]
    pub device: RenderDevice,
    /// Path length: 1 = direct lighting only.
    #[arg(
        long,
        default_value_t = 8,
        value_name = "D",
        allow_hyphen_values = true,
        value_parser = whole::<u32>(1, u32::MAX)
    )]
    pub max_depth: u32,
    /// Output image; its extension sets the format: .png, .jpg/.jpeg, .tif/.tiff (8-bit sRGB,
    /// tone-mapped) or .exr, .hdr (linear float); `-` writes a PNG to standard output.
    #[arg(long, default_value = "render.png", value_name = "FILE")]
    pub out: PathBuf,
    /// Also write the linear, un-tonemapped film: .exr (OpenEXR) or .hdr (Radiance); `-`
    /// writes OpenEXR to standard output.
    #[arg(long, value_name = "FILE.exr")]
    pub exr: Option<PathBuf>,
    /// Exposure of the 8-bit outputs in stops: pixel = film irradiance × 2^EV [default:
    /// automatic, the log-average luminance of the pixels within 10 stops of the image's
    /// brightest percent to 18 % grey].
    #[arg(long, value_name = "EV", allow_hyphen_values = true, value_parser = number::<f32>)]
    pub exposure: Option<f32>,
    /// JPEG quality of a .jpg/.jpeg output, 1–100 [default: 90].
    #[arg(long, value_name = "Q", allow_hyphen_values = true, value_parser = whole::<u8>(1, 100))]
    pub quality: Option<u8>,
    /// Write render statistics as JSON (`-`: to standard output).
    #[arg(long, value_name = "FILE.json")]
    pub stats: Option<PathBuf>,
    /// Render every zoom position of each zoom lens (`realcam lens NAME --json` lists them), one
    /// frame each, named `<out>-000-zoom1.png`, … (a lens with fixed spacings renders once).
    #[arg(long, conflicts_with_all = ["zoom_position", "zoom_focal_length"])]
    pub zoom_sweep: bool,
    /// Rack focus: render FRAMES frames focused from NEAR to FAR metres (evenly in dioptres),
    /// numbered `<out>-000.png`, … ; with several lenses, each lens gets its sequence.
    #[arg(long, value_name = "NEAR:FAR:FRAMES", allow_hyphen_values = true, conflicts_with_all = ["focus_distance", "film_distance"])]
    pub focus_sweep: Option<Sweep>,
    /// Stop sweep: FRAMES frames with the stop diameter from A to B mm (evenly in stops).
    #[arg(long, value_name = "A:B:FRAMES", allow_hyphen_values = true, conflicts_with_all = ["aperture", "f_number"])]
    pub aperture_sweep: Option<Sweep>,
    /// Stop sweep by f-number: FRAMES frames with the real f-number from A to B, evenly in
    /// stops (N_i = A·(B/A)^(i/(FRAMES−1))), named `<out>-000-f2.png`, ….
    #[arg(long, value_name = "A:B:FRAMES", allow_hyphen_values = true, conflicts_with_all = ["aperture", "f_number", "aperture_sweep"])]
    pub f_number_sweep: Option<Sweep>,
    /// Also write one picture of every render of the run, in a labelled grid (.png, .jpg or
    /// .tif).
    #[arg(long, value_name = "FILE.png")]
    pub contact_sheet: Option<PathBuf>,
    /// Where Ctrl-C, SIGTERM and --checkpoint-every save the render so far [default:
    /// `<out stem>.checkpoint.exr`, for a shard `<out stem>.shard-I-of-N.checkpoint.exr`].
    #[arg(long, value_name = "FILE.exr")]
    pub checkpoint: Option<PathBuf>,
    /// Also save a checkpoint every SECONDS of rendering.
    #[arg(long, value_name = "SECONDS", allow_hyphen_values = true, value_parser = number::<f64>)]
    pub checkpoint_every: Option<f64>,
    /// Continue the render saved in CHECKPOINT (same scene and settings, and the same --shard
    /// for a shard's checkpoint) to the target --spp.
    #[arg(long, value_name = "CHECKPOINT", conflicts_with_all = ["zoom_sweep", "focus_sweep", "aperture_sweep", "f_number_sweep"])]
    pub resume: Option<PathBuf>,
    /// Render only the I-th (0-based) of N disjoint sample subsets, to a partial EXR that
    /// `realcam merge` combines (one shard per render-farm task).
    #[arg(long, value_name = "I/N", allow_hyphen_values = true, conflicts_with_all = ["zoom_sweep", "focus_sweep", "aperture_sweep", "f_number_sweep"])]
    pub shard: Option<Shard>,
    /// Colour from the lens's glass: `on` gives every camera ray its own wavelength, refracted
    /// with each glass's index at it (axial and lateral colour, from the glass data); `off`
    /// renders every ray at the lens file's indices (n_d), as for a lens without glass data.
    #[arg(long, value_name = "on|off", default_value = "on")]
    pub dispersion: Switch,
    /// Ghosts: `on` traces the light the lens's surfaces reflect twice on to the film (one
    /// camera sample in 16 follows such a path), `off` leaves it out; a lens whose surfaces
    /// reflect nothing (`--coating ideal`) has none either way.
    #[arg(long, value_name = "on|off", default_value = "on")]
    pub flare: Switch,
    /// Wavelengths each camera sample carries when it disperses, 1–8: one scene path serves
    /// them all (each traced back through the lens to its own film point), so a grey surface
    /// renders grey instead of in colour speckles; 1 is one wavelength per sample.
    #[arg(
        long,
        default_value_t = crate::lens::hero_wavelengths::DEFAULT_WAVELENGTHS,
        value_name = "N",
        allow_hyphen_values = true,
        value_parser = whole::<u32>(1, crate::lens::hero_wavelengths::MAX_WAVELENGTHS)
    )]
    pub wavelengths: u32,
    /// The film's reconstruction filter: `tent` (radius 1.5 pixels) shares each sample's light
    /// among the pixels around the point it lands on, so a sample's wavelengths, which the
    /// lens's colour lands a fraction of a pixel apart, stay together and grey stays grey;
    /// `gaussian` (σ 0.5, radius 1.5 pixels, pbrt-v4's) is a little sharper and grainier;
    /// `box` gives each sample to the one pixel it lands in (sharpest, most colour grain).
    #[arg(long, value_name = "tent|gaussian|box", default_value = "tent", allow_hyphen_values = true, value_parser = parse_filter)]
    pub filter: Filter,
    /// Focus on what pixel X,Y sees ((0,0): the top-left pixel): a probe ray through the real
    /// lens finds the point, and the film distance that brings its real-ray image into
    /// sharpest focus is solved; each lens of the run focuses on it.
    #[arg(long, value_name = "X,Y", value_parser = parse_pixel, allow_hyphen_values = true, conflicts_with_all = ["focus_distance", "film_distance", "focus_sweep"])]
    pub focus_on: Option<[u32; 2]>,
    /// Shift the frame across the image circle, mm in the film plane: positive Y shows more of
    /// the scene above, positive X more to the right (as a shift lens raised or moved right).
    #[arg(long, value_name = "X,Y", value_parser = parse_pair, allow_hyphen_values = true)]
    pub shift: Option<[f64; 2]>,
    /// Tilt the film plane about the frame's horizontal (X) and vertical (Y) axes, degrees
    /// (under 60): positive X tips the plane of sharp focus down toward the ground ahead,
    /// positive Y makes the picture's right focus nearer (Scheimpflug).
    #[arg(long, value_name = "X,Y", value_parser = parse_pair, allow_hyphen_values = true)]
    pub tilt: Option<[f64; 2]>,
    /// Where a shard's partial goes [default: `<out stem>.shard-I-of-N.exr`].
    #[arg(long, value_name = "FILE.exr", requires = "shard")]
    pub partial: Option<PathBuf>,
}

impl RenderArgs {
    /// The job these options ask for.
    pub fn spec(&self) -> JobSpec {
        let RenderArgs {
            scene,
            lens,
            spp,
            width,
            height,
            lens_options,
            camera,
            look_from,
            look_at,
            up,
            env,
            seed,
            threads,
            device,
            max_depth,
            out,
            exr,
            exposure,
            quality,
            stats,
            zoom_sweep,
            focus_sweep,
            aperture_sweep,
            f_number_sweep,
            contact_sheet,
            checkpoint,
            checkpoint_every,
            resume,
            shard,
            dispersion,
            flare,
            wavelengths,
            filter,
            focus_on,
            shift,
            tilt,
            partial,
        } = self.clone();
        JobSpec {
            scene,
            lenses: lens,
            lens: lens_options.settings(),
            view: ViewSpec {
                camera,
                look_from,
                look_at,
                up,
            },
            // `R,G,B` is a sky; anything else names an image.
            environment: env.map(|text| match parse_vec3(&text) {
                Ok(rgb) => EnvironmentSpec::Uniform(rgb),
                Err(_) => EnvironmentSpec::Image(PathBuf::from(text)),
            }),
            spp,
            width,
            height,
            seed,
            threads,
            device,
            max_depth,
            dispersion: if dispersion.0 {
                Dispersion::On
            } else {
                Dispersion::Off
            },
            flare: if flare.0 { Flare::On } else { Flare::Off },
            wavelengths,
            filter,
            focus_on,
            movements: FilmMovements {
                shift_mm: shift.unwrap_or_default(),
                tilt_deg: tilt.unwrap_or_default(),
            },
            zoom_sweep,
            focus_sweep,
            stop_sweep: aperture_sweep
                .map(StopSweep::Diameter)
                .or(f_number_sweep.map(StopSweep::FNumber)),
            output: OutputSpec {
                out,
                exr,
                exposure,
                quality,
                stats,
                contact_sheet,
                checkpoint,
                checkpoint_every,
                resume,
                shard,
                partial,
            },
        }
    }
}

/// Reads `realcam render` arguments (without the program and command names) as the command
/// line does, with its messages: the parser a live session reads its settings with.
pub fn parse_render_arguments(arguments: &[String]) -> Result<JobSpec, String> {
    let argv = ["realcam", "render"]
        .into_iter()
        .map(String::from)
        .chain(arguments.iter().cloned());
    match Cli::try_parse_from_args(argv)? {
        Some(Command::Render(args)) => {
            let spec = args.spec();
            spec.lens.validate().map_err(|e| e.to_string())?;
            Ok(spec)
        }
        _ => Err("not a render command".into()),
    }
}

pub fn run(args: &RenderArgs) -> anyhow::Result<ExitCode> {
    let spec = args.spec();
    let formats = validate(&spec)?;
    if let Some(threads) = spec.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build_global()
            .context("cannot start worker threads")?;
    }
    let interrupt = Interrupt::install()?;
    let job = Job::prepare(&spec, formats)?;
    let stopped = job.run(&|| interrupt.requested(), &mut Bar(None))?;
    Ok(stopped.map_or(ExitCode::SUCCESS, ExitCode::from))
}

/// `--filter`'s value.
fn parse_filter(s: &str) -> Result<Filter, String> {
    Filter::from_name(s).ok_or_else(|| format!("unknown filter '{s}': use tent, gaussian or box"))
}

/// An `on|off` option's value (`--dispersion`, `--flare`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Switch(pub bool);

impl std::str::FromStr for Switch {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "on" => Ok(Switch(true)),
            "off" => Ok(Switch(false)),
            other => Err(format!("unknown setting '{other}': use on or off")),
        }
    }
}

/// A progress bar on standard error when it is a terminal.
struct Bar(Option<ProgressBar>);

impl Progress for Bar {
    fn begin(&mut self, passes: u32, pixels: u32) {
        self.0 = Some(progress_bar(passes, pixels));
    }

    fn advance(&mut self, done: u32) {
        if let Some(bar) = &self.0 {
            bar.set_position(done as u64);
        }
    }

    fn finish(&mut self) {
        if let Some(bar) = self.0.take() {
            bar.finish_and_clear();
        }
    }
}

fn progress_bar(spp: u32, pixels: u32) -> ProgressBar {
    if !std::io::stderr().is_terminal() {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(spp as u64);
    let per_pass = pixels as f64;
    bar.set_style(
        ProgressStyle::with_template(
            "{bar:40.cyan/blue} {pos}/{len} spp  {per_sec_samples}  ETA {eta}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .with_key(
            "per_sec_samples",
            move |state: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                let _ = write!(w, "{:.2} M samples/s", state.per_sec() * per_pass / 1e6);
            },
        ),
    );
    bar
}
