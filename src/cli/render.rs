//! `realcam render`: a glTF scene through one or more lenses, to PNG/EXR; with focus and
//! stop sweeps, contact sheets, checkpoints, resume and render-farm shards.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, bail};
use bevy_ecs::entity::Entity;
use clap::Args;
use glam::{Mat4, Vec3};
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::{Value, json};

use super::interrupt::Interrupt;
use super::options::LensOptions;
use super::plan::{Frame, FrameRequest, Shard, Sweep, frame_count, plan_frames, sidecar};
use super::setup::{Placement, autofocus, choose_environment, frame_scene, place_camera};
use super::values::{number, parse_pair, parse_pixel, parse_vec3, whole};
use crate::diagnosis::{SceneLighting, black_image, black_picture};
use crate::film::checkpoint::{
    CheckpointInfo, FORMAT_VERSION, Invocation, read_checkpoint, write_checkpoint,
};
use crate::film::contact_sheet::{Thumbnail, contact_sheet};
use crate::film::footprint::RunSize;
use crate::film::format::{
    Accepts, DEFAULT_JPEG_QUALITY, ImageFormat, Tone, check_tone_options, encode_rgb8,
    output_format, require_extension,
};
use crate::film::output::{
    auto_exposure, check_not_terminal, check_writable, is_stdout, same_file, shown, to_srgb8,
    write_image, write_output,
};
use crate::film::samples::SampleSequence;
use crate::film::{Image, MAX_IMAGE_SIDE, MAX_SPP};
use crate::lens::Prescription;
use crate::lens::aperture::ApertureSetting;
use crate::lens::bundled::{DEFAULT_LENS, load_lens};
use crate::lens::camera::FilmGeometry;
use crate::lens::diaphragm::Diaphragm;
use crate::lens::elements::{
    Dispersion, FilmPlacement, FocusSetting, LensDerivationStats, LensGeometry,
};
use crate::lens::focus_probe::{FocusOnPixel, FocusProbe};
use crate::lens::movements::{FilmMovements, check_coverage};
use crate::memory::MAX_THREADS;
use crate::pipeline::{
    RenderSettings, RenderStats, Renderer, SceneInputs, SceneSource, SceneWarnings, Stage,
};
use crate::scene::default_scene::{DEFAULT_SCENE_GLB, DEFAULT_SCENE_PATH};
use crate::scene::{CameraHints, referenced_files};

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
    /// automatic, the image's log-average luminance to 18 % grey].
    #[arg(long, value_name = "EV", allow_hyphen_values = true, value_parser = number::<f32>)]
    pub exposure: Option<f32>,
    /// JPEG quality of a .jpg/.jpeg output, 1–100 [default: 90].
    #[arg(long, value_name = "Q", allow_hyphen_values = true, value_parser = whole::<u8>(1, 100))]
    pub quality: Option<u8>,
    /// Write render statistics as JSON (`-`: to standard output).
    #[arg(long, value_name = "FILE.json")]
    pub stats: Option<PathBuf>,
    /// Rack focus: render FRAMES frames focused from NEAR to FAR metres (evenly in dioptres),
    /// numbered `<out>-000.png`, … ; with several lenses, each lens gets its sequence.
    #[arg(long, value_name = "NEAR:FAR:FRAMES", allow_hyphen_values = true, conflicts_with_all = ["focus_distance", "film_distance"])]
    pub focus_sweep: Option<Sweep>,
    /// Stop sweep: FRAMES frames with the stop diameter from A to B mm (evenly in stops).
    #[arg(long, value_name = "A:B:FRAMES", allow_hyphen_values = true, conflicts_with_all = ["aperture", "f_number"])]
    pub aperture_sweep: Option<Sweep>,
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
    #[arg(long, value_name = "CHECKPOINT", conflicts_with_all = ["focus_sweep", "aperture_sweep"])]
    pub resume: Option<PathBuf>,
    /// Render only the I-th (0-based) of N disjoint sample subsets, to a partial EXR that
    /// `realcam merge` combines (one shard per render-farm task).
    #[arg(long, value_name = "I/N", allow_hyphen_values = true, conflicts_with_all = ["focus_sweep", "aperture_sweep"])]
    pub shard: Option<Shard>,
    /// Colour from the lens's glass: `on` gives every camera ray its own wavelength, refracted
    /// with each glass's index at it (axial and lateral colour, from the glass data); `off`
    /// renders every ray at the lens file's indices (n_d), as for a lens without glass data.
    #[arg(long, value_name = "on|off", default_value = "on")]
    pub dispersion: DispersionArg,
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

/// A lens of the run: its prescription, entity and the defaults its frames start from.
struct RunLens {
    prescription: Prescription,
    entity: Entity,
    focus: FocusSetting,
    aperture: ApertureSetting,
}

