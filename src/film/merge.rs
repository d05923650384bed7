//! Merging the shard partials of `realcam render --shard I/N` into the film one unsharded
//! render would give (`realcam merge`).
//!
//! Shard I of N renders the sample indices s ≡ I (mod N), and its partial holds the per-pixel
//! *sums* of those samples with their count (see [`crate::film::checkpoint`]). The sums of all
//! shards are the sums of all samples, so adding sums and counts gives exactly the single
//! render's film, up to float rounding in the additions.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};

use crate::film::Image;
use crate::film::checkpoint::{CheckpointInfo, Invocation, read_checkpoint};

/// The merged film and what went into it.
#[derive(Debug)]
pub struct Merged {
    pub image: Image,
    /// N of the `--shard I/N` the partials were rendered with.
    pub shard_count: u32,
    /// Shard indices merged, ascending.
    pub merged: Vec<u32>,
    /// Shard indices of 0..N-1 with no partial (only with `allow_missing`).
    pub missing: Vec<u32>,
    /// Checkpoints of stopped shards, which had samples left to render (only with
    /// `allow_missing`).
    pub unfinished: Vec<Unfinished>,
}

/// A stopped shard's checkpoint given to merge.
#[derive(Debug, PartialEq)]
pub struct Unfinished {
    pub path: PathBuf,
    /// Samples per pixel the shard still had to render.
    pub remaining: usize,
    /// The shell command that finishes the shard: its own command line with `--resume`.
    pub finish_command: String,
}

/// What a partial says about itself. Its pixels are added up as soon as it is read and then
/// dropped, so merging 64 shards of an 8K frame holds one partial at a time, not 64.
struct Partial {
    path: PathBuf,
    info: CheckpointInfo,
    index: u32,
    count: u32,
    width: u32,
    height: u32,
}

/// Reads the partials at `paths` and adds them up. Refuses, naming the files, partials of
/// different frames (settings, size or shard count differ), a shard given twice, and, unless
/// `allow_missing`, missing or unfinished shards.
pub fn merge_partials(paths: &[PathBuf], allow_missing: bool) -> anyhow::Result<Merged> {
    let mut partials: Vec<Partial> = Vec::with_capacity(paths.len());
    // Shard index → position in `partials`.
    let mut by_index: BTreeMap<u32, usize> = BTreeMap::new();
    let mut film: Option<Film> = None;
    for path in paths {
        let (partial, image) = read_partial(path)?;
        if let Some(first) = partials.first() {
            check_same_frame(first, &partial)?;
        }
        if let Some(&earlier) = by_index.get(&partial.index) {
            bail!(
                "shard {}/{} is given twice: {} and {}; give each shard's partial once",
                partial.index,
                partial.count,
                partials[earlier].path.display(),
                partial.path.display()
            );
        }
        film.get_or_insert_with(|| Film::new(partial.width, partial.height))
            .add(&image, &partial.path)?;
        by_index.insert(partial.index, partials.len());
        partials.push(partial);
    }
    let (Some(film), Some(first)) = (film, partials.first()) else {
        bail!("no partials to merge");
    };
    let shard_count = first.count;

    let missing: Vec<u32> = (0..shard_count)
        .filter(|index| !by_index.contains_key(index))
        .collect();
    if !missing.is_empty() && !allow_missing {
        let given: Vec<String> = by_index
            .iter()
            .map(|(index, &at)| format!("{index} in {}", partials[at].path.display()))
            .collect();
        bail!(
            "shard(s) {} of 0..{} are missing (given: {}); render them with `realcam render … --shard I/{shard_count}`, or pass --allow-missing to merge what is there",
            format_indices(&missing),
            shard_count - 1,
            given.join(", "),
        );
    }
    let unfinished: Vec<Unfinished> = by_index
        .values()
        .map(|&at| &partials[at])
        .filter(|partial| !partial.info.remaining.is_empty())
        .map(|partial| Unfinished {
            path: partial.path.clone(),
            remaining: partial.info.remaining.len(),
            finish_command: finish_command(partial),
        })
        .collect();
    if let Some(shard) = unfinished.first()
        && !allow_missing
    {
        bail!(
            "{}: this shard is unfinished (it was stopped with {} of its samples not rendered); finish it with `{}` and merge the partial that writes, or pass --allow-missing to merge the samples it has",
            shard.path.display(),
            shard.remaining,
            shard.finish_command
        );
    }

    Ok(Merged {
        image: film.finish()?,
        shard_count,
        merged: by_index.keys().copied().collect(),
        missing,
        unfinished,
    })
}

