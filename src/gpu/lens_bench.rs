//! `realcam bench --device gpu`: the lens-tracing workload ([`LensWorkload`], the rays the CPU
//! variants trace) through the lens on the GPU, with the pass kernel's own `lens_trace`.
//!
//! A GPU needs far more rays in flight than the CPU's 4096-ray workload: one dispatch traces
//! the workload's rays `repeats` times over (invocation i traces ray i mod N), so the rate is
//! the same work per ray, measured at a size that fills the GPU.

use std::time::{Duration, Instant};

use super::compute::{Access, Bindings, kernel_with, read_buffer, storage_buffer, zeroed_buffer};
use super::context::{GpuContext, GpuUnavailable};
use super::lens::{GpuLens, lens_source};
use crate::lens::camera::{FilmGeometry, LensCamera};
use crate::lens::workload::LensWorkload;

const BENCH_WGSL: &str = "
struct BenchRay { origin: vec4f, direction: vec4f }
struct BenchParams { count: u32, total: u32, row: u32, _pad: u32 }
@group(3) @binding(0) var<storage, read> bench_rays: array<BenchRay>;
@group(3) @binding(1) var<storage, read> bench_params: BenchParams;
// Per workload ray: 1 when it passed (every repeat writes the same value).
@group(3) @binding(2) var<storage, read_write> bench_passed: array<u32>;

@compute @workgroup_size(64, 1, 1)
fn bench_lens(@builtin(global_invocation_id) id: vec3u) {
    let invocation = id.y * bench_params.row + id.x;
    if invocation >= bench_params.total {
        return;
    }
    let i = invocation % bench_params.count;
    let r = bench_rays[i];
    var ray = LensRay(r.origin.xyz, r.direction.xyz, true);
    lens_trace(&ray, 0.0);
    bench_passed[i] = select(0u, 1u, ray.alive);
}
";

/// Invocations per row of the dispatch grid (a dispatch has at most 65 535 workgroups a side).
const ROW: u32 = 64 * 1024;

/// The workload on the GPU, ready to trace.
pub struct GpuLensBench {
    lens: GpuLens,
    params: wgpu::Buffer,
    passed: wgpu::Buffer,
    bindings: Bindings,
    /// Groups 1 and 2 (scene, shading), which the lens kernel does not read.
    empty: Bindings,
    kernel: wgpu::ComputePipeline,
    count: u32,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct BenchRay {
    origin: [f32; 4],
    direction: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct BenchParams {
    count: u32,
    total: u32,
    row: u32,
    _pad: u32,
}

impl GpuLensBench {
    /// Uploads `workload`'s lens (non-spectral, as the CPU variants trace it) and rays.
    pub fn new(
        context: &GpuContext,
        workload: &LensWorkload,
    ) -> Result<GpuLensBench, GpuUnavailable> {
        let camera = LensCamera {
            ghosts: None,
            system: &workload.system,
            pupil: &workload.pupil,
            film: FilmGeometry::new(1, 1, LensWorkload::FILM_DIAGONAL_MM),
            world_from_camera: glam::Mat4::IDENTITY,
            dispersion: None,
            wavelengths: 1,
        };
        let lens = GpuLens::upload(context, &camera, 0)?;
        let empty = Bindings::new(context, "unused", &[]);
        let rays: Vec<BenchRay> = workload
            .rays
            .iter()
            .map(|ray| BenchRay {
                origin: [ray.origin[0], ray.origin[1], ray.origin[2], 0.0],
                direction: [ray.direction[0], ray.direction[1], ray.direction[2], 0.0],
            })
            .collect();
        let count = rays.len() as u32;
        let rays = storage_buffer(context, "bench rays", &rays);
        let params = storage_buffer(
            context,
            "bench parameters",
            &[BenchParams {
                count,
                total: count,
                row: ROW,
                _pad: 0,
            }],
        );
        let passed = zeroed_buffer::<u32>(context, "bench passed", count as usize);
        let bindings = Bindings::new(
            context,
            "bench",
            &[
                (&rays, Access::ReadOnly),
                (&params, Access::ReadOnly),
                (&passed, Access::ReadWrite),
            ],
        );
        let source = [lens_source().as_str(), BENCH_WGSL].concat();
        let kernel = kernel_with(
            context,
            "lens bench",
            &source,
            "bench_lens",
            &[
                &lens.bindings.layout,
                &empty.layout,
                &empty.layout,
                &bindings.layout,
            ],
        )?;
        Ok(GpuLensBench {
            lens,
            params,
            passed,
            bindings,
            empty,
            kernel,
            count,
        })
    }

    /// Traces the workload `repeats` times over in one dispatch; the wall time from submit to
    /// done.
    pub fn trace(&self, context: &GpuContext, repeats: u32) -> Result<Duration, GpuUnavailable> {
        let total = self.count.saturating_mul(repeats.max(1));
        let params = BenchParams {
            count: self.count,
            total,
            row: ROW,
            _pad: 0,
        };
        context
            .queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let groups = [ROW / 64, total.div_ceil(ROW), 1];
        let start = Instant::now();
        super::compute::dispatch(
            context,
            &self.kernel,
            &[
                &self.lens.bindings.group,
                &self.empty.group,
                &self.empty.group,
                &self.bindings.group,
            ],
            groups,
        )?;
        Ok(start.elapsed())
    }

    /// How many of the workload's rays pass, as the last [`GpuLensBench::trace`] found.
    pub fn passed(&self, context: &GpuContext) -> Result<usize, GpuUnavailable> {
        let passed: Vec<u32> = read_buffer(context, &self.passed, self.count as usize)?;
        Ok(passed.iter().filter(|&&p| p == 1).count())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The GPU traces the workload's rays as the CPU's SoA kernel does: the same rays pass
    /// (f32 rounding may flip a ray grazing an aperture edge).
    #[test]
    fn the_gpu_passes_the_rays_the_cpu_passes() {
        let Some(context) = GpuContext::for_tests() else {
            return;
        };
        for lens in ["dgauss.50mm", "wide.22mm", "fisheye.10mm"] {
            let workload = LensWorkload::new(lens, 2048).unwrap();
            let cpu = workload.trace_soa(
                256,
                crate::lens::trace_batch::DEFAULT_KERNEL,
                crate::lens::trace_batch::Isa::detect(),
                &mut crate::batch::RayBatch::default(),
            );
            let bench = GpuLensBench::new(&context, &workload).unwrap();
            let elapsed = bench.trace(&context, 3).unwrap();
            assert!(elapsed > Duration::ZERO);
            let gpu = bench.passed(&context).unwrap();
            assert!(
                gpu.abs_diff(cpu) <= 2,
                "{lens}: GPU {gpu} vs CPU {cpu} of 2048"
            );
            assert!(cpu > 500, "{lens}: only {cpu} of 2048 pass");
        }
    }
}