/// What one frame reported.
struct FrameReport {
    out: PathBuf,
    lens: String,
    focal_length_mm: f64,
    f_number: f64,
    focus: FocusSetting,
    film_distance_mm: f64,
    /// What --focus-on found.
    probe: Option<FocusProbe>,
    lens_derivation_seconds: f64,
    render_seconds: f64,
    samples: u32,
    /// Warnings about the frame's image (why it is black).
    warnings: Vec<String>,
}

impl FrameReport {
    fn caption(&self) -> String {
        let focus = match (self.probe, self.focus) {
            (Some(probe), _) => format!(
                "focus {:.2} m (pixel {},{})",
                probe.object_distance_mm / 1e3,
                probe.pixel[0],
                probe.pixel[1]
            ),
            (None, FocusSetting::Distance { metres, .. }) => format!("focus {metres:.2} m"),
            (None, FocusSetting::FilmDistance(mm)) => format!("film at {mm:.2} mm"),
        };
        format!(
            "{}\nf={:.1}mm f/{:.1}\n{focus}",
            self.lens, self.focal_length_mm, self.f_number
        )
    }

    fn to_json(&self) -> Value {
        json!({
            "out": self.out.display().to_string(),
            "lens": self.lens,
            "focal_length_mm": self.focal_length_mm,
            "f_number": self.f_number,
            "focus_distance_m": match (self.probe, self.focus) {
                (Some(probe), _) => json!(probe.object_distance_mm / 1e3),
                (None, FocusSetting::Distance { metres, .. }) => json!(metres),
                (None, FocusSetting::FilmDistance(_)) => Value::Null,
            },
            "focus_on": self.probe.map(|p| p.pixel),
            "film_distance_mm": self.film_distance_mm,
            "lens_derivation_seconds": self.lens_derivation_seconds,
            "render_seconds": self.render_seconds,
            "samples": self.samples,
            "warnings": self.warnings,
        })
    }
}

/// How a frame ended.
enum Outcome {
    Finished(Box<FrameReport>, Image),
    Interrupted(u8),
}

