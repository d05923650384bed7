//! The node hierarchy: world transforms of mesh instances, cameras and punctual lights.

use anyhow::{Result, bail};
use glam::{Mat4, Quat, Vec3};
use gltf::json::Root;
use gltf::json::extensions::scene::khr_lights_punctual::{Light, Type as LightType};
use gltf::json::validation::Checked;
use serde::Deserialize;

use super::{MAX_NODE_DEPTH, MAX_NODE_VISITS};
use crate::film::MAX_IMAGE_SIDE;
use crate::scene::{CameraHints, PunctualLight, SceneCamera};
use crate::units::MAX_LENGTH_MM;

/// A mesh placed by a node.
pub(super) struct MeshPlacement {
    pub mesh: usize,
    pub world_from_local: Mat4,
    pub node_name: Option<String>,
}

/// What the nodes of a scene place in the world.
#[derive(Default)]
pub(super) struct SceneContents {
    pub meshes: Vec<MeshPlacement>,
    pub cameras: Vec<SceneCamera>,
    pub lights: Vec<PunctualLight>,
}

/// Walks the node trees of scene `scene`, depth first in file order.
pub(super) fn walk_scene(
    root: &Root,
    scene: usize,
    warnings: &mut Vec<String>,
) -> Result<SceneContents> {
    let Some(json) = root.scenes.get(scene) else {
        bail!("scene {scene} does not exist");
    };
    let mut walker = Walker {
        root,
        warnings,
        on_path: vec![false; root.nodes.len()],
        visits: 0,
        contents: SceneContents::default(),
    };
    for node in &json.nodes {
        walker.visit(node.value(), Mat4::IDENTITY, 0)?;
    }
    Ok(walker.contents)
}

struct Walker<'a> {
    root: &'a Root,
    warnings: &'a mut Vec<String>,
    /// Nodes on the path from the scene root to the current node: meeting one again is a cycle.
    on_path: Vec<bool>,
    visits: usize,
    contents: SceneContents,
}

impl Walker<'_> {
    fn visit(&mut self, node: usize, parent_world: Mat4, depth: usize) -> Result<()> {
        let Some(json) = self.root.nodes.get(node) else {
            bail!("node {node} does not exist");
        };
        if self.on_path[node] {
            bail!(
                "node {node} is its own ancestor (a cycle in the node hierarchy); the file is corrupt"
            );
        }
        if depth >= MAX_NODE_DEPTH {
            bail!(
                "the node hierarchy is more than {MAX_NODE_DEPTH} levels deep at node {node}; the file is corrupt"
            );
        }
        self.visits += 1;
        if self.visits > MAX_NODE_VISITS {
            bail!(
                "the scene places more than {MAX_NODE_VISITS} nodes (nodes shared by many parents?); realcam refuses scenes this large"
            );
        }
        let label = node_label(node, json.name.as_deref());
        let world = parent_world * local_transform(json);
        if !world.is_finite() {
            self.warnings.push(format!(
                "{label} has a non-finite transform; it and its children are skipped"
            ));
            return Ok(());
        }
        if json.skin.is_some() {
            self.warnings.push(format!(
                "{label}: skinning ignored; the mesh is rendered unposed"
            ));
        }
        if let Some(mesh) = json.mesh {
            self.contents.meshes.push(MeshPlacement {
                mesh: mesh.value(),
                world_from_local: world,
                node_name: json.name.clone(),
            });
        }
        if let Some(camera) = json.camera {
            self.add_camera(json, camera.value(), world, &label);
        }
        let light = json
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref());
        if let Some(light) = light {
            self.add_light(light.light.value(), world, &label);
        }

        self.on_path[node] = true;
        for child in json.children.iter().flatten() {
            self.visit(child.value(), world, depth + 1)?;
        }
        self.on_path[node] = false;
        Ok(())
    }

    fn add_camera(&mut self, node: &gltf::json::Node, camera: usize, world: Mat4, label: &str) {
        let Some(json) = self.root.cameras.get(camera) else {
            self.warnings
                .push(format!("{label}: camera {camera} does not exist; ignored"));
            return;
        };
        let Some(world_from_camera) = rigid_frame(world) else {
            self.warnings.push(format!(
                "{label}: the camera's transform is degenerate (zero scale); camera ignored"
            ));
            return;
        };
        if json.perspective.is_none() {
            self.warnings.push(format!(
                "{label}: orthographic camera; its projection is ignored (realcam renders through a lens)"
            ));
        }
        let hints = camera_hints(
            &[
                (&json.extras, "the camera's extras"),
                (&node.extras, "the camera node's extras"),
            ],
            label,
            self.warnings,
        );
        self.contents.cameras.push(SceneCamera {
            name: node.name.clone().or_else(|| json.name.clone()),
            index: self.contents.cameras.len(),
            world_from_camera,
            yfov: json.perspective.as_ref().map(|p| p.yfov),
            aspect_ratio: json.perspective.as_ref().and_then(|p| p.aspect_ratio),
            hints,
        });
    }

    fn add_light(&mut self, light: usize, world: Mat4, label: &str) {
        let lights = self
            .root
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref());
        let Some(json) = lights.and_then(|lights| lights.lights.get(light)) else {
            self.warnings
                .push(format!("{label}: light {light} does not exist; ignored"));
            return;
        };
        match punctual_light(json, world) {
            Some(light) => self.contents.lights.push(light),
            None => self.warnings.push(format!(
                "{label}: light {light} has an invalid type or a degenerate direction; ignored"
            )),
        }
    }
}

