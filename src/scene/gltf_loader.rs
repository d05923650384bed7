//! Loading glTF 2.0 (`.gltf` with external or embedded buffers, and `.glb`) into a
//! [`LoadedScene`].
//!
//! The JSON is parsed and validated with the `gltf` crate, but buffers, accessors, images and
//! the node hierarchy are read here, with every index, offset and length checked, so that no
//! file, however corrupt, can make the loader panic: it returns an error naming the file.

mod accessor;
mod budget;
mod buffers;
mod geometry;
mod materials;
mod nodes;
mod uri;
mod world;

use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context, Result, anyhow, bail};
use gltf::json::Root;
use gltf::json::mesh::Semantic;
use gltf::json::validation::Checked;

use self::buffers::Buffers;
use self::nodes::SceneContents;
use crate::scene::{LoadedScene, Mesh, MeshInstance};

pub use budget::{MAX_TRIANGLES, MAX_VERTICES};
/// Deeper node hierarchies are taken as corrupt (real files stay far below).
pub const MAX_NODE_DEPTH: usize = 256;
/// Node visits in one scene walk. A node shared by several parents is visited once per path,
/// so a small file can describe exponentially many instances.
pub const MAX_NODE_VISITS: usize = 1_000_000;

/// Extensions realcam understands; a file that *requires* any other is refused.
const SUPPORTED_REQUIRED_EXTENSIONS: &[&str] =
    &["KHR_lights_punctual", "KHR_materials_emissive_strength"];

/// Loads a `.gltf` or `.glb` file; external buffers and images are found relative to it.
pub fn load_gltf(path: &Path) -> Result<LoadedScene> {
    let bytes = uri::read_file(path, None).map_err(|error| {
        anyhow!(
            "cannot read glTF file {}: {error}; check the path",
            path.display()
        )
    })?;
    load_gltf_bytes(&bytes, path.parent(), path)
}

/// Loads glTF or GLB from memory. `base_dir` resolves relative URIs (`None`: the file must be
/// self-contained); `source` names the data in messages and in [`LoadedScene::source`].
pub fn load_gltf_bytes(
    bytes: &[u8],
    base_dir: Option<&Path>,
    source: &Path,
) -> Result<LoadedScene> {
    // One message holding the file name and the whole cause chain, however it is printed.
    let mut scene = load(bytes, base_dir, source)
        .map_err(|error| anyhow!("cannot load glTF scene {}: {error:#}", source.display()))?;
    // Warnings name the file too: the user may not know which file a "mesh 3" is in.
    for warning in &mut scene.warnings {
        *warning = format!("{}: {warning}", source.display());
    }
    Ok(scene)
}

fn load(bytes: &[u8], base_dir: Option<&Path>, source: &Path) -> Result<LoadedScene> {
    let (root, blob) = parse_document(bytes)?;
    let mut warnings = Vec::new();

    // The default scene, else the first (glTF leaves the choice to the application).
    let scene = root.scene.map_or(0, |scene| scene.value());
    if root
        .scenes
        .get(scene)
        .is_none_or(|scene| scene.nodes.is_empty())
    {
        bail!("scene has no scenes/nodes: the file defines nothing to render");
    }
    let contents = nodes::walk_scene(&root, scene, &mut warnings)?;
    if contents.meshes.is_empty() {
        warnings.push("the scene places no meshes: there is nothing to render".to_string());
    }
    check_size_budget(&root, &contents)?;

    let buffers = Buffers::load(&root, blob, base_dir)?;
    let (meshes, instances) = build_instances(&root, &buffers, &contents, &mut warnings)?;
    let materials = materials::load_materials(&root, &buffers, base_dir, &mut warnings);
    let SceneContents {
        cameras, lights, ..
    } = contents;
    Ok(LoadedScene {
        inputs: input_files(&root, base_dir, source),
        source: source.to_path_buf(),
        bounds: world::world_bounds(&instances),
        meshes,
        instances,
        materials,
        lights,
        cameras,
        warnings,
    })
}

/// JSON read by [`referenced_files`] at most: a larger document is left to the full load.
const MAX_PREVIEW_JSON: u64 = 64 << 20;

/// The glTF file at `path` and every file its buffers and images name, from its JSON alone
/// (no buffer or image is read), so that a command can refuse to write over them before it
/// loads the scene. `None` when the document cannot be read this way; loading it reports why.
pub fn referenced_files(path: &Path) -> Option<Vec<PathBuf>> {
    use std::io::Read;
    let mut file = std::fs::File::open(path).ok()?;
    // A device or FIFO may never end: only regular files are previewed.
    file.metadata().ok()?.is_file().then_some(())?;
    let mut head = [0u8; 20];
    let json = if file.read_exact(&mut head).is_ok() && head.starts_with(b"glTF") {
        // GLB: 12-byte header, then the JSON chunk's length and type.
        let length = u32::from_le_bytes(head[12..16].try_into().ok()?) as u64;
        (&head[16..20] == b"JSON" && length <= MAX_PREVIEW_JSON).then_some(())?;
        let mut json = vec![0; length as usize];
        file.read_exact(&mut json).ok()?;
        json
    } else {
        (file.metadata().ok()?.len() <= MAX_PREVIEW_JSON).then_some(())?;
        std::fs::read(path).ok()?
    };
    let root = parse_json(&json).ok()?;
    Some(input_files(&root, path.parent(), path))
}

