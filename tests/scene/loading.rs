//! glTF loader tests: sample scenes checked against facts read from their files, synthetic
//! scenes checked against transforms computed by hand, and corrupt files that must give an
//! error naming the file (never a panic).

use crate::support;

use std::f32::consts::FRAC_PI_4;
use std::path::Path;
use std::sync::Arc;

use approx::assert_relative_eq;
use glam::{Vec2, Vec3};
use realcam::scene::default_scene::{
    DEFAULT_SCENE_GLB, DEFAULT_SCENE_PATH, build_default_scene_glb, load_default_scene,
};
use realcam::scene::{
    AlphaMode, CameraHints, LoadedScene, PunctualLight, WrapMode, load_gltf, load_gltf_bytes,
};
use serde_json::json;
use support::{GltfBuilder, png_2x1, sample_json, sample_scene};

fn load_built(
    builder: &GltfBuilder,
    name: &str,
) -> (tempfile::TempDir, anyhow::Result<LoadedScene>) {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = builder.write(dir.path(), name);
    let result = load_gltf(&path);
    (dir, result)
}

fn load_ok(builder: &GltfBuilder) -> LoadedScene {
    let (_dir, result) = load_built(builder, "scene");
    result.unwrap_or_else(|error| panic!("{error:#}"))
}

fn assert_vec3_eq(actual: Vec3, expected: Vec3) {
    assert!(actual.abs_diff_eq(expected, 1e-5), "{actual} != {expected}");
}

/// World-space corners of every instanced triangle.
fn world_triangles(scene: &LoadedScene) -> Vec<[Vec3; 3]> {
    scene
        .instances
        .iter()
        .flat_map(|instance| {
            instance.mesh.triangles.iter().map(|triangle| {
                triangle.map(|i| {
                    instance
                        .world_from_local
                        .transform_point3(instance.mesh.positions[i as usize])
                })
            })
        })
        .collect()
}

// ---------------------------------------------------------------- sample scenes

#[test]
fn box_has_12_triangles_within_its_accessor_bounds() {
    let scene = load_gltf(&sample_scene("Box/Box.gltf")).unwrap();
    assert_eq!(scene.triangle_count(), 12);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    // The POSITION accessor's min/max in the file: a cube of side 1 centred on the origin,
    // which the root node's rotation about X maps onto itself.
    let json = sample_json("Box/Box.gltf");
    let position = json["meshes"][0]["primitives"][0]["attributes"]["POSITION"]
        .as_u64()
        .unwrap();
    let accessor = &json["accessors"][position as usize];
    for axis in 0..3 {
        let min = accessor["min"][axis].as_f64().unwrap() as f32;
        let max = accessor["max"][axis].as_f64().unwrap() as f32;
        assert_eq!((min, max), (-0.5, 0.5));
        assert_relative_eq!(scene.bounds.min[axis], min, epsilon = 1e-6);
        assert_relative_eq!(scene.bounds.max[axis], max, epsilon = 1e-6);
    }
    let material = scene.materials.get(scene.instances[0].mesh.material);
    assert_eq!(material.name.as_deref(), Some("Red"));
    assert_relative_eq!(material.base_color.x, 0.8, epsilon = 1e-6);
    assert_eq!(material.metallic, 0.0);
    assert_eq!(scene.instances[0].mesh.normals.len(), 24);
}

#[test]
fn box_textured_decodes_its_png() {
    let scene = load_gltf(&sample_scene("BoxTextured/BoxTextured.gltf")).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let material = scene.materials.get(scene.instances[0].mesh.material);
    let texture = material.base_color_texture.expect("base colour texture");
    let texture = &scene.materials.textures[texture.texture];
    // Width and height from the PNG's IHDR chunk (bytes 16..24), read here by hand.
    let png = std::fs::read(sample_scene("BoxTextured/CesiumLogoFlat.png")).unwrap();
    let width = u32::from_be_bytes(png[16..20].try_into().unwrap());
    let height = u32::from_be_bytes(png[20..24].try_into().unwrap());
    assert_eq!((texture.width, texture.height), (width, height));
    assert_eq!(texture.texels.len(), (width * height) as usize);
    assert_eq!(
        scene.instances[0].mesh.uvs.len(),
        scene.instances[0].mesh.positions.len()
    );
}

#[test]
fn duck_camera_and_hierarchy_scale() {
    let scene = load_gltf(&sample_scene("Duck/Duck.gltf")).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert_eq!(scene.triangle_count(), 12636 / 3);
    assert_eq!(scene.cameras.len(), 1);
    let camera = &scene.cameras[0];
    assert_eq!(camera.index, 0);
    assert_relative_eq!(camera.yfov.unwrap(), 0.66, epsilon = 1e-3);
    assert_eq!(camera.aspect_ratio, Some(1.5));

    // The root node scales by 0.01: the mesh's POSITION max (163.97 in y) ends up at 1.6397 m,
    // and the camera at 0.01 × its node's translation.
    let json = sample_json("Duck/Duck.gltf");
    let position = json["meshes"][0]["primitives"][0]["attributes"]["POSITION"]
        .as_u64()
        .unwrap();
    let max_y = json["accessors"][position as usize]["max"][1]
        .as_f64()
        .unwrap() as f32;
    assert_relative_eq!(scene.bounds.max.y, max_y * 0.01, epsilon = 1e-5);
    let camera_matrix = &json["nodes"][1]["matrix"];
    let camera_translation = Vec3::new(
        camera_matrix[12].as_f64().unwrap() as f32,
        camera_matrix[13].as_f64().unwrap() as f32,
        camera_matrix[14].as_f64().unwrap() as f32,
    );
    assert_vec3_eq(
        camera.world_from_camera.w_axis.truncate(),
        camera_translation * 0.01,
    );
    // Rigid: orthonormal axes despite the 0.01 scale.
    let frame = camera.world_from_camera;
    for axis in [frame.x_axis, frame.y_axis, frame.z_axis] {
        assert_relative_eq!(axis.truncate().length(), 1.0, epsilon = 1e-5);
    }
    assert_relative_eq!(frame.determinant(), 1.0, epsilon = 1e-5);
    // The duck is textured; its image decodes.
    let material = scene.materials.get(scene.instances[0].mesh.material);
    assert!(material.base_color_texture.is_some());
}