fn read_partial(path: &Path) -> anyhow::Result<(Partial, Image)> {
    let (image, info) = read_checkpoint(path)?;
    let Some((index, count)) = info.shard else {
        bail!(
            "{}: a checkpoint of an unsharded render, not a shard partial; merge combines the partials of `realcam render --shard I/N` (continue a checkpoint with --resume instead)",
            path.display()
        );
    };
    if count == 0 || index >= count {
        bail!(
            "{}: damaged partial: shard {index}/{count} is not one of 0..N-1",
            path.display()
        );
    }
    let partial = Partial {
        path: path.to_path_buf(),
        info,
        index,
        count,
        width: image.width,
        height: image.height,
    };
    Ok((partial, image))
}

/// The command that continues a stopped shard from its checkpoint: the command line that wrote
/// the checkpoint, run in the same directory, with `--resume` naming the checkpoint (by its
/// canonical path, so the command works from anywhere).
fn finish_command(partial: &Partial) -> String {
    let checkpoint = partial
        .path
        .canonicalize()
        .or_else(|_| std::path::absolute(&partial.path))
        .unwrap_or_else(|_| partial.path.clone());
    let checkpoint = checkpoint.to_string_lossy();
    let Some(Invocation { directory, args }) = &partial.info.invocation else {
        // A checkpoint of an older realcam, which did not record its command line.
        return format!(
            "realcam render <the shard's own scene and options> --shard {}/{} --resume {}",
            partial.index,
            partial.count,
            shell_word(&checkpoint)
        );
    };
    let mut words: Vec<&str> = Vec::with_capacity(args.len() + 2);
    let mut arguments = args.iter();
    while let Some(arg) = arguments.next() {
        if arg == "--resume" {
            arguments.next();
        } else if !arg.starts_with("--resume=") {
            words.push(arg);
        }
    }
    words.extend(["--resume", &checkpoint]);
    let command: Vec<String> = words.into_iter().map(shell_word).collect();
    format!("cd {} && {}", shell_word(directory), command.join(" "))
}

/// `word` as one word for a POSIX shell: as it is when that is safe, else in single quotes.
fn shell_word(word: &str) -> String {
    let plain = !word.is_empty()
        && word
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./=:,+@%^".contains(c));
    if plain {
        word.to_string()
    } else {
        format!("'{}'", word.replace('\'', r"'\''"))
    }
}

/// Partials of one frame share the shard count, the image size and every setting.
fn check_same_frame(first: &Partial, partial: &Partial) -> anyhow::Result<()> {
    let (a, b) = (first.path.display(), partial.path.display());
    if partial.count != first.count {
        bail!(
            "{a} is one of {} shards but {b} is one of {}: partials of one frame are rendered with the same N in --shard I/N",
            first.count,
            partial.count
        );
    }
    if (partial.width, partial.height) != (first.width, first.height) {
        bail!(
            "{a} is {}×{} pixels but {b} is {}×{}: partials of one frame have the same size",
            first.width,
            first.height,
            partial.width,
            partial.height
        );
    }
    if partial.info.settings != first.info.settings {
        bail!(
            "{a} and {b} were rendered with different settings ({}); every shard of a frame must use the same scene, lens, settings and seed",
            settings_difference(&first.info.settings, &partial.info.settings)
        );
    }
    Ok(())
}

/// The settings that differ, as `key: a vs b`, for messages.
fn settings_difference(a: &serde_json::Value, b: &serde_json::Value) -> String {
    const SHOWN: usize = 5;
    let short = |value: Option<&serde_json::Value>| {
        let text = value.map_or("(absent)".to_string(), serde_json::Value::to_string);
        if text.chars().count() > 60 {
            format!("{}…", text.chars().take(60).collect::<String>())
        } else {
            text
        }
    };
    let (Some(a), Some(b)) = (a.as_object(), b.as_object()) else {
        return format!("{} vs {}", short(Some(a)), short(Some(b)));
    };
    let mut keys: Vec<&String> = a.keys().chain(b.keys()).collect();
    keys.sort();
    keys.dedup();
    let differing: Vec<String> = keys
        .into_iter()
        .filter(|key| a.get(*key) != b.get(*key))
        .map(|key| format!("{key}: {} vs {}", short(a.get(key)), short(b.get(key))))
        .collect();
    match differing.len() {
        0 => "they differ".to_string(),
        n if n > SHOWN => format!("{}; and {} more", differing[..SHOWN].join("; "), n - SHOWN),
        _ => differing.join("; "),
    }
}

