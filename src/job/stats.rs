//! `--stats`: the run's counters, stage times and frames as JSON.

use serde_json::{Value, json};

use super::frame::FrameReport;
use crate::lens::elements::LensDerivationStats;
use crate::pipeline::{GpuBackend, RenderStats, Renderer, Stage};

/// Seconds per stage, by the stage's name.
fn per_stage(times: &[std::time::Duration; Stage::ALL.len()]) -> Value {
    Stage::ALL
        .iter()
        .map(|s| {
            (
                s.name().to_string(),
                json!(times[*s as usize].as_secs_f64()),
            )
        })
        .collect::<serde_json::Map<_, _>>()
        .into()
}

pub(super) fn stats_json(
    renderer: &mut Renderer,
    frames: &[FrameReport],
    wall_seconds: f64,
) -> Value {
    let stats = renderer.world.resource::<RenderStats>().clone();
    let lens_stats = *renderer.world.resource::<LensDerivationStats>();
    let pass_seconds: f64 = Stage::ALL[3..]
        .iter()
        .map(|s| stats.stage_time[*s as usize].as_secs_f64())
        .sum();
    let adapter = renderer
        .world
        .get_resource::<GpuBackend>()
        .map(|backend| backend.0.adapter.to_string());
    json!({
        "device": renderer.device(),
        "gpu_adapter": adapter,
        "wall_seconds": wall_seconds,
        "gpu_kernel_seconds": stats.gpu_kernel_time.as_secs_f64(),
        "gpu_kernel_busy_seconds": stats
            .gpu_kernel_busy
            .iter()
            .map(|(kernel, time)| (kernel.to_string(), json!(time.as_secs_f64())))
            .collect::<serde_json::Map<_, _>>(),
        "stage_seconds": per_stage(&stats.stage_time),
        "stage_busy_seconds": per_stage(&stats.stage_busy),
        "threads": rayon::current_num_threads(),
        "scene_loads": stats.scene_loads,
        "bvh_builds": stats.bvh_builds,
        "triangles": stats.triangles,
        "bvh_nodes": stats.bvh_nodes,
        "camera_samples": stats.camera_samples,
        "lens_pass_fraction": if stats.camera_samples > 0 { stats.lens_rays_passed as f64 / stats.camera_samples as f64 } else { 0.0 },
        "rays_traced": stats.rays_traced,
        "rejected_samples": stats.rejected_samples,
        "camera_rays_escaped": stats.shading.camera_rays_escaped,
        "bounce_rays_escaped": stats.shading.bounce_rays_escaped,
        "emitter_hits": stats.shading.emitter_hits,
        "light_samples": {
            "drawn": stats.shading.light_samples,
            "from_behind": stats.shading.light_samples_behind,
            "blocked": stats.shading.light_samples_blocked,
            "reached": stats.shading.light_samples_reached,
        },
        "warnings": frames.iter().flat_map(|f| f.warnings.iter()).collect::<Vec<_>>(),
        "samples_per_second": if pass_seconds > 0.0 { stats.camera_samples as f64 / pass_seconds } else { 0.0 },
        "frames": frames.iter().map(FrameReport::to_json).collect::<Vec<_>>(),
        "lens_derivation": {
            "geometry_runs": lens_stats.geometry_runs,
            "placement_runs": lens_stats.placement_runs,
            "pupil_runs": lens_stats.pupil_runs,
            "seconds": lens_stats.total_time.as_secs_f64(),
        },
    })
}
