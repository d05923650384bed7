//! The scene: glTF 2.0 content in realcam's world frame.
//!
//! **World frame** = glTF's: right-handed, +Y up, metres. A camera looks down its local −Z with
//! +Y up and +X to the right of the image.
//!
//! **Units of light.** realcam renders in photometric units throughout, so glTF's
//! `KHR_lights_punctual` values are used as they are: radiance in cd/m² (nits), point and spot
//! intensities in candela (cd), directional illuminance in lux (lm/m²). Emissive materials
//! radiate `emissiveFactor × emissive texture × KHR_materials_emissive_strength` nits, and a
//! uniform sky `--env R,G,B` is a radiance in nits.
//!
//! [`LoadedScene`] is what the loader produces; the pipeline's LoadScene stage turns it into
//! entities ([`MeshInstance`], [`PunctualLight`], [`SceneCamera`]) and the [`MaterialLibrary`]
//! resource.

pub mod default_scene;
pub mod gltf_loader;
pub mod texture;

use std::path::PathBuf;
use std::sync::Arc;

use bevy_ecs::component::Component;
use bevy_ecs::resource::Resource;
use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};

pub use gltf_loader::{load_gltf, load_gltf_bytes, referenced_files};
pub use texture::{ColorEncoding, Texture, WrapMode};

/// Triangle geometry of one glTF primitive, in the mesh's local frame.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    /// Per-vertex normals; empty when the file has none (flat shading is used then).
    pub normals: Vec<Vec3>,
    /// Per-vertex tangents with handedness in `w`; empty when absent.
    pub tangents: Vec<Vec4>,
    /// `TEXCOORD_0`; empty when absent.
    pub uvs: Vec<Vec2>,
    pub triangles: Vec<[u32; 3]>,
    /// Index into [`MaterialLibrary::materials`]; `None` means glTF's default material.
    pub material: Option<usize>,
}

/// One placed copy of a mesh: an entity of the scene.
///
/// When `world_from_local` mirrors (negative determinant), the loader gives the instance a copy
/// of the mesh with reversed winding, so world-space geometric normals still face outwards.
#[derive(Component, Clone, Debug)]
pub struct MeshInstance {
    pub mesh: Arc<Mesh>,
    pub world_from_local: Mat4,
    pub node_name: Option<String>,
}

impl MeshInstance {
    /// The matrix taking local normals to world normals: the inverse transpose of
    /// `world_from_local`'s 3×3 part (re-normalise after use; non-uniform scale changes length).
    pub fn normal_from_local(&self) -> Mat3 {
        Mat3::from_mat4(self.world_from_local).inverse().transpose()
    }
}

/// A reference to a texture with the UV set it reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TextureRef {
    pub texture: usize,
    pub tex_coord: u32,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    Opaque,
    /// Cut-out: texels with alpha below the cutoff are holes.
    Mask(f32),
    /// Treated as opaque by the path tracer (no transmission model yet).
    Blend,
}

/// glTF metallic-roughness material. Colours are linear RGB.
#[derive(Clone, Debug)]
pub struct Material {
    pub name: Option<String>,
    pub base_color: Vec4,
    pub base_color_texture: Option<TextureRef>,
    pub metallic: f32,
    pub roughness: f32,
    /// Blue channel = metallic, green = roughness (glTF convention).
    pub metallic_roughness_texture: Option<TextureRef>,
    pub normal_texture: Option<TextureRef>,
    pub normal_scale: f32,
    /// Emitted radiance in nits, strength already applied.
    pub emissive: Vec3,
    pub emissive_texture: Option<TextureRef>,
    pub alpha_mode: AlphaMode,
    pub double_sided: bool,
}

impl Default for Material {
    /// glTF's default material: white, fully metallic, fully rough (spec §3.9.6).
    fn default() -> Self {
        Material {
            name: None,
            base_color: Vec4::ONE,
            base_color_texture: None,
            metallic: 1.0,
            roughness: 1.0,
            metallic_roughness_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            emissive: Vec3::ZERO,
            emissive_texture: None,
            alpha_mode: AlphaMode::Opaque,
            double_sided: false,
        }
    }
}

impl Material {
    /// A matte (Lambertian-like) dielectric of the given linear albedo.
    pub fn matte(albedo: Vec3) -> Self {
        Material {
            base_color: albedo.extend(1.0),
            metallic: 0.0,
            ..Default::default()
        }
    }

    pub fn is_emissive(&self) -> bool {
        self.emissive.max_element() > 0.0
    }

