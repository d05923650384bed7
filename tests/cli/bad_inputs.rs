//! Hostile input at the command line, tried as a user would: every bad lens file, glTF document,
//! partial and flag gives a clear error (the file, what is wrong) and exit 1 (2 for usage
//! errors), or a `warning:` and a finite image where a user expects a fallback. Never a panic,
//! a hang, or an output or temporary file left behind.
//!
//! The small bad files live in `tests/data/bad/` (see its README); large ones are made here.

use crate::support;

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use realcam::film::Image;
use realcam::film::checkpoint::{CheckpointInfo, FORMAT_VERSION, write_checkpoint};
use serde_json::json;
use support::GltfBuilder;

/// A run is killed and the test fails after this long: a hang is a bug like any other.
const TIMEOUT: Duration = Duration::from_secs(60);

struct Run {
    code: i32,
    stdout: String,
    stderr: String,
}

fn realcam<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> Run {
    let mut child = Command::new(env!("CARGO_BIN_EXE_realcam"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start realcam");
    // Drain both pipes on their own threads so a chatty child never blocks on a full pipe.
    let drain = |mut pipe: Box<dyn Read + Send>| {
        std::thread::spawn(move || {
            let mut text = Vec::new();
            let _ = pipe.read_to_end(&mut text);
            String::from_utf8_lossy(&text).into_owned()
        })
    };
    let stdout = drain(Box::new(child.stdout.take().unwrap()));
    let stderr = drain(Box::new(child.stderr.take().unwrap()));
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > TIMEOUT {
            let _ = child.kill();
            let _ = child.wait();
            let shown: Vec<String> = args
                .iter()
                .map(|a| a.as_ref().to_string_lossy().into_owned())
                .collect();
            panic!(
                "realcam {} did not finish within {TIMEOUT:?}",
                shown.join(" ")
            );
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    Run {
        code: status.code().unwrap_or(-1),
        stdout: stdout.join().unwrap(),
        stderr: stderr.join().unwrap(),
    }
}

fn bad(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/bad")
        .join(name)
}

/// A small valid scene to pair with bad lenses and flags.
fn good_scene() -> PathBuf {
    support::sample_scene("Box/Box.gltf")
}

/// `realcam render SCENE --out OUT` plus `extra`, at 1 spp and 8×8 unless `extra` says
/// otherwise.
fn render(scene: &Path, out: &Path, extra: &[&str]) -> Run {
    let mut args: Vec<std::ffi::OsString> = vec!["render".into(), scene.into()];
    for (flag, value) in [("--spp", "1"), ("--width", "8"), ("--height", "8")] {
        if !extra.contains(&flag) {
            args.extend([flag.into(), value.into()]);
        }
    }
    args.extend(["--out".into(), out.into()]);
    args.extend(extra.iter().map(Into::into));
    realcam(&args)
}

/// Exit 1, `error:` naming `file` and saying each of `phrases`; no panic, no raw control
/// characters (binary garbage echoed back must not scramble the terminal).
fn assert_refused(run: &Run, file: &str, phrases: &[&str]) {
    let context = format!("{file}: exit {}, stderr:\n{}", run.code, run.stderr);
    assert_eq!(run.code, 1, "{context}");
    assert_clean(run, &context);
    assert!(run.stderr.contains("error: "), "{context}");
    assert!(
        run.stderr.contains(file),
        "does not name the file: {context}"
    );
    for phrase in phrases {
        assert!(run.stderr.contains(phrase), "missing {phrase:?}: {context}");
    }
}

fn assert_clean(run: &Run, context: &str) {
    assert!(!run.stderr.contains("panicked"), "{context}");
    assert!(
        !run.stderr
            .chars()
            .any(|c| c.is_control() && c != '\n' && c != '\t'),
        "raw control characters: {context}"
    );
}

/// Nothing at all in `dir`: no output, no temporary file.
fn assert_empty(dir: &Path, context: &str) {
    let left: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|entry| entry.unwrap().file_name())
        .collect();
    assert!(left.is_empty(), "{context}: files left behind: {left:?}");
}

/// Renders `scene` expecting a refusal that names it; checks nothing was written.
fn assert_scene_refused(scene: &Path, phrases: &[&str]) {
    let name = scene.file_name().unwrap().to_str().unwrap();
    assert_render_refused(scene, &[], name, phrases);
}

/// Renders `scene` with `extra` flags expecting a refusal that names `file`; checks nothing
/// was written.
fn assert_render_refused(scene: &Path, extra: &[&str], file: &str, phrases: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.png");
    let exr = dir.path().join("x.exr");
    let mut args = vec!["--exr", exr.to_str().unwrap()];
    args.extend(extra);
    let run = render(scene, &out, &args);
    assert_refused(&run, file, phrases);
    assert_empty(dir.path(), file);
}

/// Renders expecting success with a `warning:` holding each of `phrases`, and a finite,
/// not entirely black 8×8 image.
fn assert_renders_with_warning(scene: &Path, phrases: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.png");
    let exr = dir.path().join("x.exr");
    let run = render(scene, &out, &["--exr", exr.to_str().unwrap()]);
    let name = scene.file_name().unwrap().to_str().unwrap();
    let context = format!("{name}: exit {}, stderr:\n{}", run.code, run.stderr);
    assert_eq!(run.code, 0, "{context}");
    assert_clean(&run, &context);
    let warnings: Vec<&str> = run
        .stderr
        .lines()
        .filter(|line| line.starts_with("warning: "))
        .collect();
    for phrase in phrases {
        assert!(
            warnings
                .iter()
                .any(|w| w.contains(phrase) && w.contains(name)),
            "no warning naming {name} with {phrase:?}: {context}"
        );
    }
    let png = image::open(&out).unwrap();
    assert_eq!((png.width(), png.height()), (8, 8), "{context}");
    let film = image::open(&exr).unwrap().to_rgb32f();
    assert!(
        film.pixels().flat_map(|p| p.0).all(f32::is_finite),
        "{context}"
    );
    assert!(
        film.pixels().flat_map(|p| p.0).any(|v| v > 0.0),
        "black image: {context}"
    );
}

// ------------------------------------------------------------------ glTF documents

/// (file in tests/data/bad, phrases the error must hold)
const REFUSED_SCENES: &[(&str, &[&str])] = &[
    ("invalid-json.gltf", &["invalid glTF JSON"]),
    ("empty-file.gltf", &["invalid glTF JSON"]),
    ("not-gltf.gltf", &["invalid glTF JSON"]),
    (
        "gltf-version-1.gltf",
        &["glTF version 1.0 is not supported"],
    ),
    ("truncated.glb", &["truncated .glb"]),
    ("glb-header-only.glb", &["truncated .glb"]),
    ("glb-version-1.glb", &["GLB container version 1"]),
    ("glb-bin-chunk-first.glb", &["first chunk must be JSON"]),
    ("glb-garbage-json-chunk.glb", &["invalid glTF JSON"]),
    ("missing-bin.gltf", &["missing-bin-absent.bin"]),
    ("short-bin.gltf", &["short-bin.bin", "byteLength"]),
    ("index-out-of-range.gltf", &["index 7 is out of range"]),
    ("accessor-past-buffer.gltf", &["accessor 0", "do not fit"]),
    (
        "accessor-offset-past-buffer.gltf",
        &["accessor 0", "do not fit"],
    ),
    ("buffer-view-past-buffer.gltf", &["buffer view 0"]),
    ("position-accessor-missing.gltf", &["accessor 99"]),
    (
        "position-accessor-wrong-type.gltf",
        &["accessor 0 has type Vec2"],
    ),
    ("float-indices.gltf", &["indices must be unsigned integers"]),
    ("stride-too-small.gltf", &["byteStride 4"]),
    ("sparse-index-out-of-range.gltf", &["sparse index 9"]),
    ("invalid-primitive-mode.gltf", &["mode"]),
    ("bad-base64-buffer.gltf", &["corrupt data URI"]),
    ("buffer-uri-http.gltf", &["not supported"]),
    ("buffer-uri-directory.gltf", &["directory"]),
    (
        "unsupported-required-extension.gltf",
        &["KHR_draco_mesh_compression"],
    ),
    ("empty-scene.gltf", &["nothing to render"]),
    ("no-scenes.gltf", &["nothing to render"]),
    ("no-geometry.gltf", &["no geometry"]),
    ("node-cycle.gltf", &["cycle"]),
    ("node-own-child.gltf", &["cycle"]),
    ("exponential-instancing.gltf", &["more than 1000000"]),
    ("too-many-triangles.gltf", &["60 M triangles", "limit"]),
];

#[test]
fn bad_gltf_files_are_refused_clearly() {
    for (name, phrases) in REFUSED_SCENES {
        assert_scene_refused(&bad(name), phrases);
    }
}

#[test]
fn too_many_triangles_are_refused_before_reading_the_buffer() {
    let dir = tempfile::tempdir().unwrap();
    let run = render(
        &bad("too-many-triangles.gltf"),
        &dir.path().join("x.png"),
        &[],
    );
    assert!(!run.stderr.contains("never-read.bin"), "{}", run.stderr);
}

#[test]
fn damaged_but_usable_scenes_render_with_a_warning() {
    let cases: &[(&str, &[&str])] = &[
        (
            "missing-texture.gltf",
            &["missing-texture-absent.png", "fall back"],
        ),
        (
            "corrupt-texture.gltf",
            &["corrupt-texture.png", "fall back"],
        ),
        (
            "degenerate-triangles.gltf",
            &["1 degenerate (zero-area) triangles dropped"],
        ),
        ("zero-area-emitter.gltf", &["degenerate (zero-area)"]),
        (
            "nan-and-inf-positions.gltf",
            &["mesh 1 primitive 0: 1 triangles with non-finite vertex positions dropped"],
        ),
        ("points-primitive.gltf", &["Points primitive skipped"]),
        ("non-finite-transform.gltf", &["non-finite transform"]),
        (
            "overflowing-world-positions.gltf",
            &["area overflows f32", "node 'far': 1 triangles lie beyond"],
        ),
        (
            "zero-scale-node.gltf",
            &["node 'flattened': 1 triangles collapse to zero area"],
        ),
    ];
    for (name, phrases) in cases {
        assert_renders_with_warning(&bad(name), phrases);
    }
}

#[test]
fn out_of_range_camera_hints_are_ignored_with_a_warning() {
    // No --height: the file's 100 000-pixel hint would have been rendered, exhausting memory.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.png");
    let scene = bad("camera-hints-out-of-range.gltf");
    let run = realcam(&[
        "render".as_ref(),
        scene.as_os_str(),
        "--spp".as_ref(),
        "1".as_ref(),
        "--width".as_ref(),
        "8".as_ref(),
        "--out".as_ref(),
        out.as_os_str(),
    ]);
    let context = format!("exit {}, stderr:\n{}", run.code, run.stderr);
    assert_eq!(run.code, 0, "{context}");
    assert_clean(&run, &context);
    for phrase in ["height 100000 ignored", "film_distance_mm -50 ignored"] {
        assert!(
            run.stderr.lines().any(|line| line.starts_with("warning: ")
                && line.contains("camera-hints-out-of-range.gltf")
                && line.contains("node 1 ('cam')")
                && line.contains(phrase)),
            "{phrase}: {context}"
        );
    }
    let png = image::open(&out).unwrap();
    assert_eq!((png.width(), png.height()), (8, 512), "{context}");
}

#[test]
fn scene_paths_that_are_not_gltf_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    assert_scene_refused(
        &dir.path().join("no-such-scene.gltf"),
        &["cannot read glTF file"],
    );
    let folder = dir.path().join("folder.gltf");
    std::fs::create_dir(&folder).unwrap();
    assert_scene_refused(&folder, &["directory"]);
    // A device never ends: it must be refused, not read until memory runs out.
    if Path::new("/dev/zero").exists() {
        assert_scene_refused(Path::new("/dev/zero"), &["device"]);
    }
    // A lens file is not a scene.
    assert_scene_refused(&bad("lens-two-stops.dat"), &["invalid glTF JSON"]);
}

#[test]
fn generated_hostile_gltf_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, bytes: &[u8]| {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    };
    // JSON nested far deeper than any glTF.
    let nested = format!("{}{}", "[".repeat(100_000), "]".repeat(100_000));
    assert_scene_refused(
        &write("nested.gltf", nested.as_bytes()),
        &["invalid glTF JSON"],
    );
    // Binary garbage, with and without the GLB magic.
    let garbage = xorshift_bytes(64 * 1024, 7);
    assert_scene_refused(&write("garbage.gltf", &garbage), &["invalid glTF JSON"]);
    let mut glb = b"glTF\x02\0\0\0".to_vec();
    glb.extend_from_slice(&(garbage.len() as u32 + 12).to_le_bytes());
    glb.extend_from_slice(&garbage);
    assert_scene_refused(&write("garbage.glb", &glb), &[".glb"]);
    // A node chain 10 000 deep.
    let mut gltf = GltfBuilder::default();
    let mut below = gltf.triangle_node(json!({}));
    for _ in 0..10_000 {
        below = gltf.node(json!({"children": [below]}));
    }
    gltf.scene(&[below]);
    assert_scene_refused(&write("deep.gltf", &gltf.embedded()), &["levels deep"]);
    // A buffer that names a device: refused, not read forever.
    if Path::new("/dev/zero").exists() {
        let mut gltf = GltfBuilder::default();
        let node = gltf.triangle_node(json!({}));
        gltf.scene(&[node]);
        let mut json = serde_json::from_slice::<serde_json::Value>(&gltf.embedded()).unwrap();
        json["buffers"][0]["uri"] = json!("file:///dev/zero");
        let path = write("device-buffer.gltf", &serde_json::to_vec(&json).unwrap());
        assert_scene_refused(&path, &["/dev/zero", "device"]);
    }
}

