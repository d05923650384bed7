//! `realcam render` from the outside: lens runs and sweeps, stats, interruption and resume,
//! shards, determinism across thread counts.

use crate::support;

use support::cli::{ok, realcam, refused, refused_by_parser};

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use realcam::film::checkpoint::read_checkpoint;

/// Linear RGB floats of an EXR written by `--exr`.
fn exr_pixels(path: &Path) -> Vec<f32> {
    image::open(path).unwrap().to_rgb32f().into_raw()
}

/// Renders `args` to `NAME.png` and `NAME.exr` in `dir`, asserting success, and returns the
/// EXR's pixels.
fn rendered_exr(dir: &Path, name: &str, args: &[&str]) -> Vec<f32> {
    let (png, exr) = (format!("{name}.png"), format!("{name}.exr"));
    let mut all = vec!["render", "--out", png.as_str(), "--exr", exr.as_str()];
    all.extend(args);
    ok(&realcam(dir, &all));
    exr_pixels(&dir.join(exr))
}

/// The `--stats stats.json` a render wrote in `dir`.
fn stats_in(dir: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join("stats.json")).unwrap()).unwrap()
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
    let stats = stats_in(dir.path());
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

/// `--stats` says how busy each pass stage kept its workers: with one tile (the frame is
/// smaller than a tile) no tile's time overlaps another's, so never more than the stage's wall
/// time on every thread, and every pass stage busy for some of it.
#[test]
fn stats_give_each_stage_its_busy_time_within_wall_time_times_threads() {
    let dir = tempfile::tempdir().unwrap();
    let mut args = vec![
        "render",
        "--spp",
        "2",
        "--threads",
        "2",
        "--stats",
        "stats.json",
    ];
    args.extend(SMALL);
    ok(&realcam(dir.path(), &args));
    let stats = stats_in(dir.path());
    assert_eq!(stats["threads"], 2);
    for stage in [
        "generate_rays",
        "trace",
        "shade",
        "land_companions",
        "weight",
        "write_film",
    ] {
        let wall = stats["stage_seconds"][stage].as_f64().unwrap();
        let busy = stats["stage_busy_seconds"][stage].as_f64().unwrap();
        assert!(busy > 0.0, "{stage}: busy {busy} s");
        // Timers read a little apart: a microsecond per tile and pass of slack.
        assert!(
            busy <= 2.0 * wall + 1e-4,
            "{stage}: busy {busy} s, wall {wall} s"
        );
    }
}

#[test]
fn each_lens_of_a_run_renders_on_its_own_film_as_it_does_alone() {
    let dir = tempfile::tempdir().unwrap();
    // Formats from the lens files (a phone lens's sensor, a 35 mm-ish triplet) and, for a lens
    // that names none, the default scene camera's 70 mm.
    let lenses = [
        ("deeplens-phone-80deg", 7.66),
        ("cooke-triplet-50mm-f4", 36.35),
        ("dgauss.50mm", 70.0),
    ];
    let mut run = vec![
        "render",
        "--spp",
        "2",
        "--exr",
        "run.exr",
        "--stats",
        "stats.json",
    ];
    for (lens, _) in lenses {
        run.extend(["--lens", lens]);
    }
    run.extend(SMALL);
    ok(&realcam(dir.path(), &run));
    let stats = stats_in(dir.path());
    let frames = stats["frames"].as_array().unwrap();
    for ((lens, diagonal), frame) in lenses.iter().zip(frames) {
        assert_eq!(frame["lens"], *lens);
        assert_eq!(frame["film_diagonal_mm"], *diagonal, "{lens}");
        let mut alone = vec![
            "render",
            "--lens",
            lens,
            "--spp",
            "2",
            "--exr",
            "alone.exr",
            "--out",
            "alone.png",
        ];
        alone.extend(SMALL);
        ok(&realcam(dir.path(), &alone));
        assert_eq!(
            std::fs::read(dir.path().join(format!("render-{lens}.png"))).unwrap(),
            std::fs::read(dir.path().join("alone.png")).unwrap(),
            "{lens}"
        );
        assert_eq!(
            exr_pixels(&dir.path().join(format!("run-{lens}.exr"))),
            exr_pixels(&dir.path().join("alone.exr")),
            "{lens}"
        );
    }
    // --film-diagonal still puts every lens on the film it names.
    let mut fixed = vec![
        "render",
        "--film-diagonal",
        "24",
        "--spp",
        "1",
        "--stats",
        "fixed.json",
    ];
    for (lens, _) in &lenses[..2] {
        fixed.extend(["--lens", lens]);
    }
    fixed.extend(SMALL);
    ok(&realcam(dir.path(), &fixed));
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("fixed.json")).unwrap()).unwrap();
    for frame in stats["frames"].as_array().unwrap() {
        assert_eq!(frame["film_diagonal_mm"], 24.0, "{frame}");
    }
}

