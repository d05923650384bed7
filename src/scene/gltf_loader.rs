//! Placeholder until the glTF loader lands from its branch.
use std::path::Path;

use super::LoadedScene;

pub fn load_gltf(path: &Path) -> anyhow::Result<LoadedScene> {
    anyhow::bail!(
        "{}: glTF loading is not available in this build",
        path.display()
    )
}

pub fn load_gltf_bytes(
    _bytes: &[u8],
    _base_dir: Option<&Path>,
    source: &Path,
) -> anyhow::Result<LoadedScene> {
    load_gltf(source)
}