#[test]
fn cornell_box_has_an_emissive_ceiling() {
    let scene = load_gltf(&sample_scene("CornellBox/cornellBox-2.80-Eevee-gltf.gltf")).unwrap();
    assert_eq!(scene.triangle_count(), 4410);
    let light = scene
        .materials
        .materials
        .iter()
        .find(|m| m.name.as_deref() == Some("light.000"));
    let light = light.expect("light material");
    assert!(light.is_emissive());
    assert_eq!(light.emissive, Vec3::ONE);
    assert_eq!(scene.materials.textures.len(), 2);
    assert!(
        scene
            .instances
            .iter()
            .any(|i| scene.materials.get(i.mesh.material).is_emissive())
    );
}

// ---------------------------------------------------------------- hierarchy and geometry

#[test]
fn trs_and_matrix_hierarchy_places_a_vertex_where_computed_by_hand() {
    let mut gltf = GltfBuilder::default();
    // Child: matrix translating by +1 in y. Its triangle's vertex (1, 0, 0) → (1, 1, 0).
    let child = gltf.triangle_node(json!({
        "name": "child",
        "matrix": [1,0,0,0, 0,1,0,0, 0,0,1,0, 0,1,0,1]
    }));
    // Parent: scale 2 → (2, 2, 0); rotate 90° about +Y, which takes +X to −Z → (0, 2, −2);
    // translate by (1, 2, 3) → (1, 4, 1).
    let half = (FRAC_PI_4).sin();
    let parent = gltf.node(json!({
        "name": "parent",
        "children": [child],
        "translation": [1.0, 2.0, 3.0],
        "rotation": [0.0, half, 0.0, half],
        "scale": [2.0, 2.0, 2.0]
    }));
    gltf.scene(&[parent]);
    let scene = load_ok(&gltf);
    assert_eq!(scene.instances.len(), 1);
    assert_eq!(scene.instances[0].node_name.as_deref(), Some("child"));
    let [origin, x, y] = world_triangles(&scene)[0];
    assert_vec3_eq(x, Vec3::new(1.0, 4.0, 1.0));
    // (0,0,0) → (0,1,0) → (0,2,0) → (0,2,0) → (1,4,3); (0,1,0) → (0,2,0) → (0,4,0) → (1,6,3).
    assert_vec3_eq(origin, Vec3::new(1.0, 4.0, 3.0));
    assert_vec3_eq(y, Vec3::new(1.0, 6.0, 3.0));
    assert_vec3_eq(scene.bounds.min, Vec3::new(1.0, 4.0, 1.0));
    assert_vec3_eq(scene.bounds.max, Vec3::new(1.0, 6.0, 3.0));
}

#[test]
fn one_mesh_is_shared_by_its_instances_and_mirrors_get_reversed_winding() {
    let mut gltf = GltfBuilder::default();
    let first = gltf.triangle_node(json!({"name": "a"}));
    let mesh = gltf.json["nodes"][first]["mesh"].clone();
    let second = gltf.node(json!({"name": "b", "mesh": mesh, "translation": [5.0, 0.0, 0.0]}));
    let mirrored = gltf.node(json!({"name": "mirror", "mesh": mesh, "scale": [-1.0, 1.0, 1.0]}));
    gltf.scene(&[first, second, mirrored]);
    let scene = load_ok(&gltf);
    assert_eq!(scene.instances.len(), 3);
    assert!(Arc::ptr_eq(
        &scene.instances[0].mesh,
        &scene.instances[1].mesh
    ));
    assert_eq!(scene.meshes.len(), 2, "one mesh plus its mirrored copy");
    // The triangle faces +Z (counter-clockwise seen from +Z); mirrored in x it must still do.
    for [a, b, c] in world_triangles(&scene) {
        let normal = (b - a).cross(c - a);
        assert!(normal.z > 0.0, "{normal}");
    }
}

