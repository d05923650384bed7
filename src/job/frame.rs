//! One frame of a render job: the lens set up, its sample passes with progress, checkpoints
//! and interruption, and what it reports.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use bevy_ecs::entity::Entity;
use serde_json::{Value, json};

use super::outputs::Formats;
use super::plan::{Frame, Shard, sidecar};
use super::spec::JobSpec;
use super::{Progress, RunContext, RunLens, choose_exposure, tone};
use crate::diagnosis::{SceneLighting, black_image};
use crate::film::Image;
use crate::film::checkpoint::{
    CheckpointInfo, FORMAT_VERSION, Invocation, read_checkpoint, write_checkpoint,
};
use crate::film::output::{shown, write_image};
use crate::film::samples::SampleSequence;
use crate::lens::coverage::FilmCoverage;
use crate::lens::elements::{
    Dispersion, FilmPlacement, FocusSetting, LensDerivationStats, LensGeometry,
};
use crate::lens::focus_probe::FocusProbe;
use crate::pipeline::{RenderSettings, RenderStats, Renderer};
use crate::scene::default_scene::DEFAULT_SCENE_PATH;

/// What one frame reported.
pub(super) struct FrameReport {
    pub(super) out: PathBuf,
    pub(super) lens: String,
    pub(super) focal_length_mm: f64,
    pub(super) f_number: f64,
    /// The zoom position (0-based) of a zoom lens.
    pub(super) zoom: Option<usize>,
    pub(super) focus: FocusSetting,
    pub(super) film_distance_mm: f64,
    pub(super) film_diagonal_mm: f64,
    /// What --focus-on found.
    pub(super) probe: Option<FocusProbe>,
    pub(super) lens_derivation_seconds: f64,
    pub(super) render_seconds: f64,
    pub(super) samples: u32,
    /// Warnings about the frame's image (why it is black).
    pub(super) warnings: Vec<String>,
}

impl FrameReport {
    pub(super) fn caption(&self) -> String {
        let focus = match (self.probe, self.focus) {
            (Some(probe), _) => format!(
                "focus {:.2} m (pixel {},{})",
                probe.object_distance_mm / 1e3,
                probe.pixel[0],
                probe.pixel[1]
            ),
            // Past a kilometre every lens here is focused at infinity to within its depth of
            // field; a rack focus "to infinity" names a far distance, which reads badly.
            (None, FocusSetting::Distance { metres, .. }) if metres >= 1e3 => {
                "focus at infinity".to_string()
            }
            (None, FocusSetting::Distance { metres, .. }) => format!("focus {metres:.2} m"),
            (None, FocusSetting::FilmDistance(mm)) => format!("film at {mm:.2} mm"),
        };
        let zoom = self
            .zoom
            .map_or(String::new(), |p| format!(" zoom {}", p + 1));
        format!(
            "{}{zoom}\nf={:.1}mm f/{:.1}\n{focus}",
            self.lens, self.focal_length_mm, self.f_number
        )
    }

    pub(super) fn to_json(&self) -> Value {
        json!({
            "out": self.out.display().to_string(),
            "lens": self.lens,
            "zoom_position": self.zoom.map(|p| p + 1),
            "focal_length_mm": self.focal_length_mm,
            "f_number": self.f_number,
            "focus_distance_m": match (self.probe, self.focus) {
                (Some(probe), _) => json!(probe.object_distance_mm / 1e3),
                (None, FocusSetting::Distance { metres, .. }) => json!(metres),
                (None, FocusSetting::FilmDistance(_)) => Value::Null,
            },
            "focus_on": self.probe.map(|p| p.pixel),
            "film_distance_mm": self.film_distance_mm,
            "film_diagonal_mm": self.film_diagonal_mm,
            "lens_derivation_seconds": self.lens_derivation_seconds,
            "render_seconds": self.render_seconds,
            "samples": self.samples,
            "warnings": self.warnings,
        })
    }
}

/// How a frame ended.
pub(super) enum Outcome {
    /// The report, the film and the checkpoints it leaves spent ([`remove_spent_checkpoints`]).
    Finished(Box<FrameReport>, Image, Vec<PathBuf>),
    Interrupted(u8),
}

