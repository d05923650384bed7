//! The bundled default scene: "dof dragons" from the Stanford CS348b course, rebuilt in glTF
//! metres. A row of eleven cones (standing in for the dragons) on a gridded ground plane, lit by
//! a large emissive disk overhead, seen by a camera looking along the row so that a real lens
//! shows depth of field.
//!
//! The scene is generated here, deterministically, and committed as `assets/dof-dragons.glb`
//! (`cargo run --release --bin make-default-scene` rewrites it); a test checks that the file
//! and the generator agree byte for byte.

use std::path::Path;

use glam::{Mat3, Quat, Vec2, Vec3};
use gltf::json::{self, Index, validation::Checked, validation::USize64};

use crate::scene::texture::{linear_to_srgb, srgb_to_linear};
use crate::scene::{LoadedScene, load_gltf_bytes};

/// Where the generated scene is committed, relative to the crate root.
pub const DEFAULT_SCENE_PATH: &str = "assets/dof-dragons.glb";

/// The committed default scene, built into the binary.
pub const DEFAULT_SCENE_GLB: &[u8] = include_bytes!("../../assets/dof-dragons.glb");

/// Loads the built-in default scene.
pub fn load_default_scene() -> anyhow::Result<LoadedScene> {
    load_gltf_bytes(DEFAULT_SCENE_GLB, None, Path::new(DEFAULT_SCENE_PATH))
}

// The scene's facts. Lengths in metres unless the name says otherwise.
const GROUND_SIZE: f32 = 40.0;
const GRID_SPACING: f32 = 0.5;
/// Pixels per grid cell of the ground texture, and how many of them each line takes on each
/// side of a cell border (so lines are 2 × 2 / 64 × 0.5 m ≈ 3 cm wide).
const GRID_TEXTURE_SIZE: u32 = 64;
const GRID_LINE_HALF_WIDTH_PX: u32 = 2;
/// Linear albedo of the grid lines; the cells are chosen so the mean albedo is this target.
const GRID_LINE_ALBEDO: f32 = 0.15;
const GROUND_MEAN_ALBEDO: f32 = 0.5;

const CONE_COUNT: usize = 11;
const CONE_RADIUS: f32 = 0.25;
const CONE_HEIGHT: f32 = 0.75;
const FIRST_CONE_X: f64 = -3.0;
const CONE_SPACING: f64 = 1.3;
const CONE_SEGMENTS: u32 = 128;
/// Linear base colours: even cones blue, odd cones red.
const BLUE: [f32; 3] = [0.2, 0.2, 0.5];
const RED: [f32; 3] = [0.8, 0.2, 0.2];

const SKY_LIGHT_RADIUS: f32 = 40.0;
const SKY_LIGHT_HEIGHT: f32 = 50.0;
const SKY_LIGHT_SEGMENTS: u32 = 128;
/// Emitted radiance of the sky light, nits.
const SKY_LIGHT_EMISSION: [f32; 3] = [1.0, 1.0, 1.0];

const CAMERA_POSITION: [f32; 3] = [11.5, 0.25, 2.5];
const CAMERA_LOOK: [f32; 3] = [-0.787, -0.052, -0.615];
const LENS: &str = "dgauss.50mm";
/// Square film: its diagonal and its distance behind the lens set the field of view.
const FILM_DIAGONAL_MM: f64 = 70.0;
const FILM_DISTANCE_MM: f64 = 36.77;
const APERTURE_MM: f64 = 17.1;
const CAMERA_ZNEAR: f32 = 0.01;

