//! A black image says why it is black: a camera inside a closed, unlit model, and surfaces
//! lit only from behind, each get a warning naming the cause (exit 0, recorded in --stats);
//! the same scenes lit properly get none. The scenes are built here by hand.

use crate::support;

use support::cli::realcam;

use std::path::{Path, PathBuf};

use serde_json::{Value, json};
use support::GltfBuilder;

/// Renders `scene` small, returning stderr and the stats' per-frame warnings; checks exit 0.
fn render(dir: &Path, scene: &Path, extra: &[&str]) -> (String, Vec<String>) {
    let mut args = vec![
        "render",
        scene.to_str().unwrap(),
        "--spp",
        "2",
        "--width",
        "32",
        "--height",
        "32",
        "--out",
        "shot.png",
        "--stats",
        "stats.json",
    ];
    args.extend(extra);
    let output = realcam(dir, &args);
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(output.status.success(), "{stderr}");
    let stats: Value =
        serde_json::from_slice(&std::fs::read(dir.join("stats.json")).unwrap()).unwrap();
    let warnings = stats["frames"][0]["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap().to_string())
        .collect();
    (stderr, warnings)
}

fn png_is_black(dir: &Path) -> bool {
    let png = image::open(dir.join("shot.png")).unwrap().to_rgb8();
    png.pixels().all(|p| p.0 == [0, 0, 0])
}

/// Adds a mesh of `positions` and triangle `indices` with `material`, returns its node.
fn mesh_node(
    gltf: &mut GltfBuilder,
    positions: &[[f32; 3]],
    indices: &[u16],
    material: Value,
) -> usize {
    let material = gltf.material(material);
    let positions = gltf.positions(positions);
    let indices = gltf.indices_u16(indices);
    let mesh = gltf.mesh(json!([{
        "attributes": {"POSITION": positions},
        "indices": indices,
        "material": material
    }]));
    gltf.node(json!({"mesh": mesh}))
}

fn grey(double_sided: bool) -> Value {
    json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0},
        "doubleSided": double_sided
    })
}

/// A closed box 4 m across, a camera at its centre, no light anywhere: realcam lights a scene
/// without lights with a white sky, which the box hides from the camera.
fn enclosed_camera(dir: &Path) -> PathBuf {
    let mut gltf = GltfBuilder::default();
    let corners: Vec<[f32; 3]> = (0..8)
        .map(|i| {
            let c = |bit: i32| if i & bit != 0 { 2.0 } else { -2.0 };
            [c(1), c(2), c(4)]
        })
        .collect();
    // Two triangles per face of the cube (corner i has x from bit 1, y from bit 2, z from bit 4).
    let faces: [[u16; 4]; 6] = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    let indices: Vec<u16> = faces
        .iter()
        .flat_map(|[a, b, c, d]| [*a, *b, *c, *a, *c, *d])
        .collect();
    let walls = mesh_node(&mut gltf, &corners, &indices, grey(true));
    gltf.add(
        "cameras",
        json!({"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01}}),
    );
    let camera = gltf.node(json!({"camera": 0, "name": "inside"}));
    gltf.scene(&[walls, camera]);
    gltf.write(dir, "enclosed")
}

/// A 2 m square facing +z and a point light at z = `light_z`.
fn lit_square(dir: &Path, name: &str, light_z: f32, double_sided: bool) -> PathBuf {
    let mut gltf = GltfBuilder::default();
    let square = mesh_node(
        &mut gltf,
        &[
            [-1.0, -1.0, 0.0],
            [1.0, -1.0, 0.0],
            [1.0, 1.0, 0.0],
            [-1.0, 1.0, 0.0],
        ],
        &[0, 1, 2, 0, 2, 3],
        grey(double_sided),
    );
    gltf.json["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    gltf.json["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": [1.0, 1.0, 1.0], "intensity": 3000.0}
    ]}});
    let light = gltf.node(json!({
        "translation": [0.0, 0.0, light_z],
        "extensions": {"KHR_lights_punctual": {"light": 0}}
    }));
    gltf.scene(&[square, light]);
    gltf.write(dir, name)
}

const FROM_THE_FRONT: [&str; 4] = ["--look-from", "0,0,5", "--look-at", "0,0,0"];

#[test]
fn a_camera_inside_a_closed_unlit_model_is_told_so() {
    let dir = tempfile::tempdir().unwrap();
    let scene = enclosed_camera(dir.path());
    let (stderr, warnings) = render(dir.path(), &scene, &[]);
    assert!(png_is_black(dir.path()), "{stderr}");
    let expected = "the image is black: no camera path reached a light; 100 % of camera rays hit geometry and none escaped to the sky (the camera may be inside a closed model)";
    assert!(
        stderr.contains(&format!("warning: shot.png: {expected}")),
        "{stderr}"
    );
    assert_eq!(warnings, [expected]);
}

#[test]
fn surfaces_lit_only_from_behind_are_told_so() {
    let dir = tempfile::tempdir().unwrap();
    for double_sided in [false, true] {
        let scene = lit_square(dir.path(), "backlit", -2.0, double_sided);
        let (stderr, warnings) = render(dir.path(), &scene, &FROM_THE_FRONT);
        assert!(png_is_black(dir.path()), "{stderr}");
        assert_eq!(warnings.len(), 1, "{stderr}");
        for phrase in [
            "the image is black: the scene's lights do not reach the surfaces in view",
            "100 % of light samples came from behind the surface",
            "lit from the back",
            "of camera rays missed the scene and see a black sky",
        ] {
            assert!(warnings[0].contains(phrase), "{phrase}: {}", warnings[0]);
        }
        assert!(stderr.contains(&warnings[0]));
    }
}

#[test]
fn the_same_scenes_lit_properly_get_no_warning() {
    let dir = tempfile::tempdir().unwrap();
    // The light in front of the square.
    let scene = lit_square(dir.path(), "frontlit", 2.0, false);
    let (stderr, warnings) = render(dir.path(), &scene, &FROM_THE_FRONT);
    assert!(!png_is_black(dir.path()), "{stderr}");
    assert!(warnings.is_empty() && !stderr.contains("black"), "{stderr}");
    // The same closed box seen from outside, under the sky.
    let scene = enclosed_camera(dir.path());
    let (stderr, warnings) = render(
        dir.path(),
        &scene,
        &["--look-from", "6,5,7", "--look-at", "0,0,0"],
    );
    assert!(!png_is_black(dir.path()), "{stderr}");
    assert!(warnings.is_empty(), "{stderr}");
}

#[test]
fn other_causes_of_black_are_told() {
    let dir = tempfile::tempdir().unwrap();
    let scene = lit_square(dir.path(), "frontlit", 2.0, false);
    // Looking away from the only thing there is.
    let (_, warnings) = render(
        dir.path(),
        &scene,
        &["--look-from", "0,0,5", "--look-at", "0,0,10"],
    );
    assert_eq!(warnings.len(), 1);
    assert!(
        warnings[0].contains("every camera ray missed the scene and the sky is black"),
        "{}",
        warnings[0]
    );
    // A film that holds light, tone-mapped to black by the exposure asked for.
    let (stderr, warnings) = render(
        dir.path(),
        &scene,
        &[&FROM_THE_FRONT[..], &["--exposure", "-40"]].concat(),
    );
    assert!(png_is_black(dir.path()));
    assert_eq!(warnings.len(), 1, "{stderr}");
    assert!(
        warnings[0].contains("black at --exposure -40") && warnings[0].contains("automatic"),
        "{}",
        warnings[0]
    );
}
