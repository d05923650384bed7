//! `realcam render` from the outside: lens runs and sweeps, stats, interruption and resume,
//! shards, determinism across thread counts.

use crate::support;

use support::cli::{ok, realcam};

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use realcam::film::checkpoint::read_checkpoint;

/// Linear RGB floats of an EXR written by `--exr`.
fn exr_pixels(path: &Path) -> Vec<f32> {
    image::open(path).unwrap().to_rgb32f().into_raw()
}

const SMALL: [&str; 6] = ["--width", "24", "--height", "16", "--max-depth", "2"];

#[test]
fn several_lenses_share_one_scene_load_and_one_bvh() {
    let dir = tempfile::tempdir().unwrap();
    let mut args = vec![
        "render",
        "--lens",
        "dgauss.50mm",
        "--lens",
        "wide.22mm",
        "--spp",
        "2",
        "--stats",
        "stats.json",
        "--contact-sheet",
        "sheet.png",
    ];
    args.extend(SMALL);
    ok(&realcam(dir.path(), &args));
    for file in [
        "render-dgauss.50mm.png",
        "render-wide.22mm.png",
        "sheet.png",
    ] {
        assert!(dir.path().join(file).exists(), "{file}");
    }
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("stats.json")).unwrap()).unwrap();
    assert_eq!(stats["bvh_builds"], 1);
    assert_eq!(stats["scene_loads"], 1);
    let frames = stats["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 2);
    assert!((frames[1]["focal_length_mm"].as_f64().unwrap() - 22.02).abs() < 0.01);
    let sheet = image::open(dir.path().join("sheet.png")).unwrap();
    assert!(
        sheet.width() >= 2 * 24 && sheet.height() > 16,
        "two thumbnails side by side with captions"
    );
}

#[test]
fn frame_n_of_a_focus_sweep_equals_a_single_render_at_that_distance() {
    let dir = tempfile::tempdir().unwrap();
    let mut args = vec![
        "render",
        "--focus-sweep",
        "1:8:3",
        "--spp",
        "2",
        "--exr",
        "sweep.exr",
        "--out",
        "sweep.png",
    ];
    args.extend(SMALL);
    ok(&realcam(dir.path(), &args));
    for n in 0..3 {
        assert!(dir.path().join(format!("sweep-{n:03}.png")).exists());
    }
    for (frame, metres) in [(0, "1"), (2, "8")] {
        let mut single = vec![
            "render",
            "--focus-distance",
            metres,
            "--spp",
            "2",
            "--exr",
            "single.exr",
            "--out",
            "single.png",
        ];
        single.extend(SMALL);
        ok(&realcam(dir.path(), &single));
        assert_eq!(
            exr_pixels(&dir.path().join(format!("sweep-{frame:03}.exr"))),
            exr_pixels(&dir.path().join("single.exr")),
            "frame {frame}"
        );
    }
    let a = exr_pixels(&dir.path().join("sweep-000.exr"));
    let c = exr_pixels(&dir.path().join("sweep-002.exr"));
    assert_ne!(a, c, "focus changes the picture");
}

#[test]
fn same_seed_same_image_with_one_or_two_threads() {
    let dir = tempfile::tempdir().unwrap();
    for threads in ["1", "2"] {
        let out = format!("t{threads}.exr");
        let mut args = vec![
            "render",
            "--spp",
            "3",
            "--threads",
            threads,
            "--exr",
            &out,
            "--out",
            "t.png",
            "--seed",
            "42",
        ];
        args.extend(SMALL);
        ok(&realcam(dir.path(), &args));
    }
    assert_eq!(
        exr_pixels(&dir.path().join("t1.exr")),
        exr_pixels(&dir.path().join("t2.exr"))
    );
}

/// Many cheap sample passes (an 8×8 image, direct light only), so that a signal lands
/// mid-render.
const CHEAP_PASSES: [&str; 10] = [
    "--spp",
    "30000",
    "--width",
    "8",
    "--height",
    "8",
    "--max-depth",
    "1",
    "--seed",
    "5",
];

/// Starts `realcam render --out cut.png` with `args`, a checkpoint every 0.05 s, sends SIGINT
/// once `checkpoint` (in `dir`) appears, and returns the checkpoint saved on the way out.
fn render_until_interrupted(
    dir: &std::path::Path,
    args: &[&str],
    checkpoint: &str,
) -> (
    realcam::film::Image,
    realcam::film::checkpoint::CheckpointInfo,
) {
    let child = Command::new(env!("CARGO_BIN_EXE_realcam"))
        .args(["render", "--out", "cut.png", "--checkpoint-every", "0.05"])
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let checkpoint = dir.join(checkpoint);
    let deadline = Instant::now() + Duration::from_secs(60);
    while !checkpoint.exists() {
        assert!(Instant::now() < deadline, "no checkpoint appeared");
        std::thread::sleep(Duration::from_millis(10));
    }
    Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(130), "{stderr}");
    let (partial, info) = read_checkpoint(&checkpoint).unwrap();
    assert!(
        partial.samples > 0 && !info.remaining.is_empty(),
        "stopped mid-way: {} done",
        partial.samples
    );
    (partial, info)
}

