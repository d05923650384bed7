//! `realcam bench`: a few seconds' check of lens-tracing speed on this CPU, one thread.
//!
//! Traces the same film→scene camera rays through a lens one ray at a time (the scalar
//! reference tracer in f32, array of structs) and in SoA batches (the renderer's kernels), and
//! prints rays per second and their ratio. [`LensWorkload`] (the library's) is also what `cargo bench`
//! (benches/lens_tracing.rs) measures, so both report the same work.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::bail;
use clap::Args;
use serde_json::json;

use super::values::whole;
use crate::batch::RayBatch;
use crate::gpu::GpuContext;
use crate::gpu::lens_bench::GpuLensBench;
use crate::lens::io::bundled::DEFAULT_LENS;
use crate::lens::trace::Ray;
use crate::lens::trace_batch::{DEFAULT_KERNEL, Isa, Kernel};
use crate::lens::workload::LensWorkload;
use crate::pipeline::RenderDevice;

#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    /// Lens prescription file or bundled lens name.
    #[arg(long, default_value = DEFAULT_LENS, value_name = "FILE")]
    pub lens: String,
    /// Camera rays in the workload.
    #[arg(long, default_value_t = 4096, value_name = "N", allow_hyphen_values = true, value_parser = whole::<usize>(1, usize::MAX))]
    pub rays: usize,
    /// Rays per SoA batch (the renderer traces one 32×32 tile, 1024 rays, per batch).
    #[arg(long, default_value_t = 1024, value_name = "N", allow_hyphen_values = true, value_parser = whole::<usize>(1, usize::MAX))]
    pub batch: usize,
    /// Rounds per variant; the median is reported. Variants alternate within a round so
    /// that load from other processes hits them alike.
    #[arg(long, default_value_t = 7, value_name = "N", allow_hyphen_values = true, value_parser = whole::<usize>(1, usize::MAX))]
    pub rounds: usize,
    /// Also measure both SoA kernels at batch sizes 64 … 4096 (for the plot in BENCHMARKS.md).
    #[arg(long)]
    pub sweep: bool,
    /// Print one JSON object instead of the summary.
    #[arg(long)]
    pub json: bool,
    /// `gpu`: also trace the workload through the lens on the GPU (`realcam devices`), the
    /// pass kernel's own lens code, repeated to at least 4M rays per dispatch.
    #[arg(long, value_name = "cpu|gpu", default_value = "cpu")]
    pub device: RenderDevice,
}

/// A way of tracing the workload.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Variant {
    Scalar,
    Soa {
        batch: usize,
        kernel: Kernel,
        isa: Isa,
    },
}

impl Variant {
    fn run(
        self,
        workload: &LensWorkload,
        scalar_out: &mut Vec<Ray<f32>>,
        work: &mut RayBatch,
    ) -> usize {
        match self {
            Variant::Scalar => workload.trace_scalar(scalar_out),
            Variant::Soa { batch, kernel, isa } => workload.trace_soa(batch, kernel, isa, work),
        }
    }

    fn name(self) -> String {
        match self {
            Variant::Scalar => "scalar per-ray (f32, array of structs)".into(),
            Variant::Soa {
                kernel: Kernel::AutoVectorised,
                isa,
                ..
            } => format!("auto-vectorised kernel, {}", isa_name(isa)),
            // `wide` fixes its layout when it is compiled, whatever the dispatch.
            Variant::Soa {
                kernel: Kernel::Simd,
                ..
            } => format!(
                "explicit wide::f32x8 kernel, {}",
                if wide_uses_avx() {
                    "AVX (8 lanes)"
                } else {
                    "2 × 128-bit"
                }
            ),
        }
    }
}

/// Time this thread has spent running on a CPU, when the OS tells (POSIX's per-thread CPU
/// clock). On a shared machine this leaves out the time other processes held the core, so rays
/// per CPU-second measure the code, not the load. The clock reads the running thread's time to
/// the nanosecond; Linux's /proc/thread-self/schedstat, read before, advances only at the
/// scheduler's ticks (about 4 ms here), which quantised each 60 ms measurement by several
/// percent (two binaries gave the same rate to four digits).
#[cfg(unix)]
fn thread_cpu_time() -> Option<Duration> {
    let mut now = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: clock_gettime writes only the timespec it is given, which lives on this stack.
    let read = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut now) } == 0;
    let (seconds, nanos) = (
        u64::try_from(now.tv_sec).ok()?,
        u32::try_from(now.tv_nsec).ok()?,
    );
    read.then(|| Duration::new(seconds, nanos))
}

