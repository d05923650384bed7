//! Builds small synthetic glTF files for the loader tests, written by hand here rather than by
//! the loader's own code, so the tests check the loader against independent data.

#![allow(dead_code)]

pub mod cli;

use std::path::{Path, PathBuf};

use serde_json::{Value, json};

/// A glTF document under construction: JSON plus one binary buffer.
pub struct GltfBuilder {
    pub json: Value,
    pub bin: Vec<u8>,
}

impl Default for GltfBuilder {
    fn default() -> Self {
        GltfBuilder {
            json: json!({
                "asset": {"version": "2.0"},
                "accessors": [], "bufferViews": [], "meshes": [], "nodes": [], "scenes": []
            }),
            bin: Vec::new(),
        }
    }
}

impl GltfBuilder {
    fn push(&mut self, array: &str, value: Value) -> usize {
        let object = self.json.as_object_mut().expect("root is an object");
        let list = object.entry(array).or_insert_with(|| json!([]));
        let list = list.as_array_mut().expect("an array");
        list.push(value);
        list.len() - 1
    }

    /// Appends bytes as a buffer view (4-byte aligned) and returns its index.
    pub fn view(&mut self, bytes: &[u8]) -> usize {
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.push(
            "bufferViews",
            json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()}),
        )
    }

    /// An accessor over new bytes; `fields` gives type, componentType, count and the rest.
    pub fn accessor(&mut self, bytes: &[u8], mut fields: Value) -> usize {
        let view = self.view(bytes);
        fields["bufferView"] = json!(view);
        self.push("accessors", fields)
    }

    /// A VEC3 float accessor with the min/max glTF requires for POSITION.
    pub fn positions(&mut self, points: &[[f32; 3]]) -> usize {
        let mut min = [f32::INFINITY; 3];
        let mut max = [f32::NEG_INFINITY; 3];
        for p in points {
            for i in 0..3 {
                if p[i].is_finite() {
                    min[i] = min[i].min(p[i]);
                    max[i] = max[i].max(p[i]);
                }
            }
        }
        let bytes: Vec<u8> = points
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        self.accessor(
            &bytes,
            json!({"componentType": 5126, "type": "VEC3", "count": points.len(), "min": min, "max": max}),
        )
    }

    pub fn floats(&mut self, values: &[f32], type_: &str, count: usize) -> usize {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        self.accessor(
            &bytes,
            json!({"componentType": 5126, "type": type_, "count": count}),
        )
    }

    pub fn indices_u16(&mut self, indices: &[u16]) -> usize {
        let bytes: Vec<u8> = indices.iter().flat_map(|v| v.to_le_bytes()).collect();
        self.accessor(
            &bytes,
            json!({"componentType": 5123, "type": "SCALAR", "count": indices.len()}),
        )
    }

    pub fn mesh(&mut self, primitives: Value) -> usize {
        self.push("meshes", json!({"primitives": primitives}))
    }

    pub fn node(&mut self, node: Value) -> usize {
        self.push("nodes", node)
    }

    pub fn material(&mut self, material: Value) -> usize {
        self.push("materials", material)
    }

    pub fn add(&mut self, array: &str, value: Value) -> usize {
        self.push(array, value)
    }

    /// Makes the default scene hold `roots`.
    pub fn scene(&mut self, roots: &[usize]) {
        let scene = self.push("scenes", json!({"nodes": roots}));
        self.json["scene"] = json!(scene);
    }

    /// A mesh node with one triangle primitive: the unit right triangle in the XY plane.
    pub fn triangle_node(&mut self, node: Value) -> usize {
        let positions = self.positions(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        let mesh = self.mesh(json!([{"attributes": {"POSITION": positions}}]));
        let mut node = node;
        node["mesh"] = json!(mesh);
        self.node(node)
    }

    fn json_with_buffer(&self, uri: Option<String>) -> Vec<u8> {
        let mut json = self.json.clone();
        if !self.bin.is_empty() {
            let mut buffer = json!({"byteLength": self.bin.len()});
            if let Some(uri) = uri {
                buffer["uri"] = json!(uri);
            }
            json["buffers"] = json!([buffer]);
        }
        serde_json::to_vec_pretty(&json).expect("serializable")
    }

    /// Writes `<name>.gltf` and `<name>.bin` into `dir`; returns the .gltf path.
    pub fn write(&self, dir: &Path, name: &str) -> PathBuf {
        std::fs::write(dir.join(format!("{name}.bin")), &self.bin).expect("write .bin");
        let path = dir.join(format!("{name}.gltf"));
        std::fs::write(&path, self.json_with_buffer(Some(format!("{name}.bin"))))
            .expect("write .gltf");
        path
    }

    /// The document as .gltf JSON with the buffer embedded as a base64 data URI.
    pub fn embedded(&self) -> Vec<u8> {
        let uri = format!("data:application/octet-stream;base64,{}", base64(&self.bin));
        self.json_with_buffer(Some(uri))
    }

    /// The document as a .glb.
    pub fn glb(&self) -> Vec<u8> {
        let mut json = self.json_with_buffer(None);
        json.resize(json.len().next_multiple_of(4), b' ');
        let mut bin = self.bin.clone();
        bin.resize(bin.len().next_multiple_of(4), 0);
        let length = 12 + 8 + json.len() + 8 + bin.len();
        let mut glb = Vec::new();
        glb.extend_from_slice(b"glTF");
        glb.extend_from_slice(&2u32.to_le_bytes());
        glb.extend_from_slice(&(length as u32).to_le_bytes());
        glb.extend_from_slice(&(json.len() as u32).to_le_bytes());
        glb.extend_from_slice(b"JSON");
        glb.extend_from_slice(&json);
        glb.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        glb.extend_from_slice(b"BIN\0");
        glb.extend_from_slice(&bin);
        glb
    }
}

