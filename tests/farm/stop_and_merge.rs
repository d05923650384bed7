//! What the farm scripts (farm/slurm, farm/kubernetes) rely on, without a scheduler: a stop
//! delivered twice still saves the checkpoint, and `realcam merge` names the exact command that
//! finishes a stopped shard — a command that works when run as printed.

use crate::support;

use support::cli::{ok, realcam};

use std::io::{BufRead, BufReader, Read};
use std::path::Path;
use std::process::{Child, Command, Stdio};

use realcam::film::checkpoint::read_checkpoint;

/// Many cheap sample passes (an 8×8 image, direct light only), so that a signal lands
/// mid-render.
const CHEAP_PASSES: [&str; 10] = [
    "--spp",
    "20000",
    "--width",
    "8",
    "--height",
    "8",
    "--max-depth",
    "1",
    "--seed",
    "11",
];

/// Starts `realcam render ARGS` in `dir` (stdin not a terminal, as under a scheduler) and
/// returns once it has begun rendering (it prints the lens line just before the first pass),
/// with the rest of its stderr. The caller waits for the child.
#[allow(clippy::zombie_processes)]
fn start_rendering(dir: &Path, args: &[&str]) -> (Child, BufReader<std::process::ChildStderr>) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_realcam"))
        .args(args)
        .current_dir(dir)
        .stdin(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = BufReader::new(child.stderr.take().unwrap());
    let mut line = String::new();
    loop {
        line.clear();
        let read = stderr.read_line(&mut line).unwrap();
        assert!(read > 0, "realcam ended before rendering");
        if line.starts_with("lens ") {
            return (child, stderr);
        }
    }
}

fn signal(child: &Child, signal: &str) {
    let status = Command::new("kill")
        .arg(format!("-{signal}"))
        .arg(child.id().to_string())
        .status()
        .unwrap();
    assert!(status.success());
}

#[test]
fn a_stop_delivered_twice_still_saves_the_checkpoint() {
    // At Slurm's time limit and on preemption both the task and srun (which forwards it) get
    // SIGTERM; a second signal must not cut the save short when no person is at a terminal.
    // One pass of the default scene at 1024×768 on one thread takes most of a second, so the
    // second SIGTERM, 20 ms after the first (two signals sent at once would merge into one),
    // arrives while realcam still finishes its pass.
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "render",
        "--out",
        "t.png",
        "--shard",
        "0/2",
        "--spp",
        "1000",
        "--width",
        "1024",
        "--height",
        "768",
        "--threads",
        "1",
    ];
    let (mut child, mut stderr) = start_rendering(dir.path(), &args);
    signal(&child, "TERM");
    std::thread::sleep(std::time::Duration::from_millis(20));
    signal(&child, "TERM");
    let status = child.wait().unwrap();
    let mut rest = String::new();
    stderr.read_to_string(&mut rest).unwrap();
    assert_eq!(status.code(), Some(143), "{rest}");
    assert!(rest.contains("interrupted: saved"), "{rest}");
    let (image, info) = read_checkpoint(&dir.path().join("t.shard-0-of-2.checkpoint.exr")).unwrap();
    assert!(image.samples > 0 && !info.remaining.is_empty());
}

#[test]
fn merge_names_the_command_that_finishes_a_stopped_shard_and_that_command_works() {
    let farm = tempfile::tempdir().unwrap();
    let frames = farm.path().join("frames");
    let elsewhere = farm.path().join("elsewhere");
    std::fs::create_dir_all(&frames).unwrap();
    std::fs::create_dir_all(&elsewhere).unwrap();

    // Shard 0 finishes; shard 1 is stopped mid-render. Both use relative paths, from `frames`.
    let mut shard0 = vec!["render", "--out", "f.png", "--shard", "0/2"];
    shard0.extend(CHEAP_PASSES);
    ok(&realcam(&frames, &shard0));
    let mut shard1 = vec!["render", "--out", "f.png", "--shard", "1/2"];
    shard1.extend(CHEAP_PASSES);
    let (mut child, _stderr) = start_rendering(&frames, &shard1);
    signal(&child, "INT");
    assert_eq!(child.wait().unwrap().code(), Some(130));

    // Merged from another directory, the checkpoint is refused, naming the command in backticks.
    let parts = [
        "../frames/f.shard-0-of-2.exr",
        "../frames/f.shard-1-of-2.checkpoint.exr",
    ];
    let mut merge = vec!["merge", "--out", "merged.png", "--exr", "merged.exr"];
    merge.extend(parts);
    let refused = realcam(&elsewhere, &merge);
    assert_eq!(refused.status.code(), Some(1));
    let message = String::from_utf8_lossy(&refused.stderr).into_owned();
    assert!(message.contains("unfinished"), "{message}");
    let command = message
        .split('`')
        .nth(1)
        .unwrap_or_else(|| panic!("no `command` in: {message}"))
        .to_string();
    assert!(
        command.starts_with(&format!(
            "cd {} && {} render --out f.png --shard 1/2 --spp 20000",
            frames.canonicalize().unwrap().display(),
            env!("CARGO_BIN_EXE_realcam")
        )),
        "{command}"
    );
    assert!(
        command.ends_with(&format!(
            " --resume {}",
            frames
                .canonicalize()
                .unwrap()
                .join("f.shard-1-of-2.checkpoint.exr")
                .display()
        )),
        "{command}"
    );

    // --allow-missing merges the samples it has and names the same command.
    let mut partial_merge = merge.clone();
    partial_merge.push("--allow-missing");
    let allowed = realcam(&elsewhere, &partial_merge);
    ok(&allowed);
    assert!(String::from_utf8_lossy(&allowed.stderr).contains(&command));

    // Run as printed, from a third directory, the command finishes the shard...
    let finished = Command::new("sh")
        .args(["-c", &command])
        .current_dir(farm.path())
        .stdin(Stdio::null())
        .output()
        .unwrap();
    ok(&finished);
    let (partial, info) = read_checkpoint(&frames.join("f.shard-1-of-2.exr")).unwrap();
    assert!(info.remaining.is_empty());
    assert_eq!(partial.samples, 10000);

    // ... and the frame merges into the single render, up to the rounding of the sums.
    let mut merge = vec!["merge", "--out", "merged.png", "--exr", "merged.exr"];
    merge.extend([
        "../frames/f.shard-0-of-2.exr",
        "../frames/f.shard-1-of-2.exr",
    ]);
    ok(&realcam(&elsewhere, &merge));
    let mut single = vec!["render", "--out", "single.png", "--exr", "single.exr"];
    single.extend(CHEAP_PASSES);
    ok(&realcam(&elsewhere, &single));
    let pixels = |name: &str| {
        image::open(elsewhere.join(name))
            .unwrap()
            .to_rgb32f()
            .into_raw()
    };
    let (merged, reference) = (pixels("merged.exr"), pixels("single.exr"));
    assert_eq!(merged.len(), reference.len());
    for (m, r) in merged.iter().zip(&reference) {
        // f32 sums of 10 000 and 20 000 samples, added in another order: a few ulps per
        // addition at most, far below one sample's weight in the mean (1/20 000).
        assert!((m - r).abs() <= 1e-4 * r.abs().max(1e-6), "{m} vs {r}");
    }
}
