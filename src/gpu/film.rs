//! The film on the GPU and the pass kernel that renders into it.
//!
//! The film's sums stay on the device between passes (only a pass's parameters go up per
//! pass); they come back to the CPU's film tiles when an image is wanted (an output, a
//! checkpoint, a live preview). One invocation owns one pixel's sums, so accumulation is in a
//! fixed order and a seed gives the same image on every run.

/// The pass kernel's entry points (pass.wgsl): they call every stage's functions.
pub const PASS_WGSL: &str = include_str!("shaders/pass.wgsl");

/// The second kernel of a several-sample dispatch (or of every dispatch with a filter wider
/// than a pixel): each pixel adds its samples from the scratch buffer to its sums, in index
/// order. It reads only the pass's own bindings.
const ACCUMULATE_WGSL: &str = include_str!("shaders/accumulate.wgsl");

/// The film's bindings and the pass parameters, which both kernels' sources declare.
const PASS_FILM_WGSL: &str = include_str!("shaders/pass_film.wgsl");

/// The pass kernel's whole WGSL source for samples of `wavelengths` wavelengths (see
/// [`super::lens::lens_source_for`]): every stage's functions, then the entry point.
pub fn pass_source(wavelengths: u32) -> String {
    [
        super::lens::lens_source_for(wavelengths).as_str(),
        super::shading::RNG_WGSL,
        super::scene::SCENE_WGSL,
        super::shading::SHADE_WGSL,
        PASS_FILM_WGSL,
        PASS_WGSL,
    ]
    .concat()
}

/// The accumulating kernels' source: the shared constants, the film's bindings, the kernels.
fn accumulate_source() -> String {
    [
        super::lens::shared_constants().as_str(),
        PASS_FILM_WGSL,
        ACCUMULATE_WGSL,
    ]
    .concat()
}

use std::collections::{BTreeMap, VecDeque};
use std::time::Duration;

use super::compute::{
    Access, Bindings, StepClock, kernel_with, read_buffers, storage_buffer, zeroed_buffer,
};
use super::context::{GpuContext, GpuUnavailable};
use crate::film::filter::Filter;
use crate::film::samples::SampleSequence;
use crate::shade::ShadeStats;

/// The pass kernel's per-pass parameters (`PassParams` in pass.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
struct PassParams {
    width: u32,
    height: u32,
    sample: u32,
    step: u32,
    count: u32,
    wavelengths: u32,
    filtered: u32,
    _pad: u32,
}

/// What the passes since the last [`GpuFilm::read`] counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PassCounts {
    /// What shading met, as the CPU counts it; its `rays_traced` includes the camera rays.
    pub shading: ShadeStats,
    /// Camera rays the lens let through.
    pub lens_rays_passed: u64,
    /// Samples whose weighted radiance was not finite (kept off the film).
    pub rejected_samples: u64,
}

/// The counters pass.wgsl keeps: ten 64-bit numbers as (low, high) pairs.
const COUNTER_WORDS: usize = 20;

impl PassCounts {
    fn of(words: &[u32]) -> PassCounts {
        let count = |i: usize| u64::from(words[2 * i]) | (u64::from(words[2 * i + 1]) << 32);
        PassCounts {
            shading: ShadeStats {
                camera_rays_escaped: count(0),
                bounce_rays_escaped: count(1),
                emitter_hits: count(2),
                light_samples: count(3),
                light_samples_behind: count(4),
                light_samples_blocked: count(5),
                light_samples_reached: count(6),
                rays_traced: count(7),
            },
            lens_rays_passed: count(8),
            rejected_samples: count(9),
        }
    }
}

