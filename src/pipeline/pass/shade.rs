//! Shade: the path-traced radiance arriving along every camera ray.

use bevy_ecs::system::{Query, Res, ResMut};
use bevy_ecs::world::Mut;

use super::{run_on_tiles, tile_parallelism};
use crate::accel::SceneAccel;
use crate::pipeline::Stage;
use crate::pipeline::resources::{
    PassCancel, RenderSettings, RenderStats, SceneEnvironment, TileBatch,
};
use crate::scene::MaterialLibrary;
use crate::shade::{Environment, LightSet, ShadeStats, Shader};

/// Shade: path-traced radiance arriving along every camera ray.
#[allow(clippy::too_many_arguments)]
pub fn shade(
    accel: Option<Res<SceneAccel>>,
    materials: Option<Res<MaterialLibrary>>,
    lights: Option<Res<LightSet>>,
    environment: Option<Res<SceneEnvironment>>,
    settings: Res<RenderSettings>,
    cancel: Option<Res<PassCancel>>,
    mut tiles: Query<&mut TileBatch>,
    mut stats: ResMut<RenderStats>,
) {
    let (Some(accel), Some(materials), Some(lights)) = (accel, materials, lights) else {
        return;
    };
    let default_env = SceneEnvironment(Environment::Uniform(glam::Vec3::ZERO));
    let environment = environment.as_deref().unwrap_or(&default_env);
    let shader = Shader {
        accel: &accel,
        materials: &materials,
        lights: &lights,
        environment: &environment.0,
        max_depth: settings.max_depth,
        seed: settings.seed,
        parallelism: tile_parallelism(tiles.iter().len()),
    };
    let shading: ShadeStats = run_on_tiles(
        Stage::Shade,
        tiles.iter_mut(),
        cancel.as_deref(),
        &mut stats,
        |mut batch: Mut<TileBatch>| {
            let mut tile_stats = ShadeStats::default();
            let batch = &mut *batch;
            shader.shade_batch(
                &batch.camera.rays,
                &batch.hits,
                &mut batch.radiance,
                &mut tile_stats,
            );
            tile_stats
        },
    )
    .sum();
    stats.rays_traced += shading.rays_traced;
    stats.shading += shading;
}