#[test]
fn normal_from_local_gives_world_geometric_normals() {
    let mut gltf = GltfBuilder::default();
    // A triangle slanted at 45°, placed with non-uniform scale and a rotation: the plain
    // matrix would tilt its normal, the inverse transpose keeps it perpendicular.
    let positions = gltf.positions(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 1.0]]);
    let mesh = gltf.mesh(json!([{"attributes": {"POSITION": positions}}]));
    let half = FRAC_PI_4.sin();
    let node = gltf.node(json!({
        "mesh": mesh, "scale": [1.0, 3.0, 0.5], "rotation": [half, 0.0, 0.0, half]
    }));
    gltf.scene(&[node]);
    let scene = load_ok(&gltf);
    let instance = &scene.instances[0];
    let [a, b, c] = world_triangles(&scene)[0];
    let world = (b - a).cross(c - a).normalize();
    let p = &instance.mesh.positions;
    let local = (p[1] - p[0]).cross(p[2] - p[0]);
    let transformed = (instance.normal_from_local() * local).normalize();
    assert_vec3_eq(transformed, world);
    let naive = instance
        .world_from_local
        .transform_vector3(local)
        .normalize();
    assert!(
        naive.dot(world) < 0.99,
        "the test needs a transform that tilts normals"
    );
}

#[test]
fn strips_and_fans_give_n_minus_2_triangles() {
    let mut gltf = GltfBuilder::default();
    // A zig-zag strip of 6 vertices along x, and a fan of 5 vertices around the origin.
    let strip = gltf.positions(&[
        [0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [2.0, 0.0, 0.0],
        [2.0, 1.0, 0.0],
    ]);
    let fan = gltf.positions(&[
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [-1.0, 1.0, 0.0],
    ]);
    let fan_indices = gltf.indices_u16(&[0, 1, 2, 3, 4]);
    let mesh = gltf.mesh(json!([
        {"attributes": {"POSITION": strip}, "mode": 5},
        {"attributes": {"POSITION": fan}, "indices": fan_indices, "mode": 6}
    ]));
    let node = gltf.node(json!({"mesh": mesh}));
    gltf.scene(&[node]);
    let scene = load_ok(&gltf);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert_eq!(scene.instances[0].mesh.triangles.len(), 6 - 2);
    assert_eq!(scene.instances[1].mesh.triangles.len(), 5 - 2);
    // All triangles of a strip or a fan keep one winding: here all face the same way.
    for instance in &scene.instances {
        let p = &instance.mesh.positions;
        let normals: Vec<f32> = instance
            .mesh
            .triangles
            .iter()
            .map(|t| {
                (p[t[1] as usize] - p[t[0] as usize])
                    .cross(p[t[2] as usize] - p[t[0] as usize])
                    .z
            })
            .collect();
        assert!(
            normals.iter().all(|z| z.signum() == normals[0].signum()),
            "{normals:?}"
        );
    }
}

#[test]
fn points_and_lines_are_skipped_with_a_warning() {
    let mut gltf = GltfBuilder::default();
    let points = gltf.positions(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let mesh = gltf.mesh(json!([
        {"attributes": {"POSITION": points}, "mode": 0},
        {"attributes": {"POSITION": points}, "mode": 1},
        {"attributes": {"POSITION": points}}
    ]));
    let node = gltf.node(json!({"mesh": mesh}));
    gltf.scene(&[node]);
    let scene = load_ok(&gltf);
    assert_eq!(scene.instances.len(), 1);
    assert_eq!(scene.triangle_count(), 1);
    assert_eq!(scene.warnings.len(), 2, "{:?}", scene.warnings);
    assert!(scene.warnings.iter().any(|w| w.contains("Points")));
    assert!(scene.warnings.iter().any(|w| w.contains("Lines")));
}

#[test]
fn non_finite_and_degenerate_triangles_are_dropped_with_warnings() {
    let mut gltf = GltfBuilder::default();
    let positions = gltf.positions(&[
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [f32::NAN, 0.0, 0.0],
        [2.0, 0.0, 0.0],
    ]);
    // Good, touches NaN, collinear, repeated vertex.
    let indices = gltf.indices_u16(&[0, 1, 2, 0, 3, 2, 0, 1, 4, 1, 1, 2]);
    let mesh = gltf.mesh(json!([{"attributes": {"POSITION": positions}, "indices": indices}]));
    let node = gltf.node(json!({"mesh": mesh}));
    gltf.scene(&[node]);
    let scene = load_ok(&gltf);
    assert_eq!(scene.triangle_count(), 1);
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("1 triangles with non-finite")),
        "{:?}",
        scene.warnings
    );
    assert!(
        scene.warnings.iter().any(|w| w.contains("2 degenerate")),
        "{:?}",
        scene.warnings
    );
    assert!(scene.bounds.min.is_finite() && scene.bounds.max.is_finite());
}

