//! WriteFilm: the pass's weighted samples added to each tile's sums, which ends the pass.

use bevy_ecs::system::{Query, Res, ResMut};
use bevy_ecs::world::Mut;

use super::run_on_tiles;
use crate::film::FilmTile;
use crate::film::splat::{PixelRect, SPREAD_BORDER, Spread};
use crate::lens::hero_wavelengths::SPLAT_RADIUS;
use crate::pipeline::Stage;
use crate::pipeline::resources::{PassState, RenderSettings, RenderStats, TileBatch};

/// WriteFilm: adds the pass's weighted samples to each tile's sums: its own samples in pixel
/// order, then the splats that land in it from every tile's list, the tiles in image order
/// (see [`crate::film::splat`]).
pub fn write_film(
    mut tiles: Query<(&mut FilmTile, &TileBatch)>,
    settings: Res<RenderSettings>,
    mut pass: ResMut<PassState>,
    mut stats: ResMut<RenderStats>,
) {
    let tiles: Vec<(Mut<FilmTile>, &TileBatch)> = tiles.iter_mut().collect();
    if !settings.filter.is_box() {
        write_spreads(tiles, &mut stats);
        pass.pending = false;
        return;
    }
    let mut sources: Vec<(PixelRect, &TileBatch)> = tiles
        .iter()
        .filter(|(_, batch)| !batch.splats.is_empty())
        .map(|(tile, batch)| (tile.rect(), *batch))
        .collect();
    sources.sort_by_key(|(rect, _)| (rect.y0, rect.x0));
    // Done when it returns; the tiles give back nothing.
    let _ = run_on_tiles(
        Stage::WriteFilm,
        tiles,
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
            let rect = tile.rect();
            for (source, batch) in &sources {
                if !source.may_reach(&rect, SPLAT_RADIUS as u32) {
                    continue;
                }
                for splat in batch.splats.iter().filter(|s| rect.contains(s.x, s.y)) {
                    let i = ((splat.y - rect.y0) * rect.width + (splat.x - rect.x0)) as usize;
                    tile.sum_r[i] += splat.rgb[0];
                    tile.sum_g[i] += splat.rgb[1];
                    tile.sum_b[i] += splat.rgb[2];
                }
            }
            tile.samples += 1;
        },
    );
    pass.pending = false;
}

/// WriteFilm with a filter wider than a pixel: every sum comes from the tiles' spreads, each
/// tile taking the part of every spread that covers it, the spreads in image order.
fn write_spreads(tiles: Vec<(Mut<FilmTile>, &TileBatch)>, stats: &mut RenderStats) {
    // An untouched spread adds only zeros.
    let mut spreads: Vec<(PixelRect, &Spread)> = tiles
        .iter()
        .filter(|(_, batch)| batch.spread.touched())
        .map(|(tile, batch)| (tile.rect(), &batch.spread))
        .collect();
    spreads.sort_by_key(|(rect, _)| (rect.y0, rect.x0));
    // Done when it returns; the tiles give back nothing.
    let _ = run_on_tiles(
        Stage::WriteFilm,
        tiles,
        None,
        stats,
        |(mut tile, _): (Mut<FilmTile>, &TileBatch)| {
            let tile = &mut *tile;
            let rect = tile.rect();
            let reaching = spreads
                .iter()
                .filter(|(source, _)| source.may_reach(&rect, SPREAD_BORDER));
            for (_, spread) in reaching {
                spread.add_to(rect, [&mut tile.sum_r, &mut tile.sum_g, &mut tile.sum_b]);
            }
            tile.samples += 1;
        },
    );
}
