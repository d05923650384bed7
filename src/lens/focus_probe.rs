//! Focusing on what a pixel sees (`--focus-on X,Y`).
//!
//! A probe ray leaves the pixel's centre on the film (shift and tilt included) toward the
//! centre of the exit pupil as that film point sees it (the real chief ray, near enough),
//! passes the lens and meets the scene. The film distance is then solved for that point: the
//! paraxial conjugate of its depth is the start, and real rays from the point through the
//! lens move the film to where their spot is smallest ([`sharpest_image_z`]). Moving the film
//! changes what the pixel sees a little (the lens moves against the film-fixed camera frame,
//! see [`crate::lens::focus`]), so probing and solving alternate until the film stays put.
//!
//! Depth is measured as everywhere in [`crate::lens::focus`]: from the film plane (through
//! the frame centre) to the point, along the axis.
//!
//! A lens that focuses by moving groups ([`FocusGroups`]) focuses with them, as the camera's
//! autofocus would: the point's depth becomes the lens's focus distance, which moves the groups
//! (a new geometry, derived as for any focus change), and the probe runs again through the
//! re-derived lens, whose framing breathed a little; the [`Renderer`](crate::pipeline::Renderer)
//! re-runs the derivation until the depth stays put ([`LensesSettling`]). The film is then
//! placed by the probe's real rays, as for a unit-focused lens.

use std::time::Instant;

use bevy_ecs::change_detection::DetectChanges;
use bevy_ecs::component::Component;
use bevy_ecs::entity::Entity;
use bevy_ecs::resource::Resource;
use bevy_ecs::system::{Commands, Query, Res, ResMut};
use bevy_ecs::world::{Mut, Ref};
use glam::{Mat4, Vec3};

use super::camera::{CameraPose, FilmGeometry, FilmResolution};
use super::elements::{
    FilmFormat, FilmPlacement, FocusSetting, Lens, LensDerivationStats, LensFault, LensGeometry,
};
use super::first_order::FirstOrder;
use super::focus::{FocusMode, INFINITY_FOCUS_MM, paraxial_film_distance, sharpest_image_z};
use super::movements::{FilmMovements, passing_rear_points};
use super::spacing::FocusGroups;
use super::system::LensSystem;
use super::trace::{Ray, Travel, normalize, trace};
use crate::accel::SceneAccel;

/// Focus the lens on what pixel (`x`, `y`) sees ((0, 0): the image's top-left pixel). A
/// component of the lens entity; while present it decides the film distance, not
/// [`FocusSetting`].
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq)]
pub struct FocusOnPixel {
    pub x: u32,
    pub y: u32,
}

/// What focusing on a pixel found: a component of the lens entity, beside its
/// [`FilmPlacement`].
#[derive(Component, Clone, Copy, Debug, PartialEq)]
pub struct FocusProbe {
    pub pixel: [u32; 2],
    /// The point the pixel sees, world frame (m).
    pub point: Vec3,
    /// Film plane → the point, along the axis, mm.
    pub object_distance_mm: f64,
    /// Rear vertex → frame centre, mm.
    pub film_distance: f64,
}

/// Probe-and-solve rounds at most; each moves the film by far less than the last.
const ROUNDS: usize = 6;
/// Real-ray refinements of the film distance per round.
const REFINEMENTS: usize = 4;

/// Present after a derivation round in which a lens with focus groups moved them to focus on a
/// pixel: its geometry must be derived again (and the pixel probed through it) before it
/// renders. The [`Renderer`](crate::pipeline::Renderer) runs the schedule again while it is.
#[derive(Resource, Debug, Default)]
pub struct LensesSettling;

/// How far (relative) the probed depth may lie from the focus distance the groups are at before
/// they move again: 0.01 %, a tenth of a millimetre at a metre, far inside any depth of field.
const GROUP_FOCUS_TOLERANCE: f64 = 1e-4;

type FocusTargetQuery<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        &'static Lens,
        Ref<'static, LensGeometry>,
        Ref<'static, FocusOnPixel>,
        Option<Ref<'static, FilmMovements>>,
        Option<&'static FocusGroups>,
        Option<Mut<'static, FocusSetting>>,
    ),
>;

