//! `realcam render`: a glTF scene through a lens, to PNG/EXR.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, bail};
use bevy_ecs::query::With;
use clap::Args;
use glam::{Mat4, Vec3};
use indicatif::{ProgressBar, ProgressStyle};
use serde_json::json;

use super::options::LensOptions;
use crate::film::output::{auto_exposure, check_writable, write_exr, write_png};
use crate::lens::Prescription;
use crate::lens::aperture::ApertureSetting;
use crate::lens::bundled::{DEFAULT_LENS, load_lens};
use crate::lens::elements::{
    ActiveLens, FilmPlacement, FocusSetting, Lens, LensDerivationStats, LensGeometry,
    build_geometry,
};
use crate::lens::focus::closest_focus_mm;
use crate::pipeline::{
    RenderSettings, RenderStats, Renderer, SceneBounds, SceneSource, SceneWarnings, Stage,
};
use crate::scene::{CameraHints, MaterialLibrary, PunctualLight, SceneCamera, look_at};
use crate::shade::Environment;

/// The bundled default scene ("dof dragons" of the CS348b course, cones for dragons).
pub const DEFAULT_SCENE: &[u8] = include_bytes!("../../assets/dof-dragons.glb");
pub const DEFAULT_SCENE_NAME: &str = "assets/dof-dragons.glb";

#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    /// glTF 2.0 scene (.gltf or .glb) [default: the built-in dof-dragons scene].
    pub scene: Option<PathBuf>,
    /// Lens prescription file or bundled lens name [default: the scene camera's hint, else
    /// dgauss.50mm].
    #[arg(long, value_name = "FILE")]
    pub lens: Option<String>,
    /// Samples per pixel.
    #[arg(long, default_value_t = 64, value_name = "N")]
    pub spp: u32,
    /// Image width in pixels [default: 512].
    #[arg(long, value_name = "W")]
    pub width: Option<u32>,
    /// Image height in pixels [default: 512].
    #[arg(long, value_name = "H")]
    pub height: Option<u32>,
    #[command(flatten)]
    pub lens_options: LensOptions,
    /// glTF camera to render from, by node/camera name or index [default: the first camera,
    /// else a view of the whole scene from +z].
    #[arg(long, value_name = "NAME|INDEX")]
    pub camera: Option<String>,
    /// Camera position (world, metres); with --look-at, overrides the scene camera.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, requires = "look_at")]
    pub look_from: Option<Vec3>,
    /// Point the camera looks at (and focuses on, unless a focus is given).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, requires = "look_from")]
    pub look_at: Option<Vec3>,
    /// Up direction for --look-from/--look-at.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, default_value = "0,1,0")]
    pub up: Vec3,
    /// Environment: a uniform sky `R,G,B` (nits) or an equirectangular .exr/.hdr image
    /// [default: black if the scene has lights or emitters, else a white sky of 1 nit].
    #[arg(long, value_name = "R,G,B|FILE")]
    pub env: Option<String>,
    /// Random seed; the same seed gives the same image whatever the thread count.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Worker threads [default: all cores].
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Path length: 1 = direct lighting only.
    #[arg(long, default_value_t = 8, value_name = "D")]
    pub max_depth: u32,
    /// Output PNG (sRGB).
    #[arg(long, default_value = "render.png", value_name = "FILE.png")]
    pub out: PathBuf,
    /// Also write the linear, un-tonemapped film as OpenEXR.
    #[arg(long, value_name = "FILE.exr")]
    pub exr: Option<PathBuf>,
    /// PNG exposure in stops: pixel = film irradiance × 2^EV [default: automatic, the image's
    /// log-average luminance to 18 % grey].
    #[arg(long, value_name = "EV", allow_hyphen_values = true)]
    pub exposure: Option<f32>,
    /// Write render statistics as JSON.
    #[arg(long, value_name = "FILE.json")]
    pub stats: Option<PathBuf>,
}

fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{s}' is not X,Y,Z"))?;
    match parts[..] {
        [x, y, z] if parts.iter().all(|v| v.is_finite()) => Ok(Vec3::new(x, y, z)),
        _ => Err(format!("'{s}' is not three finite numbers X,Y,Z")),
    }
}