/// The sums of one film on the GPU, and the pass kernel bound to them.
pub struct GpuFilm {
    pub width: u32,
    pub height: u32,
    /// Wavelengths per sample: with more than one, each sample leaves that many shares for
    /// the pixels they land in (`render_wavelengths`, `accumulate_splats`).
    pub wavelengths: u32,
    /// How each share spreads over the pixels around its film point: with any filter but the
    /// box, every dispatch ends in `accumulate_filtered`.
    pub filter: Filter,
    params: wgpu::Buffer,
    film: wgpu::Buffer,
    counters: wgpu::Buffer,
    /// Each sample's weighted radiance, `[k][pixel]` (with several wavelengths, each sample's
    /// shares, `[k][pixel][wavelength]`), between the two kernels of a dispatch of several
    /// samples (one element when a dispatch renders one sample per pixel into the film). Sized
    /// for the largest dispatch so far ([`GpuFilm::reserve_samples`]): a live lab's
    /// one-sample passes never hold a job's hundreds of MiB.
    scratch: wgpu::Buffer,
    /// The filter's weights per axis ([`Filter::tap_table`], for accumulate.wgsl's
    /// `pass_filter_tap`).
    filter_taps: wgpu::Buffer,
    /// With several wavelengths, how far each sample's shares reach (pass_film.wgsl's
    /// `pass_reach`), so the gathers skip the pixels whose shares cannot reach theirs. Sized
    /// with `scratch`.
    reach: wgpu::Buffer,
    /// Sample indices per pixel `scratch` and `reach` hold.
    scratch_samples: u32,
    bindings: Bindings,
    kernels: Option<Kernels>,
    /// Sample indices per pixel a dispatch renders (the scratch buffer holds their shares).
    per_dispatch: u32,
    /// Passes submitted and perhaps not yet done, oldest first.
    in_flight: VecDeque<wgpu::SubmissionIndex>,
    /// With `REALCAM_GPU_TIMESTAMPS=1` (on a device with timestamp queries), the clock that
    /// times every kernel a dispatch runs, and each kernel's time on the GPU so far.
    clock: Option<StepClock>,
    pub kernel_busy: BTreeMap<&'static str, Duration>,
}

/// The pass's kernels (pass.wgsl): one invocation per pixel and sample of a single-sample
/// dispatch (`render_pass`); or, for several samples, one per pixel and sample in parallel
/// (`render_samples`, into the scratch buffer) and then one per pixel adding them to its sums
/// in index order (`accumulate`): the same f32 additions, in the same order, as single passes,
/// with enough invocations to fill a large GPU at any image size. With a filter wider than a
/// pixel a share reaches the pixels around it, which only a gather can add without atomics in
/// a fixed order: every dispatch then renders into the scratch buffer and ends in
/// `accumulate_filtered`.
struct Kernels {
    render_pass: wgpu::ComputePipeline,
    render_samples: wgpu::ComputePipeline,
    accumulate: wgpu::ComputePipeline,
    render_wavelengths: wgpu::ComputePipeline,
    accumulate_splats: wgpu::ComputePipeline,
    accumulate_filtered: wgpu::ComputePipeline,
}

/// Samples one dispatch renders, pixels × samples per pixel: enough to fill a large GPU many
/// times over (sixteen million invocations), in few dispatches, since each costs a
/// millisecond or more beyond its kernels on an H200 (BENCHMARKS.md, "The GPU machine,
/// 2026-11-27, second session": 2²⁴ against 2²² renders 1.31× faster in RGB and 1.07× with
/// three wavelengths at 640²). Its scratch is 16 bytes a share, one share a wavelength: 256 MiB
/// in RGB, 768 MiB with three wavelengths, less where the GPU binds less
/// ([`GpuFilm::new`]). Progress and cancellation come between dispatches: about 40 ms apart
/// on an H200.
const SAMPLES_PER_DISPATCH: u64 = 1 << 24;

/// Passes the GPU may have queued before the CPU waits for the oldest: with the next pass
/// already queued when one finishes, the GPU never idles between passes, and progress and
/// cancellation lag the GPU by at most this many passes.
const PASSES_IN_FLIGHT: usize = 2;

/// Workgroups are 8×8 pixels (pass.wgsl's `@workgroup_size`): neighbouring pixels' rays take
/// similar paths through the lens and the BVH.
const WORKGROUP_SIDE: u32 = 8;