/// `source` and every file its buffers and images name.
fn input_files(root: &Root, base_dir: Option<&Path>, source: &Path) -> Vec<PathBuf> {
    let uris = root
        .buffers
        .iter()
        .filter_map(|buffer| buffer.uri.as_deref())
        .chain(root.images.iter().filter_map(|image| image.uri.as_deref()));
    std::iter::once(source.to_path_buf())
        .chain(uris.filter_map(|uri| uri::file_path(uri, base_dir)))
        .collect()
}

/// Parses GLB or JSON glTF, refuses unsupported required extensions, and validates indices.
/// Returns the document and the GLB `BIN` chunk, if any.
fn parse_document(bytes: &[u8]) -> Result<(Root, Option<&[u8]>)> {
    if bytes.starts_with(b"glTF") {
        let (json, bin) = parse_glb(bytes)?;
        Ok((parse_json(json)?, bin))
    } else {
        Ok((parse_json(bytes)?, None))
    }
}

fn parse_json(json: &[u8]) -> Result<Root> {
    let root: Root = gltf::json::deserialize::from_slice(json)
        .map_err(|error| anyhow!("invalid glTF JSON: {error}; the file is corrupt or not glTF"))?;

    if !root.asset.version.starts_with("2.") {
        bail!(
            "glTF version {} is not supported; realcam reads glTF 2.0",
            root.asset.version
        );
    }
    let unsupported: Vec<&str> = root
        .extensions_required
        .iter()
        .map(String::as_str)
        .filter(|extension| !SUPPORTED_REQUIRED_EXTENSIONS.contains(extension))
        .collect();
    if !unsupported.is_empty() {
        bail!(
            "the file requires the glTF extension(s) {}, which realcam does not support; re-export the scene without them (e.g. without Draco or meshopt compression)",
            unsupported.join(", ")
        );
    }
    check_position_indices(&root)?;
    let document = gltf::Document::from_json(root).map_err(describe_validation_error)?;
    Ok(document.into_json())
}

/// Splits a GLB (glTF 2.0 §4.4) into its JSON chunk and its optional `BIN` chunk, checking
/// every length against the bytes present. Chunks of unknown type are ignored, as the spec asks.
fn parse_glb(bytes: &[u8]) -> Result<(&[u8], Option<&[u8]>)> {
    const HEADER: usize = 12;
    let (Some(version), Some(length)) = (le_u32(bytes, 4), le_u32(bytes, 8)) else {
        bail!(
            "truncated .glb: {} bytes, shorter than the 12-byte header",
            bytes.len()
        );
    };
    if version != 2 {
        bail!(
            "GLB container version {version} is not supported; realcam reads glTF 2.0 (.glb version 2)"
        );
    }
    let length = length as usize;
    if length > bytes.len() {
        bail!(
            "truncated .glb: the header says {length} bytes but only {} are present; the file is incomplete, download or export it again",
            bytes.len()
        );
    }
    let mut rest = bytes.get(HEADER..length).unwrap_or_default();
    let mut json = None;
    let mut bin = None;
    while !rest.is_empty() {
        let (kind, data, after) = glb_chunk(rest)?;
        match &kind {
            b"JSON" if json.is_none() => json = Some(data),
            b"BIN\0" if json.is_some() && bin.is_none() => bin = Some(data),
            _ if json.is_none() => bail!("corrupt .glb: the first chunk must be JSON"),
            _ => {}
        }
        rest = after;
    }
    let json = json.ok_or_else(|| anyhow!("corrupt .glb: no JSON chunk"))?;
    Ok((json, bin))
}

/// One GLB chunk: its type, its data and the bytes after it.
fn glb_chunk(bytes: &[u8]) -> Result<([u8; 4], &[u8], &[u8])> {
    const CHUNK_HEADER: usize = 8;
    let (Some(length), Some(kind)) = (le_u32(bytes, 0), bytes.get(4..CHUNK_HEADER)) else {
        bail!("truncated .glb: a chunk header is cut off");
    };
    let kind = [kind[0], kind[1], kind[2], kind[3]];
    let end = CHUNK_HEADER.saturating_add(length as usize);
    let Some(data) = bytes.get(CHUNK_HEADER..end) else {
        bail!(
            "truncated .glb: the {} chunk says {length} bytes but only {} follow",
            String::from_utf8_lossy(&kind).trim_end_matches('\0'),
            bytes.len() - CHUNK_HEADER
        );
    };
    Ok((kind, data, &bytes[end..]))
}