fn node_label(node: usize, name: Option<&str>) -> String {
    match name {
        Some(name) => format!("node {node} ('{name}')"),
        None => format!("node {node}"),
    }
}

/// A node's transform relative to its parent: `matrix` (column-major) or T × R × S.
fn local_transform(node: &gltf::json::Node) -> Mat4 {
    if let Some(matrix) = &node.matrix {
        return Mat4::from_cols_array(matrix);
    }
    let translation = node.translation.map_or(Vec3::ZERO, Vec3::from);
    // Exporters often write quaternions a little off unit length; zero gives NaN, which the
    // caller reports as a non-finite transform.
    let rotation = node
        .rotation
        .map_or(Quat::IDENTITY, |r| Quat::from_array(r.0).normalize());
    let scale = node.scale.map_or(Vec3::ONE, Vec3::from);
    Mat4::from_scale_rotation_translation(scale, rotation, translation)
}

/// `world` without scale or shear: the same position, forward (−Z) axis and, as far as it is
/// orthogonal to forward, up (+Y) axis. `None` if those axes are degenerate.
fn rigid_frame(world: Mat4) -> Option<Mat4> {
    let back = world.z_axis.truncate().try_normalize()?;
    let right = world.y_axis.truncate().cross(back).try_normalize()?;
    let up = back.cross(right);
    Some(Mat4::from_cols(
        right.extend(0.0),
        up.extend(0.0),
        back.extend(0.0),
        world.w_axis,
    ))
}

/// The first `extras.realcam` object among `sources`; a malformed one is ignored with a warning.
fn camera_hints(
    sources: &[(&gltf::json::Extras, &str)],
    label: &str,
    warnings: &mut Vec<String>,
) -> CameraHints {
    for (extras, what) in sources {
        let Some(raw) = extras else { continue };
        let Ok(value) = serde_json::from_str::<serde_json::Value>(raw.get()) else {
            continue;
        };
        let Some(realcam) = value.get("realcam") else {
            continue;
        };
        return match CameraHints::deserialize(realcam) {
            Ok(hints) => usable_hints(hints, &format!("{label}: \"realcam\" in {what}"), warnings),
            Err(error) => {
                warnings.push(format!(
                    "{label}: \"realcam\" in {what} is malformed ({error}); ignored. Expected an object like {{\"lens\": \"dgauss.50mm\", \"film_diagonal_mm\": 35.0}}"
                ));
                CameraHints::default()
            }
        };
    }
    CameraHints::default()
}

/// `hints` without the values no flag would accept, each dropped with a warning: a file's
/// hint is checked like the flag it stands in for (a 100 000 × 100 000 hint would otherwise
/// exhaust memory, a negative film distance fail with a message about a flag never given).
fn usable_hints(mut hints: CameraHints, source: &str, warnings: &mut Vec<String>) -> CameraHints {
    let lengths = [
        (
            "film_diagonal_mm",
            &mut hints.film_diagonal_mm,
            MAX_LENGTH_MM,
        ),
        (
            "film_distance_mm",
            &mut hints.film_distance_mm,
            MAX_LENGTH_MM,
        ),
        ("aperture_mm", &mut hints.aperture_mm, MAX_LENGTH_MM),
        ("focus_distance_m", &mut hints.focus_distance_m, f64::MAX),
    ];
    for (name, hint, max) in lengths {
        if let Some(value) = *hint
            && !(value > 0.0 && value <= max)
        {
            warnings.push(format!(
                "{source}: {name} {value} ignored; it must be positive and at most {max:e}"
            ));
            *hint = None;
        }
    }
    for (name, hint) in [("width", &mut hints.width), ("height", &mut hints.height)] {
        if let Some(value) = *hint
            && !(1..=MAX_IMAGE_SIDE).contains(&value)
        {
            warnings.push(format!(
                "{source}: {name} {value} ignored; it must be between 1 and {MAX_IMAGE_SIDE} pixels"
            ));
            *hint = None;
        }
    }
    hints
}

