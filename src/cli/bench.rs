//! `realcam bench`: a few seconds' check of lens-tracing speed on this CPU, one thread.
//!
//! Traces the same film→scene camera rays through a lens one ray at a time (the scalar
//! reference tracer in f32, array of structs) and in SoA batches (the renderer's kernels), and
//! prints rays per second and their ratio. [`LensWorkload`] is also what `cargo bench`
//! (benches/lens_tracing.rs) measures, so both report the same work.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use clap::Args;
use serde_json::json;

use crate::batch::RayBatch;
use crate::lens::LensSystem;
use crate::lens::bundled::{DEFAULT_LENS, load_lens};
use crate::lens::first_order::FirstOrder;
use crate::lens::focus::paraxial_film_distance;
use crate::lens::pupil::{ExitPupil, PupilSampling};
use crate::lens::trace::{Ray, Travel, trace};
use crate::lens::trace_batch::{Kernel, trace_batch, trace_batch_with};
use crate::sampling::Rng;

#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    /// Lens prescription file or bundled lens name.
    #[arg(long, default_value = DEFAULT_LENS, value_name = "FILE")]
    pub lens: String,
    /// Camera rays in the workload.
    #[arg(long, default_value_t = 4096, value_name = "N")]
    pub rays: usize,
    /// Rays per SoA batch (the renderer traces one 32×32 tile, 1024 rays, per batch).
    #[arg(long, default_value_t = 1024, value_name = "N")]
    pub batch: usize,
    /// Rounds per variant; the median is reported. Variants alternate within a round so
    /// that load from other processes hits them alike.
    #[arg(long, default_value_t = 7, value_name = "N")]
    pub rounds: usize,
    /// Also measure both SoA kernels at batch sizes 64 … 4096 (for the plot in BENCHMARKS.md).
    #[arg(long)]
    pub sweep: bool,
    /// Print one JSON object instead of the summary.
    #[arg(long)]
    pub json: bool,
}

/// Film→scene camera rays for one lens, as the renderer makes them: focused at 5 m, film
/// points uniform over the central 24 × 24 mm of a 35 mm-diagonal film, each aimed at a
/// uniform point of its exit-pupil bounds. The same rays are held as structs and as SoA.
pub struct LensWorkload {
    pub system: LensSystem,
    pub film_distance: f64,
    pub rays: Vec<Ray<f32>>,
    pub batch: RayBatch,
}

impl LensWorkload {
    pub const FOCUS_MM: f64 = 5000.0;
    pub const FILM_DIAGONAL_MM: f64 = 35.0;