impl GpuFilm {
    /// Sample indices per pixel one dispatch renders on a film of `pixels`: about
    /// sixteen million samples, at most 64 a pixel (progress, cancellation and
    /// checkpoints come between dispatches). A film whose samples carry several wavelengths
    /// renders as many where its scratch buffer fits in what the GPU binds
    /// ([`GpuFilm::samples_per_dispatch`]).
    pub fn samples_per_pixel_per_dispatch(pixels: u64) -> u32 {
        (SAMPLES_PER_DISPATCH / pixels.max(1)).clamp(1, 64) as u32
    }

    /// Sample indices per pixel each of this film's dispatches renders.
    pub fn samples_per_dispatch(&self) -> u32 {
        self.per_dispatch
    }

    /// A cleared film of `width` × `height` pixels whose samples carry `wavelengths`
    /// wavelengths each, spread by `filter`; refused in words when its buffers exceed what this
    /// GPU can bind.
    pub fn new(
        context: &GpuContext,
        width: u32,
        height: u32,
        wavelengths: u32,
        filter: Filter,
    ) -> Result<GpuFilm, GpuUnavailable> {
        let pixels = width as u64 * height as u64;
        let limit = context
            .limits
            .max_storage_buffer_binding_size
            .min(context.limits.max_buffer_size);
        // A dispatch's samples, as many as on an RGB film (fewer dispatches, each filling the
        // GPU), unless their shares (16 bytes each) would not fit in one binding: then as many
        // as do.
        let shares = u64::from(wavelengths.max(1));
        let fits = limit / (16 * pixels.max(1) * shares);
        let per_pixel = Self::samples_per_pixel_per_dispatch(pixels).min(fits.max(1) as u32);
        let (scratch_len, _) = Self::scratch_lens(pixels, wavelengths, filter, per_pixel);
        // Both hold a vec4f per element: the film one per pixel, the scratch one per share.
        let largest = 16 * pixels.max(scratch_len);
        if largest > limit {
            let shares = if wavelengths > 1 {
                format!(" with {wavelengths} wavelengths per sample")
            } else {
                String::new()
            };
            return Err(GpuUnavailable(format!(
                "a {width}×{height} film{shares} needs a {} MiB buffer, over the {} MiB this GPU \
                 binds: render fewer pixels{}, or use --device cpu",
                largest >> 20,
                limit >> 20,
                if wavelengths > 1 {
                    ", fewer --wavelengths"
                } else {
                    ""
                }
            )));
        }
        let params = storage_buffer(context, "pass parameters", &[PassParams::default()]);
        let film = zeroed_buffer::<[f32; 4]>(context, "film sums", pixels as usize);
        let counters = storage_buffer(context, "pass counters", &[0u32; COUNTER_WORDS]);
        // Scratch for one sample a pixel to begin with; a dispatch of more grows it.
        let (scratch, reach) = Self::scratch_buffers(context, pixels, wavelengths, filter, 1);
        let filter_taps = storage_buffer(context, "filter taps", filter.tap_table());
        let bindings = Self::bind(
            context,
            [&params, &film, &counters, &scratch, &filter_taps, &reach],
        );
        Ok(GpuFilm {
            width,
            height,
            wavelengths,
            filter,
            params,
            film,
            counters,
            scratch,
            filter_taps,
            reach,
            scratch_samples: 1,
            bindings,
            kernels: None,
            per_dispatch: per_pixel,
            in_flight: VecDeque::new(),
            clock: std::env::var("REALCAM_GPU_TIMESTAMPS")
                .is_ok_and(|v| v == "1")
                .then(|| StepClock::new(context, 2))
                .flatten(),
            kernel_busy: BTreeMap::new(),
        })
    }

    /// Replaces the film's sums (row-major RGB per pixel; a cleared film is all zeros).
    /// Elements of the scratch buffer (shares) and of the reach buffer for `per_pixel`
    /// samples a pixel (at least one each: WGSL has no empty bindings).
    fn scratch_lens(pixels: u64, wavelengths: u32, filter: Filter, per_pixel: u32) -> (u64, u64) {
        let samples = pixels * u64::from(per_pixel);
        if wavelengths > 1 {
            (samples * u64::from(wavelengths), samples)
        } else if per_pixel > 1 || !filter.is_box() {
            (samples, 1)
        } else {
            (1, 1)
        }
    }