/// A `KHR_lights_punctual` light placed by `world`: it sits at the node's origin and shines
/// along the node's −Z. Intensity is colour × intensity in the extension's units.
fn punctual_light(json: &Light, world: Mat4) -> Option<PunctualLight> {
    let intensity = Vec3::from(json.color) * json.intensity;
    let position = world.w_axis.truncate();
    let direction = || world.transform_vector3(Vec3::NEG_Z).try_normalize();
    Some(match json.type_ {
        Checked::Valid(LightType::Point) => PunctualLight::Point {
            position,
            intensity,
            range: json.range,
        },
        Checked::Valid(LightType::Spot) => {
            // The extension's defaults when `spot` leaves a field out.
            let (inner_cone_angle, outer_cone_angle) = json
                .spot
                .as_ref()
                .map_or((0.0, std::f32::consts::FRAC_PI_4), |spot| {
                    (spot.inner_cone_angle, spot.outer_cone_angle)
                });
            PunctualLight::Spot {
                position,
                direction: direction()?,
                intensity,
                range: json.range,
                inner_cone_angle,
                outer_cone_angle,
            }
        }
        Checked::Valid(LightType::Directional) => PunctualLight::Directional {
            direction: direction()?,
            illuminance: intensity,
        },
        Checked::Invalid => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    #[test]
    fn rigid_frame_removes_scale_and_keeps_orientation() {
        let rotation = Quat::from_rotation_y(0.7) * Quat::from_rotation_x(-0.3);
        let translation = Vec3::new(1.0, 2.0, 3.0);
        let scaled =
            Mat4::from_scale_rotation_translation(Vec3::new(2.0, 0.5, 3.0), rotation, translation);
        let rigid = rigid_frame(scaled).unwrap();
        let expected = Mat4::from_rotation_translation(rotation, translation);
        for (a, b) in rigid.to_cols_array().iter().zip(expected.to_cols_array()) {
            assert_relative_eq!(*a, b, epsilon = 1e-5);
        }
        assert!(rigid_frame(Mat4::from_scale(Vec3::new(1.0, 1.0, 0.0))).is_none());
    }

    #[test]
    fn unusable_hint_values_are_dropped_with_a_warning() {
        let raw = serde_json::value::RawValue::from_string(
            r#"{"realcam": {"lens": "wide.22mm", "width": 100000, "height": 0, "film_diagonal_mm": -5, "aperture_mm": 1e308, "focus_distance_m": 2.5}}"#.into(),
        )
        .unwrap();
        let extras: gltf::json::Extras = Some(raw);
        let mut warnings = Vec::new();
        let hints = camera_hints(&[(&extras, "extras")], "node 3", &mut warnings);
        assert_eq!(
            hints,
            CameraHints {
                lens: Some("wide.22mm".into()),
                focus_distance_m: Some(2.5),
                ..CameraHints::default()
            }
        );
        assert_eq!(warnings.len(), 4, "{warnings:?}");
        assert!(
            warnings
                .iter()
                .all(|w| w.starts_with("node 3: \"realcam\" in extras: "))
        );
        assert!(warnings.iter().any(|w| w.contains("width 100000 ignored")));
    }

    #[test]
    fn malformed_hints_warn() {
        let raw =
            serde_json::value::RawValue::from_string(r#"{"realcam": {"lens": 5}}"#.into()).unwrap();
        let extras: gltf::json::Extras = Some(raw);
        let mut warnings = Vec::new();
        let hints = camera_hints(&[(&extras, "extras")], "node 0", &mut warnings);
        assert_eq!(hints, CameraHints::default());
        assert_eq!(warnings.len(), 1);
        assert!(warnings[0].contains("node 0"));
    }
}