/// The camera placement chosen for a render.
struct Placement {
    world_from_camera: Mat4,
    hints: CameraHints,
    /// Focus distance (m) implied by the placement when the user gave none.
    default_focus_m: Option<f64>,
    /// No camera in the scene: frame the bounds once the lens is known.
    frame_bounds: bool,
}

pub fn run(args: &RenderArgs) -> anyhow::Result<ExitCode> {
    validate(args)?;
    if let Some(threads) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build_global()
            .context("cannot start worker threads")?;
    }
    let start = Instant::now();
    let mut renderer = Renderer::new();
    let source = match &args.scene {
        Some(path) => SceneSource {
            path: path.clone(),
            embedded: None,
        },
        None => SceneSource {
            path: PathBuf::from(DEFAULT_SCENE_NAME),
            embedded: Some(DEFAULT_SCENE),
        },
    };
    renderer.set_scene(source);
    renderer.update()?;
    for warning in &renderer.world.resource::<SceneWarnings>().0 {
        eprintln!("warning: {warning}");
    }
    let environment = choose_environment(args, &mut renderer)?;
    renderer.set_environment(environment);

    let placement = place_camera(args, &mut renderer)?;
    let lens_spec = args
        .lens
        .clone()
        .or(placement.hints.lens.clone())
        .unwrap_or_else(|| DEFAULT_LENS.to_string());
    let prescription = load_lens(&lens_spec, args.lens_options.lens_format)?;
    // A scene's film distance and stop were chosen for its own lens: with another lens they
    // mean nothing, so that lens autofocuses and opens fully unless told otherwise.
    let hints_fit_lens =
        placement.hints.lens.as_deref().is_none_or(|hinted| {
            load_lens(hinted, None).is_ok_and(|h| h.rows == prescription.rows)
        });
    let placement = if hints_fit_lens {
        placement
    } else {
        Placement {
            hints: CameraHints {
                film_distance_mm: None,
                aperture_mm: None,
                ..placement.hints
            },
            ..placement
        }
    };
    let aperture = args.lens_options.aperture(
        placement
            .hints
            .aperture_mm
            .map_or(ApertureSetting::Full, ApertureSetting::Diameter),
    );
    let film_diagonal = args
        .lens_options
        .film_diagonal
        .or(placement.hints.film_diagonal_mm)
        .unwrap_or(35.0);
    let (world_from_camera, framed_focus) = if placement.frame_bounds {
        frame_scene(&mut renderer, &prescription, aperture, film_diagonal)?
    } else {
        (placement.world_from_camera, placement.default_focus_m)
    };
    let fallback_focus = match (
        placement.hints.film_distance_mm,
        placement.hints.focus_distance_m.or(framed_focus),
    ) {
        (Some(mm), _) => FocusSetting::FilmDistance(mm),
        (None, Some(metres)) => FocusSetting::Distance {
            metres,
            mode: Default::default(),
        },
        (None, None) => autofocus(&mut renderer, world_from_camera),
    };
    let focus = args.lens_options.focus(fallback_focus);

    let width = args.width.or(placement.hints.width).unwrap_or(512);
    let height = args.height.or(placement.hints.height).unwrap_or(512);
    renderer.set_camera(world_from_camera);
    renderer.set_film(film_diagonal, args.lens_options.pupil_sampling);
    renderer.set_settings(RenderSettings {
        width,
        height,
        seed: args.seed,
        max_depth: args.max_depth,
        tile_size: 32,
    });
    let lens = renderer.add_lens(&prescription, focus, aperture);
    renderer.set_active_lens(lens);
    renderer.update()?;
    renderer.check_active_lens()?;
    report_lens(&mut renderer);

    let progress = progress_bar(args.spp, width * height);
    let image = renderer.render(args.spp, |done, _| {
        progress.set_position(done as u64);
        true
    })?;
    progress.finish_and_clear();

    let exposure = args
        .exposure
        .map_or_else(|| auto_exposure(&image.mean()), |ev| 2f32.powf(ev));
    write_png(&args.out, &image, exposure)?;
    eprintln!(
        "wrote {} ({}×{}, {} spp, {:.1} s)",
        args.out.display(),
        width,
        height,
        image.samples,
        start.elapsed().as_secs_f64()
    );
    if let Some(exr) = &args.exr {
        write_exr(exr, &image)?;
        eprintln!("wrote {}", exr.display());
    }
    if let Some(path) = &args.stats {
        let stats = stats_json(&mut renderer, start.elapsed().as_secs_f64());
        crate::film::output::write_atomically(path, |w| {
            serde_json::to_writer_pretty(&mut *w, &stats)?;
            Ok(())
        })?;
    }
    Ok(ExitCode::SUCCESS)
}

