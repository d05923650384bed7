//! Click to focus: how far the scene is at a pixel, found by a ray from that film point through
//! the real lens into the scene (not a pinhole ray: a wide-angle or fisheye lens bends the view
//! far from where a pinhole would look).

use bevy_ecs::entity::Entity;
use glam::Vec3;

use crate::accel::SceneAccel;
use crate::lens::camera::FilmGeometry;
use crate::lens::elements::LensGeometry;
use crate::lens::pupil::ExitPupil;
use crate::lens::trace::{Ray, Travel, normalize, trace};
use crate::pipeline::{CameraPose, RenderSettings, Renderer};

/// Pupil points tried, in order, until a ray passes the lens: the centre of the film point's
/// pupil bounds first (near its chief ray), then a 5 × 5 grid over them.
fn pupil_points() -> impl Iterator<Item = [f32; 2]> {
    std::iter::once([0.5, 0.5])
        .chain((0..25).map(|k| [0.1 + 0.2 * (k % 5) as f32, 0.1 + 0.2 * (k / 5) as f32]))
}

/// Distance (m) from the film plane, along the camera's axis, to the surface the image shows at
/// pixel position (`px`, `py`) (pixels of the full image, (0, 0) its top-left corner), as the
/// `lens` entity sees it. `None` when no ray from that film point passes the lens or the ray
/// meets nothing.
pub fn focus_distance_at(renderer: &Renderer, lens: Entity, px: f64, py: f64) -> Option<f64> {
    let world = &renderer.world;
    let entity = world.get_entity(lens).ok()?;
    let (geometry, pupil) = (entity.get::<LensGeometry>()?, entity.get::<ExitPupil>()?);
    let settings = world.resource::<RenderSettings>();
    let world_from_camera = world.get_resource::<CameraPose>()?.0;
    let accel = world.get_resource::<SceneAccel>()?;
    let film = FilmGeometry::new(settings.width, settings.height, pupil.film_radius * 2.0);
    let [x, y] = film.film_point(px as f32, py as f32);
    let film_z = geometry.system.rear_z() + pupil.film_distance;
    let leaving = pupil_points().find_map(|u| {
        let sample = pupil.sample(x, y, u)?;
        let from = [x as f64, y as f64, film_z];
        let to = sample.point.map(f64::from);
        let ray = Ray {
            origin: from,
            direction: normalize([to[0] - from[0], to[1] - from[1], to[2] - from[2]]),
        };
        trace(&geometry.system.f64s, ray, Travel::FilmToScene).ok()
    })?;
    // Lens frame (mm, origin at the front vertex) → camera frame (m, origin at the film).
    let [ox, oy, oz] = leaving.origin;
    let origin = Vec3::new(ox as f32, oy as f32, (oz - film_z) as f32) * 1e-3;
    let [dx, dy, dz] = leaving.direction;
    let direction = Vec3::new(dx as f32, dy as f32, dz as f32);
    let hit = accel.intersect(
        world_from_camera.transform_point3(origin),
        world_from_camera.transform_vector3(direction).normalize(),
        f32::INFINITY,
    )?;
    let in_camera = origin + direction * hit.t;
    let depth = -in_camera.z as f64;
    (depth > 0.0).then_some(depth)
}
