//! Where the pass stages run: the CPU's cores (the SoA pass systems) or a GPU (the same stages
//! as compute kernels, see [`crate::gpu`]).

use std::fmt;
use std::sync::Arc;

use bevy_ecs::resource::Resource;

use crate::gpu::GpuContext;

/// The device that renders the passes (`--device cpu|gpu`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RenderDevice {
    /// All cores, through the SoA pass systems (rayon).
    #[default]
    Cpu,
    /// The best GPU adapter found (see `realcam devices`).
    Gpu,
}

impl std::str::FromStr for RenderDevice {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "cpu" => Ok(RenderDevice::Cpu),
            "gpu" => Ok(RenderDevice::Gpu),
            other => Err(format!("unknown device '{other}': use cpu or gpu")),
        }
    }
}

impl fmt::Display for RenderDevice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            RenderDevice::Cpu => "cpu",
            RenderDevice::Gpu => "gpu",
        })
    }
}

/// Present when the passes render on a GPU: the CPU pass systems stand aside and the GPU's
/// run (see `pipeline::gpu`).
#[derive(Resource, Clone, Debug)]
pub struct GpuBackend(pub Arc<GpuContext>);