#[test]
fn attributes_normals_tangents_and_normalized_integer_uvs() {
    let mut gltf = GltfBuilder::default();
    let positions = gltf.positions(&[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    // Normals not of unit length: the loader normalizes them.
    let normals = gltf.floats(&[0.0, 0.0, 2.0, 0.0, 0.0, 3.0, 0.0, 0.0, 0.5], "VEC3", 3);
    let tangents = gltf.floats(
        &[1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, -1.0, 1.0, 0.0, 0.0, 1.0],
        "VEC4",
        3,
    );
    // UNSIGNED_SHORT normalized UVs: 65535 → 1.0, 32768 → 0.50001.
    let uv_bytes: Vec<u8> = [0u16, 0, 65535, 0, 32768, 65535]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    let uvs = gltf.accessor(
        &uv_bytes,
        json!({"componentType": 5123, "normalized": true, "type": "VEC2", "count": 3}),
    );
    let mesh = gltf.mesh(json!([{
        "attributes": {"POSITION": positions, "NORMAL": normals, "TANGENT": tangents, "TEXCOORD_0": uvs}
    }]));
    let node = gltf.node(json!({"mesh": mesh}));
    gltf.scene(&[node]);
    let scene = load_ok(&gltf);
    let mesh = &scene.instances[0].mesh;
    assert_eq!(mesh.normals, vec![Vec3::Z; 3]);
    assert_eq!(mesh.tangents[1].w, -1.0);
    assert_eq!(mesh.uvs[0], Vec2::ZERO);
    assert_eq!(mesh.uvs[1], Vec2::new(1.0, 0.0));
    assert_relative_eq!(mesh.uvs[2].x, 32768.0 / 65535.0);
    assert_eq!(mesh.uvs[2].y, 1.0);
}

#[test]
fn embedded_buffers_and_glb_load_like_external_ones() {
    let mut gltf = GltfBuilder::default();
    let node = gltf.triangle_node(json!({}));
    gltf.scene(&[node]);
    let external = load_ok(&gltf);
    let embedded = load_gltf_bytes(&gltf.embedded(), None, Path::new("embedded.gltf")).unwrap();
    let glb = load_gltf_bytes(&gltf.glb(), None, Path::new("scene.glb")).unwrap();
    for scene in [&embedded, &glb] {
        assert_eq!(
            scene.instances[0].mesh.positions,
            external.instances[0].mesh.positions
        );
        assert_eq!(scene.bounds, external.bounds);
    }
    assert_eq!(glb.source, Path::new("scene.glb"));
}

#[test]
fn default_scene_is_scene_0_when_none_is_named() {
    let mut gltf = GltfBuilder::default();
    let node = gltf.triangle_node(json!({}));
    gltf.scene(&[node]);
    gltf.json.as_object_mut().unwrap().remove("scene");
    assert_eq!(load_ok(&gltf).triangle_count(), 1);
}

// ---------------------------------------------------------------- lights and cameras

#[test]
fn punctual_lights_in_world_space() {
    let mut gltf = GltfBuilder::default();
    gltf.json["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    gltf.json["extensions"] = json!({"KHR_lights_punctual": {"lights": [
        {"type": "point", "color": [1.0, 0.5, 0.25], "intensity": 8.0, "range": 10.0},
        {"type": "spot", "intensity": 2.0, "spot": {}},
        {"type": "directional", "color": [0.5, 1.0, 1.0], "intensity": 100.0}
    ]}});
    let light = |index: usize| json!({"KHR_lights_punctual": {"light": index}});
    let half = FRAC_PI_4.sin();
    // Rotating −90° about X turns the node's −Z into −Y: the spot points straight down.
    let spot = gltf.node(json!({
        "extensions": light(1), "translation": [0.0, 5.0, 0.0], "rotation": [-half, 0.0, 0.0, half]
    }));
    // The parent's translation moves the point light; its scale must not scale intensities.
    let point = gltf.node(json!({"extensions": light(0), "translation": [1.0, 0.0, 0.0]}));
    let parent = gltf.node(json!({"children": [point, spot], "translation": [0.0, 0.0, 2.0], "scale": [3.0, 3.0, 3.0]}));
    // Rotating 90° about Y turns −Z into −X.
    let sun = gltf.node(json!({"extensions": light(2), "rotation": [0.0, half, 0.0, half]}));
    gltf.scene(&[parent, sun]);
    let scene = load_ok(&gltf);
    assert_eq!(scene.lights.len(), 3, "{:?}", scene.warnings);
    match &scene.lights[0] {
        PunctualLight::Point {
            position,
            intensity,
            range,
        } => {
            assert_vec3_eq(*position, Vec3::new(3.0, 0.0, 2.0));
            assert_vec3_eq(*intensity, Vec3::new(8.0, 4.0, 2.0));
            assert_eq!(*range, Some(10.0));
        }
        other => panic!("expected a point light, got {other:?}"),
    }
    match &scene.lights[1] {
        PunctualLight::Spot {
            position,
            direction,
            intensity,
            inner_cone_angle,
            outer_cone_angle,
            ..
        } => {
            assert_vec3_eq(*position, Vec3::new(0.0, 15.0, 2.0));
            assert_vec3_eq(*direction, Vec3::NEG_Y);
            assert_vec3_eq(*intensity, Vec3::splat(2.0));
            assert_eq!((*inner_cone_angle, *outer_cone_angle), (0.0, FRAC_PI_4));
        }
        other => panic!("expected a spot light, got {other:?}"),
    }
    match &scene.lights[2] {
        PunctualLight::Directional {
            direction,
            illuminance,
        } => {
            assert_vec3_eq(*direction, Vec3::NEG_X);
            assert_vec3_eq(*illuminance, Vec3::new(50.0, 100.0, 100.0));
        }
        other => panic!("expected a directional light, got {other:?}"),
    }
}