/// No per-thread CPU clock: the stopwatch falls back to wall time.
#[cfg(not(unix))]
fn thread_cpu_time() -> Option<Duration> {
    None
}

/// Measures intervals of this thread's CPU time where available, else wall time.
#[derive(Clone, Copy)]
struct Stopwatch {
    wall: Instant,
    cpu: Option<Duration>,
}

impl Stopwatch {
    fn start() -> Stopwatch {
        Stopwatch {
            wall: Instant::now(),
            cpu: thread_cpu_time(),
        }
    }

    fn elapsed(&self) -> Duration {
        match (self.cpu, thread_cpu_time()) {
            (Some(start), Some(now)) => now.saturating_sub(start),
            _ => self.wall.elapsed(),
        }
    }
}

/// Rays per second of every variant: `rounds` rounds, each timing every variant in turn for
/// at least `min_time` (CPU time where available); the median round per variant.
fn measure(
    workload: &LensWorkload,
    variants: &[Variant],
    rounds: usize,
    min_time: Duration,
) -> Vec<f64> {
    let mut scalar_out = Vec::with_capacity(workload.rays.len());
    let mut work = RayBatch::with_capacity(workload.rays.len());
    let mut rates: Vec<Vec<f64>> = vec![Vec::with_capacity(rounds); variants.len()];
    for variant in variants {
        std::hint::black_box(variant.run(workload, &mut scalar_out, &mut work));
    }
    for _ in 0..rounds {
        for (variant, rates) in variants.iter().zip(&mut rates) {
            // Doubling the runs between clock reads keeps the reads (a file read each for
            // the CPU clock) to a handful per measurement, out of the short SoA runs' time.
            let start = Stopwatch::start();
            let (mut runs, mut next) = (0u64, 1u64);
            let elapsed = loop {
                for _ in 0..next {
                    std::hint::black_box(variant.run(workload, &mut scalar_out, &mut work));
                }
                runs += next;
                next *= 2;
                let elapsed = start.elapsed();
                if elapsed >= min_time {
                    break elapsed;
                }
            };
            let seconds = elapsed.as_secs_f64();
            rates.push((runs as usize * workload.rays.len()) as f64 / seconds);
        }
    }
    rates.into_iter().map(median).collect()
}

fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n % 2 == 1 {
        values[n / 2]
    } else {
        (values[n / 2 - 1] + values[n / 2]) / 2.0
    }
}

fn isa_name(isa: Isa) -> &'static str {
    match isa {
        Isa::Baseline if cfg!(target_arch = "x86_64") => "baseline SSE2 (4 lanes)",
        Isa::Baseline => "baseline",
        Isa::Avx2 => "AVX2 (8 lanes)",
        Isa::Avx512 => "AVX-512 (16 lanes)",
    }
}

/// Whether `wide`'s 8-lane type was compiled for 256-bit AVX registers (else 2 × 128-bit).
fn wide_uses_avx() -> bool {
    cfg!(target_feature = "avx")
}

/// What the rates are per: this thread's CPU time, or wall time where the OS does not tell.
fn clock_name() -> &'static str {
    if thread_cpu_time().is_some() {
        "thread-cpu-time"
    } else {
        "wall"
    }
}

const SWEEP_BATCHES: &[usize] = &[64, 128, 256, 512, 1024, 2048, 4096];

/// The SoA variants worth comparing at one batch size: the plain kernel on every instruction
/// set this CPU has, and the explicit kernel on the widest.
fn soa_variants(batch: usize) -> Vec<Variant> {
    let mut variants: Vec<Variant> = Isa::available()
        .into_iter()
        .map(|isa| Variant::Soa {
            batch,
            kernel: Kernel::AutoVectorised,
            isa,
        })
        .collect();
    variants.push(Variant::Soa {
        batch,
        kernel: Kernel::Simd,
        isa: Isa::detect(),
    });
    variants
}

