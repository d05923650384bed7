//! The lens-tracing benchmark workload: the camera rays `realcam bench` and `cargo bench`
//! (benches/lens_tracing.rs) both trace, so both report the same work.

use anyhow::{Context, bail};

use crate::batch::RayBatch;
use crate::lens::LensSystem;
use crate::lens::first_order::FirstOrder;
use crate::lens::focus::paraxial_film_distance;
use crate::lens::io::bundled::load_lens;
use crate::lens::pupil::{ExitPupil, PupilSampling};
use crate::lens::trace::{Ray, Travel, trace};
use crate::lens::trace_batch::{Isa, Kernel, Wavelengths, trace_batch_on, trace_batch_spectral_on};
use crate::sampling::Rng;
use crate::spectral::{LAMBDA_MAX, LAMBDA_MIN};

/// Film→scene camera rays for one lens, as the renderer makes them: focused at 5 m, film
/// points uniform over the central 24 × 24 mm of a 35 mm-diagonal film, each aimed at a
/// uniform point of its exit-pupil bounds. The same rays are held as structs and as SoA.
pub struct LensWorkload {
    pub system: LensSystem,
    pub film_distance: f64,
    /// The exit-pupil bounds the rays were aimed within.
    pub pupil: ExitPupil,
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
            pupil,
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
    /// in place by `kernel` compiled for `isa`. Returns the number that pass.
    pub fn trace_soa(
        &self,
        batch_size: usize,
        kernel: Kernel,
        isa: Isa,
        work: &mut RayBatch,
    ) -> usize {
        self.trace_in_batches(batch_size, work, |_, work| {
            trace_batch_on(&self.system.f32s, work, Travel::FilmToScene, kernel, isa)
        })
    }

    /// [`Self::trace_soa`] with each ray at its own wavelength (the plain kernel, as the
    /// renderer runs it): the rays' wavelengths spread evenly over the visible, in an order
    /// that mixes them within every batch as a spectral render's do. Returns `None` for a lens
    /// without glass data.
    pub fn trace_soa_spectral(
        &self,
        batch_size: usize,
        isa: Isa,
        work: &mut RayBatch,
        nm: &mut Vec<f32>,
    ) -> Option<usize> {
        let table = self.system.dispersion.as_deref()?;
        Some(self.trace_in_batches(batch_size, work, |rays, work| {
            nm.clear();
            nm.extend(rays.map(spread_wavelength));
            let wavelengths = Wavelengths { table, nm };
            trace_batch_spectral_on(
                &self.system.f32s,
                wavelengths,
                work,
                Travel::FilmToScene,
                Kernel::AutoVectorised,
                isa,
            );
        }))
    }

    /// Copies the rays into `work` a batch of `batch_size` at a time and has `trace` trace
    /// each batch (its rays' indices, the batch) in place. Returns the number that pass.
    fn trace_in_batches(
        &self,
        batch_size: usize,
        work: &mut RayBatch,
        mut trace: impl FnMut(std::ops::Range<usize>, &mut RayBatch),
    ) -> usize {
        let mut passed = 0;
        let len = self.batch.len();
        let mut start = 0;
        while start < len {
            let end = (start + batch_size).min(len);
            copy_rays(&self.batch, start..end, work);
            if self.system.f32s.reflectance.is_some() {
                // The surfaces' losses scale each ray's throughput, which starts at 1.
                for throughput in [&mut work.tr, &mut work.tg, &mut work.tb] {
                    throughput.clear();
                    throughput.resize(end - start, 1.0);
                }
            }
            trace(start..end, work);
            passed += work.alive_count();
            start = end;
        }
        passed
    }
}

/// Ray `i`'s wavelength for [`LensWorkload::trace_soa_spectral`]: a golden-ratio
/// sequence over the visible, so neighbouring rays are far apart in wavelength.
fn spread_wavelength(i: usize) -> f32 {
    const GOLDEN: f64 = 0.618_033_988_749_895;
    let u = (i as f64 * GOLDEN).fract();
    (LAMBDA_MIN + u * (LAMBDA_MAX - LAMBDA_MIN)) as f32
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
