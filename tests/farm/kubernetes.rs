//! `farm/kubernetes`: the manifests against the Kubernetes API schemas (kubernetes-validate,
//! from PyPI; `kubectl apply --dry-run=client` too where kubectl reaches a cluster), and the
//! shell scripts the pods run, run here as a pod would: stopped by SIGTERM, resumed, merged.
//!
//! Skipped, with a message, where kubernetes-validate (and the PyYAML it brings) is not
//! installed; with REALCAM_REQUIRE_KUBERNETES_VALIDATE=1 (as `.ci/run` sets) it fails instead.

use std::ffi::OsString;
use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

const REPO: &str = env!("CARGO_MANIFEST_DIR");
const REALCAM: &str = env!("CARGO_BIN_EXE_realcam");
const MANIFESTS: [&str; 3] = ["volumes.yaml", "shards.yaml", "merge.yaml"];

fn report(text: &str) {
    let _ = writeln!(std::io::stderr(), "farm::kubernetes: {text}");
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn manifest(name: &str) -> PathBuf {
    Path::new(REPO).join("farm/kubernetes").join(name)
}

/// kubernetes-validate, run by the Python it is installed in (its command may not be on PATH).
fn validator() -> Command {
    let mut command = Command::new("python3");
    command.args(["-m", "kubernetes_validate"]);
    command
}

/// Whether kubernetes-validate can run; if not, skips (or fails where it is required).
fn validator_available(test: &str) -> bool {
    let found = validator()
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|status| status.success());
    if !found {
        let reason = "kubernetes-validate is not installed (pip install kubernetes-validate)";
        if std::env::var("REALCAM_REQUIRE_KUBERNETES_VALIDATE").as_deref() == Ok("1") {
            panic!("REALCAM_REQUIRE_KUBERNETES_VALIDATE=1 but {reason}");
        }
        report(&format!("SKIPPED {test}: {reason}"));
    }
    found
}

#[test]
fn manifests_pass_the_api_schemas() {
    if !validator_available("the schema check") {
        return;
    }
    // The oldest version the Jobs' fields are on by default in, and the newest the validator
    // knows. --strict refuses unknown fields, the usual sign of a misplaced key.
    for version in ["1.29.0", "1.37.0"] {
        for name in MANIFESTS {
            let output = validator()
                .args(["--strict", "--kubernetes-version", version])
                .arg(manifest(name))
                .output()
                .unwrap();
            assert!(
                output.status.success(),
                "{name} against Kubernetes {version}:\n{}{}",
                text(&output.stdout),
                text(&output.stderr)
            );
        }
    }
    // kubectl's client-side dry run still asks the API server how to map the kinds, so it
    // needs a cluster; run it where kubectl reaches one.
    let reaches_cluster = Command::new("kubectl")
        .args(["version", "--request-timeout=5s"])
        .output()
        .is_ok_and(|output| output.status.success());
    if reaches_cluster {
        for name in MANIFESTS {
            let output = Command::new("kubectl")
                .args(["apply", "--dry-run=client", "-f"])
                .arg(manifest(name))
                .output()
                .unwrap();
            assert!(output.status.success(), "{name}: {}", text(&output.stderr));
        }
    } else {
        report("kubectl apply --dry-run=client not run: no kubectl that reaches a cluster here");
    }
}

/// The `args[0]` script of a Job's container, read with PyYAML (kubernetes-validate's
/// dependency).
fn pod_script(name: &str) -> String {
    let output = Command::new("python3")
        .args([
            "-c",
            "import sys, yaml; job = yaml.safe_load(open(sys.argv[1])); \
             print(job['spec']['template']['spec']['containers'][0]['args'][0])",
        ])
        .arg(manifest(name))
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", text(&output.stderr));
    text(&output.stdout)
}

/// Runs a pod's script with `env` (and realcam on PATH) as the container would.
fn pod(script: &str, env: &[(&str, &str)]) -> Command {
    let mut path = OsString::from(Path::new(REALCAM).parent().unwrap());
    path.push(":");
    path.push(std::env::var_os("PATH").unwrap_or_default());
    let mut command = Command::new("sh");
    command
        .args(["-c", script])
        .env("PATH", path)
        .envs(env.iter().copied())
        .stdin(Stdio::null());
    command
}

fn run(command: &mut Command) -> (Option<i32>, String) {
    let output: Output = command.output().unwrap();
    (
        output.status.code(),
        text(&output.stdout) + &text(&output.stderr),
    )
}