/// The whole default scene as one self-contained `.glb`, identical on every run.
pub fn build_default_scene_glb() -> Vec<u8> {
    let mut scene = GlbWriter::default();
    let grid = scene.grid_texture();

    let ground_material = scene.material("Ground grid", [1.0; 3], Some(grid), [0.0; 3]);
    let ground = scene.mesh("Ground", &ground_quad(), &[ground_material]);
    let mut nodes = vec![scene.node("Ground", Some(ground[0]), [0.0; 3], None, None)];

    let blue = scene.material("Matte blue", BLUE, None, [0.0; 3]);
    let red = scene.material("Matte red", RED, None, [0.0; 3]);
    // One geometry, two meshes: glTF binds materials to primitives.
    let cones = scene.mesh("Cone", &cone(), &[blue, red]);
    for k in 0..CONE_COUNT {
        // In f64, so the stored f32 is the nearest to the decimal position (−0.4, not −0.4000001).
        let x = (FIRST_CONE_X + CONE_SPACING * k as f64) as f32;
        let name = format!("Cone {k}");
        nodes.push(scene.node(&name, Some(cones[k % 2]), [x, 0.0, 0.0], None, None));
    }

    let light_material = scene.material("Sky light", [0.0; 3], None, SKY_LIGHT_EMISSION);
    let light = scene.mesh("Sky light", &disk_facing_down(), &[light_material]);
    nodes.push(scene.node(
        "Sky light",
        Some(light[0]),
        [0.0, SKY_LIGHT_HEIGHT, 0.0],
        None,
        None,
    ));

    let camera = scene.camera();
    let rotation = look_rotation(Vec3::from(CAMERA_LOOK), Vec3::Y);
    nodes.push(scene.node(
        "Camera",
        None,
        CAMERA_POSITION,
        Some(rotation),
        Some(camera),
    ));

    scene.finish(nodes)
}

/// Triangle geometry in a mesh's local frame.
struct Geometry {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uvs: Option<Vec<Vec2>>,
    triangles: Vec<[u32; 3]>,
}

/// The ground: a square in the y = 0 plane facing +Y, with one UV unit per grid cell.
fn ground_quad() -> Geometry {
    let half = GROUND_SIZE / 2.0;
    let positions = [[-half, -half], [-half, half], [half, half], [half, -half]]
        .map(|[x, z]| Vec3::new(x, 0.0, z));
    Geometry {
        uvs: Some(
            positions
                .iter()
                .map(|p| Vec2::new(p.x + half, p.z + half) / GRID_SPACING)
                .collect(),
        ),
        normals: vec![Vec3::Y; 4],
        positions: positions.to_vec(),
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    }
}

/// `segments` points on a circle of `radius` in the y = 0 plane with their angles, starting
/// at +X (shifted by `offset` segments) and turning towards +Z. The trigonometry runs in f64
/// and is rounded once, so the f32 bytes do not depend on the platform's f32 `sin`/`cos`.
fn circle(radius: f32, segments: u32, offset: f64) -> impl Iterator<Item = (f64, Vec3)> {
    (0..segments).map(move |i| {
        let angle = std::f64::consts::TAU * (f64::from(i) + offset) / f64::from(segments);
        let (sin, cos) = angle.sin_cos();
        (
            angle,
            Vec3::new(
                (f64::from(radius) * cos) as f32,
                0.0,
                (f64::from(radius) * sin) as f32,
            ),
        )
    })
}

/// An upright cone on the y = 0 plane: smooth sides (one apex vertex per segment, carrying the
/// normal of that segment's middle) and a flat base disk facing −Y.
fn cone() -> Geometry {
    let n = CONE_SEGMENTS;
    let slant = f64::from(CONE_HEIGHT).hypot(f64::from(CONE_RADIUS));
    // The side normal at angle φ tilts up by the cone's half-angle.
    let side_normal = |angle: f64| {
        let (sin, cos) = angle.sin_cos();
        let (h, r) = (f64::from(CONE_HEIGHT), f64::from(CONE_RADIUS));
        Vec3::new(
            (h * cos / slant) as f32,
            (r / slant) as f32,
            (h * sin / slant) as f32,
        )
    };
    let apex = Vec3::new(0.0, CONE_HEIGHT, 0.0);
    let mut geometry = Geometry {
        positions: Vec::new(),
        normals: Vec::new(),
        uvs: None,
        triangles: Vec::new(),
    };
    // Side: rim vertices 0..n, apex vertices n..2n.
    for (angle, point) in circle(CONE_RADIUS, n, 0.0) {
        geometry.positions.push(point);
        geometry.normals.push(side_normal(angle));
    }
    for (angle, _) in circle(CONE_RADIUS, n, 0.5) {
        geometry.positions.push(apex);
        geometry.normals.push(side_normal(angle));
    }
    for i in 0..n {
        geometry.triangles.push([i, n + i, (i + 1) % n]);
    }
    // Base: centre 2n, rim 2n+1..3n+1, flat.
    let base = geometry.positions.len() as u32;
    geometry.positions.push(Vec3::ZERO);
    geometry
        .positions
        .extend(circle(CONE_RADIUS, n, 0.0).map(|(_, point)| point));
    geometry
        .normals
        .resize(geometry.positions.len(), Vec3::NEG_Y);
    for i in 0..n {
        geometry
            .triangles
            .push([base, base + 1 + i, base + 1 + (i + 1) % n]);
    }
    geometry
}

