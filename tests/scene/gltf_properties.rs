//! Property tests: the glTF loader never panics, whatever the document. Random edits of a
//! valid scene's JSON, random bytes in a `.glb` and random accessor counts, offsets and
//! indices either load or give an error naming the file; a scene that loads has only finite
//! positions and in-range indices.

use crate::support;

use std::path::Path;

use proptest::prelude::*;
use realcam::scene::{LoadedScene, load_gltf_bytes};
use serde_json::{Value, json};
use support::{GltfBuilder, png_2x1};

const SOURCE: &str = "fuzz.gltf";

/// A small scene using most of what the loader reads: indexed and non-indexed triangles, a
/// strip, normals, UVs, tangents, a sparse accessor, a textured material (embedded PNG), a
/// camera, a punctual light and a two-level hierarchy with TRS and a matrix.
fn base_scene() -> GltfBuilder {
    let mut gltf = GltfBuilder::default();
    let quad = gltf.positions(&[
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ]);
    let normals = gltf.floats(&[0.0, 0.0, 1.0].repeat(4), "VEC3", 4);
    let tangents = gltf.floats(&[1.0, 0.0, 0.0, 1.0].repeat(4), "VEC4", 4);
    let uvs = gltf.floats(&[0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0], "VEC2", 4);
    let indices = gltf.indices_u16(&[0, 1, 2, 0, 2, 3]);
    let strip = gltf.positions(&[
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [0.0, 1.0, 1.0],
        [1.0, 1.0, 1.0],
        [0.0, 2.0, 1.0],
    ]);
    let sparse_indices = gltf.view(
        &[1u16, 0, 3, 0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect::<Vec<_>>(),
    );
    let sparse_values = gltf.view(
        &[0.5f32, 0.0, 1.0, 1.5, 1.0, 1.0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect::<Vec<_>>(),
    );
    gltf.json["accessors"][strip]["sparse"] = json!({
        "count": 2,
        "indices": {"bufferView": sparse_indices, "componentType": 5123},
        "values": {"bufferView": sparse_values}
    });
    let image_view = gltf.view(&png_2x1([255, 0, 0], [0, 0, 255]));
    gltf.add(
        "images",
        json!({"bufferView": image_view, "mimeType": "image/png"}),
    );
    gltf.add("samplers", json!({"magFilter": 9728, "wrapS": 33071}));
    gltf.add("textures", json!({"source": 0, "sampler": 0}));
    gltf.material(json!({
        "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0},
        "normalTexture": {"index": 0},
        "emissiveFactor": [0.2, 0.1, 0.0]
    }));
    let quad_mesh = gltf.mesh(json!([{
        "attributes": {"POSITION": quad, "NORMAL": normals, "TANGENT": tangents, "TEXCOORD_0": uvs},
        "indices": indices,
        "material": 0
    }]));
    let strip_mesh = gltf.mesh(json!([{"attributes": {"POSITION": strip}, "mode": 5}]));
    let child = gltf.node(json!({
        "mesh": strip_mesh,
        "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0.5, 0, -1, 1]
    }));
    let parent = gltf.node(json!({
        "mesh": quad_mesh,
        "children": [child],
        "translation": [0, 0, -3],
        "rotation": [0, 0.383, 0, 0.924],
        "scale": [2, 2, 2]
    }));
    gltf.add(
        "cameras",
        json!({"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}),
    );
    let camera = gltf.node(json!({"camera": 0, "translation": [0, 1, 4]}));
    gltf.json["extensionsUsed"] = json!(["KHR_lights_punctual"]);
    gltf.json["extensions"] = json!({"KHR_lights_punctual": {"lights": [{"type": "spot", "intensity": 20.0, "spot": {"outerConeAngle": 0.5}}]}});
    let light = gltf.node(json!({"extensions": {"KHR_lights_punctual": {"light": 0}}}));
    gltf.scene(&[parent, camera, light]);
    gltf
}

/// What every successfully loaded scene must satisfy, however strange its file.
fn check_scene(scene: &LoadedScene) {
    for mesh in &scene.meshes {
        let vertices = mesh.positions.len();
        assert!(mesh.positions.iter().all(|p| p.is_finite()));
        assert!(
            mesh.triangles
                .iter()
                .flatten()
                .all(|&i| (i as usize) < vertices)
        );
        for (name, len) in [
            ("normals", mesh.normals.len()),
            ("tangents", mesh.tangents.len()),
            ("uvs", mesh.uvs.len()),
        ] {
            assert!(len == 0 || len == vertices, "{name}: {len} for {vertices}");
        }
        assert!(mesh.normals.iter().all(|n| n.is_finite()));
        if let Some(material) = mesh.material {
            assert!(material < scene.materials.materials.len());
        }
    }
    for instance in &scene.instances {
        assert!(instance.world_from_local.is_finite());
        let mesh = &instance.mesh;
        assert!(
            mesh.triangles
                .iter()
                .flatten()
                .all(|&i| (i as usize) < mesh.positions.len())
        );
    }
    let textures = scene.materials.textures.len();
    for material in &scene.materials.materials {
        for texture in [
            material.base_color_texture,
            material.metallic_roughness_texture,
            material.normal_texture,
            material.emissive_texture,
        ]
        .into_iter()
        .flatten()
        {
            assert!(texture.texture < textures);
        }
    }
    for camera in &scene.cameras {
        assert!(camera.world_from_camera.is_finite());
    }
}

fn check(bytes: &[u8]) {
    match load_gltf_bytes(bytes, None, Path::new(SOURCE)) {
        Ok(scene) => check_scene(&scene),
        Err(error) => assert!(error.to_string().contains(SOURCE), "{error:#}"),
    }
}

// ------------------------------------------------------------------ JSON mutations

/// Every value of a JSON document, depth first, by its path of keys and indices.
fn paths(value: &Value, prefix: &mut Vec<Value>, out: &mut Vec<Vec<Value>>) {
    out.push(prefix.clone());
    match value {
        Value::Object(map) => {
            for (key, child) in map {
                prefix.push(json!(key));
                paths(child, prefix, out);
                prefix.pop();
            }
        }
        Value::Array(items) => {
            for (index, child) in items.iter().enumerate() {
                prefix.push(json!(index));
                paths(child, prefix, out);
                prefix.pop();
            }
        }
        _ => {}
    }
}

fn at<'a>(root: &'a mut Value, path: &[Value]) -> &'a mut Value {
    path.iter().fold(root, |value, step| match step {
        Value::String(key) => &mut value[key.as_str()],
        _ => &mut value[step.as_u64().unwrap() as usize],
    })
}

/// Numbers a corrupt or hostile file is likely to hold where an index, count or offset goes.
const NASTY_NUMBERS: &[f64] = &[
    0.0,
    -1.0,
    1.0,
    2.0,
    3.0,
    4.0,
    7.0,
    255.0,
    65_535.0,
    4_294_967_295.0,
    4_294_967_296.0,
    9_007_199_254_740_991.0,
    -2_147_483_648.0,
    0.5,
    1e38,
    -1e38,
    3.4e38,
    1e300,
    1e-45,
];

/// A JSON value chosen by `selector`, `value` salting it: nasty numbers, other types.
fn replacement(selector: u8, value: u32) -> Value {
    match selector % 8 {
        0..=2 => json!(NASTY_NUMBERS[value as usize % NASTY_NUMBERS.len()]),
        3 => json!(value % 64),
        4 => json!(value),
        5 => json!(
            [
                "POSITION",
                "NORMAL",
                "",
                "data:,",
                "../x.bin",
                "KHR_draco_mesh_compression"
            ][value as usize % 6]
        ),
        6 => [
            json!(null),
            json!(true),
            json!([]),
            json!({}),
            json!([0, 1, 2]),
        ][value as usize % 5]
            .clone(),
        _ => json!(-(value as i64)),
    }
}

/// Applies one edit at the `target`-th value: replace it, delete it from its parent, or
/// duplicate or drop array items.
fn mutate_json(document: &mut Value, target: usize, op: u8, value: u32) {
    let mut all = Vec::new();
    paths(document, &mut Vec::new(), &mut all);
    let path = &all[target % all.len()];
    match op % 4 {
        0 | 1 => *at(document, path) = replacement(op / 4, value),
        2 => {
            if let Some((last, parent)) = path.split_last() {
                match (at(document, parent), last) {
                    (Value::Object(map), Value::String(key)) => {
                        map.remove(key);
                    }
                    (Value::Array(items), index) => {
                        items.remove(index.as_u64().unwrap() as usize);
                    }
                    _ => {}
                }
            }
        }
        _ => {
            if let Value::Array(items) = at(document, path)
                && let Some(item) = items.get(value as usize % items.len().max(1)).cloned()
            {
                items.push(item);
            }
        }
    }
}

fn embedded_json() -> Value {
    serde_json::from_slice(&base_scene().embedded()).unwrap()
}

#[test]
fn the_base_scene_loads_cleanly() {
    let scene = load_gltf_bytes(&base_scene().embedded(), None, Path::new(SOURCE)).unwrap();
    assert!(scene.warnings.is_empty(), "{:?}", scene.warnings);
    assert_eq!(scene.triangle_count(), 2 + 3);
    assert_eq!(scene.materials.textures.len(), 2);
    assert_eq!((scene.cameras.len(), scene.lights.len()), (1, 1));
    check_scene(&scene);
}

#[test]
fn many_single_edits_still_load() {
    // The properties of loaded scenes only bite if mutated documents often still load.
    let tries = 300u32;
    let loaded = (0..tries)
        .filter(|&i| {
            let mut document = embedded_json();
            mutate_json(
                &mut document,
                i as usize * 7919,
                i as u8,
                i.wrapping_mul(2_654_435_761),
            );
            let bytes = serde_json::to_vec(&document).unwrap();
            load_gltf_bytes(&bytes, None, Path::new(SOURCE)).is_ok()
        })
        .count();
    assert!(
        loaded * 4 >= tries as usize,
        "only {loaded} of {tries} loaded"
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1024, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn mutated_json_never_panics(
        edits in prop::collection::vec((any::<usize>(), any::<u8>(), any::<u32>()), 1..6)
    ) {
        let mut document = embedded_json();
        for (target, op, value) in edits {
            mutate_json(&mut document, target, op, value);
        }
        check(&serde_json::to_vec(&document).unwrap());
    }

    #[test]
    fn mutated_glb_bytes_never_panic(
        edits in prop::collection::vec((any::<usize>(), any::<u8>()), 1..8),
        cut in any::<Option<usize>>(),
    ) {
        let mut glb = base_scene().glb();
        for (position, byte) in edits {
            let index = position % glb.len();
            glb[index] = byte;
        }
        if let Some(cut) = cut {
            glb.truncate(cut % (glb.len() + 1));
        }
        check(&glb);
    }

    #[test]
    fn random_bytes_never_panic(
        bytes in prop::collection::vec(any::<u8>(), 0..256),
        glb_magic in any::<bool>(),
    ) {
        let mut bytes = bytes;
        if glb_magic {
            let mut header = b"glTF\x02\0\0\0".to_vec();
            header.extend_from_slice(&(bytes.len() as u32 + 12).to_le_bytes());
            header.extend(bytes);
            bytes = header;
        }
        check(&bytes);
    }

    #[test]
    fn random_accessor_layouts_never_panic(
        accessor in 0usize..8,
        count in prop_oneof![0u64..16, Just(u32::MAX as u64), Just(u64::MAX), 1u64 << 33..1u64 << 40],
        byte_offset in prop_oneof![0u64..64, Just(u32::MAX as u64)],
        stride in prop::option::of(prop_oneof![0u64..40, Just(252u64), Just(u32::MAX as u64)]),
        view_offset in prop::option::of(prop_oneof![0u64..256, Just(u64::MAX / 2)]),
        view_length in prop::option::of(prop_oneof![0u64..256, Just(u64::MAX / 2)]),
        component_type in prop::sample::select(vec![5120u32, 5121, 5122, 5123, 5125, 5126, 1, 5124]),
        kind in prop::sample::select(vec!["SCALAR", "VEC2", "VEC3", "VEC4", "MAT2", "MAT3", "MAT4", "VEC5"]),
        indices in prop::collection::vec(any::<u16>(), 0..12),
        field in 0u8..7,
    ) {
        let mut gltf = base_scene();
        // Fresh indices first, so "random indices" is always one of the edits.
        let quad_indices = gltf.indices_u16(&indices);
        gltf.json["meshes"][0]["primitives"][0]["indices"] = json!(quad_indices);
        let accessors = gltf.json["accessors"].as_array().unwrap().len();
        let index = accessor % accessors;
        let target = &mut gltf.json["accessors"][index];
        match field {
            0 => target["count"] = json!(count),
            1 => target["byteOffset"] = json!(byte_offset),
            2 => target["componentType"] = json!(component_type),
            3 => target["type"] = json!(kind),
            4 => {
                let view = target["bufferView"].as_u64().unwrap_or(0) as usize;
                let view = &mut gltf.json["bufferViews"][view];
                if let Some(stride) = stride { view["byteStride"] = json!(stride); }
                if let Some(offset) = view_offset { view["byteOffset"] = json!(offset); }
                if let Some(length) = view_length { view["byteLength"] = json!(length); }
            }
            5 => {
                if let Some(map) = target.as_object_mut() {
                    map.remove("bufferView");
                }
                target["count"] = json!(count.min(1 << 20));
            }
            _ => target["sparse"] = json!({
                "count": count.min(1 << 20),
                "indices": {"bufferView": 0, "componentType": component_type, "byteOffset": byte_offset},
                "values": {"bufferView": 1}
            }),
        }
        check(&gltf.embedded());
        check(&gltf.glb());
    }
}