#[test]
fn pod_scripts_resume_a_stopped_shard_and_merge_only_a_whole_frame() {
    if !validator_available("the pod scripts") {
        return;
    }
    let (shard, merge) = (pod_script("shards.yaml"), pod_script("merge.yaml"));
    let dir = tempfile::tempdir().unwrap();
    let frame = dir.path().join("f");
    let frame = frame.to_str().unwrap();
    let scene = Path::new(REPO).join("tests/data/CornellBox/cornellBox-2.80-Eevee-gltf.gltf");
    let options = "--width 8 --height 8 --max-depth 1 --seed 11 --spp 20000 --threads 1";
    let shard_env = |index: &'static str| {
        [
            ("JOB_COMPLETION_INDEX", index),
            ("SHARDS", "2"),
            ("FRAME", frame),
            ("SCENE", scene.to_str().unwrap()),
            ("RENDER_OPTIONS", options),
        ]
    };
    let merged_exr = format!("{frame}.exr");
    let merge_env = |allow: &'static str| {
        [
            ("SHARDS", "2".to_string()),
            ("FRAME", frame.to_string()),
            ("ALLOW_MISSING", allow.to_string()),
            ("MERGE_OPTIONS", format!("--exr {merged_exr}")),
        ]
    };
    let checkpoint = format!("{frame}.shard-1-of-2.checkpoint.exr");
    let partial = format!("{frame}.shard-1-of-2.exr");

    // Shard 1 is stopped as the kubelet stops a pod: SIGTERM to the container's shell.
    let mut child = pod(&shard, &shard_env("1"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = BufReader::new(child.stderr.take().unwrap());
    let mut line = String::new();
    while !line.starts_with("lens ") {
        line.clear();
        assert!(
            stderr.read_line(&mut line).unwrap() > 0,
            "no render started"
        );
    }
    let kill = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let status = child.wait().unwrap();
    let mut said = String::new();
    child
        .stdout
        .take()
        .unwrap()
        .read_to_string(&mut said)
        .unwrap();
    stderr.read_to_string(&mut said).unwrap();
    assert_eq!(status.code(), Some(143), "{said}");
    assert!(said.contains("stopped by a signal"), "{said}");
    assert!(Path::new(&checkpoint).exists() && !Path::new(&partial).exists());

    // The merge refuses the incomplete frame, or merges what is there when allowed.
    let (code, said) = run(pod(&merge, &[]).envs(merge_env("no")));
    assert_eq!(code, Some(1), "{said}");
    assert!(
        said.contains("shard(s) 0 1 of 0..1 did not finish"),
        "{said}"
    );
    let (code, said) = run(pod(&merge, &[]).envs(merge_env("yes")));
    assert_eq!(code, Some(0), "{said}");
    assert!(said.contains("unfinished shard"), "{said}");

    // The replacement pod resumes the checkpoint, finishes and deletes it; shard 0 renders;
    // a pod of a finished shard does nothing.
    let (code, said) = run(&mut pod(&shard, &shard_env("1")));
    assert_eq!(code, Some(0), "{said}");
    assert!(said.contains("resuming"), "{said}");
    assert!(Path::new(&partial).exists() && !Path::new(&checkpoint).exists());
    let (code, said) = run(&mut pod(&shard, &shard_env("0")));
    assert_eq!(code, Some(0), "{said}");
    let (code, said) = run(&mut pod(&shard, &shard_env("0")));
    assert_eq!(code, Some(0), "{said}");
    assert!(said.contains("already finished"), "{said}");

    // The whole frame merges into the single render, up to the rounding of the sums.
    let (code, said) = run(pod(&merge, &[]).envs(merge_env("no")));
    assert_eq!(code, Some(0), "{said}");
    let single = dir.path().join("single.exr");
    let output = Command::new(REALCAM)
        .arg("render")
        .arg(&scene)
        .args(options.split(' '))
        .args(["--out".as_ref(), dir.path().join("single.png").as_os_str()])
        .args(["--exr".as_ref(), single.as_os_str()])
        .output()
        .unwrap();
    assert!(output.status.success(), "{}", text(&output.stderr));
    let pixels = |path: &Path| image::open(path).unwrap().to_rgb32f().into_raw();
    for (m, s) in pixels(Path::new(&merged_exr)).iter().zip(pixels(&single)) {
        assert!((m - s).abs() <= 1e-4 * s.abs().max(1e-6), "{m} vs {s}");
    }
}