    pub fn new(lens: &str, count: usize) -> anyhow::Result<LensWorkload> {
        let prescription = load_lens(lens, None)?;
        let system = LensSystem::new(&prescription.rows, None);
        let first_order = FirstOrder::compute(&system)
            .map_err(|e| anyhow::anyhow!("{lens}: no first-order data: {e:?}"))?;
        let film_distance = paraxial_film_distance(&system, &first_order, Self::FOCUS_MM)
            .with_context(|| format!("{lens} cannot focus at 5 m"))?;
        let pupil = ExitPupil::compute(
            &system,
            film_distance,
            Self::FILM_DIAGONAL_MM,
            PupilSampling::Bounds,
        );
        let film_z = (system.rear_z() + film_distance) as f32;
        let mut rng = Rng::new(1, 2);
        let mut rays = Vec::with_capacity(count);
        let mut batch = RayBatch::with_capacity(count);
        for _attempt in 0..count * 100 {
            if rays.len() == count {
                break;
            }
            let (x, y) = ((rng.next_f32() - 0.5) * 24.0, (rng.next_f32() - 0.5) * 24.0);
            if let Some(s) = pupil.sample(x, y, rng.next_2d()) {
                let d = [s.point[0] - x, s.point[1] - y, s.point[2] - film_z];
                let inv = 1.0 / (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                let ray = Ray {
                    origin: [x, y, film_z],
                    direction: d.map(|v| v * inv),
                };
                batch.push(ray.origin, ray.direction, 0, 0);
                rays.push(ray);
            }
        }
        if rays.len() < count {
            bail!("{lens}: too few film points see light through the lens");
        }
        Ok(LensWorkload {
            system,
            film_distance,
            rays,
            batch,
        })
    }

    /// One ray at a time through the reference tracer in f32; results into `out`. Returns the
    /// number of rays that pass.
    pub fn trace_scalar(&self, out: &mut Vec<Ray<f32>>) -> usize {
        out.clear();
        let mut passed = 0;
        for ray in &self.rays {
            let traced = trace(&self.system.f32s, *ray, Travel::FilmToScene);
            passed += usize::from(traced.is_ok());
            out.push(traced.unwrap_or(*ray));
        }
        passed
    }

    /// The same rays in SoA batches of `batch_size`, each copied into `work` and traced there
    /// in place by `kernel` (`None`: the renderer's default). Returns the number that pass.
    pub fn trace_soa(
        &self,
        batch_size: usize,
        kernel: Option<Kernel>,
        work: &mut RayBatch,
    ) -> usize {
        let mut passed = 0;
        let len = self.batch.len();
        let mut start = 0;
        while start < len {
            let end = (start + batch_size).min(len);
            copy_rays(&self.batch, start..end, work);
            match kernel {
                Some(kernel) => {
                    trace_batch_with(&self.system.f32s, work, Travel::FilmToScene, kernel)
                }
                None => trace_batch(&self.system.f32s, work, Travel::FilmToScene),
            }
            passed += work.alive_count();
            start = end;
        }
        passed
    }
}

/// Rays `range` of `from` into `to` (positions, directions, alive), replacing its contents.
fn copy_rays(from: &RayBatch, range: std::ops::Range<usize>, to: &mut RayBatch) {
    let copy = |src: &Vec<f32>, dst: &mut Vec<f32>| {
        dst.clear();
        dst.extend_from_slice(&src[range.clone()]);
    };
    copy(&from.ox, &mut to.ox);
    copy(&from.oy, &mut to.oy);
    copy(&from.oz, &mut to.oz);
    copy(&from.dx, &mut to.dx);
    copy(&from.dy, &mut to.dy);
    copy(&from.dz, &mut to.dz);
    to.alive.clear();
    to.alive.extend_from_slice(&from.alive[range]);
}

/// A way of tracing the workload, as the report names it.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Variant {
    Scalar,
    Soa {
        batch: usize,
        kernel: Option<Kernel>,
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
            Variant::Soa { batch, kernel } => workload.trace_soa(batch, kernel, work),
        }
    }
}

/// Time this thread has spent running on a CPU, when the OS tells (Linux: the first field of
/// /proc/thread-self/schedstat, ns). On a shared machine this leaves out the time other
/// processes held the core, so rays per CPU-second measure the code, not the load.
fn thread_cpu_time() -> Option<Duration> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let nanos: u64 = text.split_whitespace().next()?.parse().ok()?;
    Some(Duration::from_nanos(nanos))
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
            let start = Stopwatch::start();
            let mut runs = 0u64;
            while start.elapsed() < min_time || runs == 0 {
                std::hint::black_box(variant.run(workload, &mut scalar_out, &mut work));
                runs += 1;
            }
            let seconds = start.elapsed().as_secs_f64();
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

/// Vector extensions of this CPU that the kernels can use.
fn cpu_features() -> Vec<&'static str> {
    #[allow(unused_mut)]
    let mut features = Vec::new();
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            features.push("avx2");
        }
        if std::arch::is_x86_feature_detected!("avx512f") {
            features.push("avx512f");
        }
    }
    #[cfg(target_arch = "aarch64")]
    features.push("neon");
    features
}

/// Whether `wide`'s 8-lane type was compiled for 256-bit AVX registers (else 2 × 128-bit).
fn wide_uses_avx() -> bool {
    cfg!(target_feature = "avx")
}

/// What the rates are per: "CPU-second" (this thread's CPU time) or "second" (wall time).
fn clock_name() -> &'static str {
    if thread_cpu_time().is_some() {
        "CPU-second of this thread (time while other processes ran on the core left out)"
    } else {
        "second of wall time"
    }
}

const SWEEP_BATCHES: &[usize] = &[64, 128, 256, 512, 1024, 2048, 4096];

fn kernel_name(kernel: Kernel) -> &'static str {
    match kernel {
        Kernel::Simd => "simd",
        Kernel::AutoVectorised => "auto-vectorised",
    }
}