fn validate(args: &RenderArgs) -> anyhow::Result<()> {
    args.lens_options.validate()?;
    if args.spp == 0 {
        bail!("--spp must be at least 1");
    }
    for (name, value) in [("width", args.width), ("height", args.height)] {
        if let Some(v) = value
            && !(1..=16384).contains(&v)
        {
            bail!("--{name} must be between 1 and 16384 pixels, got {v}");
        }
    }
    if args.max_depth == 0 {
        bail!("--max-depth must be at least 1 (1 = direct lighting only)");
    }
    if args.threads == Some(0) {
        bail!("--threads must be at least 1");
    }
    if let Some(ev) = args.exposure
        && !ev.is_finite()
    {
        bail!("--exposure must be a finite number of stops");
    }
    let outputs: Vec<&Path> = [
        Some(args.out.as_path()),
        args.exr.as_deref(),
        args.stats.as_deref(),
    ]
    .into_iter()
    .flatten()
    .collect();
    let inputs: Vec<&Path> = [args.scene.as_deref(), args.lens.as_deref().map(Path::new)]
        .into_iter()
        .flatten()
        .collect();
    for output in &outputs {
        for input in &inputs {
            if same_file(output, input) {
                bail!(
                    "{}: the output would overwrite an input file; choose another --out/--exr/--stats path",
                    output.display()
                );
            }
        }
        check_writable(output)?;
    }
    Ok(())
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

fn choose_environment(args: &RenderArgs, renderer: &mut Renderer) -> anyhow::Result<Environment> {
    if let Some(spec) = &args.env {
        if let Ok(rgb) = parse_vec3(spec) {
            if rgb.min_element() < 0.0 {
                bail!("--env {spec}: radiance must not be negative");
            }
            return Ok(Environment::Uniform(rgb));
        }
        return crate::shade::load_environment(Path::new(spec));
    }
    let has_lights = renderer
        .world
        .query::<&PunctualLight>()
        .iter(&renderer.world)
        .next()
        .is_some();
    let has_emitters = renderer
        .world
        .resource::<MaterialLibrary>()
        .materials
        .iter()
        .any(|m| m.is_emissive());
    if has_lights || has_emitters {
        Ok(Environment::Uniform(Vec3::ZERO))
    } else {
        eprintln!(
            "note: the scene has no lights; lighting it with a white sky of 1 nit (set one with --env)"
        );
        Ok(Environment::Uniform(Vec3::ONE))
    }
}

fn place_camera(args: &RenderArgs, renderer: &mut Renderer) -> anyhow::Result<Placement> {
    if let (Some(from), Some(at)) = (args.look_from, args.look_at) {
        if (at - from).length() < 1e-6
            || (at - from)
                .normalize()
                .cross(args.up.normalize_or_zero())
                .length()
                < 1e-6
        {
            bail!(
                "--look-from and --look-at must differ, and --up must not be parallel to the view direction"
            );
        }
        return Ok(Placement {
            world_from_camera: look_at(from, at, args.up),
            hints: CameraHints::default(),
            default_focus_m: Some((at - from).length() as f64),
            frame_bounds: false,
        });
    }
    let cameras = renderer.scene_cameras();
    let chosen: Option<&SceneCamera> = match &args.camera {
        Some(wanted) => {
            let found = cameras
                .iter()
                .find(|c| c.name.as_deref() == Some(wanted.as_str()))
                .or_else(|| {
                    wanted
                        .parse::<usize>()
                        .ok()
                        .and_then(|i| cameras.iter().find(|c| c.index == i))
                });
            if found.is_none() {
                let names: Vec<String> = cameras
                    .iter()
                    .map(|c| format!("{} ({})", c.index, c.name.as_deref().unwrap_or("unnamed")))
                    .collect();
                bail!(
                    "--camera {wanted}: no such camera in the scene; it has {}",
                    if names.is_empty() {
                        "no cameras".to_string()
                    } else {
                        names.join(", ")
                    }
                );
            }
            found
        }
        None => cameras.first(),
    };
    Ok(match chosen {
        Some(camera) => Placement {
            world_from_camera: camera.world_from_camera,
            hints: camera.hints.clone(),
            default_focus_m: None,
            frame_bounds: false,
        },
        None => Placement {
            world_from_camera: Mat4::IDENTITY,
            hints: CameraHints::default(),
            default_focus_m: None,
            frame_bounds: true,
        },
    })
}

/// Looks at the scene's bounds from +z (front), far enough back for the lens to fit them in
/// the frame and no closer than it can focus; focused on the bounds' centre.
fn frame_scene(
    renderer: &mut Renderer,
    prescription: &Prescription,
    aperture: ApertureSetting,
    film_diagonal: f64,
) -> anyhow::Result<(Mat4, Option<f64>)> {
    let bounds = renderer.world.resource::<SceneBounds>().0;
    if bounds.is_empty() {
        bail!("the scene has no geometry to look at");
    }
    let lens = Lens {
        name: prescription.name.clone(),
        source: prescription.source.clone(),
        format: prescription.format,
    };
    let geometry =
        build_geometry(&lens, &prescription.rows, aperture).map_err(anyhow::Error::msg)?;
    let efl = geometry.first_order.focal_length;
    // Half the film's short side for a square image: diagonal / (2√2).
    let half_field = ((film_diagonal / (2.0 * 2f64.sqrt())) / efl).atan();
    let radius = (bounds.diagonal() / 2.0) as f64;
    let fit = radius / half_field.sin() * 1.05;
    let closest = closest_focus_mm(&geometry.system, &geometry.first_order) / 1000.0 * 1.02;
    if fit < closest {
        eprintln!(
            "note: the scene ({:.3} m across) is smaller than {} can fill the frame with; it will look small (closest focus {:.3} m)",
            2.0 * radius,
            prescription.name,
            closest
        );
    }
    let distance = fit.max(closest);
    let center = bounds.center();
    let eye = center + Vec3::Z * distance as f32;
    Ok((look_at(eye, center, Vec3::Y), Some(distance)))
}

/// Focus on whatever the image centre sees, like a camera's autofocus; 10 m on a miss.
fn autofocus(renderer: &mut Renderer, world_from_camera: Mat4) -> FocusSetting {
    let origin = world_from_camera.transform_point3(Vec3::ZERO);
    let forward = world_from_camera
        .transform_vector3(-Vec3::Z)
        .normalize_or_zero();
    let accel = renderer.world.get_resource::<crate::accel::SceneAccel>();
    let metres = accel
        .and_then(|a| a.intersect(origin, forward, f32::INFINITY))
        .map_or(10.0, |hit| hit.t as f64);
    FocusSetting::Distance {
        metres,
        mode: Default::default(),
    }
}

fn report_lens(renderer: &mut Renderer) {
    let mut query = renderer
        .world
        .query_filtered::<(&Lens, &LensGeometry, &FilmPlacement), With<ActiveLens>>();
    if let Some((lens, geometry, placement)) = query.iter(&renderer.world).next() {
        for warning in &geometry.warnings {
            eprintln!("warning: {warning}");
        }
        let fo = &geometry.first_order;
        eprintln!(
            "lens {}: f = {:.2} mm, f/{:.2}, film distance {:.3} mm",
            lens.name, fo.focal_length, fo.f_number, placement.film_distance
        );
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

fn stats_json(renderer: &mut Renderer, wall_seconds: f64) -> serde_json::Value {
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
        "samples_per_second": if pass_seconds > 0.0 { stats.camera_samples as f64 / pass_seconds } else { 0.0 },
        "lens_derivation": {
            "geometry_runs": lens_stats.geometry_runs,
            "placement_runs": lens_stats.placement_runs,
            "pupil_runs": lens_stats.pupil_runs,
            "seconds": lens_stats.total_time.as_secs_f64(),
        },
    })
}