/// Everything one `realcam bench` run measured.
struct Measured {
    surfaces: usize,
    rays: usize,
    pass_fraction: f64,
    /// The renderer's own variant (default kernel, widest instruction set).
    default: Variant,
    /// Scalar first, then the SoA variants at the requested batch size; rays/s each.
    variants: Vec<(Variant, f64)>,
    /// With `--sweep`: the SoA variants at every batch size of [`SWEEP_BATCHES`].
    sweep: Vec<(Variant, f64)>,
    /// With `--device gpu`: what the GPU did.
    gpu: Option<GpuMeasured>,
}

/// The workload traced on the GPU.
struct GpuMeasured {
    adapter: String,
    /// Rays per dispatch (the workload repeated).
    rays_per_dispatch: u64,
    /// Median over the rounds, wall time from submit to done.
    rays_per_s: f64,
    pass_fraction: f64,
}

/// Rays per GPU dispatch: enough to fill a large GPU many times over.
const GPU_RAYS_PER_DISPATCH: u64 = 1 << 22;

fn measure_gpu(workload: &LensWorkload, rounds: usize) -> anyhow::Result<GpuMeasured> {
    let context = GpuContext::shared().map_err(|why| anyhow::anyhow!("--device gpu: {why}"))?;
    let bench = GpuLensBench::new(&context, workload).map_err(|why| anyhow::anyhow!("{why}"))?;
    let count = workload.rays.len() as u64;
    let repeats = GPU_RAYS_PER_DISPATCH
        .div_ceil(count)
        .min(u64::from(u32::MAX / 2)) as u32;
    bench
        .trace(&context, repeats)
        .map_err(|why| anyhow::anyhow!("{why}"))?;
    let mut rates = Vec::with_capacity(rounds);
    for _ in 0..rounds {
        let elapsed = bench
            .trace(&context, repeats)
            .map_err(|why| anyhow::anyhow!("{why}"))?;
        rates.push((count * u64::from(repeats)) as f64 / elapsed.as_secs_f64());
    }
    let passed = bench
        .passed(&context)
        .map_err(|why| anyhow::anyhow!("{why}"))?;
    Ok(GpuMeasured {
        adapter: context.adapter.to_string(),
        rays_per_dispatch: count * u64::from(repeats),
        rays_per_s: median(rates),
        pass_fraction: passed as f64 / count as f64,
    })
}

impl Measured {
    fn rate(&self, variant: Variant) -> f64 {
        self.variants
            .iter()
            .find(|(v, _)| *v == variant)
            .map_or(f64::NAN, |&(_, rate)| rate)
    }

    fn scalar(&self) -> f64 {
        self.rate(Variant::Scalar)
    }

    fn soa(&self) -> f64 {
        self.rate(self.default)
    }
}

/// Memory per workload ray: the rays as structs (24 B) and as SoA (45 B), the scalar results
/// (24 B) and the SoA work copy (45 B), rounded up.
const BYTES_PER_RAY: u64 = 160;

/// Memory per round and variant: one rate (8 B).
const BYTES_PER_ROUND: u64 = 8;

fn collect(args: &BenchArgs, min_time: Duration) -> anyhow::Result<Measured> {
    if args.rays == 0 || args.batch == 0 || args.rounds == 0 {
        bail!("--rays, --batch and --rounds must be at least 1");
    }
    let variants = 3 + 2 * SWEEP_BATCHES.len() as u64;
    crate::memory::check(
        &format!(
            "a workload of {} rays over {} rounds",
            args.rays, args.rounds
        ),
        (args.rays as u64)
            .saturating_mul(BYTES_PER_RAY)
            .saturating_add((args.rounds as u64).saturating_mul(variants * BYTES_PER_ROUND)),
        "use fewer --rays or --rounds",
    )?;
    let workload = LensWorkload::new(&args.lens, args.rays)?;
    let default = Variant::Soa {
        batch: args.batch,
        kernel: DEFAULT_KERNEL,
        isa: Isa::detect(),
    };
    let mut variants = vec![Variant::Scalar];
    variants.extend(soa_variants(args.batch));
    let rates = measure(&workload, &variants, args.rounds, min_time);
    let passed = workload.trace_soa(
        args.batch,
        DEFAULT_KERNEL,
        Isa::detect(),
        &mut RayBatch::default(),
    );
    let sweep = if args.sweep {
        let variants: Vec<Variant> = SWEEP_BATCHES
            .iter()
            .flat_map(|&b| soa_variants(b))
            .collect();
        let rates = measure(&workload, &variants, args.rounds, min_time);
        variants.into_iter().zip(rates).collect()
    } else {
        Vec::new()
    };
    let gpu = match args.device {
        RenderDevice::Cpu => None,
        RenderDevice::Gpu => Some(measure_gpu(&workload, args.rounds)?),
    };
    Ok(Measured {
        surfaces: workload.system.surface_count(),
        rays: workload.rays.len(),
        pass_fraction: passed as f64 / workload.rays.len() as f64,
        default,
        variants: variants.into_iter().zip(rates).collect(),
        sweep,
        gpu,
    })
}

