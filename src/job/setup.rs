//! Setting up a render: the scene's environment, where the camera goes, what it focuses on.

use anyhow::bail;
use glam::{Mat4, Vec3};

use super::spec::EnvironmentSpec;
use super::spec::JobSpec;
use crate::lens::Prescription;
use crate::lens::aperture::ApertureSetting;
use crate::lens::elements::{FocusSetting, Lens, build_geometry};
use crate::lens::focus::closest_focus_mm;
use crate::pipeline::{Renderer, SceneBounds};
use crate::scene::{CameraHints, MaterialLibrary, PunctualLight, SceneCamera, look_at};
use crate::shade::Environment;

/// The camera placement chosen for a render.
pub struct Placement {
    pub world_from_camera: Mat4,
    pub hints: CameraHints,
    /// Focus distance (m) implied by the placement when the user gave none.
    pub default_focus_m: Option<f64>,
    /// No camera in the scene: frame the bounds once the lens is known.
    pub frame_bounds: bool,
}

pub fn choose_environment(spec: &JobSpec, renderer: &mut Renderer) -> anyhow::Result<Environment> {
    match &spec.environment {
        Some(uniform @ EnvironmentSpec::Uniform(rgb)) => {
            if rgb.min_element() < 0.0 {
                bail!("--env {uniform}: radiance must not be negative");
            }
            return Ok(Environment::Uniform(*rgb));
        }
        Some(EnvironmentSpec::Image(path)) => {
            // `--env 1,1` is a sky with a number missing more likely than a file's name.
            let numeric = path
                .to_str()
                .is_some_and(|text| text.chars().all(|c| "0123456789.,+-eE ".contains(c)));
            if numeric && !path.exists() {
                bail!(
                    "--env {}: neither a sky R,G,B (three numbers) nor an image file that exists",
                    path.display()
                );
            }
            return crate::shade::load_environment(path);
        }
        None => {}
    }
    let has_lights = renderer
        .world
        .query::<&PunctualLight>()
        .iter(&renderer.world)
        .next()
        .is_some();
    // A light fixture glows uniformly (an emissive factor, like a Cornell box's ceiling panel);
    // an emissive *texture* marks glowing details of an object (a helmet's visor), which
    // light nothing else, so such a scene still gets a sky.
    let has_fixtures = renderer
        .world
        .resource::<MaterialLibrary>()
        .materials
        .iter()
        .any(|m| m.is_emissive() && m.emissive_texture.is_none());
    if has_lights || has_fixtures {
        Ok(Environment::Uniform(Vec3::ZERO))
    } else {
        eprintln!(
            "note: the scene has no lights; lighting it with a white sky of 1 nit (set one with --env)"
        );
        Ok(Environment::Uniform(Vec3::ONE))
    }
}

pub fn place_camera(spec: &JobSpec, renderer: &mut Renderer) -> anyhow::Result<Placement> {
    if let (Some(from), Some(at)) = (spec.view.look_from, spec.view.look_at) {
        if (at - from).length() < 1e-6
            || (at - from)
                .normalize()
                .cross(spec.view.up.normalize_or_zero())
                .length()
                < 1e-6
        {
            bail!(
                "--look-from and --look-at must differ, and --up must not be parallel to the view direction"
            );
        }
        return Ok(Placement {
            world_from_camera: look_at(from, at, spec.view.up),
            hints: CameraHints::default(),
            default_focus_m: Some((at - from).length() as f64),
            frame_bounds: false,
        });
    }
    let cameras = renderer.scene_cameras();
    let chosen: Option<&SceneCamera> = match &spec.view.camera {
        Some(wanted) => {
            let found = cameras
                .iter()
                .find(|c| c.name.as_deref() == Some(wanted.as_str()))
                .or_else(|| {
                    wanted
                        .parse::<usize>()
                        .ok()
                        .and_then(|i| cameras.iter().find(|c| c.index == i))
                });
            if found.is_none() {
                bail!(
                    "--camera {wanted}: no such camera in the scene, which has {}",
                    describe_cameras(&cameras)
                );
            }
            found
        }
        None => cameras.first(),
    };
    Ok(match chosen {
        Some(camera) => Placement {
            world_from_camera: camera.world_from_camera,
            hints: camera.hints.clone(),
            default_focus_m: None,
            frame_bounds: false,
        },
        None => Placement {
            world_from_camera: Mat4::IDENTITY,
            hints: CameraHints::default(),
            default_focus_m: None,
            frame_bounds: true,
        },
    })
}

