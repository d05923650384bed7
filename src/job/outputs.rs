//! A render job's outputs: checked before anything is loaded or rendered.

use std::path::{Path, PathBuf};

use anyhow::bail;

use super::plan::frame_count;
use crate::cli::render::RenderArgs;
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

/// Checks the numbers the flags give (counts, sizes, exposure, lens settings).
pub fn check_values(args: &RenderArgs) -> anyhow::Result<()> {
    args.lens_options.validate()?;
    if let Some(movements) = super::movements(args) {
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
    Ok(())
}

/// Checks the flags and the output paths before anything is loaded or rendered; returns the
/// formats the outputs' names ask for.
pub fn validate(args: &RenderArgs) -> anyhow::Result<Formats> {
    check_values(args)?;
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
pub(crate) fn outputs(args: &RenderArgs) -> Vec<(&'static str, &Path)> {
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
pub(crate) fn refuse_overwriting_scene_files(
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
