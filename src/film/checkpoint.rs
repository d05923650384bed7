//! Checkpoints and shard partials: the film's *sums* in a linear float EXR, with the sample
//! count, seed and settings stored as an EXR attribute, so that a render can be continued
//! (`--resume`) or split across machines and merged (`realcam merge`) without losing a bit.
//!
//! The RGB channels hold per-pixel sums of weighted samples, not means: divide by the
//! `samples` recorded in the `realcam` attribute to view one.

use std::io::Cursor;
use std::path::Path;

use anyhow::{Context, bail};
use exr::meta::attribute::{AttributeValue, Text};
use exr::prelude::{
    Image as ExrImage, Layer, LayerAttributes, ReadChannels, ReadLayers, SpecificChannels,
    WritableImage, read,
};

use super::Image;
use super::format::EXR_ENCODING;
use super::output::write_atomically;

const ATTRIBUTE: &str = "realcam";
pub const FORMAT_VERSION: u32 = 1;

/// What a checkpoint or partial records besides the pixels.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CheckpointInfo {
    pub version: u32,
    /// Samples accumulated into every pixel.
    pub samples: u32,
    /// The sample indices still to render, in order (empty when complete).
    pub remaining: Vec<u32>,
    /// All sample indices this file's render was asked for (its target).
    pub planned: u32,
    /// Which shard this is (I, N), if any.
    pub shard: Option<(u32, u32)>,
    /// Settings that must match to resume or merge: seed, resolution, lens, scene, … as JSON.
    pub settings: serde_json::Value,
    /// The command line that wrote the file, so that `realcam merge` can name the command that
    /// finishes a stopped shard (absent in files of older versions).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub invocation: Option<Invocation>,
}

/// A command line and the directory it ran in (its relative paths are relative to that).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Invocation {
    pub directory: String,
    /// The program as invoked, then its arguments.
    pub args: Vec<String>,
}

impl Invocation {
    /// This process's command line, or `None` when a part of it is not UTF-8 (a lossy copy
    /// would name a command that does something else).
    pub fn current() -> Option<Invocation> {
        let directory = std::env::current_dir()
            .ok()?
            .into_os_string()
            .into_string()
            .ok()?;
        let args = std::env::args_os()
            .map(|arg| arg.into_string().ok())
            .collect::<Option<Vec<String>>>()?;
        Some(Invocation { directory, args })
    }
}

/// Writes `image` (sums) with `info`, atomically.
pub fn write_checkpoint(path: &Path, image: &Image, info: &CheckpointInfo) -> anyhow::Result<()> {
    let width = image.width as usize;
    let mut attributes = LayerAttributes::named("film sums");
    attributes.software_name = Some(Text::from("realcam"));
    let json = serde_json::to_string(info)?;
    attributes.other.insert(
        Text::from(ATTRIBUTE),
        AttributeValue::Text(Text::from(json.as_str())),
    );
    let sums = &image.sums;
    let layer = Layer::new(
        (image.width as usize, image.height as usize),
        attributes,
        EXR_ENCODING,
        SpecificChannels::rgba(|p: exr::math::Vec2<usize>| {
            let s = sums[p.y() * width + p.x()];
            (s[0], s[1], s[2], 1.0f32)
        }),
    );
    let exr = ExrImage::from_layer(layer);
    write_atomically(path, |bytes| {
        exr.write()
            .to_buffered(Cursor::new(bytes))
            .context("cannot encode EXR")?;
        Ok(())
    })
}

/// Reads a checkpoint or partial written by [`write_checkpoint`].
pub fn read_checkpoint(path: &Path) -> anyhow::Result<(Image, CheckpointInfo)> {
    let file = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |resolution, _| {
                (
                    resolution.width(),
                    vec![[0.0f32; 3]; resolution.width() * resolution.height()],
                )
            },
            |(width, pixels): &mut (usize, Vec<[f32; 3]>),
             p,
             (r, g, b, _a): (f32, f32, f32, f32)| {
                pixels[p.y() * *width + p.x()] = [r, g, b];
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .with_context(|| format!("{}: not a readable OpenEXR checkpoint", path.display()))?;
    let layer = &file.layer_data;
    let Some(AttributeValue::Text(text)) = layer.attributes.other.get(&Text::from(ATTRIBUTE))
    else {
        bail!(
            "{}: an EXR without realcam's checkpoint data (was it written by --checkpoint or --shard?)",
            path.display()
        );
    };
    let info: CheckpointInfo = serde_json::from_str(&text.to_string())
        .with_context(|| format!("{}: damaged realcam checkpoint data", path.display()))?;
    if info.version != FORMAT_VERSION {
        bail!(
            "{}: checkpoint format {} is not supported by this realcam (expects {})",
            path.display(),
            info.version,
            FORMAT_VERSION
        );
    }
    let size = layer.size;
    let (_, sums) = &layer.channel_data.pixels;
    if sums.iter().flatten().any(|v| !v.is_finite()) {
        bail!("{}: checkpoint holds non-finite values", path.display());
    }
    let image = Image {
        width: size.width() as u32,
        height: size.height() as u32,
        sums: sums.clone(),
        samples: info.samples,
    };
    Ok((image, info))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checkpoint_round_trips_bit_for_bit() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.exr");
        let sums: Vec<[f32; 3]> = (0..12)
            .map(|i| [i as f32 * 0.1, 1.0 / (i as f32 + 3.0), 1e-7 * i as f32])
            .collect();
        let image = Image {
            width: 4,
            height: 3,
            sums,
            samples: 7,
        };
        let info = CheckpointInfo {
            version: FORMAT_VERSION,
            samples: 7,
            remaining: vec![7, 8, 9],
            planned: 10,
            shard: Some((1, 3)),
            settings: serde_json::json!({"seed": 5}),
            invocation: Some(Invocation {
                directory: "/farm/frames".into(),
                args: vec![
                    "realcam".into(),
                    "render".into(),
                    "--shard".into(),
                    "1/3".into(),
                ],
            }),
        };
        write_checkpoint(&path, &image, &info).unwrap();
        let (back, back_info) = read_checkpoint(&path).unwrap();
        assert_eq!(back, image);
        assert_eq!(back_info, info);
    }

    #[test]
    fn foreign_or_broken_files_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.exr");
        std::fs::write(&path, b"not an exr").unwrap();
        assert!(
            read_checkpoint(&path)
                .unwrap_err()
                .to_string()
                .contains("x.exr")
        );
        let plain = dir.path().join("plain.exr");
        let image = Image {
            width: 2,
            height: 2,
            sums: vec![[1.0; 3]; 4],
            samples: 1,
        };
        super::super::output::write_exr(&plain, &image).unwrap();
        assert!(
            read_checkpoint(&plain)
                .unwrap_err()
                .to_string()
                .contains("checkpoint data")
        );
    }
}