fn json_entry(variant: Variant, rate: f64) -> serde_json::Value {
    match variant {
        Variant::Scalar => json!({"variant": "scalar", "rays_per_s": rate}),
        Variant::Soa { batch, kernel, isa } => json!({
            "batch": batch,
            "kernel": match kernel {
                Kernel::Simd => "simd",
                Kernel::AutoVectorised => "auto-vectorised",
            },
            "isa": isa.name(),
            "rays_per_s": rate,
        }),
    }
}

/// The `--json` report: one object; `scalar_rays_per_s`, `soa_rays_per_s` and `speedup` are
/// the headline (one thread, same lens, the renderer's kernel).
fn json_report(args: &BenchArgs, m: &Measured) -> serde_json::Value {
    json!({
        "lens": args.lens,
        "surfaces": m.surfaces,
        "rays": m.rays,
        "pass_fraction": m.pass_fraction,
        "batch": args.batch,
        "threads": 1,
        "clock": clock_name(),
        "rounds": args.rounds,
        "scalar_rays_per_s": m.scalar(),
        "soa_rays_per_s": m.soa(),
        "speedup": m.soa() / m.scalar(),
        "soa_kernel": json_entry(m.default, m.soa()),
        "variants": m.variants.iter().map(|&(v, r)| json_entry(v, r)).collect::<Vec<_>>(),
        "wide_uses_avx": wide_uses_avx(),
        "sweep": m.sweep.iter().map(|&(v, r)| json_entry(v, r)).collect::<Vec<_>>(),
        "gpu": m.gpu.as_ref().map(|g| json!({
            "adapter": g.adapter,
            "rays_per_dispatch": g.rays_per_dispatch,
            "rays_per_s": g.rays_per_s,
            "pass_fraction": g.pass_fraction,
            "speedup_over_soa": g.rays_per_s / m.soa(),
        })),
    })
}

fn print_summary(args: &BenchArgs, m: &Measured) {
    let mega = |rate: f64| rate / 1e6;
    println!(
        "lens tracing: {} ({} surfaces), {} film→scene camera rays ({:.0} % pass), one thread",
        args.lens,
        m.surfaces,
        m.rays,
        m.pass_fraction * 100.0,
    );
    println!(
        "rays per {}, median of {} rounds",
        if clock_name() == "wall" {
            "second"
        } else {
            "CPU-second of the thread (time other processes held the core left out)"
        },
        args.rounds
    );
    println!(
        "  {:<52}{:>8.2} M rays/s",
        Variant::Scalar.name(),
        mega(m.scalar())
    );
    println!("  SoA, batches of {}:", args.batch);
    for &(v, rate) in m.variants.iter().filter(|(v, _)| *v != Variant::Scalar) {
        let marker = if v == m.default { "  ← renderer" } else { "" };
        println!("    {:<50}{:>8.2} M rays/s{marker}", v.name(), mega(rate));
    }
    println!("  speedup SoA / scalar: {:.2}×", m.soa() / m.scalar());
    if let Some(gpu) = &m.gpu {
        println!(
            "  GPU, {} rays per dispatch (the workload repeated), wall time: {:.2} M rays/s \
             ({:.0} % pass), {:.1}× the renderer's SoA kernel on one thread\n    on {}",
            gpu.rays_per_dispatch,
            mega(gpu.rays_per_s),
            gpu.pass_fraction * 100.0,
            gpu.rays_per_s / m.soa(),
            gpu.adapter
        );
    }
    if !m.sweep.is_empty() {
        println!("  batch-size sweep (M rays/s):");
        let columns = soa_variants(1).len();
        for row in m.sweep.chunks(columns) {
            let Variant::Soa { batch, .. } = row[0].0 else {
                continue;
            };
            let cells: Vec<String> = row
                .iter()
                .map(|&(v, r)| format!("{}: {:.2}", v.name(), mega(r)))
                .collect();
            println!("    {batch:>5}  {}", cells.join(" | "));
        }
    }
}