/// Reproducible pseudo-random bytes.
fn xorshift_bytes(len: usize, seed: u64) -> Vec<u8> {
    let mut state = 0x2545_f491_4f6c_dd1d ^ seed;
    (0..len)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 24) as u8
        })
        .collect()
}

// ------------------------------------------------------------------ lens files

/// (file in tests/data/bad, phrase the error must hold, line it must point at)
const REFUSED_LENSES: &[(&str, &str, Option<usize>)] = &[
    ("lens-empty.dat", "no surfaces", None),
    ("lens-comments-only.dat", "no surfaces", None),
    ("lens-three-columns.dat", "expected 4 columns", Some(2)),
    ("lens-six-columns.dat", "expected 4 columns", Some(1)),
    (
        "lens-unknown-glass.dat",
        "unknown glass 'UNOBTAINIUM'",
        Some(1),
    ),
    ("lens-glass-for-air.dat", "given for air", Some(2)),
    (
        "lens-coordinate-break.zmx",
        "SURF 1: TYPE COORDBRK",
        Some(5),
    ),
    (
        "lens-index-not-a-number.dat",
        "index 'glass' is not a number",
        Some(1),
    ),
    (
        "lens-nan-aperture.dat",
        "aperture 'nan' is not a number",
        Some(1),
    ),
    (
        "lens-infinite-thickness.dat",
        "thickness 'inf' is not a number",
        Some(1),
    ),
    ("lens-negative-aperture.dat", "must be positive", Some(1)),
    ("lens-zero-aperture.dat", "must be positive", Some(1)),
    ("lens-negative-thickness.dat", "negative thickness", Some(1)),
    ("lens-index-below-one.dat", "below 1", Some(1)),
    (
        "lens-aperture-wider-than-sphere.dat",
        "wider than the sphere",
        Some(1),
    ),
    (
        "lens-surfaces-cross.dat",
        "crosses the one before it",
        Some(2),
    ),
    ("lens-no-stop.dat", "no aperture stop", None),
    ("lens-two-stops.dat", "second aperture stop", Some(3)),
    ("lens-stop-last.dat", "cannot be the last surface", Some(3)),
    ("lens-stop-only.dat", "cannot be the last surface", Some(1)),
    ("lens-ambiguous-layout.dat", "--lens-format", None),
    ("lens-utf16.dat", "not a text file", None),
    ("lens-binary-garbage.dat", "not a text file", None),
    ("lens-control-characters.dat", "expected 4 columns", Some(1)),
    ("lens-huge-values.dat", "more than 100 m", Some(1)),
    ("lens-huge-index.dat", "not a real material", Some(1)),
    ("lens-tiny-apertures.dat", "below a micrometre", Some(1)),
    ("lens-diverging.dat", "negative power", None),
];

