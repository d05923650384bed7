//! Rays from an object point (or a direction, for an object at infinity) aimed through the
//! lens: the real chief ray, through the centre of the stop, and rays through given points of
//! the entrance-pupil plane.

use super::system::LensSystem;
use super::trace::{Ray, Travel, normalize, trace_with};

/// Where a field's rays start, and how one is aimed at a point of the entrance-pupil plane.
pub struct ObjectSource {
    /// Point source (finite object), or `None` for a parallel beam of direction `direction`.
    pub point: Option<[f64; 3]>,
    pub direction: [f64; 3],
    /// Lens-frame z of the plane the aims are points of (the paraxial entrance pupil).
    pub pupil_z: f64,
}

impl ObjectSource {
    /// The ray through (`aim`, `pupil_z`).
    pub fn ray_through(&self, aim: [f64; 2]) -> Ray<f64> {
        let target = [aim[0], aim[1], self.pupil_z];
        match self.point {
            Some(p) => Ray {
                origin: p,
                direction: normalize([target[0] - p[0], target[1] - p[1], target[2] - p[2]]),
            },
            None => {
                // Start well in front of the lens along the beam.
                let back = (self.pupil_z.max(0.0) + 1.0) / self.direction[2];
                Ray {
                    origin: [
                        target[0] - back * self.direction[0],
                        target[1] - back * self.direction[1],
                        target[2] - back * self.direction[2],
                    ],
                    direction: self.direction,
                }
            }
        }
    }

    /// The aim whose ray crosses the stop plane on the axis (the real chief ray), found by
    /// scanning and bisecting along y (fields are meridional).
    pub fn chief_aim(&self, system: &LensSystem) -> Option<[f64; 2]> {
        let stop = system.stop;
        let front = system.f64s.slice(0..stop + 1);
        let height = |y: f64| -> Option<f64> {
            let mut arrays = front.clone();
            // Only the stop's position matters here, not its size.
            if let Some(limit) = arrays.semi_aperture_sq.last_mut() {
                *limit = f64::INFINITY;
            }
            let out = trace_with(
                &arrays,
                self.ray_through([0.0, y]),
                Travel::SceneToFilm,
                true,
            )
            .ok()?;
            Some(out.origin[1])
        };
        if stop == 0 {
            return Some([0.0, 0.0]);
        }
        let reach = 4.0
            * system
                .f64s
                .semi_aperture_sq
                .iter()
                .copied()
                .filter(|v| v.is_finite())
                .fold(1.0, f64::max)
                .sqrt();
        const SCAN: usize = 400;
        let samples: Vec<(f64, Option<f64>)> = (0..=SCAN)
            .map(|k| {
                let y = -reach + 2.0 * reach * k as f64 / SCAN as f64;
                (y, height(y))
            })
            .collect();
        let ((mut lo, mut f_lo), (mut hi, _)) =
            samples.windows(2).find_map(|w| match (w[0].1, w[1].1) {
                (Some(a), Some(b)) if a.signum() != b.signum() || a == 0.0 => {
                    Some(((w[0].0, a), (w[1].0, b)))
                }
                _ => None,
            })?;
        for _ in 0..80 {
            let mid = 0.5 * (lo + hi);
            let f = height(mid)?;
            if f.signum() == f_lo.signum() {
                (lo, f_lo) = (mid, f);
            } else {
                hi = mid;
            }
        }
        Some([0.0, 0.5 * (lo + hi)])
    }
}