#[test]
fn cameras_in_traversal_order_with_hints_from_extras() {
    let mut gltf = GltfBuilder::default();
    gltf.add("cameras", json!({
        "name": "lens camera",
        "type": "perspective",
        "perspective": {"yfov": 0.5, "znear": 0.1, "aspectRatio": 2.0},
        "extras": {"realcam": {"lens": "wide.22mm", "film_diagonal_mm": 43.3, "focus_distance_m": 2.5, "width": 640}}
    }));
    gltf.add(
        "cameras",
        json!({
            "type": "perspective",
            "perspective": {"yfov": 1.0, "znear": 0.1},
            "extras": {"realcam": "not an object"}
        }),
    );
    // The second camera comes first in traversal order (depth first: a's child before b).
    let hinted_child =
        gltf.node(json!({"name": "hinted", "camera": 0, "translation": [0.0, 0.0, 1.0]}));
    let a = gltf.node(json!({"children": [hinted_child], "scale": [2.0, 2.0, 2.0], "rotation": [0.0, FRAC_PI_4.sin(), 0.0, FRAC_PI_4.sin()]}));
    let b = gltf.node(json!({"camera": 1}));
    let geometry = gltf.triangle_node(json!({}));
    gltf.scene(&[a, b, geometry]);
    let scene = load_ok(&gltf);
    assert_eq!(scene.cameras.len(), 2);
    let hinted = &scene.cameras[0];
    assert_eq!((hinted.index, hinted.name.as_deref()), (0, Some("hinted")));
    assert_eq!(hinted.yfov, Some(0.5));
    assert_eq!(hinted.aspect_ratio, Some(2.0));
    assert_eq!(
        hinted.hints,
        CameraHints {
            lens: Some("wide.22mm".into()),
            film_diagonal_mm: Some(43.3),
            focus_distance_m: Some(2.5),
            width: Some(640),
            ..Default::default()
        }
    );
    // Rotation 90° about Y: the camera's −Z (view direction) becomes −X; scale 2 moves the
    // child's (0, 0, 1) to (2, 0, 0) but leaves the frame rigid.
    let frame = hinted.world_from_camera;
    assert_vec3_eq(frame.transform_vector3(Vec3::NEG_Z), Vec3::NEG_X);
    assert_vec3_eq(frame.transform_vector3(Vec3::Y), Vec3::Y);
    assert_vec3_eq(frame.w_axis.truncate(), Vec3::new(2.0, 0.0, 0.0));
    let plain = &scene.cameras[1];
    assert_eq!((plain.index, plain.yfov), (1, Some(1.0)));
    assert_eq!(plain.hints, CameraHints::default());
    assert_eq!(scene.warnings.len(), 1, "{:?}", scene.warnings);
    assert!(scene.warnings[0].contains("realcam"));
}

// ---------------------------------------------------------------- materials and textures

#[test]
fn materials_factors_textures_and_samplers() {
    let mut gltf = GltfBuilder::default();
    let node = gltf.triangle_node(json!({}));
    gltf.scene(&[node]);
    let png = png_2x1([188, 0, 255], [0, 255, 0]);
    let image_view = gltf.view(&png);
    gltf.add(
        "images",
        json!({"bufferView": image_view, "mimeType": "image/png"}),
    );
    gltf.add(
        "samplers",
        json!({"magFilter": 9728, "wrapS": 33071, "wrapT": 33648}),
    );
    gltf.add("textures", json!({"source": 0, "sampler": 0}));
    gltf.add("textures", json!({"source": 0}));
    gltf.material(json!({
        "name": "glowing",
        "pbrMetallicRoughness": {
            "baseColorFactor": [0.5, 0.5, 0.5, 1.0],
            "baseColorTexture": {"index": 0},
            "metallicFactor": 0.25, "roughnessFactor": 0.75,
            "metallicRoughnessTexture": {"index": 1}
        },
        "normalTexture": {"index": 1, "scale": 0.5},
        "emissiveFactor": [1.0, 0.5, 0.0],
        "emissiveTexture": {"index": 0},
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}},
        "alphaMode": "MASK",
        "doubleSided": true
    }));
    gltf.material(json!({"alphaMode": "MASK", "alphaCutoff": 0.25}));
    gltf.json["meshes"][0]["primitives"][0]["material"] = json!(0);
    let scene = load_ok(&gltf);
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    let material = scene.materials.get(Some(0));
    assert_eq!(material.name.as_deref(), Some("glowing"));
    assert_eq!((material.metallic, material.roughness), (0.25, 0.75));
    assert_eq!(material.normal_scale, 0.5);
    assert_vec3_eq(material.emissive, Vec3::new(4.0, 2.0, 0.0));
    assert_eq!(material.alpha_mode, AlphaMode::Mask(0.5));
    assert!(material.double_sided);
    assert_eq!(
        scene.materials.get(Some(1)).alpha_mode,
        AlphaMode::Mask(0.25)
    );

    // Colour textures are linearised, data textures are not: same image, two textures.
    let base = &scene.materials.textures[material.base_color_texture.unwrap().texture];
    let data = &scene.materials.textures[material.metallic_roughness_texture.unwrap().texture];
    assert_eq!(material.emissive_texture, material.base_color_texture);
    assert_eq!(material.normal_texture, material.metallic_roughness_texture);
    assert_relative_eq!(base.texels[0][0], 0.5029, epsilon = 1e-3);
    assert_relative_eq!(data.texels[0][0], 188.0 / 255.0, epsilon = 1e-6);
    assert_eq!(
        (base.wrap_s, base.wrap_t, base.nearest),
        (WrapMode::ClampToEdge, WrapMode::MirroredRepeat, true)
    );
    assert_eq!(
        (data.wrap_s, data.wrap_t, data.nearest),
        (WrapMode::Repeat, WrapMode::Repeat, false)
    );
    // Nearest sampling of the left texel.
    assert_relative_eq!(base.sample(Vec2::new(0.25, 0.5))[0], 0.5029, epsilon = 1e-3);
}