pub fn run(args: &RenderArgs) -> anyhow::Result<ExitCode> {
    let formats = validate(args)?;
    let diaphragm = args.lens_options.diaphragm()?;
    if let Some(threads) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build_global()
            .context("cannot start worker threads")?;
    }
    let interrupt = Interrupt::install()?;
    let start = Instant::now();
    let mut renderer = Renderer::new();
    let source = match &args.scene {
        Some(path) => SceneSource {
            path: path.clone(),
            embedded: None,
        },
        None => SceneSource {
            path: PathBuf::from(DEFAULT_SCENE_PATH),
            embedded: Some(DEFAULT_SCENE_GLB),
        },
    };
    let source_path = source.path.clone();
    renderer.set_scene(source);
    renderer.update()?;
    for warning in &renderer.world.resource::<SceneWarnings>().0 {
        eprintln!("warning: {warning}");
    }
    refuse_overwriting_scene_files(args, &renderer.world.resource::<SceneInputs>().0)?;
    let environment = choose_environment(args, &mut renderer)?;
    renderer.set_environment(environment);

    let placement = place_camera(args, &mut renderer)?;
    let specs: Vec<String> = if args.lens.is_empty() {
        vec![
            placement
                .hints
                .lens
                .clone()
                .unwrap_or_else(|| DEFAULT_LENS.to_string()),
        ]
    } else {
        args.lens.clone()
    };
    let prescriptions = specs
        .iter()
        .map(|spec| load_lens(spec, args.lens_options.lens_format))
        .collect::<Result<Vec<_>, _>>()?;
    for warning in prescriptions.iter().flat_map(|p| &p.warnings) {
        eprintln!("warning: {warning}");
    }
    // The film: as asked, else the format the (first) lens was designed for (a phone lens's is
    // a few mm), else the scene camera's.
    let film_diagonal = args
        .lens_options
        .film_diagonal
        .or(prescriptions[0].info.film_diagonal_mm)
        .or(placement.hints.film_diagonal_mm)
        .unwrap_or(35.0);
    let (world_from_camera, framed_focus) = if placement.frame_bounds {
        let aperture = args.lens_options.aperture(ApertureSetting::Full);
        frame_scene(&mut renderer, &prescriptions[0], aperture, film_diagonal)
            .with_context(|| source_path.display().to_string())?
    } else {
        (placement.world_from_camera, placement.default_focus_m)
    };
    let lenses: Vec<RunLens> = prescriptions
        .into_iter()
        .map(|prescription| {
            let (focus, aperture) = lens_defaults(
                args,
                &placement,
                &prescription,
                framed_focus,
                &mut renderer,
                world_from_camera,
            );
            let entity = renderer.add_lens(&prescription, focus, aperture);
            let mut lens = renderer.world.entity_mut(entity);
            lens.insert(args.dispersion.0);
            if let Some(movements) = movements(args) {
                lens.insert(movements);
            }
            if let Some([x, y]) = args.focus_on {
                lens.insert(FocusOnPixel { x, y });
            }
            renderer.set_diaphragm(entity, diaphragm.clone());
            RunLens {
                prescription,
                entity,
                focus,
                aperture,
            }
        })
        .collect();

    let width = args.width.or(placement.hints.width).unwrap_or(512);
    let height = args.height.or(placement.hints.height).unwrap_or(512);
    if let Some([x, y]) = args.focus_on
        && (x >= width || y >= height)
    {
        bail!(
            "--focus-on {x},{y}: the pixel lies outside the {width}×{height} image (pixels count from 0,0 at the top left)"
        );
    }
    // Before the film's tiles are allocated: refuse what this machine cannot hold.
    RunSize {
        width,
        height,
        frames: frame_count(lenses.len(), args.focus_sweep, args.aperture_sweep)?,
        contact_sheet: args.contact_sheet.is_some(),
    }
    .check()?;
    renderer.set_camera(world_from_camera);
    renderer.set_sample_plan(args.spp);
    renderer.set_film(film_diagonal, args.lens_options.pupil_sampling);
    renderer.set_settings(RenderSettings {
        width,
        height,
        seed: args.seed,
        max_depth: args.max_depth,
        tile_size: 32,
    });

    let names: Vec<String> = lenses.iter().map(|l| l.prescription.name.clone()).collect();
    let focus: Vec<FocusSetting> = lenses.iter().map(|l| l.focus).collect();
    let aperture: Vec<ApertureSetting> = lenses.iter().map(|l| l.aperture).collect();
    let frames = plan_frames(&FrameRequest {
        lens_names: &names,
        focus: &focus,
        aperture: &aperture,
        focus_sweep: args.focus_sweep,
        focus_mode: args.lens_options.focus_mode,
        aperture_sweep: args.aperture_sweep,
        out: &args.out,
        exr: args.exr.as_deref(),
    });
    let context = RunContext {
        args,
        formats,
        world_from_camera,
        film_diagonal,
        interrupt: &interrupt,
        diaphragm: diaphragm.as_ref(),
    };
    let mut reports = Vec::new();
    let mut thumbnails = Vec::new();
    let mut exposures: Vec<Option<f32>> = vec![None; lenses.len()];
    for frame in &frames {
        let lens = &lenses[frame.lens];
        match render_frame(&context, &mut renderer, lens, frame)? {
            Outcome::Interrupted(code) => return Ok(ExitCode::from(code)),
            Outcome::Finished(mut report, image) => {
                if args.shard.is_none() {
                    // One exposure per lens sequence, so a focus pull does not flicker.
                    let exposure =
                        *exposures[frame.lens].get_or_insert_with(|| choose_exposure(args, &image));
                    if let Some(ev) = args.exposure
                        && !formats.out.is_float()
                        && let Some(warning) = black_picture(&image, ev)
                    {
                        eprintln!("warning: {}: {warning}", shown(&frame.out));
                        report.warnings.push(warning);
                    }
                    write_image(&frame.out, &image, formats.out, tone(args, exposure))?;
                    eprintln!(
                        "wrote {} ({}×{}, {} spp, {})",
                        shown(&frame.out),
                        width,
                        height,
                        image.samples,
                        formats.out.name()
                    );
                    if let (Some(exr), Some(format)) = (&frame.exr, formats.exr) {
                        write_image(exr, &image, format, tone(args, 1.0))?;
                        eprintln!("wrote {} ({})", shown(exr), format.name());
                    }
                    if args.contact_sheet.is_some() {
                        let pixels = image::RgbImage::from_raw(
                            width,
                            height,
                            to_srgb8(&image.mean(), exposure),
                        )
                        .context("image size mismatch")?;
                        thumbnails.push(Thumbnail {
                            image: pixels,
                            caption: report.caption(),
                        });
                    }
                }
                reports.push(*report);
            }
        }
    }
    if let (Some(path), Some(format)) = (&args.contact_sheet, formats.contact_sheet) {
        let sheet = contact_sheet(&thumbnails);
        write_output(path, |w| {
            encode_rgb8(w, &sheet, format, tone(args, 1.0).quality)
        })?;
        eprintln!("wrote {} ({} renders)", shown(path), thumbnails.len());
    }
    if let Some(path) = &args.stats {
        let stats = stats_json(&mut renderer, &reports, start.elapsed().as_secs_f64());
        write_output(path, |w| {
            serde_json::to_writer_pretty(&mut *w, &stats)?;
            w.push(b'\n');
            Ok(())
        })?;
        eprintln!("wrote {}", shown(path));
    }
    if frames.len() > 1 {
        eprintln!(
            "{} frames in {:.1} s",
            frames.len(),
            start.elapsed().as_secs_f64()
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// Run-wide settings every frame needs.
struct RunContext<'a> {
    args: &'a RenderArgs,
    formats: Formats,
    world_from_camera: Mat4,
    film_diagonal: f64,
    interrupt: &'a Interrupt,
    diaphragm: Option<&'a Diaphragm>,
}

/// Focus and aperture a lens starts from when the flags don't set them. A scene's film
/// distance and stop hints were chosen for its own lens: with another lens they mean nothing,
/// so that lens autofocuses and opens fully instead.
fn lens_defaults(
    args: &RenderArgs,
    placement: &Placement,
    prescription: &Prescription,
    framed_focus: Option<f64>,
    renderer: &mut Renderer,
    world_from_camera: Mat4,
) -> (FocusSetting, ApertureSetting) {
    let hints_fit = placement.hints.lens.as_deref().is_none_or(|hinted| {
        load_lens(hinted, None).is_ok_and(|h| {
            h.rows.len() == prescription.rows.len()
                && h.rows
                    .iter()
                    .zip(&prescription.rows)
                    .all(|(a, b)| a.same_optics(b))
        })
    });
    let hints = if hints_fit {
        placement.hints.clone()
    } else {
        CameraHints {
            film_distance_mm: None,
            aperture_mm: None,
            ..placement.hints.clone()
        }
    };
    let aperture = args.lens_options.aperture(
        hints
            .aperture_mm
            .map_or(ApertureSetting::Full, ApertureSetting::Diameter),
    );
    let fallback = match (
        hints.film_distance_mm,
        hints.focus_distance_m.or(framed_focus),
    ) {
        (Some(mm), _) => FocusSetting::FilmDistance(mm),
        (None, Some(metres)) => FocusSetting::Distance {
            metres,
            mode: Default::default(),
        },
        (None, None) => autofocus(renderer, world_from_camera),
    };
    (args.lens_options.focus(fallback), aperture)
}

/// The film movements the flags ask for; `None` when there are none.
fn movements(args: &RenderArgs) -> Option<FilmMovements> {
    let movements = FilmMovements {
        shift_mm: args.shift.unwrap_or_default(),
        tilt_deg: args.tilt.unwrap_or_default(),
    };
    (!movements.is_none()).then_some(movements)
}

fn choose_exposure(args: &RenderArgs, image: &Image) -> f32 {
    args.exposure
        .map_or_else(|| auto_exposure(&image.mean()), |ev| 2f32.powf(ev))
}

/// How the 8-bit outputs are made at `exposure` (linear scale).
fn tone(args: &RenderArgs, exposure: f32) -> Tone {
    Tone {
        exposure,
        quality: args.quality.unwrap_or(DEFAULT_JPEG_QUALITY),
    }
}

/// Renders one frame: sets the lens up, runs its sample passes with progress, checkpoints and
/// interruption, and returns the film (or the exit code of an interruption, after saving).
fn render_frame(
    context: &RunContext,
    renderer: &mut Renderer,
    lens: &RunLens,
    frame: &Frame,
) -> anyhow::Result<Outcome> {
    let args = context.args;
    renderer.set_active_lens(lens.entity);
    set_if_changed(renderer, lens.entity, frame.focus);
    set_if_changed(renderer, lens.entity, frame.aperture);
    let derivation_before = renderer.world.resource::<LensDerivationStats>().total_time;
    renderer.update()?;
    renderer
        .check_active_lens()
        .with_context(|| format!("{}: cannot render this frame", frame.out.display()))?;
    let lens_derivation_seconds = (renderer.world.resource::<LensDerivationStats>().total_time
        - derivation_before)
        .as_secs_f64();
    let (focal_length_mm, f_number, film_distance_mm, probe) = {
        let entity = renderer.world.entity(lens.entity);
        let geometry = entity
            .get::<LensGeometry>()
            .context("lens geometry missing")?;
        for warning in &geometry.warnings {
            eprintln!("warning: {warning}");
        }
        for note in &geometry.notes {
            eprintln!("note: {note}");
        }
        let film = entity
            .get::<FilmPlacement>()
            .context("film placement missing")?
            .film_distance;
        if let Some(movements) = entity.get::<FilmMovements>() {
            let (width, height) = {
                let s = renderer.world.resource::<RenderSettings>();
                (s.width, s.height)
            };
            let format = FilmGeometry::new(width, height, context.film_diagonal);
            match check_coverage(
                &geometry.system,
                film,
                movements,
                format.width_mm as f64,
                format.height_mm as f64,
            ) {
                Ok(None) => {}
                Ok(Some(warning)) => eprintln!("warning: {warning}"),
                Err(message) => bail!(
                    "{}: cannot render this frame through {}: {message}",
                    frame.out.display(),
                    lens.prescription.name
                ),
            }
        }
        (
            geometry.first_order.focal_length,
            geometry.f_number(),
            film,
            entity.get::<FocusProbe>().copied(),
        )
    };
    if let Some(probe) = probe {
        eprintln!(
            "focus on pixel {},{}: it sees a point {:.4} m away (film plane to the point, along the axis)",
            probe.pixel[0],
            probe.pixel[1],
            probe.object_distance_mm / 1e3
        );
    }
    eprintln!(
        "lens {}: f = {focal_length_mm:.2} mm, f/{f_number:.2}, film distance {film_distance_mm:.3} mm",
        lens.prescription.name
    );

    let settings = settings_fingerprint(context, renderer, lens, frame);
    // Shards of one frame share its --out, so each keeps its own checkpoint beside it.
    let checkpoint_path = args.checkpoint.clone().unwrap_or_else(|| match args.shard {
        Some(shard) => sidecar(
            &frame.out,
            &format!("shard-{}-of-{}.checkpoint", shard.index, shard.count),
        ),
        None => sidecar(&frame.out, "checkpoint"),
    });
    let planned = match args.shard {
        Some(shard) => shard.samples(args.spp),
        None => SampleSequence::all(args.spp),
    };
    let (start_image, samples) = match &args.resume {
        Some(path) => resume_from(path, &settings, args.spp, args.shard)?,
        None => (None, planned),
    };
    renderer.begin_film(start_image.as_ref())?;
    let checkpoint_info = |remaining: SampleSequence, samples: u32| CheckpointInfo {
        version: FORMAT_VERSION,
        samples,
        remaining: remaining.to_vec(),
        planned: args.spp,
        shard: args.shard.map(|s| (s.index, s.count)),
        settings: settings.clone(),
        invocation: Invocation::current(),
    };
    let (width, height) = {
        let s = renderer.world.resource::<RenderSettings>();
        (s.width, s.height)
    };
    let stats_before = renderer.world.resource::<RenderStats>().clone();
    let progress = progress_bar(samples.len() as u32, width * height);
    let render_start = Instant::now();
    let mut last_checkpoint = Instant::now();
    for (done, sample) in samples.iter().enumerate() {
        renderer.render_pass(sample)?;
        progress.set_position(done as u64 + 1);
        let remaining = samples.after(done as u32 + 1);
        if let Some(code) = context.interrupt.requested() {
            progress.finish_and_clear();
            let image = renderer.image();
            write_checkpoint(
                &checkpoint_path,
                &image,
                &checkpoint_info(remaining, image.samples),
            )?;
            if args.shard.is_none() {
                let exposure = choose_exposure(args, &image);
                write_image(
                    &frame.out,
                    &image,
                    context.formats.out,
                    tone(args, exposure),
                )?;
                eprintln!(
                    "interrupted: wrote the image so far ({} spp) to {}",
                    image.samples,
                    shown(&frame.out)
                );
            }
            eprintln!(
                "interrupted: saved {}; continue with --resume {}",
                checkpoint_path.display(),
                checkpoint_path.display()
            );
            return Ok(Outcome::Interrupted(code));
        }
        if let Some(every) = args.checkpoint_every
            && !remaining.is_empty()
            && last_checkpoint.elapsed().as_secs_f64() >= every
        {
            let image = renderer.image();
            write_checkpoint(
                &checkpoint_path,
                &image,
                &checkpoint_info(remaining, image.samples),
            )?;
            last_checkpoint = Instant::now();
        }
    }
    progress.finish_and_clear();
    let image = renderer.image();
    let frame_stats = renderer
        .world
        .resource::<RenderStats>()
        .since(&stats_before);
    let lighting = SceneLighting::of(renderer);
    let warnings: Vec<String> = black_image(&image, &frame_stats, &lighting, args.max_depth)
        .into_iter()
        .collect();
    for warning in &warnings {
        eprintln!("warning: {}: {warning}", shown(&frame.out));
    }
    if let Some(shard) = args.shard {
        let partial = args.partial.clone().unwrap_or_else(|| {
            sidecar(
                &frame.out,
                &format!("shard-{}-of-{}", shard.index, shard.count),
            )
        });
        write_checkpoint(
            &partial,
            &image,
            &checkpoint_info(SampleSequence::default(), image.samples),
        )?;
        eprintln!(
            "wrote {} (shard {}/{}, {} of {} spp)",
            partial.display(),
            shard.index,
            shard.count,
            image.samples,
            args.spp
        );
    }
    let report = FrameReport {
        out: frame.out.clone(),
        lens: lens.prescription.name.clone(),
        focal_length_mm,
        f_number,
        focus: frame.focus,
        film_distance_mm,
        probe,
        lens_derivation_seconds,
        render_seconds: render_start.elapsed().as_secs_f64(),
        samples: image.samples,
        warnings,
    };
    Ok(Outcome::Finished(Box::new(report), image))
}

/// Writes a lens setting only when it differs, so change detection re-derives nothing needlessly.
fn set_if_changed<
    T: bevy_ecs::component::Component<Mutability = bevy_ecs::component::Mutable> + PartialEq + Copy,
>(
    renderer: &mut Renderer,
    lens: Entity,
    value: T,
) {
    if let Some(mut current) = renderer.world.get_mut::<T>(lens)
        && *current != value
    {
        *current = value;
    }
}

/// Everything that must match for a checkpoint to be continued or shards to be merged.
fn settings_fingerprint(
    context: &RunContext,
    renderer: &Renderer,
    lens: &RunLens,
    frame: &Frame,
) -> Value {
    let args = context.args;
    let settings = renderer.world.resource::<RenderSettings>();
    let rows: Vec<[f64; 4]> = lens
        .prescription
        .rows
        .iter()
        .map(|r| [r.radius, r.thickness, r.index, r.aperture])
        .collect();
    let mut fingerprint = json!({
        "scene": args.scene.as_ref().map_or(DEFAULT_SCENE_PATH.to_string(), |p| p.display().to_string()),
        "lens": lens.prescription.name,
        "lens_rows": rows,
        "focus": format!("{:?}", frame.focus),
        "aperture": format!("{:?}", frame.aperture),
        "film_diagonal_mm": context.film_diagonal,
        "pupil_sampling": args.lens_options.pupil_sampling,
        "width": settings.width,
        "height": settings.height,
        "spp": args.spp,
        "seed": settings.seed.to_string(),
        "max_depth": settings.max_depth,
        "camera": context.world_from_camera.to_cols_array().map(f64::from),
        "environment": args.env,
    });
    // What the four columns above do not say, recorded only when present, so a spherical lens
    // without glass data keeps the fingerprint it always had.
    let surfaces = &lens.prescription.rows;
    if surfaces
        .iter()
        .any(|r| r.asphere != crate::lens::Asphere::NONE || r.stop != (r.radius == 0.0))
    {
        fingerprint["lens_shapes"] = surfaces
            .iter()
            .map(|r| json!({ "stop": r.stop, "conic": r.asphere.conic, "aspheric": r.asphere.coefficients }))
            .collect();
    }
    if surfaces.iter().any(|r| r.glass.is_some()) {
        fingerprint["lens_glasses"] = surfaces
            .iter()
            .map(|r| r.glass.map(|g| g.label()))
            .collect();
        fingerprint["dispersion"] = json!(args.dispersion.0 == Dispersion::On);
    }
    // Recorded only when set, so a render without them keeps the fingerprint it always had.
    if let Some(movements) = movements(args) {
        fingerprint["shift_mm"] = json!(movements.shift_mm);
        fingerprint["tilt_deg"] = json!(movements.tilt_deg);
    }
    if let Some(pixel) = args.focus_on {
        fingerprint["focus_on"] = json!(pixel);
    }
    if let Some(diaphragm) = context.diaphragm {
        fingerprint["diaphragm"] = diaphragm.fingerprint();
    }
    fingerprint
}

/// `--dispersion on|off`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct DispersionArg(pub Dispersion);

impl std::str::FromStr for DispersionArg {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "on" => Ok(DispersionArg(Dispersion::On)),
            "off" => Ok(DispersionArg(Dispersion::Off)),
            other => Err(format!(
                "unknown dispersion setting '{other}': use on or off"
            )),
        }
    }
}

