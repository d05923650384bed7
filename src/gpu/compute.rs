//! Buffers, readback and compute kernels, with wgpu's validation errors returned as values.

use wgpu::util::DeviceExt;

use super::context::{GpuContext, GpuUnavailable};

/// A storage buffer holding `data` (read-only or read-write in the kernel as its binding says).
/// An empty slice becomes one zeroed element: WGSL has no zero-sized bindings, and a kernel
/// given a count of 0 never reads it.
pub fn storage_buffer<T: bytemuck::Pod>(
    context: &GpuContext,
    label: &str,
    data: &[T],
) -> wgpu::Buffer {
    let zero = [T::zeroed()];
    let data = if data.is_empty() { &zero[..] } else { data };
    context
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytemuck::cast_slice(data),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
        })
}

/// A zeroed read-write storage buffer of `len` elements of `T` (at least one).
pub fn zeroed_buffer<T: bytemuck::Pod>(
    context: &GpuContext,
    label: &str,
    len: usize,
) -> wgpu::Buffer {
    context.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: (len.max(1) * size_of::<T>()) as u64,
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// A uniform buffer holding one `T`.
pub fn uniform_buffer<T: bytemuck::Pod>(
    context: &GpuContext,
    label: &str,
    value: &T,
) -> wgpu::Buffer {
    context
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytemuck::bytes_of(value),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        })
}

/// The first `len` elements of `buffer`, copied back after all submitted work is done.
pub fn read_buffer<T: bytemuck::Pod>(
    context: &GpuContext,
    buffer: &wgpu::Buffer,
    len: usize,
) -> Result<Vec<T>, GpuUnavailable> {
    let bytes = (len * size_of::<T>()) as u64;
    read_buffers(context, &[(buffer, bytes)], |parts| {
        bytemuck::cast_slice::<u8, T>(parts[0]).to_vec()
    })
}

/// The first bytes of several buffers (`(buffer, bytes)`, each a multiple of 4), copied back
/// together after all submitted work is done (one copy, one wait, one mapping) and handed to
/// `use_bytes` while mapped, so a large buffer is read in place instead of copied out first.
pub fn read_buffers<R>(
    context: &GpuContext,
    parts: &[(&wgpu::Buffer, u64)],
    use_bytes: impl FnOnce(&[&[u8]]) -> R,
) -> Result<R, GpuUnavailable> {
    let size: u64 = parts.iter().map(|&(_, bytes)| bytes).sum();
    if size == 0 {
        return Ok(use_bytes(&vec![&[][..]; parts.len()]));
    }
    let staging = context.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = context
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("readback"),
        });
    let mut offset = 0;
    for &(buffer, bytes) in parts {
        if bytes > 0 {
            encoder.copy_buffer_to_buffer(buffer, 0, &staging, offset, bytes);
        }
        offset += bytes;
    }
    context.queue.submit([encoder.finish()]);
    let slice = staging.slice(..);
    let (sender, receiver) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |result| {
        let _ = sender.send(result);
    });
    context
        .device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| GpuUnavailable(format!("the GPU stopped answering: {e}")))?;
    receiver
        .recv()
        .map_err(|_| GpuUnavailable("the GPU readback was dropped".into()))?
        .map_err(|e| GpuUnavailable(format!("could not read a GPU buffer back: {e}")))?;
    let result = {
        let view = slice
            .get_mapped_range()
            .map_err(|e| GpuUnavailable(format!("could not read a GPU buffer back: {e}")))?;
        let mut rest: &[u8] = &view;
        let pieces: Vec<&[u8]> = parts
            .iter()
            .map(|&(_, bytes)| {
                let (piece, after) = rest.split_at(bytes as usize);
                rest = after;
                piece
            })
            .collect();
        use_bytes(&pieces)
    };
    staging.unmap();
    Ok(result)
}

/// The kernel `entry` of `source` with `layout`: a shader that fails validation is an error
/// naming the kernel, not a panic.
fn compile(
    context: &GpuContext,
    label: &str,
    source: &str,
    entry: &str,
    layout: &wgpu::PipelineLayout,
) -> Result<wgpu::ComputePipeline, GpuUnavailable> {
    let scope = context
        .device
        .push_error_scope(wgpu::ErrorFilter::Validation);
    let module = context
        .device
        .create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(label),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
    let pipeline = context
        .device
        .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(label),
            layout: Some(layout),
            module: &module,
            entry_point: Some(entry),
            compilation_options: Default::default(),
            cache: None,
        });
    match pollster::block_on(scope.pop()) {
        None => Ok(pipeline),
        Some(error) => Err(GpuUnavailable(format!(
            "the GPU kernel {label} is invalid: {error}"
        ))),
    }
}