pub fn run(args: &BenchArgs) -> anyhow::Result<ExitCode> {
    let measured = collect(args, Duration::from_millis(60))?;
    if args.json {
        println!("{}", json_report(args, &measured));
    } else {
        print_summary(args, &measured);
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::io::bundled::BUNDLED;

    fn quick_args() -> BenchArgs {
        BenchArgs {
            lens: DEFAULT_LENS.into(),
            rays: 256,
            batch: 64,
            rounds: 1,
            sweep: false,
            json: true,
            device: RenderDevice::Cpu,
        }
    }

    /// The scalar and SoA paths measure the same work: the same rays pass (f32 rounding may
    /// flip a ray grazing an aperture edge), and every SoA variant passes exactly the same.
    #[test]
    fn scalar_and_every_soa_variant_trace_the_same_rays() {
        for lens in BUNDLED.iter().map(|b| b.name) {
            let workload = LensWorkload::new(lens, 512).unwrap();
            let scalar = workload.trace_scalar(&mut Vec::new());
            let soa: Vec<usize> = [64, 100, 512]
                .into_iter()
                .flat_map(soa_variants)
                .map(|v| v.run(&workload, &mut Vec::new(), &mut RayBatch::default()))
                .collect();
            assert!(soa.iter().all(|&p| p == soa[0]), "{lens}: {soa:?}");
            assert!(
                scalar.abs_diff(soa[0]) <= 2,
                "{lens}: {scalar} vs {}",
                soa[0]
            );
            assert!(soa[0] > 100, "{lens}: only {} of 512 pass", soa[0]);
        }
    }

    /// The CPU clock resolves far finer than a measurement: read while the thread spins for
    /// 20 ms, it takes a new value at nearly every read (the scheduler-tick clock it replaced
    /// took about five in that time), and it does not run ahead of the wall clock (beyond the
    /// two clocks' skew).
    #[cfg(unix)]
    #[test]
    fn the_thread_clock_resolves_a_measurement_finely() {
        let (wall, cpu) = (Instant::now(), thread_cpu_time().unwrap());
        let (mut reads, mut changes, mut last) = (0u32, 0u32, cpu);
        while wall.elapsed() < Duration::from_millis(20) {
            let now = thread_cpu_time().unwrap();
            assert!(now >= last, "the clock went back");
            changes += u32::from(now != last);
            (reads, last) = (reads + 1, now);
        }
        // The two clocks have different sources: a millisecond's slack for their skew.
        let slack = Duration::from_millis(1);
        assert!(
            last - cpu <= wall.elapsed() + slack,
            "CPU time ran ahead of the wall clock"
        );
        assert!(
            changes >= 100 && changes * 2 >= reads,
            "{changes} changes in {reads} reads"
        );
    }

    #[test]
    fn json_report_has_the_headline_fields() {
        let args = quick_args();
        let measured = collect(&args, Duration::from_micros(1)).unwrap();
        let report = json_report(&args, &measured);
        for key in ["scalar_rays_per_s", "soa_rays_per_s", "speedup"] {
            let value = report[key].as_f64().unwrap_or(f64::NAN);
            assert!(value.is_finite() && value > 0.0, "{key}: {}", report[key]);
        }
        assert_eq!(report["threads"], 1);
        assert_eq!(
            report["variants"].as_array().unwrap().len(),
            measured.variants.len()
        );
    }

    #[test]
    fn bad_arguments_and_unknown_lenses_are_errors() {
        let zero = BenchArgs {
            rays: 0,
            ..quick_args()
        };
        assert!(collect(&zero, Duration::ZERO).is_err());
        let unknown = BenchArgs {
            lens: "no-such-lens".into(),
            ..quick_args()
        };
        assert!(collect(&unknown, Duration::ZERO).is_err());
    }
}