/// Solves the film distance of every lens focused on a pixel whose inputs changed.
// A system's parameters are its explicit queries and resources (bevy style), not a bundle.
#[allow(clippy::too_many_arguments)]
pub fn focus_on_pixel(
    mut commands: Commands,
    mut lenses: FocusTargetQuery,
    accel: Option<Res<SceneAccel>>,
    pose: Option<Res<CameraPose>>,
    resolution: Res<FilmResolution>,
    film: Res<FilmFormat>,
    mut stats: ResMut<LensDerivationStats>,
) {
    let world_changed = accel.as_ref().is_some_and(|a| a.is_changed())
        || pose.as_ref().is_some_and(|p| p.is_changed())
        || resolution.is_changed()
        || film.is_changed();
    for (entity, lens, geometry, target, movements, groups, focus) in &mut lenses {
        let movements_changed = movements.as_ref().is_some_and(|m| m.is_changed());
        if !(world_changed || geometry.is_changed() || target.is_changed() || movements_changed) {
            continue;
        }
        let start = Instant::now();
        let solved = match (&accel, &pose) {
            (Some(accel), Some(pose)) => {
                let film = FilmGeometry::new(resolution.width, resolution.height, film.diagonal_mm)
                    .moved(movements.as_deref().copied().unwrap_or_default());
                solve_focus_on_pixel(
                    &geometry.system,
                    &geometry.first_order,
                    accel,
                    pose.0,
                    &film,
                    [target.x, target.y],
                )
            }
            _ => Err("focusing on a pixel needs a loaded scene and a camera".to_string()),
        };
        match solved {
            Ok(probe) => {
                if let (Some(_), Some(mut focus)) = (groups, focus) {
                    let metres = probe.object_distance_mm / 1000.0;
                    let (at, mode) = match *focus {
                        FocusSetting::Distance { metres, mode } => (metres, mode),
                        FocusSetting::FilmDistance(_) => (f64::INFINITY, FocusMode::Paraxial),
                    };
                    if (metres - at).abs() > GROUP_FOCUS_TOLERANCE * metres {
                        *focus = FocusSetting::Distance { metres, mode };
                        commands.insert_resource(LensesSettling);
                    }
                }
                commands
                    .entity(entity)
                    .insert((
                        FilmPlacement {
                            film_distance: probe.film_distance,
                        },
                        probe,
                    ))
                    .remove::<LensFault>();
            }
            Err(message) => {
                let message = format!("{}: {message}", lens.source.display());
                commands
                    .entity(entity)
                    .insert(LensFault(message))
                    .remove::<(FilmPlacement, FocusProbe)>();
            }
        }
        stats.placement_runs += 1;
        stats.total_time += start.elapsed();
    }
}

/// The film distance that focuses the lens on what `pixel` of `film` sees in the scene of
/// `accel`, the camera placed by `world_from_camera` (see the module docs): the probe leaves
/// the pixel's centre.
pub fn solve_focus_on_pixel(
    system: &LensSystem,
    first_order: &FirstOrder,
    accel: &SceneAccel,
    world_from_camera: Mat4,
    film: &FilmGeometry,
    pixel: [u32; 2],
) -> Result<FocusProbe, String> {
    let [x, y] = pixel;
    if x >= film.width || y >= film.height {
        return Err(format!(
            "--focus-on {x},{y}: the pixel lies outside the {}×{} image (pixels count from 0,0 at the top left)",
            film.width, film.height
        ));
    }
    let position = [x as f32 + 0.5, y as f32 + 0.5];
    solve_focus_at(
        system,
        first_order,
        accel,
        world_from_camera,
        film,
        position,
    )
    .map_err(|e| format!("--focus-on {x},{y}: {e}"))
}

