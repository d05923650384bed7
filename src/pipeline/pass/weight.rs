//! Weight: radiance times the lens weight, and in a spectral render what its wavelengths add
//! to the film.

use bevy_ecs::system::{Query, Res, ResMut};
use bevy_ecs::world::Mut;

use super::run_on_tiles;
use crate::film::FilmTile;
use crate::film::filter::{Filter, grid_point};
use crate::film::splat::Splat;
use crate::lens::hero_wavelengths::MAX_WAVELENGTHS;
use crate::lens::trace_batch::{Isa, on_isa, widened};
use crate::pipeline::Stage;
use crate::pipeline::resources::{RenderSettings, RenderStats, TileBatch};
use crate::spectral::SpectralFilm;

/// One share of a sample: what it adds to the film, and where.
#[derive(Clone, Copy, Default)]
struct Share {
    rgb: [f32; 3],
    /// Pixel offset from the ray's pixel (the box filter's target).
    offset: [i8; 2],
    /// Film point relative to the ray's pixel's corner, pixels (see `CameraRays::film_position`).
    position: [f32; 2],
}

/// Weight: multiplies radiance by the lens weight (and in a spectral render turns it into what
/// its wavelengths add to the film, see [`crate::spectral`]). With the box filter a share goes
/// to the ray's own pixel, or with several wavelengths per sample to the tile's splats for the
/// pixel it lands in; with a wider filter every share spreads into the tile's
/// [`Spread`](crate::film::splat::Spread). A sample with any non-finite share never reaches
/// the film.
pub fn weight(
    mut tiles: Query<(&FilmTile, &mut TileBatch)>,
    settings: Res<RenderSettings>,
    mut stats: ResMut<RenderStats>,
) {
    let film = crate::spectral::spectral_film();
    let filter = settings.filter;
    let size = [settings.width, settings.height];
    let rejected: u64 = run_on_tiles(
        Stage::Weight,
        tiles.iter_mut(),
        None,
        &mut stats,
        |(tile, mut batch): (&FilmTile, Mut<TileBatch>)| {
            let job = WeighTile {
                tile,
                batch: &mut batch,
                film,
                filter,
                size,
            };
            // Compiled again for wider vector units and the widest this CPU has chosen, as
            // for the lens kernel (the same operations, so the same bits).
            on_isa!(Isa::detect(),
                baseline: job.run(),
                avx2: job.run_avx2(),
                avx512: job.run_avx512(),
            )
        },
    )
    .sum();
    stats.rejected_samples += rejected;
}

/// One tile's Weight step: what [`weight`] runs per tile.
struct WeighTile<'a> {
    tile: &'a FilmTile,
    batch: &'a mut TileBatch,
    film: &'a SpectralFilm,
    filter: Filter,
    size: [u32; 2],
}

impl WeighTile<'_> {
    widened! {
        fn run_avx2 / run_avx512(self) -> u64 {
            self.run()
        }
    }

    /// Weighs every ray of the tile; returns how many samples were rejected as non-finite.
    #[inline(always)]
    fn run(self) -> u64 {
        let WeighTile {
            tile,
            batch,
            film,
            filter,
            size,
        } = self;
        let TileBatch {
            camera,
            radiance,
            splats,
            spread,
            ..
        } = batch;
        splats.clear();
        if !filter.is_box() {
            spread.reset(tile.rect());
        }
        let mut rejected = 0;
        let n = camera.weight.len();
        // Spectral: `count` wavelengths per ray, wavelength-major (see CameraRays).
        let count = camera.wavelength.len() / n.max(1);
        let taps = filter.grid();
        let mut shares = [Share::default(); MAX_WAVELENGTHS as usize];
        // Ray i is the tile's pixel i (FilmTile::pixels order): its pixel, kept as the rays
        // go by rather than divided out of i for each.
        let (mut next_x, mut next_y) = (tile.x0, tile.y0);
        for i in 0..n {
            let (x, y) = (next_x, next_y);
            next_x += 1;
            if next_x == tile.x0 + tile.width {
                (next_x, next_y) = (tile.x0, y + 1);
            }
            let w = camera.weight[i];
            let radiance_i = [radiance.r[i], radiance.g[i], radiance.b[i]];
            // A ray of weight 0 (the lens blocked it, or its hero wavelength) adds nothing:
            // every share the loop below would make of it is its radiance times 0. Nor does
            // a path that found no light (LandCompanions left its companions unlanded). A
            // non-finite radiance still goes there, to be counted as rejected.
            if !radiance.found_light(i) || (w == 0.0 && radiance_i.iter().all(|v| v.is_finite())) {
                [radiance.r[i], radiance.g[i], radiance.b[i]] = [0.0; 3];
                continue;
            }
            let rgb = radiance_i.map(|v| v * w);
            let mut made = 0;
            if count == 0 {
                shares[0] = Share {
                    rgb,
                    offset: [0, 0],
                    position: camera.film_position[i],
                };
                made = 1;
            }
            for k in 0..count {
                let j = k * n + i;
                let factor = camera.wavelength_weight[j];
                if factor == 0.0 {
                    continue;
                }
                shares[made] = Share {
                    rgb: film.film_rgb(camera.wavelength[j], factor, rgb),
                    offset: camera.wavelength_offset.get(j).copied().unwrap_or([0, 0]),
                    position: camera.film_position[if count > 1 { j } else { i }],
                };
                made += 1;
            }
            let shares = &shares[..made];
            let finite = shares.iter().all(|s| s.rgb.iter().all(|v| v.is_finite()));
            rejected += u64::from(!finite);
            let mut own = [0.0f32; 3];
            // A share with no light (a blocked ray's, a path that found none) would add zeros:
            // most of a fisheye's frame, outside its image circle.
            let lit = shares.iter().filter(|share| share.rgb != [0.0; 3]);
            if finite && filter.is_box() {
                for share in lit {
                    if share.offset == [0, 0] {
                        own = [
                            own[0] + share.rgb[0],
                            own[1] + share.rgb[1],
                            own[2] + share.rgb[2],
                        ];
                    } else {
                        splats.push(Splat {
                            x: x.wrapping_add_signed(i32::from(share.offset[0])),
                            y: y.wrapping_add_signed(i32::from(share.offset[1])),
                            rgb: share.rgb,
                        });
                    }
                }
            } else if finite {
                for share in lit {
                    let at = [
                        grid_point(x, share.position[0]),
                        grid_point(y, share.position[1]),
                    ];
                    spread.add(&taps, at, size, share.rgb);
                }
            }
            [radiance.r[i], radiance.g[i], radiance.b[i]] = own;
        }
        rejected
    }
}
