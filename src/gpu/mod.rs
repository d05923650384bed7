//! The GPU backend: the pass stages (GenerateRays → Trace → Shade → Weight → WriteFilm) as
//! WGSL compute kernels on wgpu (Vulkan on Linux, Metal on macOS, DX12 on Windows; headless).
//!
//! The ECS stays the orchestration: the scene is loaded and its BVH built on the CPU once and
//! uploaded; the lens is derived on the CPU by the lens systems (change detection) and uploaded
//! as one small buffer; the kernels draw the same sample sequences as the CPU path, so the two
//! devices render the same estimator.
//!
//! - [`context`]: finding an adapter and opening a device (`realcam devices` lists them).
//! - [`compute`]: buffers, readback and kernels with errors as values, never panics.
//! - [`lens`]: the active lens for `camera_ray` (shaders: sampling, spectral, lens).
//! - [`lens_bench`]: the lens-tracing workload on the GPU (`realcam bench --device gpu`).
//! - [`scene`]: the BVH, triangles and textures uploaded once per scene, traversed and sampled
//!   in WGSL as the CPU does.
//! - [`shading`]: materials, lights and the environment for the path tracer of
//!   `shaders/shade.wgsl` (with the PCG streams of `shaders/rng.wgsl`).
//! - [`film`]: the film's sums on the GPU and the pass kernel.

pub mod compute;
pub mod context;
pub mod film;
pub mod lens;
pub mod lens_bench;
pub mod scene;
pub mod shading;

pub use context::{AdapterSummary, GpuContext, GpuUnavailable, adapters};