#[test]
fn bad_lens_files_are_refused_by_lens_and_render() {
    for &(name, phrase, line) in REFUSED_LENSES {
        let path = bad(name);
        let mut phrases = vec![phrase];
        let located = line.map(|line| format!("{name}:{line}: "));
        phrases.extend(located.as_deref());
        let run = realcam(&["lens".as_ref(), path.as_os_str()]);
        assert_refused(&run, name, &phrases);
        assert!(run.stdout.is_empty(), "{name}: {}", run.stdout);
        let lens_flag = ["--lens", path.to_str().unwrap()];
        assert_render_refused(&good_scene(), &lens_flag, name, &phrases);
    }
}

#[test]
fn generated_hostile_lens_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, bytes: &[u8]| {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    };
    let row = "50 5 1.5 20\n";
    let cases: Vec<(PathBuf, &str)> = vec![
        (
            write("huge.dat", row.repeat(3 << 20 >> 4).as_bytes()),
            "more than 1048576 bytes",
        ),
        (
            write("long-line.dat", "5".repeat(1_000_000).as_bytes()),
            "long-line.dat:1: line is 1000000 characters long",
        ),
        (
            write("garbage.dat", &xorshift_bytes(4096, 3)),
            "not a text file",
        ),
        (
            write(
                "many-stops.dat",
                format!("{}-50 0 1 20\n", "0 1 0 10\n".repeat(50_000)).as_bytes(),
            ),
            "second aperture stop",
        ),
    ];
    for (path, phrase) in &cases {
        let name = path.file_name().unwrap().to_str().unwrap();
        let run = realcam(&["lens".as_ref(), path.as_os_str()]);
        assert_refused(&run, name, &[phrase]);
    }
    if Path::new("/dev/zero").exists() {
        let run = realcam(&["lens", "/dev/zero"]);
        assert_refused(&run, "/dev/zero", &["more than 1048576 bytes"]);
    }
    let folder = dir.path().join("folder.dat");
    std::fs::create_dir(&folder).unwrap();
    let run = realcam(&["lens".as_ref(), folder.as_os_str()]);
    assert_refused(&run, "folder.dat", &["directory"]);
    let run = realcam(&["lens", "no-such-lens.50mm"]);
    assert_refused(&run, "no-such-lens.50mm", &["not a bundled lens"]);
}