#[test]
fn interrupted_shard_resumes_to_the_uninterrupted_partial() {
    let dir = tempfile::tempdir().unwrap();
    let common = CHEAP_PASSES;
    let mut shard = common.to_vec();
    shard.extend(["--shard", "1/3"]);
    // Each shard of a frame saves to a checkpoint of its own by default.
    let (partial, info) =
        render_until_interrupted(dir.path(), &shard, "cut.shard-1-of-3.checkpoint.exr");
    assert_eq!(info.shard, Some((1, 3)));
    assert_eq!(partial.samples as usize + info.remaining.len(), 10000);

    // The checkpoint refuses to continue as the whole frame or as another shard.
    for (flags, phrase) in [
        (vec![], "resume it with --shard 1/3"),
        (vec!["--shard", "2/3"], "not of shard 2/3"),
    ] {
        let mut args = vec![
            "render",
            "--out",
            "cut.png",
            "--resume",
            "cut.shard-1-of-3.checkpoint.exr",
        ];
        args.extend(common);
        args.extend(flags);
        let run = realcam(dir.path(), &args);
        assert_eq!(run.status.code(), Some(1));
        assert!(String::from_utf8_lossy(&run.stderr).contains(phrase));
    }

    let mut resume = vec![
        "render",
        "--out",
        "cut.png",
        "--partial",
        "resumed.exr",
        "--resume",
        "cut.shard-1-of-3.checkpoint.exr",
    ];
    resume.extend(&shard);
    ok(&realcam(dir.path(), &resume));
    let mut whole = vec!["render", "--out", "whole.png", "--partial", "whole.exr"];
    whole.extend(&shard);
    ok(&realcam(dir.path(), &whole));
    let (resumed, resumed_info) = read_checkpoint(&dir.path().join("resumed.exr")).unwrap();
    let (uninterrupted, _) = read_checkpoint(&dir.path().join("whole.exr")).unwrap();
    assert!(resumed_info.remaining.is_empty());
    assert_eq!(resumed.samples, 10000);
    assert_eq!(resumed.sums, uninterrupted.sums);
}

#[test]
fn interrupted_render_resumes_to_the_uninterrupted_image() {
    let dir = tempfile::tempdir().unwrap();
    let common = CHEAP_PASSES;
    let (partial, info) = render_until_interrupted(dir.path(), &common, "cut.checkpoint.exr");
    assert!(
        dir.path().join("cut.png").exists(),
        "the image so far is written"
    );
    assert!(info.shard.is_none());
    assert_eq!(partial.samples as usize + info.remaining.len(), 30000);

    let mut resume = vec![
        "render",
        "--out",
        "cut.png",
        "--exr",
        "resumed.exr",
        "--resume",
        "cut.checkpoint.exr",
    ];
    resume.extend(common);
    ok(&realcam(dir.path(), &resume));
    let mut whole = vec!["render", "--out", "whole.png", "--exr", "whole.exr"];
    whole.extend(common);
    ok(&realcam(dir.path(), &whole));
    assert_eq!(
        exr_pixels(&dir.path().join("resumed.exr")),
        exr_pixels(&dir.path().join("whole.exr"))
    );

    // A checkpoint refuses other settings, naming what differs.
    let mut other = vec!["render", "--out", "x.png", "--resume", "cut.checkpoint.exr"];
    other.extend(CHEAP_PASSES);
    *other.last_mut().unwrap() = "6"; // --seed
    let output = realcam(dir.path(), &other);
    assert_eq!(output.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&output.stderr).contains("seed"),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
}

#[test]
fn sigterm_also_saves_and_exits_143() {
    let dir = tempfile::tempdir().unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_realcam"))
        .args([
            "render",
            "--out",
            "t.png",
            "--checkpoint-every",
            "0.05",
            "--spp",
            "100000",
            "--width",
            "8",
            "--height",
            "8",
            "--max-depth",
            "1",
        ])
        .current_dir(dir.path())
        .stdin(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let deadline = Instant::now() + Duration::from_secs(60);
    while !dir.path().join("t.checkpoint.exr").exists() {
        assert!(Instant::now() < deadline);
        std::thread::sleep(Duration::from_millis(10));
    }
    Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert_eq!(child.wait().unwrap().code(), Some(143));
    assert!(dir.path().join("t.png").exists());
}

#[test]
fn shards_sum_to_the_single_render() {
    let dir = tempfile::tempdir().unwrap();
    let common = [
        "--spp",
        "6",
        "--width",
        "24",
        "--height",
        "16",
        "--max-depth",
        "2",
        "--seed",
        "9",
    ];
    for shard in ["0/3", "1/3", "2/3"] {
        let mut args = vec!["render", "--out", "frame.png", "--shard", shard];
        args.extend(common);
        ok(&realcam(dir.path(), &args));
    }
    assert!(
        !dir.path().join("frame.png").exists(),
        "a shard writes only its partial"
    );
    let mut whole = vec!["render", "--out", "whole.png", "--exr", "whole.exr"];
    whole.extend(common);
    ok(&realcam(dir.path(), &whole));
    let reference = exr_pixels(&dir.path().join("whole.exr"));
    let mut sums = vec![0.0f64; reference.len()];
    let mut samples = 0;
    for i in 0..3 {
        let (part, info) =
            read_checkpoint(&dir.path().join(format!("frame.shard-{i}-of-3.exr"))).unwrap();
        assert_eq!(info.shard, Some((i, 3)));
        assert_eq!(part.samples, 2);
        samples += part.samples;
        for (k, v) in part.sums.iter().flatten().enumerate() {
            sums[k] += *v as f64;
        }
    }
    assert_eq!(samples, 6);
    for (k, (&s, &r)) in sums.iter().zip(&reference).enumerate() {
        let merged = s / samples as f64;
        assert!(
            (merged - r as f64).abs() <= 1e-5 * (r as f64).abs().max(1e-3),
            "pixel value {k}: merged {merged} vs single {r}"
        );
    }
}
