//! A render job: the scene set up once (camera, environment, lenses, film), then its frames
//! (lens × focus × stop) rendered with checkpoints, written, and reported. The command line
//! (`realcam render`) and the live server (`realcam serve`) both drive it.

pub mod frame;
pub mod outputs;
pub mod plan;
pub mod setup;
pub mod spec;
pub mod stats;

use std::path::PathBuf;
use std::time::Instant;

use anyhow::{Context, bail};
use bevy_ecs::entity::Entity;
use glam::Mat4;

use crate::diagnosis::exposure_warning;
use crate::film::contact_sheet::{Thumbnail, contact_sheet};
use crate::film::footprint::RunSize;
use crate::film::format::{DEFAULT_JPEG_QUALITY, Tone, encode_rgb8};
use crate::film::output::{auto_exposure, shown, to_srgb8, write_output};
use crate::film::{DEFAULT_IMAGE_SIDE, Image};
use crate::lens::Prescription;
use crate::lens::aperture::ApertureSetting;
use crate::lens::diaphragm::Diaphragm;
use crate::lens::elements::FocusSetting;
use crate::lens::focus::FocusMode;
use crate::lens::focus_probe::FocusOnPixel;
use crate::lens::io::bundled::{DEFAULT_LENS, load_lens, read_lens};
use crate::pipeline::{RenderSettings, Renderer, SceneInputs, SceneSource, SceneWarnings};
use crate::scene::CameraHints;
use crate::scene::default_scene::{DEFAULT_SCENE_GLB, DEFAULT_SCENE_PATH};
use frame::{Outcome, remove_spent_checkpoints, render_frame, write_frame_images};
use outputs::{Formats, refuse_overwriting_scene_files};
use plan::{FrameRequest, StopSweep, ZoomFrames, frame_count, plan_frames};
use setup::{
    Placement, autofocus, choose_environment, frame_scene, place_camera, within_focus_range,
};
use spec::JobSpec;
use stats::stats_json;

/// How a front end shows a frame's progress (the command line: a progress bar).
pub trait Progress {
    /// A frame starts: `passes` sample passes over `pixels` pixels each.
    fn begin(&mut self, passes: u32, pixels: u32);
    /// `done` passes of the frame are rendered.
    fn advance(&mut self, done: u32);
    fn finish(&mut self);
}

/// No progress display.
pub struct Silent;

impl Progress for Silent {
    fn begin(&mut self, _: u32, _: u32) {}
    fn advance(&mut self, _: u32) {}
    fn finish(&mut self) {}
}

/// A job whose scene is loaded, BVH built, camera placed and lenses spawned with their
/// starting focus and stop: ready to render its frames, or to be driven live.
pub struct Job<'a> {
    pub spec: &'a JobSpec,
    pub formats: Formats,
    pub renderer: Renderer,
    pub lenses: Vec<RunLens>,
    pub world_from_camera: Mat4,
    /// The scene camera's film diagonal (mm), for lenses that do not say their own format.
    pub hinted_film_diagonal: Option<f64>,
    pub width: u32,
    pub height: u32,
    /// When the job started, for its wall time.
    pub start: Instant,
    /// The diaphragm `--blades`/`--aperture-image` ask for, on every lens of the job.
    pub diaphragm: Option<Diaphragm>,
}

/// A lens of the run: its prescription, entity, film and the defaults its frames start from.
pub struct RunLens {
    pub prescription: Prescription,
    /// The film diagonal (mm) its frames render on ([`LensSettings::film_diagonal_for`](crate::lens::settings::LensSettings::film_diagonal_for)).
    pub film_diagonal: f64,
    pub entity: Entity,
    pub focus: FocusSetting,
    pub aperture: ApertureSetting,
    /// The zoom positions its frames render.
    pub zoom: ZoomFrames,
}

