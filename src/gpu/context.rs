//! Finding a GPU adapter and opening a device on it.
//!
//! realcam computes only (no window, no surface), so any adapter with compute shaders will do:
//! a discrete GPU is preferred, a software one (Mesa's lavapipe, which CI uses) is taken when it
//! is all there is.

use std::fmt;
use std::sync::{Arc, OnceLock};

/// Why no GPU device could be opened: shown to the user as is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GpuUnavailable(pub String);

impl fmt::Display for GpuUnavailable {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for GpuUnavailable {}

/// One adapter wgpu found, as `realcam devices` lists it.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct AdapterSummary {
    pub name: String,
    /// "discrete", "integrated", "virtual", "cpu" (a software rasteriser) or "other".
    pub kind: String,
    pub backend: String,
    pub driver: String,
}

impl AdapterSummary {
    fn of(info: &wgpu::AdapterInfo) -> AdapterSummary {
        let kind = match info.device_type {
            wgpu::DeviceType::DiscreteGpu => "discrete",
            wgpu::DeviceType::IntegratedGpu => "integrated",
            wgpu::DeviceType::VirtualGpu => "virtual",
            wgpu::DeviceType::Cpu => "cpu",
            wgpu::DeviceType::Other => "other",
        };
        let driver = [info.driver.as_str(), info.driver_info.as_str()]
            .into_iter()
            .filter(|s| !s.is_empty())
            .collect::<Vec<_>>()
            .join(" ");
        AdapterSummary {
            name: info.name.clone(),
            kind: kind.into(),
            backend: info.backend.to_string(),
            driver,
        }
    }
}

impl fmt::Display for AdapterSummary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({}, {}", self.name, self.kind, self.backend)?;
        if !self.driver.is_empty() {
            write!(f, ", {}", self.driver)?;
        }
        f.write_str(")")
    }
}

fn instance() -> wgpu::Instance {
    let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle();
    descriptor.backends = wgpu::Backends::PRIMARY;
    // Validation layers are for development; they slow every dispatch and print to stderr.
    descriptor.flags = wgpu::InstanceFlags::empty();
    wgpu::Instance::new(descriptor)
}

/// Every adapter wgpu finds with compute shaders, best first (discrete, integrated, others).
pub fn adapters() -> Vec<AdapterSummary> {
    let mut found: Vec<wgpu::AdapterInfo> =
        pollster::block_on(instance().enumerate_adapters(wgpu::Backends::PRIMARY))
            .iter()
            .filter(|adapter| {
                adapter.get_downlevel_capabilities().is_webgpu_compliant()
                    || adapter
                        .get_downlevel_capabilities()
                        .flags
                        .contains(wgpu::DownlevelFlags::COMPUTE_SHADERS)
            })
            .map(|adapter| adapter.get_info())
            .collect();
    found.sort_by_key(|info| preference(info.device_type));
    found.iter().map(AdapterSummary::of).collect()
}

fn preference(kind: wgpu::DeviceType) -> u8 {
    match kind {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

/// An open device and its queue: what every kernel runs on.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter: AdapterSummary,
    pub limits: wgpu::Limits,
    /// Whether the device was opened with timestamp queries (when the adapter offers them):
    /// [`super::compute::StepClock`] times kernels with them.
    pub timestamps: bool,
}

impl fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("GpuContext")
            .field("adapter", &self.adapter)
            .finish_non_exhaustive()
    }
}

impl GpuContext {
    /// Opens the best adapter found (see [`adapters`]) with the largest limits it offers: a
    /// million-triangle scene needs storage buffers far above WebGPU's defaults.
    pub fn open() -> Result<GpuContext, GpuUnavailable> {
        let instance = instance();
        let mut candidates =
            pollster::block_on(instance.enumerate_adapters(wgpu::Backends::PRIMARY));
        candidates.sort_by_key(|adapter| preference(adapter.get_info().device_type));
        let adapter = candidates
            .into_iter()
            .find(|adapter| {
                adapter
                    .get_downlevel_capabilities()
                    .flags
                    .contains(wgpu::DownlevelFlags::COMPUTE_SHADERS)
            })
            .ok_or_else(|| {
                GpuUnavailable(
                    "no GPU adapter found (wgpu looked for Vulkan, Metal and DX12 devices); \
                     on Linux install a Vulkan driver (for a software one: Debian's \
                     mesa-vulkan-drivers), or render with --device cpu"
                        .into(),
                )
            })?;
        let summary = AdapterSummary::of(&adapter.get_info());
        let limits = adapter.limits();
        let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("realcam"),
            required_features: if timestamps {
                wgpu::Features::TIMESTAMP_QUERY
            } else {
                wgpu::Features::empty()
            },
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| GpuUnavailable(format!("could not open the GPU {summary}: {e}")))?;
        // Errors are caught where they can happen (error scopes in `compute`); one that escapes
        // is reported, never a panic inside wgpu's callback.
        device.on_uncaptured_error(Arc::new(|error| {
            eprintln!("realcam: GPU error: {error}");
        }));
        Ok(GpuContext {
            device,
            queue,
            adapter: summary,
            limits,
            timestamps,
        })
    }

    /// One context for the whole process, opened on first use: opening a device costs tens of
    /// milliseconds on a GPU and more on a software one, and tests share it.
    pub fn shared() -> Result<Arc<GpuContext>, GpuUnavailable> {
        static SHARED: OnceLock<Result<Arc<GpuContext>, GpuUnavailable>> = OnceLock::new();
        SHARED
            .get_or_init(|| GpuContext::open().map(Arc::new))
            .clone()
    }

    /// The shared context for a test, or `None` (after saying why) where no adapter is found.
    /// With `REALCAM_REQUIRE_GPU=1` (CI sets it, with lavapipe installed) a missing adapter
    /// fails the test instead of skipping it.
    #[doc(hidden)]
    pub fn for_tests() -> Option<Arc<GpuContext>> {
        match GpuContext::shared() {
            Ok(context) => Some(context),
            Err(why) if std::env::var("REALCAM_REQUIRE_GPU").is_ok_and(|v| v == "1") => {
                panic!("REALCAM_REQUIRE_GPU=1 but {why}")
            }
            Err(why) => {
                eprintln!("skipped: {why}");
                None
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_listed_adapters_include_the_one_opened() {
        let Some(context) = GpuContext::for_tests() else {
            return;
        };
        assert!(adapters().contains(&context.adapter), "{:?}", adapters());
        assert!(context.limits.max_storage_buffers_per_shader_stage >= 8);
    }
}