    fn scratch_buffers(
        context: &GpuContext,
        pixels: u64,
        wavelengths: u32,
        filter: Filter,
        per_pixel: u32,
    ) -> (wgpu::Buffer, wgpu::Buffer) {
        let (scratch_len, reach_len) = Self::scratch_lens(pixels, wavelengths, filter, per_pixel);
        (
            zeroed_buffer::<[f32; 4]>(context, "sample scratch", scratch_len as usize),
            zeroed_buffer::<u32>(context, "share reach", reach_len as usize),
        )
    }

    /// The pass's bind group over its buffers, in pass_film.wgsl's binding order.
    fn bind(context: &GpuContext, buffers: [&wgpu::Buffer; 6]) -> Bindings {
        let [params, film, counters, scratch, filter_taps, reach] = buffers;
        Bindings::new(
            context,
            "pass",
            &[
                (params, Access::ReadOnly),
                (film, Access::ReadWrite),
                (counters, Access::ReadWrite),
                (scratch, Access::ReadWrite),
                (filter_taps, Access::ReadOnly),
                (reach, Access::ReadWrite),
            ],
        )
    }

    /// Makes the scratch hold `samples` sample indices a pixel (at most
    /// [`GpuFilm::samples_per_dispatch`]), growing it (and binding the new buffers: the
    /// layout, and so the compiled kernels, stay as they are) when it holds fewer.
    pub fn reserve_samples(&mut self, context: &GpuContext, samples: u32) {
        let samples = samples.min(self.per_dispatch);
        if samples <= self.scratch_samples {
            return;
        }
        let pixels = u64::from(self.width) * u64::from(self.height);
        (self.scratch, self.reach) =
            Self::scratch_buffers(context, pixels, self.wavelengths, self.filter, samples);
        self.bindings = Self::bind(
            context,
            [
                &self.params,
                &self.film,
                &self.counters,
                &self.scratch,
                &self.filter_taps,
                &self.reach,
            ],
        );
        self.scratch_samples = samples;
    }

    /// Bytes of scratch the film holds now.
    pub fn scratch_bytes(&self) -> u64 {
        self.scratch.size() + self.reach.size()
    }

