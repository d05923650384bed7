//! Exact ray tracing through the lens, one ray at a time: the reference implementation.
//!
//! Written for clarity in the textbook form (each surface's shape from [`super::shape`], Snell's
//! law in vector form) and generic over the float type, so the same code is the f64 reference for the optics
//! and the f32 per-ray path that the batched SoA tracer ([`super::trace_batch`]) is measured
//! against. Lens frame, mm (see [`crate::lens`]).

use num_traits::Float;

pub use super::ray::{Ray, add, dot, normalize, scale};
use super::system::SurfaceArrays;

/// Which way a ray travels through the lens.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Travel {
    /// From the scene (z < 0) toward the film (+z), surfaces front to back.
    SceneToFilm,
    /// From the film toward the scene (−z), surfaces back to front.
    FilmToScene,
}

impl Travel {
    /// The surface (front = 0) a ray travelling this way meets at `step` (0 = the first it
    /// meets) of a lens of `count` surfaces; the same map takes a surface to its step.
    #[inline(always)]
    pub fn surface_of_step(self, step: usize, count: usize) -> usize {
        match self {
            Travel::SceneToFilm => step,
            Travel::FilmToScene => count - 1 - step,
        }
    }
}

/// Why a ray stopped inside the lens.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum BlockReason {
    /// Hit the surface outside its clear aperture (or the diaphragm around the stop).
    Aperture,
    /// Total internal reflection.
    Tir,
    /// Never reaches the surface's cap next to its vertex, or turned back after refracting.
    Miss,
}

/// The first surface (row index, front = 0) that stopped a ray, and why.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Blocked {
    pub reason: BlockReason,
    pub surface: usize,
}

/// Traces `ray` through every surface in the order of `travel`; on success returns the ray as
/// it leaves the last surface crossed (point on that surface, refracted unit direction).
pub fn trace<T: Float>(
    surfaces: &SurfaceArrays<T>,
    ray: Ray<T>,
    travel: Travel,
) -> Result<Ray<T>, Blocked> {
    trace_with(surfaces, ray, travel, true)
}

/// As [`trace`], optionally ignoring clear apertures (for geometric chief rays).
pub fn trace_with<T: Float>(
    surfaces: &SurfaceArrays<T>,
    ray: Ray<T>,
    travel: Travel,
    check_apertures: bool,
) -> Result<Ray<T>, Blocked> {
    trace_path(surfaces, ray, travel, check_apertures, |_, _| {})
}

/// As [`trace_with`], calling `visit(surface, point)` at every surface the ray reaches
/// (including the one that blocks it, where it has a point there): for drawing ray paths.
pub fn trace_path<T: Float>(
    surfaces: &SurfaceArrays<T>,
    ray: Ray<T>,
    travel: Travel,
    check_apertures: bool,
    visit: impl FnMut(usize, [T; 3]),
) -> Result<Ray<T>, Blocked> {
    trace_transmitted(surfaces, ray, travel, check_apertures, visit).map(|(ray, _)| ray)
}

/// As [`trace_path`], also returning the fraction of the ray's light the lens passes: the
/// grey level of a diaphragm's mask where the ray crosses the stop (1 without one). A ray
/// meeting a blade, or a mask's opaque part, is blocked at the stop
/// ([`BlockReason::Aperture`]).
pub fn trace_transmitted<T: Float>(
    surfaces: &SurfaceArrays<T>,
    ray: Ray<T>,
    travel: Travel,
    check_apertures: bool,
    visit: impl FnMut(usize, [T; 3]),
) -> Result<(Ray<T>, T), Blocked> {
    trace_through(surfaces, ray, travel, check_apertures, None, visit)
}

/// As [`trace_transmitted`] with the surfaces' losses at `wavelength_nm` (the wavelength the
/// arrays' indices are at) in the fraction passed: each surface transmits 1 − R, R its
/// coating's exact reflectance of unpolarised light at the ray's angle there
/// ([`SurfaceArrays::reflectance`]; none without it). The reference for the batch kernels'
/// tables.
pub fn trace_with_losses<T: Float>(
    surfaces: &SurfaceArrays<T>,
    ray: Ray<T>,
    travel: Travel,
    wavelength_nm: f64,
) -> Result<(Ray<T>, T), Blocked> {
    trace_through(surfaces, ray, travel, true, Some(wavelength_nm), |_, _| {})
}

