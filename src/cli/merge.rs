//! `realcam merge`: combines the shard partials of `realcam render --shard I/N` into the image
//! one unsharded render would give ([`crate::film::merge`] does the work).
//!
//! Shard I of N renders the sample indices s ≡ I (mod N), and its partial holds the per-pixel
//! *sums* of those samples with their count (see [`crate::film::checkpoint`]). The sums of all
//! shards are the sums of all samples, so adding sums and counts gives exactly the single
//! render's film, up to float rounding in the additions.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::bail;
use clap::Args;

use super::values::{number, whole};
use crate::film::format::{
    Accepts, DEFAULT_JPEG_QUALITY, ImageFormat, Tone, check_tone_options, output_format,
};
use crate::film::merge::{format_indices, merge_partials};
use crate::film::output::{
    auto_exposure, check_not_terminal, check_writable, same_file, shown, write_image,
};

#[derive(Args, Debug, Clone)]
pub struct MergeArgs {
    /// Shard partials (.exr) written by `realcam render --shard I/N`, in any order.
    #[arg(required = true, value_name = "PARTS")]
    pub parts: Vec<PathBuf>,
    /// Output image; its extension sets the format: .png, .jpg/.jpeg, .tif/.tiff (8-bit sRGB,
    /// tone-mapped) or .exr, .hdr (linear float); `-` writes a PNG to standard output.
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Also write the linear, un-tonemapped film: .exr (OpenEXR) or .hdr (Radiance); `-`
    /// writes OpenEXR to standard output.
    #[arg(long, value_name = "FILE.exr")]
    pub exr: Option<PathBuf>,
    /// Exposure of an 8-bit output in stops: pixel = film irradiance × 2^EV [default:
    /// automatic, the log-average luminance of the pixels within 10 stops of the image's
    /// brightest percent to 18 % grey].
    #[arg(long, value_name = "EV", allow_hyphen_values = true, value_parser = number::<f32>)]
    pub exposure: Option<f32>,
    /// JPEG quality of a .jpg/.jpeg output, 1–100 [default: 90].
    #[arg(long, value_name = "Q", allow_hyphen_values = true, value_parser = whole::<u8>(1, 100))]
    pub quality: Option<u8>,
    /// Merge the shards that are there even if some of 0..N-1 are missing or unfinished (the
    /// image then has fewer samples per pixel, and more noise, than the full render).
    #[arg(long)]
    pub allow_missing: bool,
}

pub fn run(args: &MergeArgs) -> anyhow::Result<ExitCode> {
    let (out_format, exr_format) = validate(args)?;
    let merged = merge_partials(&args.parts, args.allow_missing)?;
    let n = merged.shard_count;
    if !merged.missing.is_empty() {
        eprintln!(
            "warning: shard(s) {} of 0..{} missing; merging the {} present",
            format_indices(&merged.missing),
            n - 1,
            merged.merged.len()
        );
    }
    for shard in &merged.unfinished {
        eprintln!(
            "warning: {}: unfinished shard ({} samples not rendered); merging the samples it has; finish it with `{}`",
            shard.path.display(),
            shard.remaining,
            shard.finish_command
        );
    }
    let image = &merged.image;
    let tone = |exposure| Tone {
        exposure,
        quality: args.quality.unwrap_or(DEFAULT_JPEG_QUALITY),
    };
    let exposure = args
        .exposure
        .map_or_else(|| auto_exposure(&image.mean()), |ev| 2f32.powf(ev));
    write_image(&args.out, image, out_format, tone(exposure))?;
    eprintln!(
        "wrote {} ({}×{}, {} spp from {} of {n} shards, {})",
        shown(&args.out),
        image.width,
        image.height,
        image.samples,
        merged.merged.len(),
        out_format.name()
    );
    if let (Some(exr), Some(format)) = (&args.exr, exr_format) {
        write_image(exr, image, format, tone(1.0))?;
        eprintln!("wrote {} ({})", shown(exr), format.name());
    }
    Ok(ExitCode::SUCCESS)
}

/// Checks the flags and the output paths before any partial is read; returns the formats of
/// `--out` and `--exr` from their names.
fn validate(args: &MergeArgs) -> anyhow::Result<(ImageFormat, Option<ImageFormat>)> {
    if let Some(ev) = args.exposure
        && !ev.is_finite()
    {
        bail!("--exposure must be a finite number of stops");
    }
    if let Some(quality) = args.quality
        && !(1..=100).contains(&quality)
    {
        bail!("--quality must be between 1 and 100, got {quality}");
    }
    if let Some(exr) = &args.exr
        && (args.out == *exr || same_file(&args.out, exr))
    {
        bail!(
            "{}: --out and --exr name the same file; give them different paths",
            shown(exr)
        );
    }
    let outputs: Vec<(&str, &Path)> = [
        ("--out", Some(args.out.as_path())),
        ("--exr", args.exr.as_deref()),
    ]
    .into_iter()
    .filter_map(|(option, path)| Some((option, path?)))
    .collect();
    for (_, output) in &outputs {
        if let Some(part) = args.parts.iter().find(|part| same_file(output, part)) {
            bail!(
                "{}: the output would overwrite the partial {}; choose another --out/--exr path",
                output.display(),
                part.display()
            );
        }
    }
    let out_format = output_format("--out", &args.out, Accepts::Any)?;
    let exr_format = args
        .exr
        .as_deref()
        .map(|exr| output_format("--exr", exr, Accepts::Float))
        .transpose()?;
    let mut images = vec![("--out", args.out.as_path(), out_format)];
    images.extend(
        args.exr
            .as_deref()
            .zip(exr_format)
            .map(|(p, f)| ("--exr", p, f)),
    );
    check_tone_options(&images, args.exposure.is_some(), args.quality.is_some())?;
    for (option, output) in &outputs {
        check_not_terminal(option, output)?;
        check_writable(output)?;
    }
    Ok((out_format, exr_format))
}

#[cfg(test)]
mod tests {

    use super::*;
    use crate::film::merge::tests::partial;

    #[test]
    fn command_writes_png_and_exr_and_never_overwrites_a_partial() {
        let dir = tempfile::tempdir().unwrap();
        let parts = vec![
            partial(dir.path(), 0, 2, 1.0, 2),
            partial(dir.path(), 1, 2, 3.0, 2),
        ];
        let out = dir.path().join("frame.png");
        let exr = dir.path().join("frame.exr");
        let args = MergeArgs {
            parts: parts.clone(),
            out: out.clone(),
            exr: Some(exr.clone()),
            exposure: Some(0.0),
            quality: None,
            allow_missing: false,
        };
        run(&args).unwrap();
        let png = image::open(&out).unwrap().to_rgb8();
        assert_eq!(png.dimensions(), (3, 2));
        let linear = image::open(&exr).unwrap().to_rgb32f();
        // Pixel 1: sums 2 + 4 = 6 red over 4 samples.
        assert_eq!(linear.get_pixel(1, 0).0, [1.5, 1.0, 0.5]);
        let leftovers = std::fs::read_dir(dir.path())
            .unwrap()
            .filter(|entry| entry.as_ref().unwrap().path().extension() == Some("tmp".as_ref()))
            .count();
        assert_eq!(leftovers, 0);

        let before = std::fs::read(&parts[0]).unwrap();
        let overwrite = MergeArgs {
            out: parts[0].clone(),
            exr: None,
            ..args.clone()
        };
        let message = format!("{:#}", run(&overwrite).unwrap_err());
        assert!(message.contains("would overwrite the partial"), "{message}");
        assert_eq!(std::fs::read(&parts[0]).unwrap(), before);
    }
}