// ------------------------------------------------------------------ flags

#[test]
fn impossible_flags_are_refused_before_rendering() {
    let scene = good_scene();
    // (flags, exit code, phrase): clap's usage errors exit 2, realcam's own checks 1.
    let cases: &[(&[&str], i32, &str)] = &[
        (&["--spp", "0"], 1, "--spp must be at least 1"),
        (&["--spp", "-3"], 2, "'-3'"),
        (&["--spp", "many"], 2, "--spp"),
        (&["--width", "0"], 1, "--width must be between 1 and 16384"),
        (&["--height", "-1"], 2, "'-1'"),
        (
            &["--width", "100000"],
            1,
            "--width must be between 1 and 16384",
        ),
        (&["--height", "4294967296"], 2, "--height"),
        (&["--max-depth", "0"], 1, "--max-depth"),
        (
            &["--wavelengths", "0"],
            1,
            "--wavelengths must be between 1 and 8, got 0",
        ),
        (
            &["--wavelengths", "9"],
            1,
            "--wavelengths must be between 1 and 8, got 9",
        ),
        (&["--wavelengths", "four"], 2, "--wavelengths"),
        (
            &["--filter", "mitchell"],
            2,
            "unknown filter 'mitchell': use tent, gaussian or box",
        ),
        (&["--filter", "-1"], 2, "unknown filter '-1'"),
        (
            &["--coating", "mgf2"],
            2,
            "unknown coating 'mgf2': use none, single, multi or ideal",
        ),
        (&["--threads", "0"], 1, "--threads"),
        (&["--exposure", "inf"], 1, "--exposure"),
        (&["--focus-distance", "-3"], 1, "focus-distance"),
        (&["--f-number", "0"], 1, "f-number"),
        (&["--aperture", "-1"], 1, "aperture"),
        (&["--film-diagonal", "0"], 1, "film-diagonal"),
        (
            &["--look-from", "0,0,0", "--look-at", "0,0,0"],
            1,
            "--look-from",
        ),
        (
            &["--look-from", "nan,0,0", "--look-at", "0,0,1"],
            2,
            "--look-from",
        ),
        (
            &["--env=-1,0,0"],
            1,
            "--env -1,0,0: radiance must not be negative",
        ),
        (&["--env", "-1,0,0"], 1, "radiance must not be negative"),
        (&["--env", "no-such-sky.exr"], 1, "no-such-sky.exr"),
        (
            &["--env", "1,1"],
            1,
            "--env 1,1: neither a sky R,G,B (three numbers) nor an image file that exists",
        ),
        (
            &["--checkpoint-every", "-5"],
            1,
            "--checkpoint-every must be a positive number",
        ),
        (&["--shard", "-1/2"], 2, "'-1/2' is not I/N"),
        (&["--focus-sweep", "-1:2:3"], 2, "two positive numbers"),
        (&["--film-distance", "1e30"], 1, "--film-distance 1"),
        (&["--focus-distance", "nan"], 1, "focus-distance"),
        (&["--camera", "7"], 1, "--camera 7"),
        (&["--lens", "no-such-lens"], 1, "no-such-lens"),
    ];
    let mut failures = Vec::new();
    for (flags, code, phrase) in cases {
        let dir = tempfile::tempdir().unwrap();
        let run = render(&scene, &dir.path().join("x.png"), flags);
        let context = format!("{flags:?}: exit {}, stderr:\n{}", run.code, run.stderr);
        if run.code != *code || !run.stderr.contains(phrase) {
            failures.push(context.clone());
        }
        assert_clean(&run, &context);
        assert_empty(dir.path(), &context);
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn unwritable_outputs_are_refused_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let scene = good_scene();
    let missing = dir.path().join("no-such-folder/x.png");
    let run = render(&scene, &missing, &[]);
    assert_refused(&run, "no-such-folder/x.png", &["cannot write"]);
    let run = render(&scene, dir.path(), &[]);
    assert_refused(&run, dir.path().to_str().unwrap(), &["is a directory"]);
    let ok = dir.path().join("ok.png");
    for flag in ["--exr", "--stats"] {
        let run = render(&scene, &ok, &[flag, missing.to_str().unwrap()]);
        assert_refused(&run, "no-such-folder/x.png", &["cannot write"]);
    }
    assert_empty(dir.path(), "unwritable outputs");
}

#[test]
fn outputs_never_overwrite_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let mut gltf = GltfBuilder::default();
    let node = gltf.triangle_node(json!({}));
    gltf.scene(&[node]);
    let scene = gltf.write(dir.path(), "scene");
    let lens = dir.path().join("my.lens.dat");
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("lenses/dgauss.50mm.dat"),
        &lens,
    )
    .unwrap();
    let files = [scene.clone(), lens.clone()];
    let before: Vec<Vec<u8>> = files.iter().map(|f| std::fs::read(f).unwrap()).collect();
    let lens_flag = ["--lens", lens.to_str().unwrap()];
    // The same file, also spelled another way.
    let scene_again = dir.path().join(".").join("scene.gltf");
    for out in [&scene, &lens, &scene_again] {
        let run = render(&scene, out, &lens_flag);
        assert_refused(
            &run,
            out.file_name().unwrap().to_str().unwrap(),
            &["would overwrite an input file"],
        );
        for flag in ["--exr", "--stats"] {
            let ok = dir.path().join("ok.png");
            let run = render(
                &scene,
                &ok,
                &[&lens_flag[..], &[flag, out.to_str().unwrap()]].concat(),
            );
            assert_refused(&run, "would overwrite", &[]);
        }
    }
    let after: Vec<Vec<u8>> = files.iter().map(|f| std::fs::read(f).unwrap()).collect();
    assert!(before == after, "an input file was changed");
    let mut names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|entry| entry.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, ["my.lens.dat", "scene.bin", "scene.gltf"]);
}

