//! LandCompanions: in a spectral render with several wavelengths per sample, where each
//! sample's further wavelengths land on the film, for the samples that carry light.
//!
//! A sample's companion wavelengths share its scene path (see
//! [`crate::lens::hero_wavelengths`]), so one whose path found no light (a camera ray into a
//! black sky) adds nothing at any wavelength, and tracing its companions back through the lens
//! would be work thrown away. This stage runs once Shade has shown which samples those are.

use bevy_ecs::system::{Query, Res, ResMut};
use bevy_ecs::world::Mut;

use super::rays::{ActiveLensQuery, lens_camera};
use super::run_on_tiles;
use crate::lens::camera::CameraPose;
use crate::lens::elements::FilmFormat;
use crate::pipeline::Stage;
use crate::pipeline::resources::{RenderSettings, RenderStats, TileBatch};

/// LandCompanions: lands the companion wavelengths of every sample with any radiance (a
/// non-finite one too, so that Weight counts it as rejected).
pub fn land_companions(
    lens: ActiveLensQuery,
    pose: Option<Res<CameraPose>>,
    settings: Res<RenderSettings>,
    film_format: Res<FilmFormat>,
    mut tiles: Query<&mut TileBatch>,
    mut stats: ResMut<RenderStats>,
) {
    // GenerateRays reported a missing lens or pose, and left no companions to land.
    let (Ok(active), Some(pose)) = (lens.single(), pose) else {
        return;
    };
    let camera = lens_camera(active, &pose, &settings, &film_format);
    if camera.wavelengths_per_sample() < 2 {
        return;
    }
    run_on_tiles(
        Stage::LandCompanions,
        tiles.iter_mut(),
        None,
        &mut stats,
        |mut batch: Mut<TileBatch>| {
            let TileBatch {
                camera: rays,
                radiance,
                ..
            } = &mut *batch;
            camera.land_companions(rays, |i| radiance.found_light(i));
        },
    )
    .for_each(drop);
}