#[test]
fn missing_texture_warns_and_falls_back_to_the_factor() {
    let mut gltf = GltfBuilder::default();
    let node = gltf.triangle_node(json!({}));
    gltf.scene(&[node]);
    gltf.add("images", json!({"uri": "no-such-image.png"}));
    gltf.add(
        "images",
        json!({"uri": "data:image/png;base64,bm90IGEgcG5n"}),
    );
    gltf.add("textures", json!({"source": 0}));
    gltf.add("textures", json!({"source": 1}));
    gltf.material(json!({"pbrMetallicRoughness": {
        "baseColorFactor": [0.1, 0.2, 0.3, 1.0],
        "baseColorTexture": {"index": 0},
        "metallicRoughnessTexture": {"index": 1}
    }}));
    gltf.json["meshes"][0]["primitives"][0]["material"] = json!(0);
    let scene = load_ok(&gltf);
    let material = scene.materials.get(Some(0));
    assert_eq!(material.base_color_texture, None);
    assert_eq!(material.metallic_roughness_texture, None);
    assert_relative_eq!(material.base_color.z, 0.3);
    assert!(scene.materials.textures.is_empty());
    assert_eq!(scene.warnings.len(), 2, "{:?}", scene.warnings);
    assert!(
        scene.warnings[0].contains("no-such-image.png"),
        "{}",
        scene.warnings[0]
    );
    assert!(
        scene.warnings[1].contains("image 1"),
        "{}",
        scene.warnings[1]
    );
}

// ---------------------------------------------------------------- bad files

/// Loads `bytes` written to a file named `name` and returns the error message.
fn load_error(name: &str, bytes: &[u8]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).unwrap();
    match load_gltf(&path) {
        Ok(_) => panic!("{name} loaded but should not"),
        Err(error) => {
            let message = error.to_string();
            assert!(
                message.contains(name),
                "message does not name the file: {message}"
            );
            message
        }
    }
}

fn one_triangle() -> GltfBuilder {
    let mut gltf = GltfBuilder::default();
    let node = gltf.triangle_node(json!({}));
    gltf.scene(&[node]);
    gltf
}

fn json_bytes(value: &serde_json::Value) -> Vec<u8> {
    serde_json::to_vec(value).unwrap()
}

#[test]
fn missing_file_is_an_error_naming_it() {
    let error = load_gltf(Path::new("/nonexistent/where.gltf")).unwrap_err();
    assert!(error.to_string().contains("where.gltf"));
}