/// The merged film so far: per-pixel sums in f64 (adding a few dozen f32 partials in f64 loses
/// nothing, so the order of the files hardly matters) and the total sample count.
struct Film {
    width: u32,
    height: u32,
    sums: Vec<[f64; 3]>,
    samples: u32,
}

impl Film {
    fn new(width: u32, height: u32) -> Film {
        Film {
            width,
            height,
            sums: vec![[0.0; 3]; width as usize * height as usize],
            samples: 0,
        }
    }

    fn add(&mut self, image: &Image, path: &Path) -> anyhow::Result<()> {
        self.samples = self
            .samples
            .checked_add(image.samples)
            .with_context(|| format!("{}: too many samples in all", path.display()))?;
        for (total, part) in self.sums.iter_mut().zip(&image.sums) {
            for channel in 0..3 {
                total[channel] += f64::from(part[channel]);
            }
        }
        Ok(())
    }

    fn finish(self) -> anyhow::Result<Image> {
        if self.samples == 0 {
            bail!(
                "the partials hold no samples (more shards than samples per pixel?); nothing to merge"
            );
        }
        Ok(Image {
            width: self.width,
            height: self.height,
            sums: self.sums.iter().map(|s| s.map(|c| c as f32)).collect(),
            samples: self.samples,
        })
    }
}