/// The film and the samples still to render from a checkpoint, after checking it belongs to
/// this render.
fn resume_from(
    path: &Path,
    settings: &Value,
    spp: u32,
    shard: Option<Shard>,
) -> anyhow::Result<(Option<Image>, SampleSequence)> {
    let (image, info) = read_checkpoint(path)?;
    let shard = shard.map(|s| (s.index, s.count));
    match (info.shard, shard) {
        (Some(_), None) if info.remaining.is_empty() => bail!(
            "{}: is a finished shard partial, not a checkpoint; combine partials with `realcam merge`",
            path.display()
        ),
        (Some((index, count)), None) => bail!(
            "{}: is the checkpoint of shard {index}/{count}; resume it with --shard {index}/{count}",
            path.display()
        ),
        (None, Some((index, count))) => bail!(
            "{}: is the checkpoint of a whole frame, not of shard {index}/{count}; resume it without --shard",
            path.display()
        ),
        (Some(theirs), Some(ours)) if theirs != ours => bail!(
            "{}: is the checkpoint of shard {}/{}, not of shard {}/{}",
            path.display(),
            theirs.0,
            theirs.1,
            ours.0,
            ours.1
        ),
        _ => {}
    }
    if &info.settings != settings {
        let differing: Vec<String> = match (&info.settings, settings) {
            (Value::Object(a), Value::Object(b)) => b
                .keys()
                .filter(|k| a.get(*k) != b.get(*k))
                .cloned()
                .collect(),
            _ => vec!["all".into()],
        };
        bail!(
            "{}: the checkpoint was rendered with different settings ({}); resume with the same scene, lens and options",
            path.display(),
            differing.join(", ")
        );
    }
    if info.planned != spp {
        bail!(
            "{}: the checkpoint targets {} spp, not {}",
            path.display(),
            info.planned,
            spp
        );
    }
    if info.remaining.is_empty() {
        eprintln!(
            "note: {} is already complete ({} spp)",
            path.display(),
            info.samples
        );
    }
    let Some(remaining) = SampleSequence::from_list(&info.remaining) else {
        bail!(
            "{}: damaged checkpoint: its remaining samples are not a sequence realcam renders",
            path.display()
        );
    };
    Ok((Some(image), remaining))
}

