//! Regenerates the bundled default scene: `cargo run --release --bin make-default-scene
//! [OUTPUT]` writes `assets/dof-dragons.glb` (or OUTPUT). Commit the result; a test checks that
//! the committed file matches the generator.

use std::path::PathBuf;

use anyhow::Context;
use realcam::scene::default_scene::{DEFAULT_SCENE_PATH, build_default_scene_glb};

fn main() -> anyhow::Result<()> {
    let output = match std::env::args_os().nth(1) {
        Some(path) => PathBuf::from(path),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(DEFAULT_SCENE_PATH),
    };
    let glb = build_default_scene_glb();
    std::fs::write(&output, &glb)
        .with_context(|| format!("cannot write the default scene to {}", output.display()))?;
    println!("wrote {} ({} bytes)", output.display(), glb.len());
    Ok(())
}