    /// The textures shading reads of this material (the emissive one only where it emits).
    pub fn shaded_textures(&self) -> impl Iterator<Item = TextureRef> {
        let emissive = self.emissive_texture.filter(|_| self.is_emissive());
        [
            self.base_color_texture,
            self.metallic_roughness_texture,
            self.normal_texture,
            emissive,
        ]
        .into_iter()
        .flatten()
    }
}

/// Materials and the textures they read: a resource shared by BVH building and shading.
#[derive(Resource, Clone, Debug, Default)]
pub struct MaterialLibrary {
    pub materials: Vec<Material>,
    pub textures: Vec<Arc<Texture>>,
    /// Used for primitives without a material.
    pub default_material: Material,
}

impl MaterialLibrary {
    pub fn get(&self, index: Option<usize>) -> &Material {
        index
            .and_then(|i| self.materials.get(i))
            .unwrap_or(&self.default_material)
    }
}

/// `KHR_lights_punctual` lights in world space, photometric units (see the module docs).
#[derive(Component, Clone, Debug, PartialEq)]
pub enum PunctualLight {
    Point {
        position: Vec3,
        intensity: Vec3,
        range: Option<f32>,
    },
    Spot {
        position: Vec3,
        /// Unit direction the spot points along (the node's −Z).
        direction: Vec3,
        intensity: Vec3,
        range: Option<f32>,
        inner_cone_angle: f32,
        outer_cone_angle: f32,
    },
    /// `direction` is the unit direction the light travels (the node's −Z).
    Directional { direction: Vec3, illuminance: Vec3 },
}

/// Optional realcam settings stored in a glTF camera's `extras.realcam` object, so a scene can
/// carry the lens set-up it was made for (the bundled default scene does). CLI flags win.
#[derive(Clone, Debug, Default, PartialEq, serde::Deserialize)]
#[serde(default)]
pub struct CameraHints {
    pub lens: Option<String>,
    pub film_diagonal_mm: Option<f64>,
    pub film_distance_mm: Option<f64>,
    pub focus_distance_m: Option<f64>,
    pub aperture_mm: Option<f64>,
    pub width: Option<u32>,
    pub height: Option<u32>,
}

/// A glTF camera node. `world_from_camera` is rigid (scale removed): the camera looks down its
/// local −Z with +Y up.
#[derive(Component, Clone, Debug)]
pub struct SceneCamera {
    pub name: Option<String>,
    pub index: usize,
    pub world_from_camera: Mat4,
    /// Vertical field of view of a perspective camera, radians.
    pub yfov: Option<f32>,
    pub aspect_ratio: Option<f32>,
    pub hints: CameraHints,
}

/// Rigid world-from-camera transform of a camera at `eye` looking at `target` (glTF camera
/// convention: it looks down its local −Z with +Y up). `up` must not be parallel to the view.
pub fn look_at(eye: Vec3, target: Vec3, up: Vec3) -> Mat4 {
    let back = (eye - target).normalize();
    let right = up.cross(back).normalize();
    let true_up = back.cross(right);
    Mat4::from_cols(
        right.extend(0.0),
        true_up.extend(0.0),
        back.extend(0.0),
        eye.extend(1.0),
    )
}

/// Axis-aligned bounds in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub min: Vec3,
    pub max: Vec3,
}

impl Default for Bounds {
    fn default() -> Self {
        Bounds::EMPTY
    }
}

impl Bounds {
    pub const EMPTY: Bounds = Bounds {
        min: Vec3::INFINITY,
        max: Vec3::NEG_INFINITY,
    };

    pub fn include(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    pub fn diagonal(&self) -> f32 {
        (self.max - self.min).length()
    }
}

/// Everything read from one glTF file.
#[derive(Clone, Debug, Default)]
pub struct LoadedScene {
    pub source: PathBuf,
    pub meshes: Vec<Arc<Mesh>>,
    pub instances: Vec<MeshInstance>,
    pub materials: MaterialLibrary,
    pub lights: Vec<PunctualLight>,
    pub cameras: Vec<SceneCamera>,
    /// World-space bounds of all instanced triangles.
    pub bounds: Bounds,
    /// Problems that did not stop loading (missing texture, skipped point primitives, …).
    pub warnings: Vec<String>,
    /// The files the scene was read from: the glTF itself and the external buffers and images
    /// it names (read or not), so that no output overwrites them.
    pub inputs: Vec<PathBuf>,
}

impl LoadedScene {
    pub fn triangle_count(&self) -> usize {
        self.instances.iter().map(|i| i.mesh.triangles.len()).sum()
    }
}
