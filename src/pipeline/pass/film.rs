//! WriteFilm: the pass's weighted samples added to each tile's sums, which ends the pass.

use bevy_ecs::system::{Query, ResMut};
use bevy_ecs::world::Mut;

use super::run_on_tiles;
use crate::film::FilmTile;
use crate::pipeline::Stage;
use crate::pipeline::resources::{PassState, RenderStats, TileBatch};

/// WriteFilm: adds the pass's weighted samples to each tile's sums.
pub fn write_film(
    mut tiles: Query<(&mut FilmTile, &TileBatch)>,
    mut pass: ResMut<PassState>,
    mut stats: ResMut<RenderStats>,
) {
    run_on_tiles(
        Stage::WriteFilm,
        tiles.iter_mut(),
        None,
        &mut stats,
        |(mut tile, batch): (Mut<FilmTile>, &TileBatch)| {
            let tile = &mut *tile;
            // Camera rays were generated in `FilmTile::pixels` order: index i is local pixel i.
            for i in 0..tile.sum_r.len() {
                tile.sum_r[i] += batch.radiance.r[i];
                tile.sum_g[i] += batch.radiance.g[i];
                tile.sum_b[i] += batch.radiance.b[i];
            }
            tile.samples += 1;
        },
    );
    pass.pending = false;
}
