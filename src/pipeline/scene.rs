//! The scene stages: LoadScene reads the glTF a new [`SceneSource`] names and spawns its
//! objects; BuildBvh builds the BVH over new mesh instances, then the light set.

use std::time::Instant;

use bevy_ecs::change_detection::DetectChanges;
use bevy_ecs::entity::Entity;
use bevy_ecs::query::{Added, With};
use bevy_ecs::schedule::{IntoScheduleConfigs, Schedule};
use bevy_ecs::system::{Commands, Query, Res, ResMut};
use bevy_ecs::world::Ref;

use super::Stage;
use super::resources::{
    PipelineFault, RenderStats, SceneBounds, SceneEnvironment, SceneInputs, SceneObject,
    SceneSource, SceneWarnings,
};
use crate::accel::SceneAccel;
use crate::scene::{LoadedScene, MaterialLibrary, MeshInstance, PunctualLight};
use crate::shade::{Environment, LightSet};

/// Adds the LoadScene and BuildBvh systems to `schedule`.
pub(super) fn add_systems(schedule: &mut Schedule) {
    schedule.add_systems((
        load_scene.in_set(Stage::LoadScene),
        (build_bvh, build_lights).chain().in_set(Stage::BuildBvh),
    ));
}

/// LoadScene: reads the glTF named by a new [`SceneSource`] and spawns its objects.
pub fn load_scene(
    mut commands: Commands,
    source: Option<Res<SceneSource>>,
    old: Query<Entity, With<SceneObject>>,
    mut stats: ResMut<RenderStats>,
) {
    let Some(source) = source else { return };
    if !source.is_changed() {
        return;
    }
    let start = Instant::now();
    let loaded = match source.embedded {
        Some(bytes) => crate::scene::load_gltf_bytes(bytes, None, &source.path),
        None => crate::scene::load_gltf(&source.path),
    };
    match loaded {
        Ok(scene) => {
            for entity in &old {
                commands.entity(entity).despawn();
            }
            spawn_scene(&mut commands, scene);
            stats.scene_loads += 1;
        }
        Err(e) => commands.insert_resource(PipelineFault(format!("{e:#}"))),
    }
    stats.add_time(Stage::LoadScene, start);
}

fn spawn_scene(commands: &mut Commands, scene: LoadedScene) {
    for instance in scene.instances {
        commands.spawn((instance, SceneObject));
    }
    for light in scene.lights {
        commands.spawn((light, SceneObject));
    }
    for camera in scene.cameras {
        commands.spawn((camera, SceneObject));
    }
    commands.insert_resource(scene.materials);
    commands.insert_resource(SceneBounds(scene.bounds));
    commands.insert_resource(SceneWarnings(scene.warnings));
    commands.insert_resource(SceneInputs(scene.inputs));
}

/// BuildBvh: builds the BVH when mesh instances were added.
pub fn build_bvh(
    mut commands: Commands,
    added: Query<(), Added<MeshInstance>>,
    instances: Query<&MeshInstance>,
    materials: Option<Res<MaterialLibrary>>,
    mut stats: ResMut<RenderStats>,
) {
    let Some(materials) = materials else { return };
    if added.is_empty() && !materials.is_changed() {
        return;
    }
    let start = Instant::now();
    match SceneAccel::build(instances.iter(), &materials) {
        Ok(accel) => {
            stats.bvh_builds += 1;
            stats.triangles = accel.triangle_count() as u64;
            stats.bvh_nodes = accel.node_count() as u64;
            commands.insert_resource(accel);
        }
        Err(e) => commands.insert_resource(PipelineFault(format!("{e:#}"))),
    }
    stats.add_time(Stage::BuildBvh, start);
}

/// BuildBvh (after the BVH): the light set, rebuilt when the BVH, lights or environment change.
pub fn build_lights(
    mut commands: Commands,
    accel: Option<Res<SceneAccel>>,
    materials: Option<Res<MaterialLibrary>>,
    environment: Option<Res<SceneEnvironment>>,
    lights: Query<Ref<PunctualLight>>,
    mut stats: ResMut<RenderStats>,
) {
    let (Some(accel), Some(materials)) = (accel, materials) else {
        return;
    };
    let environment_changed = environment.as_ref().is_some_and(|e| e.is_changed());
    let lights_changed = lights.iter().any(|l| l.is_changed());
    if !(accel.is_changed() || environment_changed || lights_changed) {
        return;
    }
    let start = Instant::now();
    let punctual: Vec<PunctualLight> = lights.iter().map(|l| (*l).clone()).collect();
    let black = Environment::Uniform(glam::Vec3::ZERO);
    let environment = environment.as_deref().map_or(&black, |e| &e.0);
    commands.insert_resource(LightSet::build(&punctual, &accel, &materials, environment));
    stats.add_time(Stage::BuildBvh, start);
}
