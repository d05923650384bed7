//! A render job's outputs: checked before anything is loaded or rendered.

use std::path::{Path, PathBuf};

use anyhow::bail;

use super::plan::{StopSweep, frame_count};
use super::spec::JobSpec;
use crate::film::format::{
    Accepts, ImageFormat, check_tone_options, output_format, require_extension,
};
use crate::film::output::{check_not_terminal, check_writable, is_stdout, same_file, shown};
use crate::film::{MAX_IMAGE_SIDE, MAX_SPP};
use crate::memory::MAX_THREADS;
use crate::scene::referenced_files;

/// The formats the run's image outputs are written in, from their names.
#[derive(Clone, Copy, Debug)]
pub struct Formats {
    pub out: ImageFormat,
    pub exr: Option<ImageFormat>,
    pub contact_sheet: Option<ImageFormat>,
}

/// Checks the numbers the spec gives (counts, sizes, exposure, lens settings).
pub fn check_values(spec: &JobSpec) -> anyhow::Result<()> {
    spec.lens.validate()?;
    if let Some(movements) = spec.movements() {
        movements.validate().map_err(|e| anyhow::anyhow!("--{e}"))?;
    }
    if spec.spp == 0 {
        bail!("--spp must be at least 1");
    }
    if spec.spp > MAX_SPP {
        bail!(
            "--spp must be at most {MAX_SPP} (2^24), got {}: the film sums samples in f32, which cannot take in one more sample beyond 2^24 of them",
            spec.spp
        );
    }
    for (name, value) in [("width", spec.width), ("height", spec.height)] {
        if let Some(v) = value
            && !(1..=MAX_IMAGE_SIDE).contains(&v)
        {
            bail!("--{name} must be between 1 and {MAX_IMAGE_SIDE} pixels, got {v}");
        }
    }
    if spec.max_depth == 0 {
        bail!("--max-depth must be at least 1 (1 = direct lighting only)");
    }
    let most = crate::lens::hero_wavelengths::MAX_WAVELENGTHS;
    if !(1..=most).contains(&spec.wavelengths) {
        bail!(
            "--wavelengths must be between 1 and {most}, got {}: the wavelengths each camera sample carries through the glass",
            spec.wavelengths
        );
    }
    if let Some(threads) = spec.threads
        && !(1..=MAX_THREADS).contains(&threads)
    {
        bail!(
            "--threads must be between 1 and {MAX_THREADS}, got {threads}: more threads than that only cost memory"
        );
    }
    if let Some(quality) = spec.output.quality
        && !(1..=100).contains(&quality)
    {
        bail!("--quality must be between 1 and 100, got {quality}");
    }
    if let Some(ev) = spec.output.exposure
        && !ev.is_finite()
    {
        bail!("--exposure must be a finite number of stops");
    }
    if let Some(every) = spec.output.checkpoint_every
        && !(every.is_finite() && every > 0.0)
    {
        bail!("--checkpoint-every must be a positive number of seconds");
    }
    Ok(())
}

/// Checks the spec's values and output paths before anything is loaded or rendered; returns the
/// formats the outputs' names ask for.
pub fn validate(spec: &JobSpec) -> anyhow::Result<Formats> {
    check_values(spec)?;
    // Before the lenses are read, a zoom sweep counts as its fewest positions, two a lens.
    let zoom_frames = vec![if spec.zoom_sweep { 2 } else { 1 }; spec.lenses.len().max(1)];
    let frames = frame_count(
        &zoom_frames,
        spec.focus_sweep,
        spec.stop_sweep.map(StopSweep::sweep),
    )?;
    let outputs = spec.output.files();
    for (i, (_, a)) in outputs.iter().enumerate() {
        if outputs[..i].iter().any(|(_, b)| a == b) {
            bail!(
                "{}: given for two outputs; each output needs its own path",
                shown(a)
            );
        }
    }
    let inputs: Vec<&Path> = spec
        .scene
        .iter()
        .map(PathBuf::as_path)
        .chain(spec.lenses.iter().map(Path::new))
        .chain(spec.lens.aperture_image.as_deref())
        .chain(
            spec.output
                .resume
                .as_deref()
                .filter(|r| Some(*r) != spec.output.checkpoint.as_deref()),
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
    if let Some(scene_files) = spec.scene.as_deref().and_then(referenced_files) {
        refuse_overwriting_scene_files(spec, &scene_files)?;
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
        out: output_format("--out", &spec.output.out, Accepts::Any)?,
        exr: spec
            .output
            .exr
            .as_deref()
            .map(|p| output_format("--exr", p, Accepts::Float))
            .transpose()?,
        contact_sheet: spec
            .output
            .contact_sheet
            .as_deref()
            .map(|p| output_format("--contact-sheet", p, Accepts::EightBit))
            .transpose()?,
    };
    for (option, path) in [
        ("--checkpoint", &spec.output.checkpoint),
        ("--partial", &spec.output.partial),
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
    if let Some(stats) = &spec.output.stats
        && !is_stdout(stats)
    {
        require_extension("--stats", stats, "json", "JSON")?;
    }
    if spec.output.shard.is_none() {
        let images: Vec<(&str, &Path, ImageFormat)> = [
            Some(("--out", spec.output.out.as_path(), formats.out)),
            spec.output
                .exr
                .as_deref()
                .zip(formats.exr)
                .map(|(p, f)| ("--exr", p, f)),
            spec.output
                .contact_sheet
                .as_deref()
                .zip(formats.contact_sheet)
                .map(|(p, f)| ("--contact-sheet", p, f)),
        ]
        .into_iter()
        .flatten()
        .collect();
        check_tone_options(
            &images,
            spec.output.exposure.is_some(),
            spec.output.quality.is_some(),
        )?;
    }
    Ok(formats)
}

/// Outputs must not replace the scene's buffers or textures (`--out scene.bin`).
pub(crate) fn refuse_overwriting_scene_files(
    spec: &JobSpec,
    scene_files: &[PathBuf],
) -> anyhow::Result<()> {
    for (_, output) in spec.output.files() {
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