#[test]
fn an_implied_focus_closer_than_the_lens_reaches_is_clamped_but_an_asked_one_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let lens = realcam(dir.path(), &["lens", "dgauss.50mm", "--json"]);
    let report: serde_json::Value = serde_json::from_slice(&lens.stdout).unwrap();
    let closest = report["closest_focus_m"].as_f64().unwrap();
    // Looking at a point 10 cm away implies focusing there, closer than the lens can.
    let view = [
        "--lens",
        "dgauss.50mm",
        "--look-from",
        "0,0.5,3",
        "--look-at",
        "0,0.5,2.9",
        "--spp",
        "1",
    ];
    let mut implied = vec!["render", "--stats", "stats.json"];
    implied.extend(view);
    implied.extend(SMALL);
    let stderr = ok(&realcam(dir.path(), &implied));
    assert!(
        stderr.contains("warning: ")
            && stderr.contains("0.1000 m")
            && stderr.contains(&format!("{closest:.4} m")),
        "{stderr}"
    );
    let stats = stats_in(dir.path());
    let focused = stats["frames"][0]["focus_distance_m"].as_f64().unwrap();
    assert!(
        (focused - closest).abs() < 1e-6 * closest,
        "{focused} vs {closest}"
    );

    let mut asked = vec!["render", "--focus-distance", "0.1"];
    asked.extend(view);
    asked.extend(SMALL);
    refused(&realcam(dir.path(), &asked), &["cannot focus at 0.1000 m"]);
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
fn an_f_number_sweep_renders_each_stop_as_a_single_render_at_that_f_number() {
    let dir = tempfile::tempdir().unwrap();
    let mut args = vec![
        "render",
        "--f-number-sweep",
        "2.8:5.6:2",
        "--spp",
        "1",
        "--exr",
        "stops.exr",
        "--out",
        "stops.png",
        "--stats",
        "stats.json",
    ];
    args.extend(SMALL);
    ok(&realcam(dir.path(), &args));
    let stats = stats_in(dir.path());
    for (frame, (n, name)) in [(2.8, "000-f2.8"), (5.6, "001-f5.6")].iter().enumerate() {
        // The lens's real f-number (EFL / entrance-pupil diameter) is the one asked for.
        let real = stats["frames"][frame]["f_number"].as_f64().unwrap();
        assert!((real - n).abs() < 1e-3 * n, "f/{real} for f/{n}");
        let mut single = vec![
            "render",
            "--f-number",
            &n.to_string(),
            "--spp",
            "1",
            "--exr",
            "single.exr",
            "--out",
            "single.png",
        ]
        .into_iter()
        .map(String::from)
        .collect::<Vec<_>>();
        single.extend(SMALL.map(String::from));
        let single: Vec<&str> = single.iter().map(String::as_str).collect();
        ok(&realcam(dir.path(), &single));
        assert_eq!(
            exr_pixels(&dir.path().join(format!("stops-{name}.exr"))),
            exr_pixels(&dir.path().join("single.exr")),
            "f/{n}"
        );
    }
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
    // (Checked before the resume, which removes the checkpoint it finishes.)
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

    let resume = [&["--resume", "cut.checkpoint.exr"][..], &common].concat();
    assert_eq!(
        rendered_exr(dir.path(), "resumed", &resume),
        rendered_exr(dir.path(), "whole", &common)
    );
}

/// A stopped render continues to more samples than it first asked for, and the picture is the
/// one a render asking for that spp from the start gives, bit for bit: sample *k* of a pixel
/// does not depend on the target spp, the checkpoint keeps the film's f32 sums exactly, and the
/// samples are added in the same order.
#[test]
fn a_stopped_render_continues_to_more_samples() {
    let dir = tempfile::tempdir().unwrap();
    let common = CHEAP_PASSES;
    let mut first = common.to_vec();
    first.extend(["--exr", "cut.exr"]);
    let (partial, _) = render_until_interrupted(dir.path(), &first, "cut.checkpoint.exr");
    assert!(
        dir.path().join("cut.exr").exists(),
        "an interruption writes --exr as well as --out"
    );
    let more = "30002";
    /// Continue cut.checkpoint.exr to `spp` with `extra` options.
    fn with_spp<'a>(spp: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
        let mut args = vec![
            "render",
            "--out",
            "more.png",
            "--resume",
            "cut.checkpoint.exr",
        ];
        args.extend(CHEAP_PASSES);
        args[6] = spp; // --spp
        args.extend(extra);
        args
    }
    // Fewer samples than the checkpoint holds, or another stop: refused, naming why.
    let fewer = (partial.samples - 1).to_string();
    refused(
        &realcam(dir.path(), &with_spp(&fewer, &[])),
        &["already holds", "resume with --spp"],
    );
    refused(
        &realcam(dir.path(), &with_spp(more, &["--f-number", "4"])),
        &["different settings (aperture)"],
    );

    ok(&realcam(
        dir.path(),
        &with_spp(more, &["--exr", "more.exr"]),
    ));
    assert!(
        !dir.path().join("cut.checkpoint.exr").exists(),
        "a finished resume removes its checkpoint"
    );

    let mut direct = common.to_vec();
    direct[1] = more; // --spp
    assert_eq!(
        exr_pixels(&dir.path().join("more.exr")),
        rendered_exr(dir.path(), "direct", &direct)
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

/// `--focus-mode best` acts on a focus distance; where the film distance is given instead (the
/// built-in scene's camera gives one) the run says the mode went unused rather than ignoring it.
#[test]
fn an_unused_focus_mode_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let small = ["render", "--spp", "1", "--width", "16", "--height", "16"];
    let mut hinted = small.to_vec();
    hinted.extend(["--focus-mode", "best", "--out", "hinted.png"]);
    let said = ok(&realcam(dir.path(), &hinted));
    assert!(
        said.contains("--focus-mode best chooses the film distance")
            && said.contains("the scene camera's film-distance hint"),
        "{said}"
    );
    let mut focused = small.to_vec();
    focused.extend([
        "--focus-mode",
        "best",
        "--focus-distance",
        "3",
        "--out",
        "focused.png",
    ]);
    let said = ok(&realcam(dir.path(), &focused));
    assert!(!said.contains("--focus-mode best chooses"), "{said}");
}