/// A scene with an external buffer and an external texture, written to `dir`.
fn scene_with_external_files(dir: &Path) -> PathBuf {
    let mut gltf = GltfBuilder::default();
    let node = gltf.triangle_node(json!({}));
    gltf.scene(&[node]);
    std::fs::write(
        dir.join("wood.png"),
        support::png_2x1([200, 150, 100], [90, 60, 30]),
    )
    .unwrap();
    gltf.add("images", json!({"uri": "wood.png"}));
    gltf.add("textures", json!({"source": 0}));
    gltf.material(json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}));
    gltf.json["meshes"][0]["primitives"][0]["material"] = json!(0);
    gltf.write(dir, "scene")
}

#[test]
fn the_loader_lists_every_file_a_scene_reads() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_with_external_files(dir.path());
    let loaded = realcam::scene::load_gltf(&scene).unwrap();
    assert_eq!(
        loaded.inputs,
        [
            scene.clone(),
            dir.path().join("scene.bin"),
            dir.path().join("wood.png")
        ]
    );
    // The preview from the JSON alone, which render checks before loading, agrees.
    assert_eq!(
        realcam::scene::referenced_files(&scene).unwrap(),
        loaded.inputs
    );
    // A .glb's JSON chunk names its external images too; a device is never read.
    let mut gltf = GltfBuilder::default();
    let node = gltf.triangle_node(json!({}));
    gltf.scene(&[node]);
    gltf.add("images", json!({"uri": "wood.png"}));
    let glb = dir.path().join("scene.glb");
    std::fs::write(&glb, gltf.glb()).unwrap();
    assert_eq!(
        realcam::scene::referenced_files(&glb).unwrap(),
        [glb.clone(), dir.path().join("wood.png")]
    );
    if Path::new("/dev/zero").exists() {
        assert_eq!(
            realcam::scene::referenced_files(Path::new("/dev/zero")),
            None
        );
    }
}