/// Renders one frame: sets the lens up, runs its sample passes with progress, checkpoints and
/// interruption, and returns the film (or the exit code of an interruption, after saving).
pub(super) fn render_frame(
    context: &RunContext,
    renderer: &mut Renderer,
    lens: &RunLens,
    frame: &Frame,
    progress: &mut dyn Progress,
) -> anyhow::Result<Outcome> {
    let spec = context.spec;
    renderer.set_active_lens(lens.entity);
    // Each lens on its own film: the lens derivation re-runs through change detection.
    renderer.set_film(lens.film_diagonal, spec.lens.pupil_sampling);
    renderer.set_zoom_position(lens.entity, frame.zoom);
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
        if let Some(warning) = entity.get::<FilmCoverage>().and_then(FilmCoverage::warning) {
            eprintln!("warning: {warning}");
        }
        (
            geometry.first_order.focal_length,
            geometry.f_number(),
            film,
            entity.get::<FocusProbe>().copied(),
        )
    };
    eprintln!(
        "lens {}: f = {focal_length_mm:.2} mm, f/{f_number:.2}, film distance {film_distance_mm:.3} mm",
        lens.prescription.name
    );
    if let Some(probe) = probe {
        eprintln!(
            "focus on pixel {},{}: it sees a point {:.4} m away (film plane to the point, along the axis)",
            probe.pixel[0],
            probe.pixel[1],
            probe.object_distance_mm / 1e3
        );
    }

    let settings = settings_fingerprint(context, renderer, lens, frame);
    // Shards of one frame share its --out, so each keeps its own checkpoint beside it.
    let checkpoint_path =
        spec.output
            .checkpoint
            .clone()
            .unwrap_or_else(|| match spec.output.shard {
                Some(shard) => sidecar(
                    &frame.out,
                    &format!("shard-{}-of-{}.checkpoint", shard.index, shard.count),
                ),
                None => sidecar(&frame.out, "checkpoint"),
            });
    let planned = match spec.output.shard {
        Some(shard) => shard.samples(spec.spp),
        None => SampleSequence::all(spec.spp),
    };
    let Resumed {
        image: start_image,
        remaining: samples,
        spent,
    } = match &spec.output.resume {
        Some(path) => resume_from(path, &settings, spec.spp, spec.output.shard)?,
        None => Resumed {
            image: None,
            remaining: planned,
            spent: None,
        },
    };
    renderer.begin_film(start_image.as_ref())?;
    // Checkpoints this frame leaves spent once it is finished: the one it resumed and the one
    // it saved on the way.
    let mut spent: Vec<PathBuf> = spent.into_iter().collect();
    // The film so far and the samples still to render, for a resume (the checkpoint) or a
    // shard merge (the partial).
    let save_checkpoint = |path: &Path, image: &Image, remaining: SampleSequence| {
        let info = CheckpointInfo {
            version: FORMAT_VERSION,
            samples: image.samples,
            remaining: remaining.to_vec(),
            planned: spec.spp,
            shard: spec.output.shard.map(|s| (s.index, s.count)),
            settings: settings.clone(),
            invocation: Invocation::current(),
        };
        write_checkpoint(path, image, &info)
    };
    let (width, height) = {
        let s = renderer.world.resource::<RenderSettings>();
        (s.width, s.height)
    };
    let stats_before = renderer.world.resource::<RenderStats>().clone();
    progress.begin(samples.len() as u32, width * height);
    let render_start = Instant::now();
    let mut last_checkpoint = Instant::now();
    let per_update = renderer.passes_per_update();
    let mut done = 0;
    while done < samples.count {
        let batch = samples.after(done).first_n(per_update);
        renderer.render_passes(batch)?;
        done += batch.count;
        progress.advance(done);
        let remaining = samples.after(done);
        if let Some(code) = (context.stop)() {
            progress.finish();
            let image = renderer.image()?;
            save_checkpoint(&checkpoint_path, &image, remaining)?;
            if spec.output.shard.is_none() {
                let exposure = choose_exposure(spec, &image);
                write_frame_images(spec, &context.formats, frame, &image, exposure)?;
                let linear = match (&frame.exr, context.formats.exr) {
                    (Some(exr), Some(_)) => format!(" and {}", shown(exr)),
                    _ => String::new(),
                };
                eprintln!(
                    "interrupted: wrote the image so far ({} spp) to {}{linear}",
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
        if let Some(every) = spec.output.checkpoint_every
            && !remaining.is_empty()
            && last_checkpoint.elapsed().as_secs_f64() >= every
        {
            let image = renderer.image()?;
            save_checkpoint(&checkpoint_path, &image, remaining)?;
            last_checkpoint = Instant::now();
            if !spent.contains(&checkpoint_path) {
                spent.push(checkpoint_path.clone());
            }
        }
    }
    progress.finish();
    let image = renderer.image()?;
    let frame_stats = renderer
        .world
        .resource::<RenderStats>()
        .since(&stats_before);
    let lighting = SceneLighting::of(renderer);
    let warnings: Vec<String> = black_image(&image, &frame_stats, &lighting, spec.max_depth)
        .into_iter()
        .collect();
    for warning in &warnings {
        eprintln!("warning: {}: {warning}", shown(&frame.out));
    }
    if let Some(shard) = spec.output.shard {
        let partial = spec.output.partial.clone().unwrap_or_else(|| {
            sidecar(
                &frame.out,
                &format!("shard-{}-of-{}", shard.index, shard.count),
            )
        });
        save_checkpoint(&partial, &image, SampleSequence::default())?;
        eprintln!(
            "wrote {} (shard {}/{}, {} of {} spp)",
            partial.display(),
            shard.index,
            shard.count,
            image.samples,
            spec.spp
        );
    }
    let report = FrameReport {
        out: frame.out.clone(),
        lens: lens.prescription.name.clone(),
        focal_length_mm,
        f_number,
        zoom: frame.zoom,
        focus: frame.focus,
        film_distance_mm,
        film_diagonal_mm: lens.film_diagonal,
        probe,
        lens_derivation_seconds,
        render_seconds: render_start.elapsed().as_secs_f64(),
        samples: image.samples,
        warnings,
    };
    Ok(Outcome::Finished(Box::new(report), image, spent))
}

/// Writes a frame's picture to its `--out` at `exposure` (linear scale) and its linear film to
/// its `--exr`, when one is asked for.
pub(super) fn write_frame_images(
    spec: &JobSpec,
    formats: &Formats,
    frame: &Frame,
    image: &Image,
    exposure: f32,
) -> anyhow::Result<()> {
    write_image(&frame.out, image, formats.out, tone(spec, exposure))?;
    if let (Some(exr), Some(format)) = (&frame.exr, formats.exr) {
        write_image(exr, image, format, tone(spec, 1.0))?;
    }
    Ok(())
}

/// Removes the checkpoints of a finished frame, once its outputs are written: continuing one
/// would only render the frame again. Only plain files go (a checkpoint written into a FIFO or
/// a device is not a file to delete).
pub(super) fn remove_spent_checkpoints(spent: &[PathBuf]) {
    for path in spent {
        if !std::fs::symlink_metadata(path).is_ok_and(|m| m.is_file()) {
            continue;
        }
        match std::fs::remove_file(path) {
            Ok(()) => eprintln!("removed {} (the frame is finished)", path.display()),
            Err(e) => eprintln!("warning: cannot remove {}: {e}", path.display()),
        }
    }
}

/// Writes a lens setting only when it differs, so change detection re-derives nothing needlessly.
pub(crate) fn set_if_changed<
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
    let spec = context.spec;
    let settings = renderer.world.resource::<RenderSettings>();
    let rows: Vec<[f64; 4]> = lens
        .prescription
        .rows
        .iter()
        .map(|r| {
            [
                r.base.radius,
                r.base.thickness,
                r.base.index,
                r.base.aperture,
            ]
        })
        .collect();
    let mut fingerprint = json!({
        "scene": spec.scene.as_ref().map_or(DEFAULT_SCENE_PATH.to_string(), |p| p.display().to_string()),
        "lens": lens.prescription.name,
        "lens_rows": rows,
        "focus": format!("{:?}", frame.focus),
        "aperture": format!("{:?}", frame.aperture),
        "film_diagonal_mm": lens.film_diagonal,
        "pupil_sampling": spec.lens.pupil_sampling,
        "width": settings.width,
        "height": settings.height,
        "spp": spec.spp,
        "seed": settings.seed.to_string(),
        "max_depth": settings.max_depth,
        "camera": context.world_from_camera.to_cols_array().map(f64::from),
        "environment": spec.environment.as_ref().map(ToString::to_string),
    });
    // What the four columns above do not say, recorded only when present, so a spherical lens
    // without glass data keeps the fingerprint it always had.
    let surfaces = &lens.prescription.rows;
    if surfaces
        .iter()
        .any(|r| r.asphere != crate::lens::Asphere::NONE || r.base.stop != (r.base.radius == 0.0))
    {
        fingerprint["lens_shapes"] = surfaces
            .iter()
            .map(|r| json!({ "stop": r.base.stop, "conic": r.asphere.conic, "aspheric": r.asphere.coefficients }))
            .collect();
    }
    if surfaces.iter().any(|r| r.glass.is_some()) {
        fingerprint["lens_glasses"] = surfaces
            .iter()
            .map(|r| r.glass.map(|g| g.label()))
            .collect();
        fingerprint["dispersion"] = json!(spec.dispersion == Dispersion::On);
        if spec.dispersion == Dispersion::On {
            fingerprint["wavelengths"] = json!(settings.wavelengths);
        }
    }
    // A checkpoint's sums hold shares spread by one filter: a box render's fingerprint is the
    // one it had before the film had a choice.
    if !settings.filter.is_box() {
        fingerprint["filter"] = json!(settings.filter.name());
    }
    // The surfaces' losses scale every pixel: how the lens is coated, and what its file says.
    fingerprint["coating"] = json!(
        spec.lens
            .coating_choice()
            .describe(!lens.prescription.coatings.is_empty())
    );
    fingerprint["flare"] = json!(spec.flare == crate::lens::elements::Flare::On);
    // A zoom lens's position changes the picture as a lens swap does (recorded only for a zoom
    // lens, so a fixed lens keeps the fingerprint it had).
    if !lens.prescription.spacings.zoom.is_empty() {
        fingerprint["zoom_position"] = json!(frame.zoom.map(|p| p + 1));
    }
    if !lens.prescription.coatings.is_empty() {
        fingerprint["lens_coatings"] = lens
            .prescription
            .coatings
            .iter()
            .map(|c| format!("{c:?}"))
            .collect();
    }
    if let Some(diaphragm) = context.diaphragm {
        fingerprint["diaphragm"] = diaphragm.fingerprint();
    }
    // Recorded only when set, so a render without them keeps the fingerprint it always had.
    if let Some(movements) = spec.movements() {
        fingerprint["shift_mm"] = json!(movements.shift_mm);
        fingerprint["tilt_deg"] = json!(movements.tilt_deg);
    }
    if let Some(pixel) = spec.focus_on {
        fingerprint["focus_on"] = json!(pixel);
    }
    fingerprint
}

/// Where a frame starts from.
struct Resumed {
    /// The film so far (`None`: a fresh film).
    image: Option<Image>,
    /// The samples still to render.
    remaining: SampleSequence,
    /// The checkpoint continued, which the finished frame leaves spent (a finished file resumed
    /// is not: it was no checkpoint).
    spent: Option<PathBuf>,
}

/// Continues the checkpoint at `path` after checking it belongs to this render. A whole frame's
/// checkpoint continues to any `spp` at least the samples it holds: sample *k* of a pixel is the
/// same whatever the target (the camera's sequences are progressive), so the result is the
/// render made at that spp directly. A shard's continues to its own target only, which its
/// partition depends on.
fn resume_from(
    path: &Path,
    settings: &Value,
    spp: u32,
    shard: Option<Shard>,
) -> anyhow::Result<Resumed> {
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
    // A whole frame may continue to another spp; a shard may not.
    let free: &[&str] = match shard {
        None => &["spp"],
        Some(_) => &[],
    };
    let differing = differing_settings(&info.settings, settings, free);
    if !differing.is_empty() {
        bail!(
            "{}: the checkpoint was rendered with different settings ({}); resume with the same scene, lens and options",
            path.display(),
            differing.join(", ")
        );
    }
    if shard.is_some() && info.planned != spp {
        bail!(
            "{}: the checkpoint targets {} spp, not {}",
            path.display(),
            info.planned,
            spp
        );
    }
    if spp < info.samples {
        bail!(
            "{}: the checkpoint already holds {} spp, more than --spp {spp}; resume with --spp {} or more",
            path.display(),
            info.samples,
            info.samples
        );
    }
    let Some(remaining) = SampleSequence::from_list(&info.remaining) else {
        bail!(
            "{}: damaged checkpoint: its remaining samples are not a sequence realcam renders",
            path.display()
        );
    };
    let remaining = if spp == info.planned {
        remaining
    } else {
        // A whole frame renders its samples in order, so what is left is all the rest.
        if remaining != SampleSequence::all(info.planned).after(info.samples) {
            bail!(
                "{}: damaged checkpoint: its remaining samples do not follow the {} it holds",
                path.display(),
                info.samples
            );
        }
        SampleSequence::all(spp).after(info.samples)
    };
    if remaining.is_empty() {
        eprintln!(
            "note: {} is already complete ({} spp)",
            path.display(),
            info.samples
        );
    }
    Ok(Resumed {
        image: Some(image),
        remaining,
        spent: (!info.remaining.is_empty()).then(|| path.to_path_buf()),
    })
}

/// The settings that differ between a checkpoint's and this render's, by name, except `free`.
fn differing_settings(theirs: &Value, ours: &Value, free: &[&str]) -> Vec<String> {
    match (theirs, ours) {
        (Value::Object(a), Value::Object(b)) => {
            let mut keys: Vec<&String> = b
                .keys()
                .chain(a.keys().filter(|k| !b.contains_key(*k)))
                .collect();
            keys.retain(|k| !free.contains(&k.as_str()) && a.get(*k) != b.get(*k));
            keys.into_iter().cloned().collect()
        }
        _ if theirs == ours => Vec::new(),
        _ => vec!["all".into()],
    }
}
