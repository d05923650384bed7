//! GenerateRays: this pass's camera rays for every tile, traced through the active lens.

use bevy_ecs::query::With;
use bevy_ecs::system::{Commands, Query, Res, ResMut};
use bevy_ecs::world::Mut;

use super::run_on_tiles;
use crate::film::FilmTile;
use crate::lens::camera::{CameraPose, FilmGeometry, LensCamera};
use crate::lens::elements::{ActiveLens, Dispersion, FilmFormat, FilmPlacement, LensGeometry};
use crate::lens::movements::FilmMovements;
use crate::lens::pupil::ExitPupil;
use crate::pipeline::Stage;
use crate::pipeline::resources::{
    PassCancel, PassState, PipelineFault, RenderSettings, RenderStats, TileBatch,
};

type ActiveLensQuery<'w, 's> = Query<
    'w,
    's,
    (
        &'static LensGeometry,
        &'static FilmPlacement,
        &'static ExitPupil,
        Option<&'static Dispersion>,
        Option<&'static FilmMovements>,
    ),
    With<ActiveLens>,
>;

/// GenerateRays: camera rays of this pass for every tile, traced through the active lens.
// A system's parameters are its explicit queries and resources (bevy style), not a bundle.
#[allow(clippy::too_many_arguments)]
pub fn generate_rays(
    mut commands: Commands,
    lens: ActiveLensQuery,
    pose: Option<Res<CameraPose>>,
    settings: Res<RenderSettings>,
    film_format: Res<FilmFormat>,
    pass: Res<PassState>,
    cancel: Option<Res<PassCancel>>,
    mut tiles: Query<(&FilmTile, &mut TileBatch)>,
    mut stats: ResMut<RenderStats>,
) {
    let (Ok((geometry, _placement, pupil, dispersion, movements)), Some(pose)) =
        (lens.single(), pose)
    else {
        commands.insert_resource(PipelineFault(
            "no active lens with a valid focus, or no camera pose".into(),
        ));
        return;
    };
    let camera = LensCamera {
        system: &geometry.system,
        pupil,
        film: FilmGeometry::new(settings.width, settings.height, film_format.diagonal_mm)
            .moved(movements.copied().unwrap_or_default()),
        world_from_camera: pose.0,
        dispersion: geometry
            .system
            .dispersion
            .as_deref()
            .filter(|_| Dispersion::is_spectral(dispersion, geometry)),
    };
    let passed: u64 = run_on_tiles(
        Stage::GenerateRays,
        tiles.iter_mut(),
        cancel.as_deref(),
        &mut stats,
        |(tile, mut batch): (&FilmTile, Mut<TileBatch>)| {
            camera.generate(tile.pixels(), pass.sample, settings.seed, &mut batch.camera);
            batch.camera.rays.alive_count() as u64
        },
    )
    .into_iter()
    .sum();
    stats.camera_samples += (settings.width * settings.height) as u64;
    stats.lens_rays_passed += passed;
}