#[test]
fn outputs_never_overwrite_files_the_scene_refers_to() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_with_external_files(dir.path());
    for name in ["scene.bin", "wood.png"] {
        let input = dir.path().join(name);
        let before = std::fs::read(&input).unwrap();
        for flag in ["--out", "--exr", "--stats"] {
            let ok = dir.path().join("ok.png");
            let run = if flag == "--out" {
                render(&scene, &input, &[])
            } else {
                render(&scene, &ok, &[flag, input.to_str().unwrap()])
            };
            assert_refused(&run, name, &["would overwrite an input file"]);
            assert_eq!(std::fs::read(&input).unwrap(), before, "{flag} {name}");
        }
    }
}

// ------------------------------------------------------------------ merge

fn write_partial(dir: &Path, name: &str, shard: (u32, u32), seed: u64) -> PathBuf {
    let path = dir.join(name);
    let image = Image {
        width: 4,
        height: 2,
        sums: vec![[0.5, 0.25, 0.125]; 8],
        samples: 2,
    };
    let info = CheckpointInfo {
        version: FORMAT_VERSION,
        samples: 2,
        remaining: Vec::new(),
        planned: 2,
        shard: Some(shard),
        settings: json!({"seed": seed, "width": 4, "height": 2}),
        invocation: None,
    };
    write_checkpoint(&path, &image, &info).unwrap();
    path
}