impl<'a> Job<'a> {
    /// Loads the scene and builds its BVH, chooses the environment, places the camera, loads
    /// the lenses and settles each one's starting focus and stop, and sizes the film. `formats`
    /// come from [`outputs::validate`], run first.
    pub fn prepare(spec: &'a JobSpec, formats: Formats) -> anyhow::Result<Job<'a>> {
        let start = Instant::now();
        let diaphragm = spec.lens.diaphragm()?;
        for message in spec.lens.mask_messages(diaphragm.as_ref()) {
            eprintln!("{message}");
        }
        let mut renderer = Renderer::new();
        renderer.set_device(spec.device)?;
        let source = match &spec.scene {
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
        refuse_overwriting_scene_files(spec, &renderer.world.resource::<SceneInputs>().0)?;
        let environment = choose_environment(spec, &mut renderer)?;
        renderer.set_environment(environment);

        let placement = place_camera(spec, &mut renderer)?;
        let names: Vec<String> = if spec.lenses.is_empty() {
            vec![
                placement
                    .hints
                    .lens
                    .clone()
                    .unwrap_or_else(|| DEFAULT_LENS.to_string()),
            ]
        } else {
            spec.lenses.clone()
        };
        let prescriptions = names
            .iter()
            .map(|name| read_lens(name, &spec.lens.reading()))
            .collect::<Result<Vec<_>, _>>()?;
        for warning in prescriptions.iter().flat_map(|p| &p.warnings) {
            eprintln!("warning: {warning}");
        }
        if spec.zoom_sweep && prescriptions.iter().all(|p| p.spacings.zoom.is_empty()) {
            bail!(
                "--zoom-sweep: {} has fixed spacings, no zoom positions to sweep (`realcam lens NAME --json` lists a zoom lens's zoom_positions)",
                prescriptions[0].name
            );
        }
        let hinted_film_diagonal = placement.hints.film_diagonal_mm;
        let film_diagonal =
            |lens: &Prescription| spec.lens.film_diagonal_for(lens, hinted_film_diagonal);
        let (world_from_camera, framed_focus) = if placement.frame_bounds {
            // One camera for the whole run: placed for the first lens.
            let aperture = spec.lens.aperture(ApertureSetting::Full);
            let first = &prescriptions[0];
            frame_scene(&mut renderer, first, aperture, film_diagonal(first))
                .with_context(|| source_path.display().to_string())?
        } else {
            (placement.world_from_camera, placement.default_focus_m)
        };
        let lenses: Vec<RunLens> = prescriptions
            .into_iter()
            .map(|prescription| -> anyhow::Result<RunLens> {
                let (focus, aperture) = lens_defaults(
                    spec,
                    &placement,
                    &prescription,
                    framed_focus,
                    &mut renderer,
                    world_from_camera,
                );
                let entity = renderer.add_lens(&prescription, focus, aperture);
                let mut lens = renderer.world.entity_mut(entity);
                lens.insert((spec.dispersion, spec.flare));
                if let Some(movements) = spec.movements() {
                    lens.insert(movements);
                }
                if let Some([x, y]) = spec.focus_on {
                    lens.insert(FocusOnPixel { x, y });
                }
                renderer.set_diaphragm(entity, diaphragm.clone());
                let zoom = if spec.zoom_sweep {
                    ZoomFrames::sweep(prescription.spacings.zoom.len())
                } else {
                    ZoomFrames::Fixed(spec.lens.zoom_setting_for(&prescription)?)
                };
                if let ZoomFrames::Fixed(setting) = zoom {
                    renderer.set_zoom_position(entity, setting);
                }
                renderer.set_coating_choice(entity, spec.lens.coating_choice());
                Ok(RunLens {
                    film_diagonal: film_diagonal(&prescription),
                    prescription,
                    entity,
                    focus,
                    aperture,
                    zoom,
                })
            })
            .collect::<anyhow::Result<_>>()?;

        let width = spec
            .width
            .or(placement.hints.width)
            .unwrap_or(DEFAULT_IMAGE_SIDE);
        let height = spec
            .height
            .or(placement.hints.height)
            .unwrap_or(DEFAULT_IMAGE_SIDE);
        if let Some([x, y]) = spec.focus_on
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
            frames: frame_count(
                &lenses.iter().map(|l| l.zoom.count()).collect::<Vec<_>>(),
                spec.focus_sweep,
                spec.stop_sweep.map(StopSweep::sweep),
            )?,
            contact_sheet: spec.output.contact_sheet.is_some(),
            wavelengths: spec.camera_wavelengths(),
        }
        .check()?;
        renderer.set_camera(world_from_camera);
        renderer.set_film(lenses[0].film_diagonal, spec.lens.pupil_sampling);
        renderer.set_settings(RenderSettings {
            width,
            height,
            seed: spec.seed,
            max_depth: spec.max_depth,
            tile_size: 32,
            wavelengths: spec.wavelengths,
            filter: spec.filter,
        });
        Ok(Job {
            spec,
            formats,
            renderer,
            lenses,
            world_from_camera,
            hinted_film_diagonal,
            width,
            height,
            start,
            diaphragm,
        })
    }

    /// Renders every frame of the run and writes its outputs; returns the exit code of a stop
    /// `stop` asked for (after saving the checkpoint), or `None` when the run finished.
    pub fn run(
        self,
        stop: &dyn Fn() -> Option<u8>,
        progress: &mut dyn Progress,
    ) -> anyhow::Result<Option<u8>> {
        let Job {
            spec,
            formats,
            mut renderer,
            lenses,
            world_from_camera,
            width,
            height,
            start,
            diaphragm,
            ..
        } = self;
        let names: Vec<String> = lenses.iter().map(|l| l.prescription.name.clone()).collect();
        let focus: Vec<FocusSetting> = lenses.iter().map(|l| l.focus).collect();
        let aperture: Vec<ApertureSetting> = lenses.iter().map(|l| l.aperture).collect();
        let zoom: Vec<ZoomFrames> = lenses.iter().map(|l| l.zoom.clone()).collect();
        let frames = plan_frames(&FrameRequest {
            lens_names: &names,
            zoom: &zoom,
            focus: &focus,
            aperture: &aperture,
            focus_sweep: spec.focus_sweep,
            focus_mode: spec.lens.focus_mode,
            stop_sweep: spec.stop_sweep,
            out: &spec.output.out,
            exr: spec.output.exr.as_deref(),
        });
        let context = RunContext {
            spec,
            formats,
            world_from_camera,
            stop,
            diaphragm: diaphragm.as_ref(),
        };
        let mut reports = Vec::new();
        let mut thumbnails = Vec::new();
        let mut exposures: Vec<Option<f32>> = vec![None; lenses.len()];
        for frame in &frames {
            let lens = &lenses[frame.lens];
            match render_frame(&context, &mut renderer, lens, frame, progress)? {
                Outcome::Interrupted(code) => return Ok(Some(code)),
                Outcome::Finished(mut report, image, spent) => {
                    if spec.output.shard.is_none() {
                        // One exposure per lens sequence, so a focus pull does not flicker.
                        let exposure = *exposures[frame.lens]
                            .get_or_insert_with(|| choose_exposure(spec, &image));
                        if let Some(ev) = spec.output.exposure
                            && !formats.out.is_float()
                            && let Some(warning) = exposure_warning(&image, ev)
                        {
                            eprintln!("warning: {}: {warning}", shown(&frame.out));
                            report.warnings.push(warning);
                        }
                        write_frame_images(spec, &formats, frame, &image, exposure)?;
                        eprintln!(
                            "wrote {} ({}×{}, {} spp, {})",
                            shown(&frame.out),
                            width,
                            height,
                            image.samples,
                            formats.out.name()
                        );
                        if let (Some(exr), Some(format)) = (&frame.exr, formats.exr) {
                            eprintln!("wrote {} ({})", shown(exr), format.name());
                        }
                        if spec.output.contact_sheet.is_some() {
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
                    remove_spent_checkpoints(&spent);
                    reports.push(*report);
                }
            }
        }
        if let (Some(path), Some(format)) = (&spec.output.contact_sheet, formats.contact_sheet) {
            let sheet = contact_sheet(&thumbnails);
            write_output(path, |w| {
                encode_rgb8(w, &sheet, format, tone(spec, 1.0).quality)
            })?;
            eprintln!("wrote {} ({} renders)", shown(path), thumbnails.len());
        }
        if let Some(path) = &spec.output.stats {
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
        Ok(None)
    }
}

/// Run-wide settings every frame needs.
struct RunContext<'a> {
    spec: &'a JobSpec,
    formats: Formats,
    world_from_camera: Mat4,
    /// The exit code to stop with, once the front end was asked to stop (Ctrl-C).
    stop: &'a dyn Fn() -> Option<u8>,
    diaphragm: Option<&'a Diaphragm>,
}

/// Focus and aperture a lens starts from when the flags don't set them. A scene's film
/// distance and stop hints were chosen for its own lens: with another lens they mean nothing,
/// so that lens autofocuses and opens fully instead. A focus distance the flags did not ask for
/// is kept within the lens's reach ([`within_focus_range`]).
pub fn lens_defaults(
    spec: &JobSpec,
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
    let aperture = spec.lens.aperture(
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
    let implied = spec.lens.focus_distance.is_none() && spec.lens.film_distance.is_none();
    let focus = spec.lens.focus(fallback);
    // The mode chooses a film distance for a focus distance: with the film distance given,
    // it has nothing to choose, which the user who asked for it should hear.
    if let (FocusMode::Best, FocusSetting::FilmDistance(mm)) = (spec.lens.focus_mode, focus) {
        let source = if spec.lens.film_distance.is_some() {
            "--film-distance"
        } else {
            "the scene camera's film-distance hint"
        };
        eprintln!(
            "note: {}: --focus-mode best chooses the film distance for a focus distance, but the film distance ({mm} mm) is set by {source}; give --focus-distance to focus in best mode",
            prescription.name
        );
    }
    if implied {
        (within_focus_range(prescription, focus), aperture)
    } else {
        (focus, aperture)
    }
}

pub fn choose_exposure(spec: &JobSpec, image: &Image) -> f32 {
    spec.output
        .exposure
        .map_or_else(|| auto_exposure(&image.mean()), |ev| 2f32.powf(ev))
}

/// How the 8-bit outputs are made at `exposure` (linear scale).
pub fn tone(spec: &JobSpec, exposure: f32) -> Tone {
    Tone {
        exposure,
        quality: spec.output.quality.unwrap_or(DEFAULT_JPEG_QUALITY),
    }
}