/// `0, 3–5, 9` for messages.
pub fn format_indices(indices: &[u32]) -> String {
    let mut runs: Vec<(u32, u32)> = Vec::new();
    for &index in indices {
        match runs.last_mut() {
            Some((_, end)) if *end + 1 == index => *end = index,
            _ => runs.push((index, index)),
        }
    }
    runs.iter()
        .map(|&(start, end)| match end - start {
            0 => start.to_string(),
            1 => format!("{start}, {end}"),
            _ => format!("{start}–{end}"),
        })
        .collect::<Vec<_>>()
        .join(", ")
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::film::checkpoint::{FORMAT_VERSION, write_checkpoint};
    use serde_json::json;

    /// A 3×2 partial of shard `index`/`count` whose pixel i holds `base + i` in every channel.
    pub(crate) fn partial(dir: &Path, index: u32, count: u32, base: f32, samples: u32) -> PathBuf {
        let image = Image {
            width: 3,
            height: 2,
            sums: (0..6)
                .map(|i| [base + i as f32, base, 0.5 * base])
                .collect(),
            samples,
        };
        write(
            dir,
            &format!("p{index}-{count}.exr"),
            &image,
            info(index, count, samples),
        )
    }

    fn info(index: u32, count: u32, samples: u32) -> CheckpointInfo {
        CheckpointInfo {
            version: FORMAT_VERSION,
            samples,
            remaining: Vec::new(),
            planned: samples,
            shard: Some((index, count)),
            settings: json!({"seed": 7, "spp": 8, "lens": "dgauss.50mm"}),
            invocation: None,
        }
    }

    fn write(dir: &Path, name: &str, image: &Image, info: CheckpointInfo) -> PathBuf {
        let path = dir.join(name);
        write_checkpoint(&path, image, &info).unwrap();
        path
    }

    fn error(paths: &[PathBuf]) -> String {
        format!("{:#}", merge_partials(paths, false).unwrap_err())
    }

    #[test]
    fn sums_and_sample_counts_add_up() {
        let dir = tempfile::tempdir().unwrap();
        let a = partial(dir.path(), 0, 2, 1.0, 3);
        let b = partial(dir.path(), 1, 2, 10.0, 5);
        let merged = merge_partials(&[a.clone(), b.clone()], false).unwrap();
        assert_eq!(merged.image.samples, 8);
        assert_eq!((merged.image.width, merged.image.height), (3, 2));
        for (i, sum) in merged.image.sums.iter().enumerate() {
            assert_eq!(*sum, [11.0 + 2.0 * i as f32, 11.0, 5.5]);
        }
        assert_eq!(merged.merged, [0, 1]);
        assert!(merged.missing.is_empty() && merged.unfinished.is_empty());
        // The order of the arguments does not matter (f64 sums of these f32 values are exact).
        let swapped = merge_partials(&[b, a], false).unwrap();
        assert_eq!(swapped.image, merged.image);
    }

    #[test]
    fn partials_of_different_frames_are_refused_naming_both() {
        let dir = tempfile::tempdir().unwrap();
        let a = partial(dir.path(), 0, 2, 1.0, 4);
        let image = Image {
            width: 3,
            height: 2,
            sums: vec![[1.0; 3]; 6],
            samples: 4,
        };
        let mut other_seed = info(1, 2, 4);
        other_seed.settings["seed"] = json!(8);
        let b = write(dir.path(), "seed8.exr", &image, other_seed);
        let message = error(&[a.clone(), b]);
        assert!(
            message.contains("p0-2.exr") && message.contains("seed8.exr"),
            "{message}"
        );
        assert!(message.contains("seed: 7 vs 8"), "{message}");
        assert!(!message.contains("spp"), "only what differs: {message}");

        let small = Image {
            width: 2,
            height: 2,
            sums: vec![[1.0; 3]; 4],
            samples: 4,
        };
        let b = write(dir.path(), "small.exr", &small, info(1, 2, 4));
        let message = error(&[a.clone(), b]);
        assert!(
            message.contains("3×2") && message.contains("2×2"),
            "{message}"
        );

        let b = partial(dir.path(), 1, 3, 1.0, 4);
        let message = error(&[a, b]);
        assert!(
            message.contains("p1-3.exr") && message.contains("same N"),
            "{message}"
        );
    }

    #[test]
    fn a_shard_given_twice_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let a = partial(dir.path(), 0, 2, 1.0, 4);
        let copy = dir.path().join("copy.exr");
        std::fs::copy(&a, &copy).unwrap();
        let message = error(&[a, copy]);
        assert!(
            message.contains("shard 0/2 is given twice")
                && message.contains("p0-2.exr")
                && message.contains("copy.exr"),
            "{message}"
        );
    }

    #[test]
    fn missing_shards_are_listed_unless_allowed() {
        let dir = tempfile::tempdir().unwrap();
        let parts: Vec<PathBuf> = [0, 1, 5, 7]
            .into_iter()
            .map(|i| partial(dir.path(), i, 8, i as f32, 1))
            .collect();
        let message = error(&parts);
        assert!(
            message.contains("shard(s) 2–4, 6 of 0..7 are missing"),
            "{message}"
        );
        assert!(message.contains("--allow-missing"), "{message}");
        let merged = merge_partials(&parts, true).unwrap();
        assert_eq!(merged.missing, [2, 3, 4, 6]);
        assert_eq!(merged.merged, [0, 1, 5, 7]);
        assert_eq!(merged.image.samples, 4);
        assert_eq!(merged.image.sums[0], [13.0, 13.0, 6.5]);
    }

    #[test]
    fn unfinished_shards_and_plain_checkpoints_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let a = partial(dir.path(), 0, 2, 1.0, 4);
        let image = Image {
            width: 3,
            height: 2,
            sums: vec![[1.0; 3]; 6],
            samples: 2,
        };
        let mut unfinished = info(1, 2, 2);
        unfinished.remaining = vec![5, 7];
        unfinished.invocation = Some(Invocation {
            directory: "/farm/job 7".into(),
            args: [
                "/opt/realcam",
                "render",
                "/scenes/it's.glb",
                "--shard",
                "1/2",
                "--resume",
                "old.exr",
                "--spp",
                "8",
                "--resume=older.exr",
            ]
            .map(String::from)
            .to_vec(),
        });
        let b = write(dir.path(), "half.exr", &image, unfinished);
        let message = error(&[a.clone(), b.clone()]);
        assert!(
            message.contains("half.exr") && message.contains("unfinished"),
            "{message}"
        );
        // The shard's own command line, in its directory, resuming this checkpoint (and no
        // earlier one), quoted for a shell.
        let finish = format!(
            "cd '/farm/job 7' && /opt/realcam render '/scenes/it'\\''s.glb' --shard 1/2 --spp 8 --resume {}",
            b.canonicalize().unwrap().display()
        );
        assert!(message.contains(&format!("`{finish}`")), "{message}");
        let merged = merge_partials(&[a.clone(), b.clone()], true).unwrap();
        assert_eq!(
            merged.unfinished,
            [Unfinished {
                path: b,
                remaining: 2,
                finish_command: finish
            }]
        );
        assert_eq!(merged.image.samples, 6);

        let mut plain = info(0, 1, 2);
        plain.shard = None;
        let c = write(dir.path(), "plain.exr", &image, plain);
        let message = error(&[c]);
        assert!(
            message.contains("plain.exr") && message.contains("not a shard partial"),
            "{message}"
        );

        let broken = write(dir.path(), "broken.exr", &image, info(4, 2, 2));
        let message = error(&[a, broken]);
        assert!(
            message.contains("broken.exr") && message.contains("4/2"),
            "{message}"
        );
    }

    #[test]
    fn index_lists_are_compact() {
        assert_eq!(format_indices(&[0, 3, 4, 5, 9]), "0, 3–5, 9");
        assert_eq!(format_indices(&[1, 2]), "1, 2");
        assert_eq!(format_indices(&[]), "");
    }
}