/// The formats the run's image outputs are written in, from their names.
#[derive(Clone, Copy, Debug)]
struct Formats {
    out: ImageFormat,
    exr: Option<ImageFormat>,
    contact_sheet: Option<ImageFormat>,
}

/// Checks the flags and the output paths before anything is loaded or rendered; returns the
/// formats the outputs' names ask for.
fn validate(args: &RenderArgs) -> anyhow::Result<Formats> {
    args.lens_options.validate()?;
    if let Some(movements) = movements(args) {
        movements.validate().map_err(|e| anyhow::anyhow!("--{e}"))?;
    }
    if args.spp == 0 {
        bail!("--spp must be at least 1");
    }
    if args.spp > MAX_SPP {
        bail!(
            "--spp must be at most {MAX_SPP} (2^24), got {}: the film sums samples in f32, which cannot take in one more sample beyond 2^24 of them",
            args.spp
        );
    }
    for (name, value) in [("width", args.width), ("height", args.height)] {
        if let Some(v) = value
            && !(1..=MAX_IMAGE_SIDE).contains(&v)
        {
            bail!("--{name} must be between 1 and {MAX_IMAGE_SIDE} pixels, got {v}");
        }
    }
    if args.max_depth == 0 {
        bail!("--max-depth must be at least 1 (1 = direct lighting only)");
    }
    if let Some(threads) = args.threads
        && !(1..=MAX_THREADS).contains(&threads)
    {
        bail!(
            "--threads must be between 1 and {MAX_THREADS}, got {threads}: more threads than that only cost memory"
        );
    }
    if let Some(quality) = args.quality
        && !(1..=100).contains(&quality)
    {
        bail!("--quality must be between 1 and 100, got {quality}");
    }
    if let Some(ev) = args.exposure
        && !ev.is_finite()
    {
        bail!("--exposure must be a finite number of stops");
    }
    if let Some(every) = args.checkpoint_every
        && !(every.is_finite() && every > 0.0)
    {
        bail!("--checkpoint-every must be a positive number of seconds");
    }
    let frames = frame_count(args.lens.len(), args.focus_sweep, args.aperture_sweep)?;
    let outputs = outputs(args);
    for (i, (_, a)) in outputs.iter().enumerate() {
        if outputs[..i].iter().any(|(_, b)| a == b) {
            bail!(
                "{}: given for two outputs; each output needs its own path",
                shown(a)
            );
        }
    }
    let inputs: Vec<&Path> = args
        .scene
        .iter()
        .map(PathBuf::as_path)
        .chain(args.lens.iter().map(Path::new))
        .chain(args.lens_options.aperture_image.as_deref())
        .chain(
            args.resume
                .as_deref()
                .filter(|r| Some(*r) != args.checkpoint.as_deref()),
        )
        .collect();
    for (_, output) in &outputs {
        for input in &inputs {
            if same_file(output, input) {
                bail!(
                    "{}: the output would overwrite an input file; choose another output path",
                    output.display()
                );
            }
        }
    }
    // The files the scene refers to, from its JSON alone (checked again once it is loaded).
    if let Some(scene_files) = args.scene.as_deref().and_then(referenced_files) {
        refuse_overwriting_scene_files(args, &scene_files)?;
    }
    for (option, output) in &outputs {
        if !is_stdout(output) {
            continue;
        }
        match *option {
            "--checkpoint" | "--partial" => bail!(
                "{option} -: a {} is read back later, so it must be a file; give a file name",
                if *option == "--checkpoint" {
                    "checkpoint"
                } else {
                    "partial"
                }
            ),
            _ if frames > 1 => bail!(
                "{option} -: standard output takes one image, but this run renders {frames} frames; give a file name"
            ),
            _ => {}
        }
    }
    for (option, output) in &outputs {
        if *option != "--stats" {
            check_not_terminal(option, output)?;
        }
        check_writable(output)?;
    }
    let formats = Formats {
        out: output_format("--out", &args.out, Accepts::Any)?,
        exr: args
            .exr
            .as_deref()
            .map(|p| output_format("--exr", p, Accepts::Float))
            .transpose()?,
        contact_sheet: args
            .contact_sheet
            .as_deref()
            .map(|p| output_format("--contact-sheet", p, Accepts::EightBit))
            .transpose()?,
    };
    for (option, path) in [
        ("--checkpoint", &args.checkpoint),
        ("--partial", &args.partial),
    ] {
        if let Some(path) = path {
            require_extension(
                option,
                path,
                "exr",
                "an OpenEXR file with realcam's sample record",
            )?;
        }
    }
    if let Some(stats) = &args.stats
        && !is_stdout(stats)
    {
        require_extension("--stats", stats, "json", "JSON")?;
    }
    if args.shard.is_none() {
        let images: Vec<(&str, &Path, ImageFormat)> = [
            Some(("--out", args.out.as_path(), formats.out)),
            args.exr
                .as_deref()
                .zip(formats.exr)
                .map(|(p, f)| ("--exr", p, f)),
            args.contact_sheet
                .as_deref()
                .zip(formats.contact_sheet)
                .map(|(p, f)| ("--contact-sheet", p, f)),
        ]
        .into_iter()
        .flatten()
        .collect();
        check_tone_options(&images, args.exposure.is_some(), args.quality.is_some())?;
    }
    Ok(formats)
}