pub fn run(args: &BenchArgs) -> anyhow::Result<ExitCode> {
    if args.rays == 0 || args.batch == 0 || args.rounds == 0 {
        bail!("--rays, --batch and --rounds must be at least 1");
    }
    let workload = LensWorkload::new(&args.lens, args.rays)?;
    let min_time = Duration::from_millis(60);
    let variants = [
        Variant::Scalar,
        Variant::Soa {
            batch: args.batch,
            kernel: None,
        },
        Variant::Soa {
            batch: args.batch,
            kernel: Some(Kernel::AutoVectorised),
        },
        Variant::Soa {
            batch: args.batch,
            kernel: Some(Kernel::Simd),
        },
    ];
    let rates = measure(&workload, &variants, args.rounds, min_time);
    let (scalar, soa) = (rates[0], rates[1]);
    let passed = workload.trace_soa(args.batch, None, &mut RayBatch::default());
    let pass_fraction = passed as f64 / workload.rays.len() as f64;

    let sweep: Vec<(usize, Kernel, f64)> = if args.sweep {
        let variants: Vec<Variant> = SWEEP_BATCHES
            .iter()
            .flat_map(|&batch| {
                [Kernel::AutoVectorised, Kernel::Simd].map(|kernel| Variant::Soa {
                    batch,
                    kernel: Some(kernel),
                })
            })
            .collect();
        let rates = measure(&workload, &variants, args.rounds, min_time);
        variants
            .iter()
            .zip(rates)
            .map(|(v, rate)| match *v {
                Variant::Soa { batch, kernel } => {
                    (batch, kernel.expect("sweep names kernels"), rate)
                }
                Variant::Scalar => unreachable!("the sweep has SoA variants only"),
            })
            .collect()
    } else {
        Vec::new()
    };

    if args.json {
        let report = json!({
            "lens": args.lens,
            "surfaces": workload.system.surface_count(),
            "rays": workload.rays.len(),
            "pass_fraction": pass_fraction,
            "batch": args.batch,
            "threads": 1,
            "clock": if thread_cpu_time().is_some() { "thread-cpu-time" } else { "wall" },
            "rounds": args.rounds,
            "scalar_rays_per_s": scalar,
            "soa_rays_per_s": soa,
            "speedup": soa / scalar,
            "soa_kernel": "auto-vectorised",
            "kernels": {
                "auto-vectorised": rates[2],
                "simd": rates[3],
            },
            "cpu_features": cpu_features(),
            "wide_uses_avx": wide_uses_avx(),
            "sweep": sweep.iter().map(|&(batch, kernel, rate)| json!({
                "batch": batch,
                "kernel": kernel_name(kernel),
                "rays_per_s": rate,
            })).collect::<Vec<_>>(),
        });
        println!("{report}");
        return Ok(ExitCode::SUCCESS);
    }
    let m = |rate: f64| rate / 1e6;
    println!(
        "lens tracing, {} ({} surfaces), {} film→scene rays ({:.0} % pass), one thread, median of {} rounds",
        args.lens,
        workload.system.surface_count(),
        workload.rays.len(),
        pass_fraction * 100.0,
        args.rounds
    );
    println!("  rates per {}", clock_name());
    println!(
        "  scalar per-ray (f32, array of structs)  {:>8.2} M rays/s",
        m(scalar)
    );
    println!(
        "  SoA, batches of {:<5} (renderer default) {:>8.2} M rays/s",
        args.batch,
        m(soa)
    );
    println!(
        "    auto-vectorised kernel                {:>8.2} M rays/s",
        m(rates[2])
    );
    println!(
        "    explicit 8-lane SIMD kernel           {:>8.2} M rays/s",
        m(rates[3])
    );
    println!(
        "  speedup SoA / scalar                    {:>8.2}×",
        soa / scalar
    );
    println!(
        "  CPU: {}; wide::f32x8 compiled for {}",
        match cpu_features().as_slice() {
            [] => "no AVX2".to_string(),
            features => features.join(", "),
        },
        if wide_uses_avx() {
            "AVX (256-bit)"
        } else {
            "2 × 128-bit"
        }
    );
    if !sweep.is_empty() {
        println!("  batch size sweep (M rays/s):");
        println!(
            "    {:>6}  {:>15}  {:>6}",
            "batch", "auto-vectorised", "simd"
        );
        for pair in sweep.chunks(2) {
            println!(
                "    {:>6}  {:>15.2}  {:>6.2}",
                pair[0].0,
                m(pair[0].2),
                m(pair[1].2)
            );
        }
    }
    Ok(ExitCode::SUCCESS)
}