/// How a kernel sees one buffer of a [`Bindings`] set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    Uniform,
    ReadOnly,
    ReadWrite,
}

/// One bind group with its layout: the buffers of one part of the renderer (the lens, the
/// scene, the shading data, a pass's film), bound to bindings 0, 1, … in order. Kernels are
/// made with explicit layouts ([`kernel_with`]) so that a kernel may leave bindings unused.
#[derive(Debug)]
pub struct Bindings {
    pub layout: wgpu::BindGroupLayout,
    pub group: wgpu::BindGroup,
}

impl Bindings {
    pub fn new(context: &GpuContext, label: &str, buffers: &[(&wgpu::Buffer, Access)]) -> Bindings {
        let layout_entries: Vec<wgpu::BindGroupLayoutEntry> = buffers
            .iter()
            .enumerate()
            .map(|(binding, (_, access))| wgpu::BindGroupLayoutEntry {
                binding: binding as u32,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: match access {
                        Access::Uniform => wgpu::BufferBindingType::Uniform,
                        Access::ReadOnly => wgpu::BufferBindingType::Storage { read_only: true },
                        Access::ReadWrite => wgpu::BufferBindingType::Storage { read_only: false },
                    },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            })
            .collect();
        let layout = context
            .device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(label),
                entries: &layout_entries,
            });
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(binding, (buffer, _))| wgpu::BindGroupEntry {
                binding: binding as u32,
                resource: buffer.as_entire_binding(),
            })
            .collect();
        let group = context
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: &layout,
                entries: &entries,
            });
        Bindings { layout, group }
    }
}

/// A compute kernel: `entry` of the WGSL `source`, with explicit bind group layouts (group i =
/// `layouts[i]`, so a kernel may leave bindings unused).
pub fn kernel_with(
    context: &GpuContext,
    label: &str,
    source: &str,
    entry: &str,
    layouts: &[&wgpu::BindGroupLayout],
) -> Result<wgpu::ComputePipeline, GpuUnavailable> {
    let layouts: Vec<Option<&wgpu::BindGroupLayout>> = layouts.iter().copied().map(Some).collect();
    let layout = context
        .device
        .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(label),
            bind_group_layouts: &layouts,
            immediate_size: 0,
        });
    compile(context, label, source, entry, &layout)
}

/// Runs `pipeline` over `workgroups` with `bind_groups` (group i = the i-th), and waits for it.
pub fn dispatch(
    context: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    bind_groups: &[&wgpu::BindGroup],
    workgroups: [u32; 3],
) -> Result<(), GpuUnavailable> {
    let submission = submit(context, pipeline, bind_groups, workgroups)?;
    wait_for(context, submission)
}

/// Waits until the GPU has finished `submission` (and everything submitted before it).
pub fn wait_for(
    context: &GpuContext,
    submission: wgpu::SubmissionIndex,
) -> Result<(), GpuUnavailable> {
    context
        .device
        .poll(wgpu::PollType::Wait {
            submission_index: Some(submission),
            timeout: None,
        })
        .map_err(|e| GpuUnavailable(format!("the GPU stopped answering: {e}")))?;
    Ok(())
}

/// Queues `pipeline` over `workgroups` with `bind_groups` (group i = the i-th) without waiting:
/// the CPU can prepare the next dispatch while the GPU runs this one.
pub fn submit(
    context: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    bind_groups: &[&wgpu::BindGroup],
    workgroups: [u32; 3],
) -> Result<wgpu::SubmissionIndex, GpuUnavailable> {
    submit_steps(context, &[(pipeline, workgroups)], bind_groups)
}

/// Queues `steps` (kernels with their workgroups, sharing `bind_groups`) in one submission, in
/// order: each step sees what the one before wrote (wgpu puts a barrier between dispatches
/// that share a storage buffer).
pub fn submit_steps(
    context: &GpuContext,
    steps: &[(&wgpu::ComputePipeline, [u32; 3])],
    bind_groups: &[&wgpu::BindGroup],
) -> Result<wgpu::SubmissionIndex, GpuUnavailable> {
    submit_steps_timed(context, steps, bind_groups, None)
}