fn trace_through<T: Float>(
    surfaces: &SurfaceArrays<T>,
    mut ray: Ray<T>,
    travel: Travel,
    check_apertures: bool,
    losses_at_nm: Option<f64>,
    mut visit: impl FnMut(usize, [T; 3]),
) -> Result<(Ray<T>, T), Blocked> {
    let to_f64 = |v: T| v.to_f64().unwrap_or(f64::NAN);
    let reflectance = losses_at_nm.zip(surfaces.reflectance.as_deref());
    let mut transmission = T::one();
    let n = surfaces.len();
    for step in 0..n {
        let i = match travel {
            Travel::SceneToFilm => step,
            Travel::FilmToScene => n - 1 - step,
        };
        let (index_in, index_out) = match travel {
            Travel::SceneToFilm => (surfaces.index_front[i], surfaces.index_back[i]),
            Travel::FilmToScene => (surfaces.index_back[i], surfaces.index_front[i]),
        };
        let blocked = |reason| Blocked { reason, surface: i };
        let profile = surfaces.profile(i);
        let vertex_z = surfaces.vertex_z[i];
        let t = profile
            .intersect(vertex_z, &ray)
            .ok_or(blocked(BlockReason::Miss))?;
        let p = add(ray.origin, scale(ray.direction, t));
        visit(i, p);
        if check_apertures && p[0] * p[0] + p[1] * p[1] > surfaces.semi_aperture_sq[i] {
            return Err(blocked(BlockReason::Aperture));
        }
        if check_apertures
            && let Some(clip) = surfaces.stop_clip.as_deref()
            && clip.surface == i
        {
            let passed = clip.transmission(to_f64(p[0]), to_f64(p[1]));
            if passed.is_nan() || passed <= 0.0 {
                return Err(blocked(BlockReason::Aperture));
            }
            transmission = transmission * T::from(passed).unwrap_or_else(T::zero);
        }
        let normal = profile
            .normal(vertex_z, p)
            .ok_or(blocked(BlockReason::Miss))?;
        let direction = refract(ray.direction, normal, index_in / index_out)
            .ok_or(blocked(BlockReason::Tir))?;
        let forward = match travel {
            Travel::SceneToFilm => direction[2] > T::zero(),
            Travel::FilmToScene => direction[2] < T::zero(),
        };
        if !forward {
            return Err(blocked(BlockReason::Miss));
        }
        if let Some((nm, reflectance)) = reflectance {
            let cos_in = to_f64(dot(ray.direction, normal)).abs();
            let from_front = travel == Travel::SceneToFilm;
            let r = reflectance.exact(
                i,
                to_f64(index_in),
                to_f64(index_out),
                cos_in,
                nm,
                from_front,
            );
            transmission = transmission * T::from(1.0 - r).unwrap_or_else(T::zero);
        }
        ray = Ray {
            origin: p,
            direction,
        };
    }
    Ok((ray, transmission))
}

/// Snell refraction of unit `direction` at a surface with unit `normal` (either orientation),
/// `eta` = n_incident / n_transmitted. `None` on total internal reflection.
pub fn refract<T: Float>(direction: [T; 3], normal: [T; 3], eta: T) -> Option<[T; 3]> {
    let mut n = normal;
    let mut cos_i = -dot(direction, n);
    if cos_i < T::zero() {
        n = scale(n, -T::one());
        cos_i = -cos_i;
    }
    let sin2_t = eta * eta * (T::one() - cos_i * cos_i);
    if sin2_t > T::one() {
        return None;
    }
    let cos_t = (T::one() - sin2_t).sqrt();
    Some(normalize(add(
        scale(direction, eta),
        scale(n, eta * cos_i - cos_t),
    )))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::shape::Profile;
    use crate::lens::{LensSystem, SurfaceRow};

    fn row(radius: f64, thickness: f64, index: f64, aperture: f64) -> SurfaceRow {
        SurfaceRow::new(radius, thickness, index, aperture)
    }

    #[test]
    fn vertex_cap_is_chosen_for_both_signs_and_directions() {
        for &(radius, dz) in &[(10.0, 1.0), (-10.0, 1.0), (10.0, -1.0), (-10.0, -1.0)] {
            let ray = Ray {
                origin: [1.0, 0.0, -30.0 * dz],
                direction: [0.0, 0.0, dz],
            };
            let t = Profile::sphere(1.0 / radius).intersect(0.0, &ray).unwrap();
            let z = ray.origin[2] + t * dz;
            let expected_z = radius - (radius * radius - 1.0f64).sqrt() * radius.signum();
            assert!((z - expected_z).abs() < 1e-12, "R={radius} dz={dz}: z={z}");
        }
    }

    #[test]
    fn snell_law_holds() {
        let theta: f64 = 0.4;
        let d = [theta.sin(), 0.0, theta.cos()];
        let out = refract(d, [0.0, 0.0, -1.0], 1.0 / 1.5).unwrap();
        assert!((out[0] * 1.5 - theta.sin()).abs() < 1e-12);
        assert!(
            refract([0.8, 0.0, 0.6], [0.0, 0.0, -1.0], 1.5).is_none(),
            "TIR expected"
        );
    }

    #[test]
    fn flat_plate_shifts_but_keeps_direction() {
        // A tilted ray through a parallel plate leaves parallel to itself (Snell twice).
        let system = LensSystem::new(
            &[
                row(f64::INFINITY, 5.0, 1.5, 40.0),
                row(0.0, 5.0, 1.0, 30.0),
                row(f64::INFINITY, 0.0, 1.0, 40.0),
            ],
            None,
        );
        let d = normalize([0.2, 0.1, 1.0]);
        let out = trace(
            &system.f64s,
            Ray {
                origin: [0.0, 0.0, -10.0],
                direction: d,
            },
            Travel::SceneToFilm,
        )
        .unwrap();
        for (got, want) in out.direction.iter().zip(d) {
            assert!((got - want).abs() < 1e-12);
        }
    }

    #[test]
    fn blocked_reasons() {
        let system = LensSystem::new(
            &[
                row(20.0, 5.0, 1.5, 10.0),
                row(0.0, 5.0, 1.0, 4.0),
                row(-20.0, 0.0, 1.0, 10.0),
            ],
            None,
        );
        let outside = Ray {
            origin: [6.0, 0.0, -10.0],
            direction: [0.0, 0.0, 1.0],
        };
        assert_eq!(
            trace(&system.f64s, outside, Travel::SceneToFilm),
            Err(Blocked {
                reason: BlockReason::Aperture,
                surface: 0
            })
        );
        let at_stop = Ray {
            origin: [3.0, 0.0, -10.0],
            direction: [0.0, 0.0, 1.0],
        };
        assert_eq!(
            trace(&system.f64s, at_stop, Travel::SceneToFilm)
                .unwrap_err()
                .surface,
            1
        );
        let parallel = Ray {
            origin: [0.0, 0.0, -10.0],
            direction: [1.0, 0.0, 0.0],
        };
        assert_eq!(
            trace(&system.f64s, parallel, Travel::SceneToFilm)
                .unwrap_err()
                .reason,
            BlockReason::Miss
        );
    }
}