#[test]
fn merge_refuses_bad_partials_naming_them() {
    let dir = tempfile::tempdir().unwrap();
    let parts = dir.path().join("parts");
    std::fs::create_dir(&parts).unwrap();
    let a = write_partial(&parts, "a.exr", (0, 2), 1);
    let b = write_partial(&parts, "b.exr", (1, 2), 1);
    let other_seed = write_partial(&parts, "seed2.exr", (1, 2), 2);
    let not_exr = bad("lens-two-stops.dat");
    let plain_exr = parts.join("plain.exr");
    let film = image::Rgb32FImage::from_pixel(4, 2, image::Rgb([1.0, 1.0, 1.0]));
    film.save(&plain_exr).unwrap();
    let out_dir = dir.path().join("out");
    std::fs::create_dir(&out_dir).unwrap();
    let out = out_dir.join("frame.png");

    let merge = |parts: &[&Path], extra: &[&str]| {
        let mut args: Vec<std::ffi::OsString> = vec!["merge".into()];
        args.extend(parts.iter().map(|p| p.as_os_str().to_owned()));
        args.extend(["--out".into(), out.clone().into_os_string()]);
        args.extend(extra.iter().map(Into::into));
        realcam(&args)
    };
    let cases: &[(&[&Path], &str, &[&str])] = &[
        (
            &[&a, &dir.path().join("gone.exr")],
            "gone.exr",
            &["not a readable OpenEXR"],
        ),
        (
            &[&a, &not_exr],
            "lens-two-stops.dat",
            &["not a readable OpenEXR"],
        ),
        (&[&a, &plain_exr], "plain.exr", &["checkpoint data"]),
        (&[&a, &other_seed], "seed2.exr", &["a.exr", "seed: 1 vs 2"]),
        (&[&a, &a, &b], "a.exr", &["shard 0/2 is given twice"]),
        (
            &[&b],
            "b.exr",
            &["shard(s) 0 of 0..1 are missing", "--allow-missing"],
        ),
    ];
    for (parts, file, phrases) in cases {
        let run = merge(parts, &[]);
        assert_refused(&run, file, phrases);
        assert_empty(&out_dir, file);
    }
    // A missing file is named once, not by the EXR reader and again by its source: for merge,
    // and for a render resuming from it.
    let gone = dir.path().join("gone.exr");
    let run = merge(&[&a, &gone], &[]);
    assert_eq!(
        run.stderr.matches("No such file").count(),
        1,
        "{}",
        run.stderr
    );
    let resume: [&std::ffi::OsStr; 11] = [
        "render".as_ref(),
        "--spp".as_ref(),
        "1".as_ref(),
        "--width".as_ref(),
        "8".as_ref(),
        "--height".as_ref(),
        "8".as_ref(),
        "--resume".as_ref(),
        gone.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
    ];
    let run = realcam(&resume);
    assert_eq!(run.code, 1, "{}", run.stderr);
    assert_eq!(
        run.stderr.matches("No such file").count(),
        1,
        "{}",
        run.stderr
    );
    let run = merge(
        &[&b],
        &[
            "--allow-missing",
            "--exr",
            out_dir.join("frame.exr").to_str().unwrap(),
        ],
    );
    assert_eq!(run.code, 0, "{}", run.stderr);
    assert!(
        run.stderr.contains("warning: shard(s) 0 of 0..1 missing"),
        "{}",
        run.stderr
    );
    assert!(run.stderr.contains("wrote"), "{}", run.stderr);
    let merged = image::open(out_dir.join("frame.exr")).unwrap().to_rgb32f();
    assert_eq!(merged.get_pixel(3, 1).0, [0.25, 0.125, 0.0625]);

    // Usage errors, and outputs that would overwrite a partial.
    let run = realcam(&["merge", "--out", out.to_str().unwrap()]);
    assert_eq!(run.code, 2, "{}", run.stderr);
    let before = std::fs::read(&a).unwrap();
    let run = realcam(&[
        "merge".as_ref(),
        a.as_os_str(),
        b.as_os_str(),
        "--out".as_ref(),
        a.as_os_str(),
    ]);
    assert_refused(&run, "a.exr", &["would overwrite the partial"]);
    assert_eq!(std::fs::read(&a).unwrap(), before);
    let run = merge(&[&a, &b], &["--exr", out.to_str().unwrap()]);
    assert_refused(&run, "frame.png", &["same file"]);
}