/// [`submit_steps`], and with a `clock` each step in a compute pass of its own whose start and
/// end the GPU stamps (read them with [`StepClock::read`] once the submission is done).
pub fn submit_steps_timed(
    context: &GpuContext,
    steps: &[(&wgpu::ComputePipeline, [u32; 3])],
    bind_groups: &[&wgpu::BindGroup],
    clock: Option<&StepClock>,
) -> Result<wgpu::SubmissionIndex, GpuUnavailable> {
    let scope = context
        .device
        .push_error_scope(wgpu::ErrorFilter::Validation);
    let mut encoder = context
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    let encode = |pass: &mut wgpu::ComputePass, steps: &[(&wgpu::ComputePipeline, [u32; 3])]| {
        for (group, bind_group) in bind_groups.iter().enumerate() {
            pass.set_bind_group(group as u32, *bind_group, &[]);
        }
        for (pipeline, workgroups) in steps {
            pass.set_pipeline(pipeline);
            pass.dispatch_workgroups(workgroups[0], workgroups[1], workgroups[2]);
        }
    };
    match clock {
        None => encode(
            &mut encoder.begin_compute_pass(&wgpu::ComputePassDescriptor::default()),
            steps,
        ),
        Some(clock) => {
            // The clock times its first `clock.steps` steps; any after them run untimed.
            let timed = steps.len().min(clock.steps as usize);
            for (k, step) in steps.iter().enumerate() {
                let k = k as u32;
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                    label: None,
                    timestamp_writes: ((k as usize) < timed).then_some(
                        wgpu::ComputePassTimestampWrites {
                            query_set: &clock.queries,
                            beginning_of_pass_write_index: Some(2 * k),
                            end_of_pass_write_index: Some(2 * k + 1),
                        },
                    ),
                });
                encode(&mut pass, std::slice::from_ref(step));
            }
            let stamps = 2 * timed as u32;
            encoder.resolve_query_set(&clock.queries, 0..stamps, &clock.resolved, 0);
        }
    }
    let submission = context.queue.submit([encoder.finish()]);
    if let Some(error) = pollster::block_on(scope.pop()) {
        return Err(GpuUnavailable(format!("a GPU dispatch failed: {error}")));
    }
    Ok(submission)
}

/// The GPU's own clock around each step of a submission (wgpu's timestamp queries): how long
/// each kernel ran on the device, apart from the time the CPU waits and the other kernels of
/// the same submission.
#[derive(Debug)]
pub struct StepClock {
    queries: wgpu::QuerySet,
    /// The stamps, resolved into GPU ticks (two per step: start, end).
    resolved: wgpu::Buffer,
    /// Steps it can time in one submission.
    steps: u32,
    /// Nanoseconds per tick.
    period_ns: f64,
}

impl StepClock {
    /// A clock for submissions of up to `steps` steps, or `None` where the device was opened
    /// without timestamp queries (see [`GpuContext::timestamps`]).
    pub fn new(context: &GpuContext, steps: u32) -> Option<StepClock> {
        if !context.timestamps {
            return None;
        }
        let queries = context.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("step clock"),
            ty: wgpu::QueryType::Timestamp,
            count: 2 * steps,
        });
        let resolved = context.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("step clock stamps"),
            size: u64::from(2 * steps) * 8,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        Some(StepClock {
            queries,
            resolved,
            steps,
            period_ns: f64::from(context.queue.get_timestamp_period()),
        })
    }

    /// How long each of the last submission's first `steps` steps ran, once it is done (this
    /// waits for it).
    pub fn read(
        &self,
        context: &GpuContext,
        steps: usize,
    ) -> Result<Vec<std::time::Duration>, GpuUnavailable> {
        let steps = steps.min(self.steps as usize);
        let stamps: Vec<u64> = read_buffer(context, &self.resolved, 2 * steps)?;
        Ok(stamps
            .chunks_exact(2)
            .map(|pair| {
                let ticks = pair[1].saturating_sub(pair[0]);
                std::time::Duration::from_nanos((ticks as f64 * self.period_ns).round() as u64)
            })
            .collect())
    }
}

