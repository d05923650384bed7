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

use super::format::EXR_ENCODING;
use super::output::write_atomically;
use super::samples::SampleSequence;
use super::{Image, MAX_IMAGE_SIDE};

const ATTRIBUTE: &str = "realcam";
/// Version 2 records the remaining samples as a sequence (three numbers) where version 1
/// listed them; both are read.
pub const FORMAT_VERSION: u32 = 2;
const READABLE_VERSIONS: std::ops::RangeInclusive<u32> = 1..=FORMAT_VERSION;

/// Memory per pixel while a checkpoint is read and merged, rounded up: the decoded sums
/// (12 B), the exr crate's block buffers, and `realcam merge`'s f64 film (24 B).
const READ_BYTES_PER_PIXEL: u64 = 64;

/// What a checkpoint or partial records besides the pixels.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CheckpointInfo {
    pub version: u32,
    /// Samples accumulated into every pixel.
    pub samples: u32,
    /// The sample indices still to render, in order (empty when complete). Recorded in the
    /// file as a [`SampleSequence`] when they form one (they always do for realcam's own
    /// renders), so that the record stays small whatever the sample count.
    #[serde(with = "compact_indices")]
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
    write_with_record(path, image, &serde_json::to_string(info)?)
}

/// Writes `image` (sums) with `json` as the `realcam` attribute, atomically.
fn write_with_record(path: &Path, image: &Image, json: &str) -> anyhow::Result<()> {
    let width = image.width as usize;
    let mut attributes = LayerAttributes::named("film sums");
    attributes.software_name = Some(Text::from("realcam"));
    attributes.other.insert(
        Text::from(ATTRIBUTE),
        AttributeValue::Text(Text::from(json)),
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

/// Sample indices as a [`SampleSequence`] object when they form one, else as a list; either
/// is read back.
mod compact_indices {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    use super::SampleSequence;

    pub fn serialize<S: Serializer>(indices: &[u32], serializer: S) -> Result<S::Ok, S::Error> {
        match SampleSequence::from_list(indices) {
            Some(sequence) => sequence.serialize(serializer),
            None => indices.serialize(serializer),
        }
    }

    /// A list first: serde would also read `[a, b, c]` as a sequence's three fields.
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Recorded {
        List(Vec<u32>),
        Sequence(SampleSequence),
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(deserializer: D) -> Result<Vec<u32>, D::Error> {
        Ok(match Recorded::deserialize(deserializer)? {
            // Three numbers could ask for billions: no render of realcam's has that many.
            Recorded::Sequence(sequence) if sequence.count > crate::film::MAX_SPP => {
                return Err(serde::de::Error::custom(format!(
                    "{} samples remaining, more than the {} realcam renders",
                    sequence.count,
                    crate::film::MAX_SPP
                )));
            }
            Recorded::Sequence(sequence) => sequence.to_vec(),
            Recorded::List(list) => list,
        })
    }
}

/// Reads a checkpoint or partial written by [`write_checkpoint`]. Its size is checked from
/// the header first, so a damaged or hostile file cannot make realcam allocate without bound.
pub fn read_checkpoint(path: &Path) -> anyhow::Result<(Image, CheckpointInfo)> {
    check_size(path)?;
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
        .map_err(|e| not_readable(path, e))?;
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
    if !READABLE_VERSIONS.contains(&info.version) {
        bail!(
            "{}: checkpoint format {} is not supported by this realcam (it reads {} to {})",
            path.display(),
            info.version,
            READABLE_VERSIONS.start(),
            READABLE_VERSIONS.end()
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

/// A checkpoint the EXR reader could not read. exr's errors repeat their source in their own
/// text, so the message takes that text alone (a missing file is named once, not twice).
fn not_readable(path: &Path, error: exr::error::Error) -> anyhow::Error {
    anyhow::anyhow!(
        "{}: not a readable OpenEXR checkpoint: {error}",
        path.display()
    )
}

/// Refuses a file whose header claims an image larger than realcam renders or than memory
/// holds, before any pixel is read.
fn check_size(path: &Path) -> anyhow::Result<()> {
    let meta =
        exr::meta::MetaData::read_from_file(path, false).map_err(|e| not_readable(path, e))?;
    for header in &meta.headers {
        let (width, height) = (header.layer_size.width(), header.layer_size.height());
        if width > MAX_IMAGE_SIDE as usize || height > MAX_IMAGE_SIDE as usize {
            bail!(
                "{}: a {width}×{height} image, larger than any realcam renders (at most {MAX_IMAGE_SIDE} pixels a side); not a realcam checkpoint",
                path.display()
            );
        }
        crate::memory::check(
            &format!("{} ({width}×{height})", path.display()),
            (width as u64 * height as u64).saturating_mul(READ_BYTES_PER_PIXEL),
            "read it on a machine with more memory",
        )?;
    }
    Ok(())
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

    fn record(path: &Path) -> String {
        let bytes = std::fs::read(path).unwrap();
        let text = String::from_utf8_lossy(&bytes);
        let start = text.find("{\"version\"").unwrap();
        let end = start + text[start..].find('}').unwrap();
        text[start..=end].to_string()
    }

    #[test]
    fn remaining_samples_are_recorded_as_a_sequence_and_lists_still_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.exr");
        let image = Image {
            width: 2,
            height: 1,
            sums: vec![[1.0; 3]; 2],
            samples: 1,
        };
        let mut info = CheckpointInfo {
            version: FORMAT_VERSION,
            samples: 1,
            remaining: SampleSequence::every(4, 3, 1 << 24).to_vec(),
            planned: 1 << 24,
            shard: Some((1, 3)),
            settings: serde_json::json!({}),
            invocation: None,
        };
        write_checkpoint(&path, &image, &info).unwrap();
        let recorded = record(&path);
        assert!(
            recorded.contains(r#""remaining":{"first":4,"step":3,"count":5592404}"#),
            "{recorded}"
        );
        assert_eq!(read_checkpoint(&path).unwrap().1, info);
        // Not a sequence: kept as a list.
        info.remaining = vec![4, 7, 8];
        write_checkpoint(&path, &image, &info).unwrap();
        assert!(record(&path).contains(r#""remaining":[4,7,8]"#));
        assert_eq!(read_checkpoint(&path).unwrap().1, info);
        // Version 1 listed the samples.
        let version_1 = r#"{"version":1,"samples":1,"remaining":[5,7],"planned":8,"shard":[1,2],"settings":{}}"#;
        write_with_record(&path, &image, version_1).unwrap();
        let (_, read) = read_checkpoint(&path).unwrap();
        assert_eq!((read.version, read.remaining), (1, vec![5, 7]));
        // A damaged record cannot ask for billions of indices.
        let huge = r#"{"version":2,"samples":1,"remaining":{"first":0,"step":1,"count":4000000000},"planned":8,"shard":null,"settings":{}}"#;
        write_with_record(&path, &image, huge).unwrap();
        let message = format!("{:#}", read_checkpoint(&path).unwrap_err());
        assert!(
            message.contains("damaged") && message.contains("4000000000"),
            "{message}"
        );
    }

    #[test]
    fn an_image_larger_than_realcam_renders_is_refused_before_reading_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("wide.exr");
        let width = MAX_IMAGE_SIDE + 1;
        let image = Image {
            width,
            height: 1,
            sums: vec![[0.0; 3]; width as usize],
            samples: 1,
        };
        let info = CheckpointInfo {
            version: FORMAT_VERSION,
            samples: 1,
            remaining: Vec::new(),
            planned: 1,
            shard: None,
            settings: serde_json::json!({}),
            invocation: None,
        };
        write_checkpoint(&path, &image, &info).unwrap();
        let message = read_checkpoint(&path).unwrap_err().to_string();
        assert!(
            message.contains("wide.exr") && message.contains("16385×1"),
            "{message}"
        );
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