/// As [`solve_focus_on_pixel`], from the continuous image position `position` (pixels, (0, 0)
/// the top-left corner of the image; a click needs no rounding to a pixel's centre).
pub fn solve_focus_at(
    system: &LensSystem,
    first_order: &FirstOrder,
    accel: &SceneAccel,
    world_from_camera: Mat4,
    film: &FilmGeometry,
    position: [f32; 2],
) -> Result<FocusProbe, String> {
    let [px, py] = position;
    let pixel = [px.max(0.0) as u32, py.max(0.0) as u32];
    let [fx, fy, dz] = film.film_position(px, py);
    let camera_from_world = world_from_camera.inverse();
    let mut film_distance = paraxial_film_distance(system, first_order, INFINITY_FOCUS_MM)
        .map_err(|e| e.to_string())?;
    let mut probe = None;
    for _ in 0..ROUNDS {
        let film_z = system.rear_z() + film_distance;
        let ray = probe_ray(system, [fx, fy, film_z + dz]).ok_or_else(|| {
            "no light reaches the pixel through this lens (it lies outside the image circle)"
                .to_string()
        })?;
        // Lens frame (mm) → camera frame (m, origin at the frame centre's plane on the axis).
        let to_camera =
            |p: [f64; 3]| Vec3::new(p[0] as f32, p[1] as f32, (p[2] - film_z) as f32) * 1e-3;
        let origin = world_from_camera.transform_point3(to_camera(ray.origin));
        let direction = world_from_camera
            .transform_vector3(Vec3::from(ray.direction.map(|v| v as f32)))
            .normalize();
        let hit = accel.intersect(origin, direction, f32::INFINITY).ok_or_else(|| {
            "the pixel sees only the sky (its ray meets no surface); choose a pixel on an object"
                .to_string()
        })?;
        let point = origin + direction * hit.t;
        let seen = camera_from_world.transform_point3(point);
        let depth = -(seen.z as f64) * 1e3;
        let lateral = [seen.x as f64 * 1e3, seen.y as f64 * 1e3];
        let solved = film_distance_for_point(system, first_order, lateral, depth, dz)?;
        let settled = (solved - film_distance).abs() < 1e-6;
        film_distance = solved;
        probe = Some(FocusProbe {
            pixel,
            point,
            object_distance_mm: depth,
            film_distance,
        });
        if settled {
            break;
        }
    }
    probe.ok_or_else(|| "no focus rounds ran".to_string())
}

/// The film distance (rear vertex → frame centre) that brings the real-ray image of the point
/// at `lateral` (camera x, y, mm) and `depth` (film plane → point along the axis, mm) into
/// sharpest focus on a film point `dz` behind the frame centre's plane (a tilted film's).
pub fn film_distance_for_point(
    system: &LensSystem,
    first_order: &FirstOrder,
    lateral: [f64; 2],
    depth: f64,
    dz: f64,
) -> Result<f64, String> {
    if !(depth.is_finite() && depth > 0.0) {
        return Err(format!(
            "the point it sees lies {:.1} mm behind the film plane",
            -depth
        ));
    }
    // The film point at the pixel is depth + dz from the point, along the axis.
    let paraxial = paraxial_film_distance(system, first_order, depth + dz).map_err(|e| {
        format!(
            "the point it sees, {:.4} m away, cannot be focused: {e}",
            depth / 1e3
        )
    })? - dz;
    let mut film_distance = paraxial;
    for _ in 0..REFINEMENTS {
        // The camera frame is fixed to the film: the point's lens-frame z moves with it.
        let object = [
            lateral[0],
            lateral[1],
            system.rear_z() + film_distance - depth,
        ];
        let Some(z) = sharpest_image_z(system, object) else {
            return Err(format!(
                "no real rays from the point it sees ({:.4} m away) pass the lens",
                depth / 1e3
            ));
        };
        film_distance = z - system.rear_z() - dz;
    }
    if !(film_distance.is_finite() && film_distance > 0.0) {
        return Err(format!(
            "the point it sees ({:.4} m away) images inside the lens",
            depth / 1e3
        ));
    }
    Ok(film_distance)
}

/// The real ray from the lens-frame film point `point` toward the centre of the region of the
/// rear element whose rays pass (the exit pupil as the point sees it), traced out of the front
/// of the lens; `None` when no ray from the point passes.
pub fn probe_ray(system: &LensSystem, point: [f64; 3]) -> Option<Ray<f64>> {
    let passing = passing_rear_points(system, point);
    if passing.is_empty() {
        return None;
    }
    let n = passing.len() as f64;
    let centre = passing
        .iter()
        .fold([0.0, 0.0], |c, p| [c[0] + p[0] / n, c[1] + p[1] / n]);
    let rear_z = system.rear_z();
    let toward = |aim: [f64; 2]| {
        let direction = normalize([aim[0] - point[0], aim[1] - point[1], rear_z - point[2]]);
        trace(
            &system.f64s,
            Ray {
                origin: point,
                direction,
            },
            Travel::FilmToScene,
        )
        .ok()
    };
    toward(centre).or_else(|| {
        // A cat's eye can be bent enough that its centroid's ray is blocked: take the passing
        // ray nearest to it.
        let nearest = passing.iter().min_by(|a, b| {
            let d = |p: &[f64; 2]| (p[0] - centre[0]).hypot(p[1] - centre[1]);
            d(a).total_cmp(&d(b))
        })?;
        toward(*nearest)
    })
}