#[test]
fn merged_real_shards_equal_the_single_render_and_mismatched_ones_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scene = good_scene();
    let frame = dir.path().join("frame.png");
    let common = ["--spp", "4", "--seed", "3", "--max-depth", "2"];
    for shard in ["0/2", "1/2"] {
        let run = render(&scene, &frame, &[&common[..], &["--shard", shard]].concat());
        assert_eq!(run.code, 0, "{}", run.stderr);
    }
    let whole = dir.path().join("whole.exr");
    let run = render(
        &scene,
        &dir.path().join("whole.png"),
        &[&common[..], &["--exr", whole.to_str().unwrap()]].concat(),
    );
    assert_eq!(run.code, 0, "{}", run.stderr);

    let parts = [0, 1].map(|i| dir.path().join(format!("frame.shard-{i}-of-2.exr")));
    let merged = dir.path().join("merged.exr");
    let run = realcam(&[
        "merge".as_ref(),
        parts[1].as_os_str(),
        parts[0].as_os_str(),
        "--out".as_ref(),
        frame.as_os_str(),
        "--exr".as_ref(),
        merged.as_os_str(),
    ]);
    assert_eq!(run.code, 0, "{}", run.stderr);
    assert!(
        run.stderr.contains("4 spp from 2 of 2 shards"),
        "{}",
        run.stderr
    );
    let merged = image::open(&merged).unwrap().to_rgb32f();
    let whole = image::open(&whole).unwrap().to_rgb32f();
    assert_eq!(merged.dimensions(), whole.dimensions());
    for (m, w) in merged
        .pixels()
        .flat_map(|p| p.0)
        .zip(whole.pixels().flat_map(|p| p.0))
    {
        assert!(
            (m - w).abs() <= 1e-5 * w.abs().max(1e-3),
            "merged {m} vs single {w}"
        );
    }

    // A shard of the same frame rendered with another seed cannot join.
    let stray = dir.path().join("stray.exr");
    let run = render(
        &scene,
        &frame,
        &[
            "--spp",
            "4",
            "--seed",
            "4",
            "--max-depth",
            "2",
            "--shard",
            "1/2",
            "--partial",
            stray.to_str().unwrap(),
        ],
    );
    assert_eq!(run.code, 0, "{}", run.stderr);
    let run = realcam(&[
        "merge".as_ref(),
        parts[0].as_os_str(),
        stray.as_os_str(),
        "--out".as_ref(),
        dir.path().join("mixed.png").as_os_str(),
    ]);
    assert_refused(&run, "stray.exr", &["frame.shard-0-of-2.exr", "seed"]);
}
