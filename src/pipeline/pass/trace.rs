//! Trace: the closest hits of every tile's camera rays.

use bevy_ecs::system::{Query, Res, ResMut};
use bevy_ecs::world::Mut;

use super::{run_on_tiles, tile_parallelism};
use crate::accel::SceneAccel;
use crate::pipeline::Stage;
use crate::pipeline::resources::{PassCancel, RenderStats, TileBatch};

/// Trace: closest hits of every tile's camera rays.
pub fn trace_rays(
    accel: Option<Res<SceneAccel>>,
    cancel: Option<Res<PassCancel>>,
    mut tiles: Query<&mut TileBatch>,
    mut stats: ResMut<RenderStats>,
) {
    let Some(accel) = accel else { return };
    let parallelism = tile_parallelism(tiles.iter().len());
    let traced: u64 = run_on_tiles(
        Stage::Trace,
        tiles.iter_mut(),
        cancel.as_deref(),
        &mut stats,
        |mut batch: Mut<TileBatch>| {
            let batch = &mut *batch;
            accel.intersect_batch_with(&batch.camera.rays, &mut batch.hits, parallelism);
            batch.camera.rays.alive_count() as u64
        },
    )
    .sum();
    stats.rays_traced += traced;
}