/// The run's output files with their options (frames of sweeps and lens runs are suffixed
/// copies of these).
fn outputs(args: &RenderArgs) -> Vec<(&'static str, &Path)> {
    [
        ("--out", Some(args.out.as_path())),
        ("--exr", args.exr.as_deref()),
        ("--stats", args.stats.as_deref()),
        ("--contact-sheet", args.contact_sheet.as_deref()),
        ("--checkpoint", args.checkpoint.as_deref()),
        ("--partial", args.partial.as_deref()),
    ]
    .into_iter()
    .filter_map(|(option, path)| Some((option, path?)))
    .collect()
}

/// Outputs must not replace the scene's buffers or textures (`--out scene.bin`).
fn refuse_overwriting_scene_files(
    args: &RenderArgs,
    scene_files: &[PathBuf],
) -> anyhow::Result<()> {
    for (_, output) in outputs(args) {
        if let Some(input) = scene_files.iter().find(|input| same_file(output, input)) {
            bail!(
                "{}: the output would overwrite an input file ({}, which the scene reads); choose another output path",
                output.display(),
                input.display()
            );
        }
    }
    Ok(())
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

fn stats_json(renderer: &mut Renderer, frames: &[FrameReport], wall_seconds: f64) -> Value {
    let stats = renderer.world.resource::<RenderStats>().clone();
    let lens_stats = *renderer.world.resource::<LensDerivationStats>();
    let stages: serde_json::Map<String, serde_json::Value> = Stage::ALL
        .iter()
        .map(|s| {
            (
                s.name().to_string(),
                json!(stats.stage_time[*s as usize].as_secs_f64()),
            )
        })
        .collect();
    let pass_seconds: f64 = Stage::ALL[3..]
        .iter()
        .map(|s| stats.stage_time[*s as usize].as_secs_f64())
        .sum();
    json!({
        "wall_seconds": wall_seconds,
        "stage_seconds": stages,
        "scene_loads": stats.scene_loads,
        "bvh_builds": stats.bvh_builds,
        "triangles": stats.triangles,
        "bvh_nodes": stats.bvh_nodes,
        "camera_samples": stats.camera_samples,
        "lens_pass_fraction": if stats.camera_samples > 0 { stats.lens_rays_passed as f64 / stats.camera_samples as f64 } else { 0.0 },
        "rays_traced": stats.rays_traced,
        "rejected_samples": stats.rejected_samples,
        "camera_rays_escaped": stats.shading.camera_rays_escaped,
        "bounce_rays_escaped": stats.shading.bounce_rays_escaped,
        "emitter_hits": stats.shading.emitter_hits,
        "light_samples": {
            "drawn": stats.shading.light_samples,
            "from_behind": stats.shading.light_samples_behind,
            "blocked": stats.shading.light_samples_blocked,
            "reached": stats.shading.light_samples_reached,
        },
        "warnings": frames.iter().flat_map(|f| f.warnings.iter()).collect::<Vec<_>>(),
        "samples_per_second": if pass_seconds > 0.0 { stats.camera_samples as f64 / pass_seconds } else { 0.0 },
        "frames": frames.iter().map(FrameReport::to_json).collect::<Vec<_>>(),
        "lens_derivation": {
            "geometry_runs": lens_stats.geometry_runs,
            "placement_runs": lens_stats.placement_runs,
            "pupil_runs": lens_stats.pupil_runs,
            "seconds": lens_stats.total_time.as_secs_f64(),
        },
    })
}
