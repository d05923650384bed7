//! `examples/render_gltf.rs`, the library in a page, is built by `cargo test` with every
//! example; here it runs as a newcomer would run it, and its picture is checked.

use std::path::PathBuf;
use std::process::Command;

/// Where cargo put the example: `target/<profile>/examples/`, beside this test's `deps/`.
fn example(name: &str) -> PathBuf {
    let test = std::env::current_exe().unwrap();
    let profile = test.parent().unwrap().parent().unwrap();
    profile
        .join("examples")
        .join(format!("{name}{}", std::env::consts::EXE_SUFFIX))
}

#[test]
fn the_library_example_renders_a_gltf_through_a_bundled_lens() {
    let binary = example("render_gltf");
    assert!(
        binary.exists(),
        "{} is missing: `cargo test` builds the examples before it runs the tests",
        binary.display()
    );
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("duck.png");
    let scene = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/Duck/Duck.gltf");
    let run = Command::new(&binary)
        .args([scene.as_os_str(), out.as_os_str(), "wide.22mm".as_ref()])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(stdout.contains("through wide.22mm at f/4"), "{stdout}");
    let picture = image::open(&out).unwrap().to_rgb8();
    assert_eq!(picture.dimensions(), (192, 128));
    // The duck is yellow in front of a white sky: the picture is neither blank nor one colour.
    let levels: Vec<u8> = picture.pixels().map(|p| p.0[2]).collect();
    let (min, max) = (levels.iter().min().unwrap(), levels.iter().max().unwrap());
    assert!(max - min > 64, "blue channel spans only {min}..{max}");
}
