//! GenerateRays: this pass's camera rays for every tile, traced through the active lens.

use bevy_ecs::query::{Added, Changed, Or, With};
use bevy_ecs::system::{Commands, Query, Res, ResMut};
use bevy_ecs::world::Mut;

use super::run_on_tiles;
use crate::film::FilmTile;
use crate::lens::camera::{CameraPose, FilmGeometry, LensCamera};
use crate::lens::elements::{
    ActiveLens, Dispersion, FilmFormat, FilmPlacement, Flare, LensGeometry,
};
use crate::lens::movements::FilmMovements;
use crate::lens::pupil::ExitPupil;
use crate::pipeline::Stage;
use crate::pipeline::resources::{
    PassCancel, PassState, PipelineFault, RenderSettings, RenderStats, TileBatch,
};

/// The active lens's derived components, as the pass stages (on either device) read them.
pub(crate) type ActiveLensQuery<'w, 's> = Query<
    'w,
    's,
    (
        &'static LensGeometry,
        &'static FilmPlacement,
        &'static ExitPupil,
        Option<&'static Dispersion>,
        Option<&'static FilmMovements>,
        Option<&'static Flare>,
    ),
    With<ActiveLens>,
>;

/// What the active lens's camera rays depend on changed: its derivation, its colour setting,
/// its film movements, or which lens is active.
pub(crate) type LensChanged = Or<(
    Changed<LensGeometry>,
    Changed<FilmPlacement>,
    Changed<ExitPupil>,
    Changed<Dispersion>,
    Changed<FilmMovements>,
    Changed<Flare>,
    Added<ActiveLens>,
)>;

/// The camera the active lens makes for this render's film and pose.
pub(crate) fn lens_camera<'a>(
    (geometry, _placement, pupil, dispersion, movements, flare): ActiveLensItem<'a>,
    pose: &CameraPose,
    settings: &RenderSettings,
    film_format: &FilmFormat,
) -> LensCamera<'a> {
    LensCamera {
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
        wavelengths: settings.wavelengths,
        ghosts: geometry
            .system
            .ghosts
            .as_deref()
            .filter(|_| flare != Some(&Flare::Off)),
    }
}

/// One item of [`ActiveLensQuery`].
pub(crate) type ActiveLensItem<'a> = (
    &'a LensGeometry,
    &'a FilmPlacement,
    &'a ExitPupil,
    Option<&'a Dispersion>,
    Option<&'a FilmMovements>,
    Option<&'a Flare>,
);

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
    let (Ok(active), Some(pose)) = (lens.single(), pose) else {
        commands.insert_resource(PipelineFault(
            "no active lens with a valid focus, or no camera pose".into(),
        ));
        return;
    };
    let camera = lens_camera(active, &pose, &settings, &film_format);
    let passed: u64 = run_on_tiles(
        Stage::GenerateRays,
        tiles.iter_mut(),
        cancel.as_deref(),
        &mut stats,
        |(tile, mut batch): (&FilmTile, Mut<TileBatch>)| {
            // The companion wavelengths land once shading has shown which samples carry light.
            camera.generate_heroes(tile.pixels(), pass.sample, settings.seed, &mut batch.camera);
            batch.camera.rays.alive_count() as u64
        },
    )
    .sum();
    stats.camera_samples += (settings.width * settings.height) as u64;
    stats.lens_rays_passed += passed;
}