/// Workgroups of `size` threads covering `n` items.
pub fn workgroups_for(n: usize, size: u32) -> u32 {
    (n as u32).div_ceil(size).max(1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_kernel_doubles_every_element_and_reads_back() {
        let Some(context) = GpuContext::for_tests() else {
            return;
        };
        let source = "@group(0) @binding(0) var<storage, read_write> values: array<f32>;\n\
            @compute @workgroup_size(64) fn main(@builtin(global_invocation_id) id: vec3u) {\n\
            if id.x < arrayLength(&values) { values[id.x] = 2.0 * values[id.x]; } }";
        let input: Vec<f32> = (0..1000).map(|i| i as f32).collect();
        let buffer = storage_buffer(&context, "values", &input);
        let bindings = Bindings::new(&context, "values", &[(&buffer, Access::ReadWrite)]);
        let pipeline =
            kernel_with(&context, "double", source, "main", &[&bindings.layout]).unwrap();
        dispatch(
            &context,
            &pipeline,
            &[&bindings.group],
            [workgroups_for(1000, 64), 1, 1],
        )
        .unwrap();
        let output: Vec<f32> = read_buffer(&context, &buffer, 1000).unwrap();
        assert!(output.iter().enumerate().all(|(i, &v)| v == 2.0 * i as f32));
    }

    #[test]
    fn explicit_layouts_allow_unused_bindings() {
        let Some(context) = GpuContext::for_tests() else {
            return;
        };
        let source = "@group(0) @binding(1) var<storage, read_write> out: array<u32>;\n\
            @compute @workgroup_size(1) fn main() { out[0] = 7u; }";
        let unused = storage_buffer(&context, "unused", &[1u32]);
        let out = zeroed_buffer::<u32>(&context, "out", 1);
        let bindings = Bindings::new(
            &context,
            "set",
            &[(&unused, Access::ReadOnly), (&out, Access::ReadWrite)],
        );
        let pipeline = kernel_with(&context, "seven", source, "main", &[&bindings.layout]).unwrap();
        dispatch(&context, &pipeline, &[&bindings.group], [1, 1, 1]).unwrap();
        assert_eq!(read_buffer::<u32>(&context, &out, 1).unwrap(), vec![7]);
    }

    /// Two kernels timed apart: the one that loops a thousand times longer takes longer, and
    /// both took some time.
    #[test]
    fn the_step_clock_times_each_kernel_of_a_submission() {
        let Some(context) = GpuContext::for_tests() else {
            return;
        };
        let Some(clock) = StepClock::new(&context, 2) else {
            eprintln!("skipped: {} has no timestamp queries", context.adapter);
            return;
        };
        let source = "@group(0) @binding(0) var<storage, read_write> out: array<f32>;\n\
            fn spin(n: u32, id: u32) { var x = f32(id); for (var i = 0u; i < n; i++) \
            { x = sin(x) + 1.0; } out[id] = x; }\n\
            @compute @workgroup_size(64) fn short(@builtin(global_invocation_id) id: vec3u) \
            { spin(10u, id.x); }\n\
            @compute @workgroup_size(64) fn long(@builtin(global_invocation_id) id: vec3u) \
            { spin(10000u, id.x); }";
        let out = zeroed_buffer::<f32>(&context, "out", 64 * 64);
        let bindings = Bindings::new(&context, "out", &[(&out, Access::ReadWrite)]);
        let short = kernel_with(&context, "short", source, "short", &[&bindings.layout]).unwrap();
        let long = kernel_with(&context, "long", source, "long", &[&bindings.layout]).unwrap();
        let steps = [(&short, [64, 1, 1]), (&long, [64, 1, 1])];
        let submission =
            submit_steps_timed(&context, &steps, &[&bindings.group], Some(&clock)).unwrap();
        wait_for(&context, submission).unwrap();
        let times = clock.read(&context, 2).unwrap();
        assert_eq!(times.len(), 2);
        assert!(times[1] > times[0], "{times:?}");
        assert!(times[0] > std::time::Duration::ZERO, "{times:?}");
        // A clock for fewer steps than a submission has times the first and still runs all.
        let small = StepClock::new(&context, 1).unwrap();
        let writes = "@group(0) @binding(0) var<storage, read_write> out: array<f32>;\n\
            @compute @workgroup_size(64) fn one(@builtin(global_invocation_id) id: vec3u) \
            { out[id.x] = 1.0; }\n\
            @compute @workgroup_size(64) fn two(@builtin(global_invocation_id) id: vec3u) \
            { out[id.x] = out[id.x] + 2.0; }";
        let one = kernel_with(&context, "one", writes, "one", &[&bindings.layout]).unwrap();
        let two = kernel_with(&context, "two", writes, "two", &[&bindings.layout]).unwrap();
        let steps = [(&one, [64, 1, 1]), (&two, [64, 1, 1])];
        let submission =
            submit_steps_timed(&context, &steps, &[&bindings.group], Some(&small)).unwrap();
        wait_for(&context, submission).unwrap();
        assert_eq!(small.read(&context, 2).unwrap().len(), 1);
        let written: Vec<f32> = read_buffer(&context, &out, 64 * 64).unwrap();
        assert!(
            written.iter().all(|&x| x == 3.0),
            "both steps ran, in order"
        );
    }

    #[test]
    fn an_invalid_shader_is_an_error_naming_the_kernel() {
        let Some(context) = GpuContext::for_tests() else {
            return;
        };
        let error = kernel_with(
            &context,
            "broken",
            "fn main() { let x: f32 = true; }",
            "main",
            &[],
        )
        .unwrap_err();
        assert!(error.0.contains("broken"), "{error}");
    }
}