#[test]
fn invalid_json_and_non_gltf_are_errors() {
    let message = load_error("broken.gltf", b"{\"asset\": {\"version\": \"2.0\"");
    assert!(message.contains("JSON"), "{message}");
    load_error("empty.gltf", b"");
    load_error("no-asset.gltf", b"{}");
    let message = load_error("old.gltf", br#"{"asset": {"version": "1.0"}}"#);
    assert!(message.contains("1.0"), "{message}");
}

#[test]
fn file_without_scenes_is_an_error() {
    let message = load_error("no-scene.gltf", br#"{"asset": {"version": "2.0"}}"#);
    assert!(message.contains("scene has no scenes/nodes"), "{message}");
    let message = load_error(
        "empty-scene.gltf",
        br#"{"asset": {"version": "2.0"}, "scenes": [{"nodes": []}]}"#,
    );
    assert!(message.contains("scene has no scenes/nodes"), "{message}");
}

#[test]
fn truncated_glb_is_an_error() {
    let glb = one_triangle().glb();
    let message = load_error("cut.glb", &glb[..glb.len() - 10]);
    assert!(message.contains("truncated"), "{message}");
    load_error("header-only.glb", &glb[..10]);
    let mut wrong_version = glb.clone();
    wrong_version[4] = 1;
    load_error("version1.glb", &wrong_version);
    let mut tiny_length = glb.clone();
    tiny_length[8..12].copy_from_slice(&4u32.to_le_bytes());
    load_error("tiny.glb", &tiny_length);
}

#[test]
fn missing_or_short_bin_is_an_error_naming_both_files() {
    let gltf = one_triangle();
    let dir = tempfile::tempdir().unwrap();
    let path = gltf.write(dir.path(), "lonely");
    std::fs::remove_file(dir.path().join("lonely.bin")).unwrap();
    let message = load_gltf(&path).unwrap_err().to_string();
    assert!(
        message.contains("lonely.gltf") && message.contains("lonely.bin"),
        "{message}"
    );

    std::fs::write(
        dir.path().join("lonely.bin"),
        &gltf.bin[..gltf.bin.len() / 2],
    )
    .unwrap();
    let message = load_gltf(&path).unwrap_err().to_string();
    assert!(
        message.contains("lonely.gltf") && message.contains("byteLength"),
        "{message}"
    );
}

#[test]
fn bad_accessors_and_indices_are_errors() {
    // Accessor reaching past its buffer view.
    let mut gltf = one_triangle();
    gltf.json["accessors"][0]["count"] = json!(1000);
    let message = load_error("long-accessor.gltf", &gltf.embedded());
    assert!(message.contains("accessor 0"), "{message}");

    // Byte offset past the end.
    let mut gltf = one_triangle();
    gltf.json["accessors"][0]["byteOffset"] = json!(u32::MAX);
    load_error("offset.gltf", &gltf.embedded());

    // Buffer view past the buffer.
    let mut gltf = one_triangle();
    gltf.json["bufferViews"][0]["byteLength"] = json!(4096);
    load_error("view.gltf", &gltf.embedded());

    // Index out of range.
    let mut gltf = one_triangle();
    let indices = gltf.indices_u16(&[0, 1, 7]);
    gltf.json["meshes"][0]["primitives"][0]["indices"] = json!(indices);
    let message = load_error("index.gltf", &gltf.embedded());
    assert!(message.contains("index 7 is out of range"), "{message}");

    // POSITION pointing at a missing accessor, and at one of the wrong type.
    let mut gltf = one_triangle();
    gltf.json["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(99);
    load_error("position.gltf", &gltf.embedded());
    let mut gltf = one_triangle();
    gltf.json["accessors"][0]["type"] = json!("VEC2");
    load_error("vec2.gltf", &gltf.embedded());

    // Float indices.
    let mut gltf = one_triangle();
    let indices = gltf.floats(&[0.0, 1.0, 2.0], "SCALAR", 3);
    gltf.json["meshes"][0]["primitives"][0]["indices"] = json!(indices);
    load_error("float-indices.gltf", &gltf.embedded());
}

#[test]
fn required_unsupported_extension_is_named() {
    let mut gltf = one_triangle();
    gltf.json["extensionsUsed"] = json!(["KHR_draco_mesh_compression"]);
    gltf.json["extensionsRequired"] = json!(["KHR_draco_mesh_compression"]);
    let message = load_error("draco.gltf", &gltf.embedded());
    assert!(message.contains("KHR_draco_mesh_compression"), "{message}");
    // Merely *used* extensions are fine.
    let mut gltf = one_triangle();
    gltf.json["extensionsUsed"] = json!(["EXT_meshopt_compression"]);
    assert!(load_gltf_bytes(&gltf.embedded(), None, Path::new("used.gltf")).is_ok());
}

#[test]
fn node_cycles_and_absurd_depth_are_errors() {
    let mut gltf = one_triangle();
    let child = gltf.node(json!({"children": [0]}));
    gltf.json["nodes"][0]["children"] = json!([child]);
    let message = load_error("cycle.gltf", &gltf.embedded());
    assert!(message.contains("cycle"), "{message}");

    let mut gltf = one_triangle();
    let mut below = 0;
    for _ in 0..10_000 {
        below = gltf.node(json!({"children": [below]}));
    }
    gltf.scene(&[below]);
    let message = load_error("deep.gltf", &gltf.embedded());
    assert!(message.contains("levels deep"), "{message}");

    // A chain where every node has its child twice: 2^40 paths from 41 nodes.
    let mut gltf = one_triangle();
    let mut below = 0;
    for _ in 0..40 {
        below = gltf.node(json!({"children": [below, below]}));
    }
    gltf.scene(&[below]);
    load_error("explosive.gltf", &gltf.embedded());
}

#[test]
fn too_many_triangles_are_refused_before_reading_buffers() {
    let mut gltf = one_triangle();
    // The accessor claims 60 M triangles' worth of vertices; no buffer holds them.
    gltf.json["accessors"][0]["count"] = json!(180_000_000u64);
    gltf.json["buffers"] = json!([{"byteLength": 36, "uri": "never-read.bin"}]);
    let message = load_error("huge.gltf", &json_bytes(&gltf.json));
    assert!(message.contains("limit"), "{message}");
    assert!(!message.contains("never-read.bin"), "{message}");
}

#[test]
fn corrupted_files_never_panic() {
    // Every truncation and many single-byte corruptions of real files must give Ok or Err.
    let glb = one_triangle().glb();
    let embedded = one_triangle().embedded();
    for (name, bytes) in [
        ("a.glb", &glb),
        ("a.gltf", &embedded),
        ("d.glb", &DEFAULT_SCENE_GLB.to_vec()),
    ] {
        let step = (bytes.len() / 300).max(1);
        for cut in (0..bytes.len()).step_by(step) {
            if let Err(error) = load_gltf_bytes(&bytes[..cut], None, Path::new(name)) {
                assert!(error.to_string().contains(name));
            }
        }
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..400 {
            // xorshift: a fixed, reproducible sequence of positions and values.
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let mut corrupted = bytes.clone();
            let at = (state % bytes.len() as u64) as usize;
            corrupted[at] = (state >> 32) as u8;
            let _ = load_gltf_bytes(&corrupted, None, Path::new(name));
        }
    }
}

// ---------------------------------------------------------------- the default scene

#[test]
fn committed_default_scene_matches_its_generator() {
    let committed =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join(DEFAULT_SCENE_PATH)).unwrap();
    assert!(
        committed == build_default_scene_glb(),
        "{DEFAULT_SCENE_PATH} differs from build_default_scene_glb(): run `cargo run --release --bin make-default-scene` and commit the result"
    );
    assert_eq!(DEFAULT_SCENE_GLB, committed.as_slice());
}

#[test]
fn default_scene_content() {
    let scene = load_default_scene().unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);

    // One camera at the stated position, looking along the stated direction, with its hints.
    assert_eq!(scene.cameras.len(), 1);
    let camera = &scene.cameras[0];
    assert_vec3_eq(
        camera.world_from_camera.w_axis.truncate(),
        Vec3::new(11.5, 0.25, 2.5),
    );
    let look = camera.world_from_camera.transform_vector3(Vec3::NEG_Z);
    assert!(
        look.abs_diff_eq(Vec3::new(-0.787, -0.052, -0.615).normalize(), 1e-5),
        "{look}"
    );
    let up = camera.world_from_camera.transform_vector3(Vec3::Y);
    assert!(up.y > 0.99 && up.dot(look).abs() < 1e-5, "{up}");
    assert_eq!(camera.hints.lens.as_deref(), Some("dgauss.50mm"));
    assert_eq!(camera.hints.film_diagonal_mm, Some(70.0));
    assert_eq!(camera.hints.film_distance_mm, Some(36.77));
    assert_eq!(camera.hints.aperture_mm, Some(17.1));
    // Square 70 mm-diagonal film at 36.77 mm: half height 24.75 mm.
    let expected_yfov = 2.0 * ((70.0 / 2f32.sqrt() / 2.0) / 36.77).atan();
    assert_relative_eq!(camera.yfov.unwrap(), expected_yfov, epsilon = 1e-6);

    // Eleven cones, blue for even k and red for odd k, bases on the ground at x = −3 + 1.3 k.
    let cones: Vec<_> = scene
        .instances
        .iter()
        .filter(|i| {
            i.node_name
                .as_deref()
                .is_some_and(|n| n.starts_with("Cone"))
        })
        .collect();
    assert_eq!(cones.len(), 11);
    for (k, cone) in cones.iter().enumerate() {
        let x = -3.0 + 1.3 * k as f32;
        assert_vec3_eq(
            cone.world_from_local.w_axis.truncate(),
            Vec3::new(x, 0.0, 0.0),
        );
        let colour = scene
            .materials
            .get(cone.mesh.material)
            .base_color
            .truncate();
        let expected = if k % 2 == 0 {
            Vec3::new(0.2, 0.2, 0.5)
        } else {
            Vec3::new(0.8, 0.2, 0.2)
        };
        assert_vec3_eq(colour, expected);
        let heights = cone.mesh.positions.iter().map(|p| p.y);
        assert_relative_eq!(heights.fold(0.0, f32::max), 0.75);
        let radius = cone
            .mesh
            .positions
            .iter()
            .map(|p| Vec2::new(p.x, p.z).length())
            .fold(0.0, f32::max);
        assert_relative_eq!(radius, 0.25, epsilon = 1e-6);
        assert!(cone.mesh.triangles.len() >= 2 * 64);
        // Smooth normals agree with the geometric ones (outward, counter-clockwise winding).
        for t in &cone.mesh.triangles {
            let [a, b, c] = t.map(|i| cone.mesh.positions[i as usize]);
            let face = (b - a).cross(c - a).normalize();
            for i in t {
                assert!(cone.mesh.normals[*i as usize].dot(face) > 0.5);
            }
        }
    }

    // An emissive sky light, and bounds spanning the 40 m-radius light disk (x, z) from the
    // ground (y = 0) to the light (y = 50 m).
    let emissive: Vec<_> = scene
        .instances
        .iter()
        .filter(|i| scene.materials.get(i.mesh.material).is_emissive())
        .collect();
    assert_eq!(emissive.len(), 1);
    let light = scene.materials.get(emissive[0].mesh.material);
    assert_eq!(light.emissive, Vec3::ONE);
    assert_eq!(light.base_color.truncate(), Vec3::ZERO);
    assert_vec3_eq(scene.bounds.min, Vec3::new(-40.0, 0.0, -40.0));
    assert_vec3_eq(scene.bounds.max, Vec3::new(40.0, 50.0, 40.0));

    // The ground: 40 m square at y = 0 facing +Y, matte, grid texture of mean albedo ≈ 0.5.
    let ground = scene
        .instances
        .iter()
        .find(|i| i.node_name.as_deref() == Some("Ground"))
        .unwrap();
    let xs = ground.mesh.positions.iter().map(|p| p.x);
    assert_eq!(xs.clone().fold(f32::MAX, f32::min), -20.0);
    assert_eq!(xs.fold(f32::MIN, f32::max), 20.0);
    assert!(ground.mesh.normals.iter().all(|n| *n == Vec3::Y));
    let material = scene.materials.get(ground.mesh.material);
    assert_eq!((material.metallic, material.roughness), (0.0, 1.0));
    let texture = &scene.materials.textures[material.base_color_texture.unwrap().texture];
    assert_eq!(
        (texture.wrap_s, texture.wrap_t),
        (WrapMode::Repeat, WrapMode::Repeat)
    );
    let mean = texture.texels.iter().map(|t| t[0]).sum::<f32>() / texture.texels.len() as f32;
    assert_relative_eq!(mean, 0.5, epsilon = 0.005);
    // One UV unit per 0.5 m grid cell.
    let uv_span = ground.mesh.uvs.iter().map(|uv| uv.x).fold(0.0, f32::max);
    assert_relative_eq!(uv_span, 40.0 / 0.5);
}
