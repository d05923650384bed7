//! The render schedule: one bevy_ecs [`Schedule`] whose stages are named [`SystemSet`]s.
//!
//! ```text
//! LoadScene → BuildBvh → DeriveLens → GenerateRays → Trace → Shade → LandCompanions → Weight → WriteFilm
//! └─ once per scene ─┘   └ on change ┘ └──────────────────── once per sample pass ───────────────────┘
//! ```
//!
//! Every run of the schedule is cheap when nothing changed: LoadScene acts only on a new
//! [`SceneSource`], BuildBvh only on new mesh instances, the lens systems only on changed lens
//! entities (change detection), and the pass stages only while a pass is pending. The pass
//! stages work tile by tile in parallel (rayon); rays travel between them as SoA batches in
//! each tile's [`TileBatch`]. See ARCHITECTURE.md for what each stage reads and writes.
//!
//! Laid out as bevy's own crates are: this module chains the stages and lets each stage group
//! add its systems (`scene`: LoadScene and BuildBvh; the lens's derivation systems for
//! DeriveLens; `pass`: the six pass stages); `resources` holds what they share and
//! `renderer` the [`Renderer`] that drives them.

#[cfg(test)]
mod allocations;
mod device;
mod gpu;
mod pass;
mod renderer;
mod resources;
mod scene;

use bevy_ecs::schedule::{IntoScheduleConfigs, Schedule, ScheduleLabel, SystemSet};

use crate::lens::elements::{LensDerivation, add_lens_systems};

pub use crate::lens::camera::{CameraPose, FilmResolution};
pub use device::{GpuBackend, RenderDevice};
pub use pass::{generate_rays, shade, trace_rays, weight, write_film};
pub use renderer::Renderer;
pub use resources::{
    PassCancel, PassState, PipelineFault, RenderSettings, RenderStats, SceneBounds,
    SceneEnvironment, SceneInputs, SceneObject, SceneSource, SceneWarnings, TileBatch,
};
pub use scene::{build_bvh, build_lights, load_scene};

/// The schedule's label.
#[derive(ScheduleLabel, Clone, Debug, PartialEq, Eq, Hash)]
pub struct RenderSchedule;

/// The stages, in the order they run.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Stage {
    LoadScene,
    BuildBvh,
    DeriveLens,
    GenerateRays,
    Trace,
    Shade,
    LandCompanions,
    Weight,
    WriteFilm,
}

impl Stage {
    pub const ALL: [Stage; 9] = [
        Stage::LoadScene,
        Stage::BuildBvh,
        Stage::DeriveLens,
        Stage::GenerateRays,
        Stage::Trace,
        Stage::Shade,
        Stage::LandCompanions,
        Stage::Weight,
        Stage::WriteFilm,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Stage::LoadScene => "load_scene",
            Stage::BuildBvh => "build_bvh",
            Stage::DeriveLens => "derive_lens",
            Stage::GenerateRays => "generate_rays",
            Stage::Trace => "trace",
            Stage::Shade => "shade",
            Stage::LandCompanions => "land_companions",
            Stage::Weight => "weight",
            Stage::WriteFilm => "write_film",
        }
    }
}

/// Builds the schedule with every stage.
pub fn render_schedule() -> Schedule {
    let mut schedule = Schedule::new(RenderSchedule);
    // Stage::ALL is the order: each stage runs before the next.
    for pair in Stage::ALL.windows(2) {
        schedule.configure_sets(pair[0].before(pair[1]));
    }
    add_lens_systems(&mut schedule);
    schedule.configure_sets(
        (
            LensDerivation::Geometry,
            LensDerivation::Placement,
            LensDerivation::Pupil,
        )
            .in_set(Stage::DeriveLens),
    );
    scene::add_systems(&mut schedule);
    pass::add_systems(&mut schedule);
    gpu::add_systems(&mut schedule);
    schedule
}