/// Cameras listed at most in a message.
const LISTED_CAMERAS: usize = 20;

/// `2 cameras: #0 "Front", #1 (unnamed)`, for messages: how many, then each index and name.
pub fn describe_cameras(cameras: &[SceneCamera]) -> String {
    if cameras.is_empty() {
        return "no cameras; place one with --look-from and --look-at".to_string();
    }
    let mut listed: Vec<String> = cameras
        .iter()
        .take(LISTED_CAMERAS)
        .map(|c| match &c.name {
            Some(name) => format!("#{} \"{name}\"", c.index),
            None => format!("#{} (unnamed)", c.index),
        })
        .collect();
    if cameras.len() > LISTED_CAMERAS {
        listed.push(format!("and {} more", cameras.len() - LISTED_CAMERAS));
    }
    format!(
        "{} camera{}: {} (give --camera an index or a name)",
        cameras.len(),
        if cameras.len() == 1 { "" } else { "s" },
        listed.join(", ")
    )
}

/// Looks at the scene's bounds from +z (front), far enough back for the lens to fit them in
/// the frame and no closer than it can focus; focused on the bounds' centre.
pub fn frame_scene(
    renderer: &mut Renderer,
    prescription: &Prescription,
    aperture: ApertureSetting,
    film_diagonal: f64,
) -> anyhow::Result<(Mat4, Option<f64>)> {
    let bounds = renderer.world.resource::<SceneBounds>().0;
    if bounds.is_empty() {
        bail!("the scene has no geometry to look at");
    }
    let lens = Lens::of(prescription);
    let geometry =
        build_geometry(&lens, &prescription.rows, aperture).map_err(anyhow::Error::msg)?;
    let efl = geometry.first_order.focal_length;
    // Half the film's short side for a square image: diagonal / (2√2).
    let half_field = ((film_diagonal / (2.0 * 2f64.sqrt())) / efl).atan();
    let radius = (bounds.diagonal() / 2.0) as f64;
    let fit = radius / half_field.sin() * 1.05;
    let closest = prescription
        .spacings
        .closest_focus_mm(closest_focus_mm(&geometry.system, &geometry.first_order))
        / 1000.0
        * 1.02;
    if fit < closest {
        eprintln!(
            "note: the scene ({:.3} m across) is smaller than {} can fill the frame with; it will look small (closest focus {:.3} m)",
            2.0 * radius,
            prescription.name,
            closest
        );
    }
    let distance = fit.max(closest);
    let center = bounds.center();
    let eye = center + Vec3::Z * distance as f32;
    Ok((look_at(eye, center, Vec3::Y), Some(distance)))
}

/// An implied focus (the scene camera's, the look-at point's, the framing's or autofocus) that
/// is closer than `prescription` can focus, moved out to its closest focus with a warning naming
/// both distances: the user asked for no distance, so the nearest sharp one serves. An explicit
/// `--focus-distance` is not passed here; the lens refuses it with its own message.
pub fn within_focus_range(prescription: &Prescription, focus: FocusSetting) -> FocusSetting {
    let FocusSetting::Distance { metres, mode } = focus else {
        return focus;
    };
    let lens = Lens::of(prescription);
    // A lens that does not derive is reported when its frame is rendered.
    let Ok(geometry) = build_geometry(&lens, &prescription.rows, ApertureSetting::Full) else {
        return focus;
    };
    let closest_mm = prescription
        .spacings
        .closest_focus_mm(closest_focus_mm(&geometry.system, &geometry.first_order));
    if metres * 1000.0 >= closest_mm {
        return focus;
    }
    eprintln!(
        "warning: {}: the implied focus distance {metres:.4} m is closer than the lens can focus; focusing at its closest, {:.4} m",
        prescription.name,
        closest_mm / 1000.0
    );
    FocusSetting::Distance {
        // At the closest conjugate the focus equation's discriminant is zero, which rounding can
        // make a hair negative: a part in 10⁹ farther (a micrometre at a metre) stays solvable.
        metres: closest_mm * (1.0 + 1e-9) / 1000.0,
        mode,
    }
}