fn le_u32(bytes: &[u8], at: usize) -> Option<u32> {
    let word = bytes.get(at..at.checked_add(4)?)?;
    Some(u32::from_le_bytes([word[0], word[1], word[2], word[3]]))
}

/// The `gltf` crate's validator indexes the POSITION accessor without a bounds check: check
/// first so a bad index is an error, not a panic.
fn check_position_indices(root: &Root) -> Result<()> {
    for (mesh_index, mesh) in root.meshes.iter().enumerate() {
        for (primitive_index, primitive) in mesh.primitives.iter().enumerate() {
            let position = primitive
                .attributes
                .get(&Checked::Valid(Semantic::Positions));
            if let Some(accessor) = position.filter(|a| a.value() >= root.accessors.len()) {
                bail!(
                    "{}: POSITION refers to accessor {}, but there are only {} accessors",
                    geometry::primitive_label(root, mesh_index, primitive_index),
                    accessor.value(),
                    root.accessors.len()
                );
            }
        }
    }
    Ok(())
}

fn describe_validation_error(error: gltf::Error) -> anyhow::Error {
    match error {
        gltf::Error::Validation(problems) => {
            const SHOWN: usize = 5;
            let mut listed: Vec<String> = problems
                .iter()
                .take(SHOWN)
                .map(|(path, problem)| format!("{path}: {problem}"))
                .collect();
            if problems.len() > SHOWN {
                listed.push(format!("and {} more", problems.len() - SHOWN));
            }
            anyhow!(
                "the glTF is invalid ({}); fix or re-export the file",
                listed.join("; ")
            )
        }
        other => anyhow!("the glTF is invalid: {other}"),
    }
}

/// Refuses scenes too large to hold, from the accessor counts alone (no buffer is read yet).
fn check_size_budget(root: &Root, contents: &SceneContents) -> Result<()> {
    let mut sizes = HashMap::new();
    let mut triangles = 0u64;
    for placement in &contents.meshes {
        let Some(mesh) = root.meshes.get(placement.mesh) else {
            bail!("mesh {} does not exist", placement.mesh);
        };
        for (index, primitive) in mesh.primitives.iter().enumerate() {
            let size = match sizes.entry((placement.mesh, index)) {
                Entry::Occupied(entry) => *entry.get(),
                Entry::Vacant(entry) => *entry.insert(
                    geometry::estimated_size(root, primitive)
                        .with_context(|| geometry::primitive_label(root, placement.mesh, index))?,
                ),
            };
            triangles = triangles.saturating_add(size.0);
        }
    }
    let vertices = sizes
        .values()
        .fold(0u64, |sum, &(_, vertices)| sum.saturating_add(vertices));
    budget::check(triangles, vertices, crate::memory::available_memory())
}

/// One [`MeshInstance`] per (placed mesh, primitive), sharing one [`Mesh`] per primitive.
/// Mirroring placements (negative determinant) get a shared copy with reversed winding.
fn build_instances(
    root: &Root,
    buffers: &Buffers,
    contents: &SceneContents,
    warnings: &mut Vec<String>,
) -> Result<(Vec<Arc<Mesh>>, Vec<MeshInstance>)> {
    let mut read: HashMap<(usize, usize), Option<Arc<Mesh>>> = HashMap::new();
    let mut degenerate = geometry::DegenerateTriangles::default();
    let mut mirrored: HashMap<(usize, usize), Arc<Mesh>> = HashMap::new();
    let mut meshes = Vec::new();
    let mut instances = Vec::new();
    for placement in &contents.meshes {
        let primitive_count = root
            .meshes
            .get(placement.mesh)
            .map_or(0, |mesh| mesh.primitives.len());
        let mirrors = placement.world_from_local.determinant() < 0.0;
        for primitive in 0..primitive_count {
            let key = (placement.mesh, primitive);
            let mesh = match read.entry(key) {
                Entry::Occupied(entry) => entry.get().clone(),
                Entry::Vacant(entry) => {
                    let mesh = geometry::read_primitive(
                        root,
                        buffers,
                        placement.mesh,
                        primitive,
                        warnings,
                        &mut degenerate,
                    )?
                    .map(Arc::new);
                    meshes.extend(mesh.clone());
                    entry.insert(mesh).clone()
                }
            };
            let Some(mesh) = mesh else {
                continue;
            };
            let mesh = if mirrors {
                mirrored
                    .entry(key)
                    .or_insert_with(|| {
                        let copy = Arc::new(geometry::with_reversed_winding(&mesh));
                        meshes.push(copy.clone());
                        copy
                    })
                    .clone()
            } else {
                mesh
            };
            let instance = MeshInstance {
                mesh,
                world_from_local: placement.world_from_local,
                node_name: placement.node_name.clone(),
            };
            instances.extend(world::usable_in_world(instance, &mut meshes, warnings));
        }
    }
    warnings.extend(degenerate.warning());
    Ok((meshes, instances))
}