    /// Zeroes the film's sums on the GPU: [`GpuFilm::load`] of a cleared film, with nothing
    /// to upload.
    pub fn clear(&self, context: &GpuContext) {
        let mut encoder = context
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("clear film"),
            });
        encoder.clear_buffer(&self.film, 0, None);
        context.queue.submit([encoder.finish()]);
    }

    pub fn load(&self, context: &GpuContext, sums: &[[f32; 3]]) {
        assert_eq!(sums.len(), (self.width * self.height) as usize);
        let padded: Vec<[f32; 4]> = sums.iter().map(|&[r, g, b]| [r, g, b, 0.0]).collect();
        context
            .queue
            .write_buffer(&self.film, 0, bytemuck::cast_slice(&padded));
    }

    /// Compiles the pass kernel, once: `upstream` are the bind groups of the lens, the scene
    /// and the shading data (groups 0, 1, 2), `source` the whole kernel's WGSL. Later uploads
    /// rewrite buffers in place or bind layouts equal to these (wgpu deduplicates equal
    /// layouts), so the kernel is kept. True when it compiled now.
    pub fn prepare_kernel(
        &mut self,
        context: &GpuContext,
        upstream: [&Bindings; 3],
        source: impl FnOnce() -> String,
    ) -> Result<bool, GpuUnavailable> {
        if self.kernels.is_some() {
            return Ok(false);
        }
        let layouts = [
            &upstream[0].layout,
            &upstream[1].layout,
            &upstream[2].layout,
            &self.bindings.layout,
        ];
        let source = source();
        let accumulate = accumulate_source();
        let compile = |label: &str, source: &str, entry: &str| {
            kernel_with(context, label, source, entry, &layouts)
        };
        let kernels = Kernels {
            render_pass: compile("render pass", &source, "render_pass")?,
            render_samples: compile("render samples", &source, "render_samples")?,
            accumulate: compile("accumulate", &accumulate, "accumulate")?,
            render_wavelengths: compile("render wavelengths", &source, "render_wavelengths")?,
            accumulate_splats: compile("accumulate splats", &accumulate, "accumulate_splats")?,
            accumulate_filtered: compile(
                "accumulate filtered",
                &accumulate,
                "accumulate_filtered",
            )?,
        };
        // A driver may compile a pipeline only when it first runs: one dispatch of each on an
        // empty film (every invocation outside it, nothing written) keeps that in set-up, out
        // of the first pass's time.
        let empty = PassParams::default();
        context
            .queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&empty));
        let groups = [
            &upstream[0].group,
            &upstream[1].group,
            &upstream[2].group,
            &self.bindings.group,
        ];
        let steps = [
            (&kernels.render_pass, [1, 1, 1]),
            (&kernels.render_samples, [1, 1, 1]),
            (&kernels.accumulate, [1, 1, 1]),
            (&kernels.render_wavelengths, [1, 1, 1]),
            (&kernels.accumulate_splats, [1, 1, 1]),
            (&kernels.accumulate_filtered, [1, 1, 1]),
        ];
        let submission = super::compute::submit_steps(context, &steps, &groups)?;
        super::compute::wait_for(context, submission)?;
        self.kernels = Some(kernels);
        Ok(true)
    }

    /// Renders `samples` (sample indices `first + k·step`, k < count) into every pixel, in
    /// index order, with the kernel [`GpuFilm::prepare_kernel`] compiled and the same
    /// `upstream` bind groups (their buffers as they are now).
    pub fn render_pass(
        &mut self,
        context: &GpuContext,
        upstream: [&Bindings; 3],
        samples: SampleSequence,
    ) -> Result<(), GpuUnavailable> {
        let per_dispatch = self.per_dispatch;
        let mut done = 0;
        while done < samples.count {
            let chunk = samples.after(done).first_n(per_dispatch);
            self.dispatch(context, upstream, chunk)?;
            done += chunk.count;
        }
        Ok(())
    }

    fn dispatch(
        &mut self,
        context: &GpuContext,
        upstream: [&Bindings; 3],
        samples: SampleSequence,
    ) -> Result<(), GpuUnavailable> {
        if self.kernels.is_none() {
            return Err(GpuUnavailable("the pass kernel was not compiled".into()));
        }
        self.reserve_samples(context, samples.count);
        let kernels = self.kernels.as_ref().expect("checked above");
        let params = PassParams {
            width: self.width,
            height: self.height,
            sample: samples.first,
            step: samples.step,
            count: samples.count,
            wavelengths: self.wavelengths,
            filtered: u32::from(!self.filter.is_box()),
            _pad: 0,
        };
        context
            .queue
            .write_buffer(&self.params, 0, bytemuck::bytes_of(&params));
        let groups = [
            &upstream[0].group,
            &upstream[1].group,
            &upstream[2].group,
            &self.bindings.group,
        ];
        let tiles = [
            self.width.div_ceil(WORKGROUP_SIDE),
            self.height.div_ceil(WORKGROUP_SIDE),
        ];
        let pixels = self.width * self.height;
        let gather = [pixels.div_ceil(64), 1, 1];
        let filtered = !self.filter.is_box();
        let steps: Vec<(&'static str, &wgpu::ComputePipeline, [u32; 3])> = if self.wavelengths > 1 {
            vec![
                (
                    "render_wavelengths",
                    &kernels.render_wavelengths,
                    [tiles[0], tiles[1], samples.count],
                ),
                if filtered {
                    ("accumulate_filtered", &kernels.accumulate_filtered, gather)
                } else {
                    ("accumulate_splats", &kernels.accumulate_splats, gather)
                },
            ]
        } else if samples.count == 1 && !filtered {
            vec![("render_pass", &kernels.render_pass, [tiles[0], tiles[1], 1])]
        } else {
            vec![
                (
                    "render_samples",
                    &kernels.render_samples,
                    [tiles[0], tiles[1], samples.count],
                ),
                if filtered {
                    ("accumulate_filtered", &kernels.accumulate_filtered, gather)
                } else {
                    ("accumulate", &kernels.accumulate, gather)
                },
            ]
        };
        let kernel_steps: Vec<_> = steps.iter().map(|&(_, k, w)| (k, w)).collect();
        let submission = super::compute::submit_steps_timed(
            context,
            &kernel_steps,
            &groups,
            self.clock.as_ref(),
        )?;
        if let Some(clock) = &self.clock {
            // Reading the stamps waits for this dispatch: timed renders do not overlap the
            // CPU's next dispatch with the GPU's work, but each kernel's own time is exact.
            let times = clock.read(context, steps.len())?;
            for (&(name, ..), time) in steps.iter().zip(times) {
                *self.kernel_busy.entry(name).or_default() += time;
            }
        }
        self.in_flight.push_back(submission);
        while self.in_flight.len() > PASSES_IN_FLIGHT {
            let oldest = self.in_flight.pop_front().expect("longer than the bound");
            super::compute::wait_for(context, oldest)?;
        }
        Ok(())
    }

    /// The film's sums (row-major RGB per pixel) and the counts since the last read, which it
    /// resets.
    pub fn read(
        &mut self,
        context: &GpuContext,
    ) -> Result<(Vec<[f32; 3]>, PassCounts), GpuUnavailable> {
        let mut out = Vec::new();
        let counts = self.read_with(context, |sums| {
            out = sums.iter().map(|&[r, g, b, _]| [r, g, b]).collect();
        })?;
        Ok((out, counts))
    }

    /// [`GpuFilm::read`] with the sums handed to `use_sums` where the readback maps them
    /// (row-major, RGB and an unused w per pixel): the film and the counters come back in one
    /// copy and one wait, and nothing copies the frame out before it is used.
    pub fn read_with(
        &mut self,
        context: &GpuContext,
        use_sums: impl FnOnce(&[[f32; 4]]),
    ) -> Result<PassCounts, GpuUnavailable> {
        // The readback is queued after every pass and waits for them all.
        self.in_flight.clear();
        let film_bytes = u64::from(self.width * self.height) * 16;
        let counters_bytes = (COUNTER_WORDS * 4) as u64;
        let counters = read_buffers(
            context,
            &[(&self.film, film_bytes), (&self.counters, counters_bytes)],
            |parts| {
                use_sums(bytemuck::cast_slice(parts[0]));
                bytemuck::cast_slice::<u8, u32>(parts[1]).to_vec()
            },
        )?;
        context.queue.write_buffer(
            &self.counters,
            0,
            bytemuck::cast_slice(&[0u32; COUNTER_WORDS]),
        );
        Ok(PassCounts::of(&counters))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::filter::POSITION_STEP;
    use crate::gpu::compute::{dispatch, kernel_with};
    use crate::lens::hero_wavelengths::SPLAT_RADIUS;
    use crate::sampling::Rng;

    /// accumulate.wgsl's position codes: (qy + B)·2B + (qx + B), in steps.
    fn position_code([qx, qy]: [i32; 2]) -> f32 {
        const BIAS: i32 = 1024;
        ((qy + BIAS) * 2 * BIAS + (qx + BIAS)) as f32
    }

    /// A share's film position along one axis of `extent` pixels from pixel `pixel`, in steps:
    /// the film jitter (in [0, 1]) or a companion wavelength's landing point (within the splat
    /// radius, on the frame), often on the edges where rounding and the frame's end meet.
    fn position_steps(rng: &mut Rng, pixel: i32, extent: i32, companion: bool) -> i32 {
        let steps = (1.0 / POSITION_STEP) as i32;
        let (lo, hi) = if companion {
            let r = SPLAT_RADIUS;
            (
                (-r).max(-pixel) * steps,
                (r + 1).min(extent - pixel) * steps,
            )
        } else {
            (0, steps)
        };
        match rng.next_u32() % 4 {
            0 => lo,
            1 => hi,
            _ => (lo as f32 + rng.next_f32() * (hi - lo) as f32).round() as i32,
        }
    }

    /// A film whose samples carry three wavelengths dispatches as many samples as an RGB one
    /// (not a third of them) where their shares fit in one binding, and as many as fit where
    /// they do not.
    #[test]
    fn a_spectral_film_dispatches_as_many_samples_as_fit() {
        let Some(context) = GpuContext::for_tests() else {
            return;
        };
        let limit = context
            .limits
            .max_storage_buffer_binding_size
            .min(context.limits.max_buffer_size);
        for side in [64u32, 160, 400, 640] {
            let pixels = u64::from(side * side);
            let rgb = GpuFilm::samples_per_pixel_per_dispatch(pixels);
            let fitting = (limit / (16 * pixels * 3)).max(1) as u32;
            if 16 * pixels * 3 > limit {
                continue;
            }
            let film = GpuFilm::new(&context, side, side, 3, Filter::Tent).unwrap();
            let got = film.samples_per_dispatch();
            assert!(got >= 1 && got <= rgb, "{side}²: {got} against {rgb}");
            assert!(16 * pixels * 3 * u64::from(got) <= limit, "{side}²: {got}");
            assert!(
                got == rgb || got == fitting,
                "{side}²: {got}, {rgb}, {fitting}"
            );
        }
    }

    /// The scratch starts at one sample a pixel and grows to what a dispatch asks for, never
    /// beyond the film's dispatch size: a live lab's one-sample passes keep it small.
    #[test]
    fn the_scratch_grows_to_the_largest_dispatch_only() {
        let Some(context) = GpuContext::for_tests() else {
            return;
        };
        let mut film = GpuFilm::new(&context, 64, 48, 3, Filter::Tent).unwrap();
        let one = film.scratch_bytes();
        // One sample a pixel: three shares of 16 bytes and a reach word each.
        assert_eq!(one, 64 * 48 * (3 * 16 + 4));
        film.reserve_samples(&context, 1);
        assert_eq!(film.scratch_bytes(), one);
        film.reserve_samples(&context, 5);
        assert_eq!(film.scratch_bytes(), 5 * one);
        film.reserve_samples(&context, 2);
        assert_eq!(film.scratch_bytes(), 5 * one);
        let most = film.samples_per_dispatch();
        film.reserve_samples(&context, most + 100);
        assert_eq!(film.scratch_bytes(), u64::from(most) * one);
    }

    /// accumulate_filtered against the CPU's filter: shares at positions all over their range
    /// (the frame's edges, a companion on the far edge of its last pixel, frames one and two
    /// pixels wide) spread as Filter::taps weights them, sample after sample onto the sums.
    #[test]
    fn the_filtered_gather_spreads_shares_as_the_cpu_filter_does() {
        let Some(context) = GpuContext::for_tests() else {
            return;
        };
        let empty = Bindings::new(&context, "empty", &[]);
        let mut rng = Rng::new(7, 3);
        for filter in [Filter::Tent, Filter::Gaussian] {
            for (width, height, wavelengths) in [(9, 7, 1), (8, 6, 4), (1, 2, 3), (2, 1, 1)] {
                let mut film = GpuFilm::new(&context, width, height, wavelengths, filter).unwrap();
                let layouts = [
                    &empty.layout,
                    &empty.layout,
                    &empty.layout,
                    &film.bindings.layout,
                ];
                let kernel = kernel_with(
                    &context,
                    "accumulate filtered",
                    &accumulate_source(),
                    "accumulate_filtered",
                    &layouts,
                )
                .unwrap();
                let (w, h) = (width as i32, height as i32);
                let pixels = (width * height) as usize;
                let count = wavelengths.max(1) as usize;
                let samples = 3;
                let mut shares = vec![[0.0f32; 4]; samples * pixels * count];
                let start: Vec<[f32; 3]> = (0..pixels)
                    .map(|_| [rng.next_f32(), rng.next_f32(), rng.next_f32()])
                    .collect();
                let mut expected: Vec<[f64; 3]> = start.iter().map(|s| s.map(f64::from)).collect();
                let mut scale = vec![0.0f64; pixels];
                // Per sample and pixel, as render_wavelengths leaves it: how many pixels from
                // its own its shares land, at most (what the gather may skip beyond).
                let mut reach = vec![0u32; samples * pixels];
                let steps = (1.0 / POSITION_STEP) as i32;
                for (index, share) in shares.iter_mut().enumerate() {
                    let pixel = (index / count) % pixels;
                    let companion = index % count > 0;
                    let (x, y) = (
                        (pixel % width as usize) as i32,
                        (pixel / width as usize) as i32,
                    );
                    if rng.next_u32().is_multiple_of(8) {
                        *share = [0.0, 0.0, 0.0, -1.0];
                        continue;
                    }
                    let q = [
                        position_steps(&mut rng, x, w, companion),
                        position_steps(&mut rng, y, h, companion),
                    ];
                    let rgb = [rng.next_f32(), rng.next_f32(), 2.0 * rng.next_f32()];
                    *share = [rgb[0], rgb[1], rgb[2], position_code(q)];
                    let landed = q.map(|q| q.div_euclid(steps).unsigned_abs());
                    let r = &mut reach[index / count];
                    *r = (*r).max(landed[0]).max(landed[1]);
                    let at = [
                        x as f32 + q[0] as f32 * POSITION_STEP,
                        y as f32 + q[1] as f32 * POSITION_STEP,
                    ];
                    let (first_x, wx) = filter.taps(at[0], width);
                    let (first_y, wy) = filter.taps(at[1], height);
                    for (ky, &wy) in wy.iter().enumerate() {
                        for (kx, &wx) in wx.iter().enumerate() {
                            let weight = wx * wy;
                            if weight == 0.0 {
                                continue;
                            }
                            let (tx, ty) = (first_x + kx as i32, first_y + ky as i32);
                            assert!((0..w).contains(&tx) && (0..h).contains(&ty));
                            let target = (ty * w + tx) as usize;
                            for c in 0..3 {
                                expected[target][c] += f64::from(rgb[c] * weight);
                                scale[target] += f64::from(rgb[c]);
                            }
                        }
                    }
                }
                film.load(&context, &start);
                film.reserve_samples(&context, samples as u32);
                context
                    .queue
                    .write_buffer(&film.scratch, 0, bytemuck::cast_slice(&shares));
                if wavelengths > 1 {
                    context
                        .queue
                        .write_buffer(&film.reach, 0, bytemuck::cast_slice(&reach));
                }
                let params = PassParams {
                    width,
                    height,
                    sample: 0,
                    step: 1,
                    count: samples as u32,
                    wavelengths,
                    filtered: 1,
                    _pad: 0,
                };
                context
                    .queue
                    .write_buffer(&film.params, 0, bytemuck::bytes_of(&params));
                let groups = [
                    &empty.group,
                    &empty.group,
                    &empty.group,
                    &film.bindings.group,
                ];
                let workgroups = [(pixels as u32).div_ceil(64), 1, 1];
                dispatch(&context, &kernel, &groups, workgroups).unwrap();
                let (sums, _) = film.read(&context).unwrap();
                for (pixel, (got, want)) in sums.iter().zip(&expected).enumerate() {
                    for c in 0..3 {
                        assert!(
                            (f64::from(got[c]) - want[c]).abs() <= 1e-6 * (1.0 + scale[pixel]),
                            "{filter} on {width}×{height} with {wavelengths} wavelengths, \
                             pixel {pixel}: {got:?} vs {want:?}"
                        );
                    }
                }
            }
        }
    }
}