/// Focus on whatever the image centre sees, like a camera's autofocus; 10 m on a miss.
pub fn autofocus(renderer: &mut Renderer, world_from_camera: Mat4) -> FocusSetting {
    let origin = world_from_camera.transform_point3(Vec3::ZERO);
    let forward = world_from_camera
        .transform_vector3(-Vec3::Z)
        .normalize_or_zero();
    let accel = renderer.world.get_resource::<crate::accel::SceneAccel>();
    let metres = accel
        .and_then(|a| a.intersect(origin, forward, f32::INFINITY))
        .map_or(10.0, |hit| hit.t as f64);
    FocusSetting::Distance {
        metres,
        mode: Default::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::elements::film_distance_for;
    use crate::lens::focus::FocusMode;
    use crate::lens::io::bundled::load_lens;

    #[test]
    fn an_implied_focus_too_close_is_moved_out_to_the_closest_focus() {
        let lens = load_lens("dgauss.50mm", None).unwrap();
        let element = Lens::of(&lens);
        let geometry = build_geometry(&element, &lens.rows, ApertureSetting::Full).unwrap();
        // The thick-lens closest conjugate: L = EFL·(2 + A + D) from the rear vertex.
        let m = geometry.first_order.system;
        let closest_m = (geometry.first_order.focal_length * (2.0 + m.a + m.d)
            + geometry.system.rear_z())
            / 1000.0;
        for mode in [FocusMode::Paraxial, FocusMode::Best] {
            let near = FocusSetting::Distance {
                metres: closest_m * 0.97,
                mode,
            };
            assert!(
                film_distance_for(&geometry, near).is_err(),
                "too close as asked"
            );
            let moved = within_focus_range(&lens, near);
            let FocusSetting::Distance { metres, mode: kept } = moved else {
                panic!("{moved:?}")
            };
            assert_eq!(kept, mode);
            assert!(
                (metres - closest_m).abs() < 1e-6 * closest_m,
                "{metres} vs {closest_m}"
            );
            assert!(film_distance_for(&geometry, moved).is_ok(), "{mode:?}");
        }
        // Within reach, and film distances, stay as they are.
        for focus in [
            FocusSetting::Distance {
                metres: closest_m * 1.5,
                mode: FocusMode::Paraxial,
            },
            FocusSetting::FilmDistance(40.0),
        ] {
            assert_eq!(within_focus_range(&lens, focus), focus);
        }
    }

    fn camera(index: usize, name: Option<&str>) -> SceneCamera {
        SceneCamera {
            name: name.map(str::to_string),
            index,
            world_from_camera: Mat4::IDENTITY,
            yfov: None,
            aspect_ratio: None,
            hints: CameraHints::default(),
        }
    }

    #[test]
    fn camera_lists_say_how_many_then_each_index_and_name() {
        assert_eq!(
            describe_cameras(&[camera(0, Some("Camera"))]),
            "1 camera: #0 \"Camera\" (give --camera an index or a name)"
        );
        let message = describe_cameras(&[camera(0, None), camera(1, Some("Top"))]);
        assert!(
            message.starts_with("2 cameras: #0 (unnamed), #1 \"Top\""),
            "{message}"
        );
        assert!(describe_cameras(&[]).starts_with("no cameras"));
        let many: Vec<SceneCamera> = (0..25).map(|i| camera(i, None)).collect();
        let message = describe_cameras(&many);
        assert!(
            message.starts_with("25 cameras: #0") && message.contains("#19 (unnamed), and 5 more"),
            "{message}"
        );
    }
}