/// Standard base64 with padding (RFC 4648 §4).
pub fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let word = u32::from(chunk[0]) << 16
            | u32::from(*chunk.get(1).unwrap_or(&0)) << 8
            | u32::from(*chunk.get(2).unwrap_or(&0));
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(ALPHABET[(word >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// A tiny PNG (2×1, opaque RGB) encoded by hand-picked bytes through the image crate.
pub fn png_2x1(left: [u8; 3], right: [u8; 3]) -> Vec<u8> {
    let image =
        image::RgbImage::from_fn(2, 1, |x, _| image::Rgb(if x == 0 { left } else { right }));
    let mut bytes = std::io::Cursor::new(Vec::new());
    image
        .write_to(&mut bytes, image::ImageFormat::Png)
        .expect("encode PNG");
    bytes.into_inner()
}

/// The public sample scenes copied into `tests/data` (with their licences)
/// (see `../shared/README.md`; their READMEs ask that they not be committed into the project).
pub fn sample_scene(relative: &str) -> PathBuf {
    let root = std::env::var_os("REALCAM_SAMPLE_SCENES")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data"));
    let path = root.join(relative);
    assert!(
        path.exists(),
        "sample scene {} not found: the tests read the sample scenes in tests/data (or $REALCAM_SAMPLE_SCENES)",
        path.display()
    );
    path
}

/// The sample scene's JSON, read independently of the loader.
pub fn sample_json(relative: &str) -> Value {
    let text = std::fs::read_to_string(sample_scene(relative)).expect("read sample");
    serde_json::from_str(&text).expect("sample is JSON")
}

/// A square of side `size` (m) facing +z at `centre`, with UVs repeating `uv_repeat` times.
pub fn quad(
    gltf: &mut GltfBuilder,
    centre: [f32; 3],
    size: f32,
    material: usize,
    uv_repeat: f32,
) -> usize {
    let h = size / 2.0;
    let [x, y, z] = centre;
    let positions = gltf.positions(&[
        [x - h, y - h, z],
        [x + h, y - h, z],
        [x + h, y + h, z],
        [x - h, y + h, z],
    ]);
    let normals = gltf.floats(
        &[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0],
        "VEC3",
        4,
    );
    let r = uv_repeat;
    let uvs = gltf.floats(&[0.0, r, r, r, r, 0.0, 0.0, 0.0], "VEC2", 4);
    let indices = gltf.indices_u16(&[0, 1, 2, 0, 2, 3]);
    let mesh = gltf.mesh(json!([{"attributes": {"POSITION": positions, "NORMAL": normals, "TEXCOORD_0": uvs}, "indices": indices, "material": material}]));
    gltf.node(json!({"mesh": mesh}))
}

/// A matte dielectric of base colour `rgb`.
pub fn matte(gltf: &mut GltfBuilder, rgb: [f32; 3]) -> usize {
    gltf.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [rgb[0], rgb[1], rgb[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}))
}

/// A white emitter of `nits` (KHR_materials_emissive_strength).
pub fn emitter(gltf: &mut GltfBuilder, nits: f32) -> usize {
    gltf.material(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0]}, "emissiveFactor": [1.0, 1.0, 1.0], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": nits}}, "extensionsUsed": []}))
}

/// A two-group zoom lens (`.toml`): the gap after surface 2 is 20, 50 or 90 mm at its three
/// positions (published focal lengths 39, 56 and 100 mm; stop 10, 9, 8 mm).
pub const TWO_GROUP_ZOOM: &str = r#"
name = "test-zoom"
surfaces = [
  { radius = 100.0, thickness = 3.0, glass = { n = 1.5 }, diameter = 30.0 },
  { radius = -100.0, thickness = 20.0, diameter = 30.0 },
  { stop = true, thickness = 2.0, diameter = 10.0 },
  { radius = 50.0, thickness = 4.0, glass = { n = 1.5 }, diameter = 24.0 },
  { radius = -50.0, thickness = 40.0, diameter = 24.0 },
]

[zoom]
surfaces = [2]
positions = [
  { focal_length_mm = 39, gaps = [20.0], stop_diameter = 10.0 },
  { focal_length_mm = 56, gaps = [50.0], stop_diameter = 9.0 },
  { focal_length_mm = 100, gaps = [90.0], stop_diameter = 8.0 },
]
"#;

/// The paraxial focal length and back focal length (mm) of [`TWO_GROUP_ZOOM`] with `gap` mm
/// after its first element: a y–nu trace of its four refracting surfaces (curvature, thickness
/// after, index after), written here from the fixture's numbers.
pub fn two_group_zoom_paraxial(gap: f64) -> (f64, f64) {
    let surfaces = [
        (1.0 / 100.0, 3.0, 1.5),
        (-1.0 / 100.0, gap + 2.0, 1.0),
        (1.0 / 50.0, 4.0, 1.5),
        (-1.0 / 50.0, 0.0, 1.0),
    ];
    let (mut y, mut nu, mut n) = (1.0, 0.0, 1.0);
    for (c, t, n_after) in surfaces {
        nu -= y * c * (n_after - n);
        n = n_after;
        y += t * nu / n;
    }
    (-1.0 / nu, -y / nu)
}