/// A flat disk in the y = 0 plane facing −Y.
fn disk_facing_down() -> Geometry {
    let n = SKY_LIGHT_SEGMENTS;
    let mut positions = vec![Vec3::ZERO];
    positions.extend(circle(SKY_LIGHT_RADIUS, n, 0.0).map(|(_, point)| point));
    Geometry {
        normals: vec![Vec3::NEG_Y; positions.len()],
        positions,
        uvs: None,
        triangles: (0..n).map(|i| [0, 1 + i, 1 + (i + 1) % n]).collect(),
    }
}

/// The rotation taking a glTF camera's −Z to `look` and its +Y as close to `up` as possible.
fn look_rotation(look: Vec3, up: Vec3) -> [f32; 4] {
    let back = -look.normalize();
    let right = up.cross(back).normalize();
    let true_up = back.cross(right);
    Quat::from_mat3(&Mat3::from_cols(right, true_up, back))
        .normalize()
        .to_array()
}

/// Vertical field of view of the square film seen from the film distance, radians.
fn film_yfov() -> f32 {
    let half_height = FILM_DIAGONAL_MM / 2f64.sqrt() / 2.0;
    (2.0 * (half_height / FILM_DISTANCE_MM).atan()) as f32
}

/// The ground texture: light cells with darker grey border lines, one cell per texture.
/// Stored as 8-bit sRGB grey; the cell value is the one whose decoded mean is closest to
/// [`GROUND_MEAN_ALBEDO`].
fn grid_texture_png() -> Vec<u8> {
    let size = GRID_TEXTURE_SIZE;
    let on_line = |i: u32| i < GRID_LINE_HALF_WIDTH_PX || i >= size - GRID_LINE_HALF_WIDTH_PX;
    let line_count = (0..size * size)
        .filter(|&i| on_line(i % size) || on_line(i / size))
        .count();
    let line_fraction = line_count as f32 / (size * size) as f32;
    let encode = |linear: f32| (linear_to_srgb(linear) * 255.0).round() as u8;
    let decode = |byte: u8| srgb_to_linear(f32::from(byte) / 255.0);
    let line = encode(GRID_LINE_ALBEDO);
    let mean = |cell: u8| decode(cell) * (1.0 - line_fraction) + decode(line) * line_fraction;
    let cell = (0..=255u8)
        .min_by(|&a, &b| {
            let error = |cell| (mean(cell) - GROUND_MEAN_ALBEDO).abs();
            error(a).total_cmp(&error(b))
        })
        .unwrap_or(u8::MAX);
    let image = image::GrayImage::from_fn(size, size, |x, y| {
        image::Luma([if on_line(x) || on_line(y) { line } else { cell }])
    });
    let mut png = Vec::new();
    image
        .write_with_encoder(image::codecs::png::PngEncoder::new(&mut png))
        .expect("encoding a small in-memory PNG cannot fail");
    png
}

/// Accumulates the glTF JSON and its binary chunk.
#[derive(Default)]
struct GlbWriter {
    root: json::Root,
    bin: Vec<u8>,
}

impl GlbWriter {
    /// Appends bytes as a buffer view, 4-byte aligned as glTF requires.
    fn view(
        &mut self,
        bytes: &[u8],
        target: Option<json::buffer::Target>,
    ) -> Index<json::buffer::View> {
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        let view = json::buffer::View {
            buffer: Index::new(0),
            byte_length: USize64::from(bytes.len()),
            byte_offset: Some(USize64::from(self.bin.len())),
            byte_stride: None,
            name: None,
            target: target.map(Checked::Valid),
            extensions: None,
            extras: None,
        };
        self.bin.extend_from_slice(bytes);
        self.root.push(view)
    }

