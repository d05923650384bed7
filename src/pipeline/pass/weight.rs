//! Weight: radiance times the lens weight, and in a spectral render what its wavelength adds
//! to the film.

use bevy_ecs::system::{Query, ResMut};
use bevy_ecs::world::Mut;

use super::run_on_tiles;
use crate::pipeline::Stage;
use crate::pipeline::resources::{RenderStats, TileBatch};

/// Weight: multiplies radiance by the lens weight (and in a spectral render turns it into what
/// its wavelength adds to the film, see [`crate::spectral`]); non-finite samples never reach
/// the film.
pub fn weight(mut tiles: Query<&mut TileBatch>, mut stats: ResMut<RenderStats>) {
    let film = crate::spectral::spectral_film();
    let rejected: u64 = run_on_tiles(
        Stage::Weight,
        tiles.iter_mut(),
        None,
        &mut stats,
        |mut batch: Mut<TileBatch>| {
            let TileBatch {
                camera, radiance, ..
            } = &mut *batch;
            let mut rejected = 0;
            let spectral = !camera.wavelength.is_empty();
            for i in 0..camera.weight.len() {
                let w = camera.weight[i];
                let (r, g, b) = (radiance.r[i] * w, radiance.g[i] * w, radiance.b[i] * w);
                let [r, g, b] = if spectral {
                    film.film_rgb(camera.wavelength[i], camera.wavelength_weight[i], [r, g, b])
                } else {
                    [r, g, b]
                };
                let finite = r.is_finite() && g.is_finite() && b.is_finite();
                rejected += u64::from(!finite);
                radiance.r[i] = if finite { r } else { 0.0 };
                radiance.g[i] = if finite { g } else { 0.0 };
                radiance.b[i] = if finite { b } else { 0.0 };
            }
            rejected
        },
    )
    .into_iter()
    .sum();
    stats.rejected_samples += rejected;
}
