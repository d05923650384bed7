//! Weight: radiance times the lens weight, and in a spectral render what its wavelengths add
//! to the film.

use bevy_ecs::system::{Query, ResMut};
use bevy_ecs::world::Mut;

use super::run_on_tiles;
use crate::film::FilmTile;
use crate::film::splat::Splat;
use crate::pipeline::Stage;
use crate::pipeline::resources::{RenderStats, TileBatch};

/// Weight: multiplies radiance by the lens weight (and in a spectral render turns it into what
/// its wavelengths add to the film, see [`crate::spectral`]: to the ray's own pixel, and with
/// several wavelengths per sample to the tile's splats for the pixels the others land in);
/// non-finite samples never reach the film.
pub fn weight(mut tiles: Query<(&FilmTile, &mut TileBatch)>, mut stats: ResMut<RenderStats>) {
    let film = crate::spectral::spectral_film();
    let rejected: u64 = run_on_tiles(
        Stage::Weight,
        tiles.iter_mut(),
        None,
        &mut stats,
        |(tile, mut batch): (&FilmTile, Mut<TileBatch>)| {
            let TileBatch {
                camera,
                radiance,
                splats,
                ..
            } = &mut *batch;
            splats.clear();
            let mut rejected = 0;
            let n = camera.weight.len();
            // Spectral: `count` wavelengths per ray, wavelength-major (see CameraRays).
            let count = camera.wavelength.len() / n.max(1);
            for i in 0..n {
                let w = camera.weight[i];
                let (r, g, b) = (radiance.r[i] * w, radiance.g[i] * w, radiance.b[i] * w);
                let ray_splats = splats.len();
                let [r, g, b] = if count == 0 {
                    [r, g, b]
                } else {
                    let mut own = [0.0f32; 3];
                    for k in 0..count {
                        let j = k * n + i;
                        let factor = camera.wavelength_weight[j];
                        if factor == 0.0 {
                            continue;
                        }
                        let add = film.film_rgb(camera.wavelength[j], factor, [r, g, b]);
                        match camera.wavelength_offset.get(j) {
                            Some(&[dx, dy]) if [dx, dy] != [0, 0] => {
                                // Ray i is the tile's pixel i (FilmTile::pixels order).
                                let x = tile.x0 + (i as u32 % tile.width);
                                let y = tile.y0 + (i as u32 / tile.width);
                                splats.push(Splat {
                                    x: x.wrapping_add_signed(i32::from(dx)),
                                    y: y.wrapping_add_signed(i32::from(dy)),
                                    rgb: add,
                                });
                            }
                            _ => own = [own[0] + add[0], own[1] + add[1], own[2] + add[2]],
                        }
                    }
                    own
                };
                let finite = [r, g, b].iter().all(|v| v.is_finite())
                    && splats[ray_splats..]
                        .iter()
                        .all(|s| s.rgb.iter().all(|v| v.is_finite()));
                rejected += u64::from(!finite);
                if !finite {
                    splats.truncate(ray_splats);
                }
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