    fn accessor(
        &mut self,
        bytes: &[u8],
        count: usize,
        component_type: json::accessor::ComponentType,
        type_: json::accessor::Type,
        bounds: Option<(Vec3, Vec3)>,
    ) -> Index<json::Accessor> {
        let target = if type_ == json::accessor::Type::Scalar {
            json::buffer::Target::ElementArrayBuffer
        } else {
            json::buffer::Target::ArrayBuffer
        };
        let view = self.view(bytes, Some(target));
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(count),
            component_type: Checked::Valid(json::accessor::GenericComponentType(component_type)),
            extensions: None,
            extras: None,
            type_: Checked::Valid(type_),
            min: bounds.map(|(min, _)| json::Value::from(min.to_array().to_vec())),
            max: bounds.map(|(_, max)| json::Value::from(max.to_array().to_vec())),
            name: None,
            normalized: false,
            sparse: None,
        })
    }

    fn floats<const N: usize>(
        &mut self,
        values: &[[f32; N]],
        bounds: Option<(Vec3, Vec3)>,
    ) -> Index<json::Accessor> {
        let bytes: Vec<u8> = values
            .iter()
            .flatten()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let type_ = match N {
            2 => json::accessor::Type::Vec2,
            3 => json::accessor::Type::Vec3,
            _ => json::accessor::Type::Vec4,
        };
        self.accessor(
            &bytes,
            values.len(),
            json::accessor::ComponentType::F32,
            type_,
            bounds,
        )
    }

    /// One mesh per material, all sharing the geometry's accessors.
    fn mesh(
        &mut self,
        name: &str,
        geometry: &Geometry,
        materials: &[Index<json::Material>],
    ) -> Vec<Index<json::Mesh>> {
        let positions: Vec<[f32; 3]> = geometry.positions.iter().map(|p| p.to_array()).collect();
        let min = geometry
            .positions
            .iter()
            .fold(Vec3::INFINITY, |a, &b| a.min(b));
        let max = geometry
            .positions
            .iter()
            .fold(Vec3::NEG_INFINITY, |a, &b| a.max(b));
        let mut attributes = std::collections::BTreeMap::new();
        attributes.insert(
            Checked::Valid(json::mesh::Semantic::Positions),
            self.floats(&positions, Some((min, max))),
        );
        let normals: Vec<[f32; 3]> = geometry.normals.iter().map(|n| n.to_array()).collect();
        attributes.insert(
            Checked::Valid(json::mesh::Semantic::Normals),
            self.floats(&normals, None),
        );
        if let Some(uvs) = &geometry.uvs {
            let uvs: Vec<[f32; 2]> = uvs.iter().map(|uv| uv.to_array()).collect();
            attributes.insert(
                Checked::Valid(json::mesh::Semantic::TexCoords(0)),
                self.floats(&uvs, None),
            );
        }
        let indices: Vec<u8> = geometry
            .triangles
            .iter()
            .flatten()
            .flat_map(|i| i.to_le_bytes())
            .collect();
        let indices = self.accessor(
            &indices,
            geometry.triangles.len() * 3,
            json::accessor::ComponentType::U32,
            json::accessor::Type::Scalar,
            None,
        );
        materials
            .iter()
            .map(|&material| {
                let material_name = self.root.materials[material.value()]
                    .name
                    .clone()
                    .unwrap_or_default();
                let name = if materials.len() > 1 {
                    format!("{name} ({material_name})")
                } else {
                    name.to_string()
                };
                self.root.push(json::Mesh {
                    extensions: None,
                    extras: None,
                    name: Some(name),
                    primitives: vec![json::mesh::Primitive {
                        attributes: attributes.clone(),
                        extensions: None,
                        extras: None,
                        indices: Some(indices),
                        material: Some(material),
                        mode: Checked::Valid(json::mesh::Mode::Triangles),
                        targets: None,
                    }],
                    weights: None,
                })
            })
            .collect()
    }

    /// A matte (metallic 0, roughness 1) material.
    fn material(
        &mut self,
        name: &str,
        base_color: [f32; 3],
        base_color_texture: Option<Index<json::Texture>>,
        emissive: [f32; 3],
    ) -> Index<json::Material> {
        self.root.push(json::Material {
            name: Some(name.to_string()),
            pbr_metallic_roughness: json::material::PbrMetallicRoughness {
                base_color_factor: json::material::PbrBaseColorFactor([
                    base_color[0],
                    base_color[1],
                    base_color[2],
                    1.0,
                ]),
                base_color_texture: base_color_texture.map(|index| json::texture::Info {
                    index,
                    tex_coord: 0,
                    extensions: None,
                    extras: None,
                }),
                metallic_factor: json::material::StrengthFactor(0.0),
                roughness_factor: json::material::StrengthFactor(1.0),
                ..Default::default()
            },
            emissive_factor: json::material::EmissiveFactor(emissive),
            ..Default::default()
        })
    }

    /// The ground's grid texture, embedded as PNG and repeated across the plane.
    fn grid_texture(&mut self) -> Index<json::Texture> {
        let png = grid_texture_png();
        let view = self.view(&png, None);
        let image = self.root.push(json::Image {
            buffer_view: Some(view),
            mime_type: Some(json::image::MimeType("image/png".to_string())),
            name: Some("Grid".to_string()),
            uri: None,
            extensions: None,
            extras: None,
        });
        let sampler = self.root.push(json::texture::Sampler {
            mag_filter: Some(Checked::Valid(json::texture::MagFilter::Linear)),
            min_filter: Some(Checked::Valid(json::texture::MinFilter::LinearMipmapLinear)),
            wrap_s: Checked::Valid(json::texture::WrappingMode::Repeat),
            wrap_t: Checked::Valid(json::texture::WrappingMode::Repeat),
            ..Default::default()
        });
        self.root.push(json::Texture {
            name: Some("Grid".to_string()),
            sampler: Some(sampler),
            source: image,
            extensions: None,
            extras: None,
        })
    }

    /// The perspective camera, carrying realcam's lens set-up in `extras.realcam`.
    fn camera(&mut self) -> Index<json::Camera> {
        let hints = serde_json::json!({
            "realcam": {
                "lens": LENS,
                "film_diagonal_mm": FILM_DIAGONAL_MM,
                "film_distance_mm": FILM_DISTANCE_MM,
                "aperture_mm": APERTURE_MM,
            }
        });
        let extras = json::extras::RawValue::from_string(hints.to_string())
            .expect("serde_json output is valid JSON");
        self.root.push(json::Camera {
            name: Some(format!("{LENS} camera")),
            orthographic: None,
            perspective: Some(json::camera::Perspective {
                aspect_ratio: Some(1.0),
                yfov: film_yfov(),
                zfar: None,
                znear: CAMERA_ZNEAR,
                extensions: None,
                extras: None,
            }),
            type_: Checked::Valid(json::camera::Type::Perspective),
            extensions: None,
            extras: Some(extras),
        })
    }

    fn node(
        &mut self,
        name: &str,
        mesh: Option<Index<json::Mesh>>,
        translation: [f32; 3],
        rotation: Option<[f32; 4]>,
        camera: Option<Index<json::Camera>>,
    ) -> Index<json::Node> {
        self.root.push(json::Node {
            name: Some(name.to_string()),
            mesh,
            camera,
            translation: (translation != [0.0; 3]).then_some(translation),
            rotation: rotation.map(json::scene::UnitQuaternion),
            ..Default::default()
        })
    }

    fn finish(mut self, nodes: Vec<Index<json::Node>>) -> Vec<u8> {
        let scene = self.root.push(json::Scene {
            extensions: None,
            extras: None,
            name: Some("dof dragons".to_string()),
            nodes,
        });
        self.root.scene = Some(scene);
        self.root.asset.generator = Some("realcam src/scene/default_scene.rs".to_string());
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        self.root.push(json::Buffer {
            byte_length: USize64::from(self.bin.len()),
            name: None,
            uri: None,
            extensions: None,
            extras: None,
        });
        let json = json::serialize::to_vec(&self.root).expect("the glTF JSON serializes");
        let glb = gltf::binary::Glb {
            header: gltf::binary::Header {
                magic: *b"glTF",
                version: 2,
                length: 0,
            },
            json: json.into(),
            bin: Some(self.bin.into()),
        };
        glb.to_vec().expect("writing a GLB to memory cannot fail")
    }
}