/// A zoom lens's position is part of a frame's settings: shards rendered at two positions are
/// refused by `merge` (and a checkpoint by `--resume`) as different settings, named.
#[test]
fn shards_of_two_zoom_positions_do_not_merge() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("zoom.toml"), support::TWO_GROUP_ZOOM).unwrap();
    for (shard, position, out) in [("0/2", "1", "a.png"), ("1/2", "3", "b.png")] {
        ok(&realcam(
            dir.path(),
            &[
                "render",
                "--lens",
                "zoom.toml",
                "--zoom-position",
                position,
                "--spp",
                "2",
                "--width",
                "16",
                "--height",
                "16",
                "--shard",
                shard,
                "--out",
                out,
            ],
        ));
    }
    refused(
        &realcam(
            dir.path(),
            &[
                "merge",
                "a.shard-0-of-2.exr",
                "b.shard-1-of-2.exr",
                "--out",
                "m.png",
            ],
        ),
        &["different settings", "zoom_position: 1 vs 3"],
    );
}

/// `--zoom-sweep` renders each zoom position of a zoom lens, one frame each, named by the
/// position, at that position's focal length (a paraxial trace of its gaps, written here); a
/// lens with fixed spacings beside it
/// renders once, a run of fixed lenses alone is refused, and so is a position given too.
#[test]
fn a_zoom_sweep_renders_every_position_of_a_zoom_lens() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("zoom.toml"), support::TWO_GROUP_ZOOM).unwrap();
    let small = [
        "render", "--spp", "2", "--width", "24", "--height", "16", "--out", "z.png",
    ];
    let with = |extra: &[&'static str]| [&small[..], extra].concat();
    ok(&realcam(
        dir.path(),
        &with(&[
            "--lens",
            "zoom.toml",
            "--lens",
            "dgauss.50mm",
            "--zoom-sweep",
            "--stats",
            "stats.json",
            "--contact-sheet",
            "sheet.png",
        ]),
    ));
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("stats.json")).unwrap())
            .unwrap();
    let frames = stats["frames"].as_array().unwrap();
    let seen: Vec<(String, serde_json::Value)> = frames
        .iter()
        .map(|f| {
            (
                f["out"].as_str().unwrap().to_string(),
                f["zoom_position"].clone(),
            )
        })
        .collect();
    assert_eq!(
        seen,
        [
            ("z-test-zoom-000-zoom1.png", serde_json::json!(1)),
            ("z-test-zoom-001-zoom2.png", serde_json::json!(2)),
            ("z-test-zoom-002-zoom3.png", serde_json::json!(3)),
            ("z-dgauss.50mm.png", serde_json::Value::Null),
        ]
        .map(|(o, z)| (o.to_string(), z))
    );
    for (frame, gap) in frames.iter().zip([20.0, 50.0, 90.0]) {
        let f = frame["focal_length_mm"].as_f64().unwrap();
        let expected = support::two_group_zoom_paraxial(gap).0;
        assert!((f / expected - 1.0).abs() < 1e-6, "{f} vs {expected}");
        assert!(dir.path().join(frame["out"].as_str().unwrap()).is_file());
    }
    assert!(dir.path().join("sheet.png").is_file());
    refused(
        &realcam(
            dir.path(),
            &with(&["--lens", "dgauss.50mm", "--zoom-sweep"]),
        ),
        &["--zoom-sweep", "dgauss.50mm has fixed spacings"],
    );
    refused_by_parser(
        &realcam(
            dir.path(),
            &with(&[
                "--lens",
                "zoom.toml",
                "--zoom-sweep",
                "--zoom-position",
                "2",
            ]),
        ),
        &["--zoom-sweep", "--zoom-position"],
    );
}
