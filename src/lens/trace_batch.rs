//! Exact ray tracing through the lens for a whole batch at once (structure of arrays, f32).
//!
//! The loop runs surface by surface over all rays, with no branches inside: every lane computes
//! both roots, the cap test, the aperture test and Snell's law, and blocked rays are masked off.
//! The compiler turns these loops into SIMD code. The physics is that of [`super::trace`]
//! (the per-ray reference), written in the curvature form of the sphere so that flat surfaces
//! (c = 0) need no special case:
//!
//! the surface through vertex z_v is c(x² + y² + (z − z_v)²) − 2(z − z_v) = 0; along o + t·d
//! (|d| = 1) this is c·t² + 2b·t + k = 0 with b = c(o'·d) − d_z, k = c|o'|² − 2o'_z, o' = o − z_v ẑ.

use super::system::SurfaceArrays;
use super::trace::Travel;
use wide::f32x8;

use crate::batch::RayBatch;

/// Which implementation of the per-surface kernel to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    /// Explicit 8-lane SIMD (`wide::f32x8`: AVX where the build targets it, SSE pairs otherwise).
    Simd,
    /// A plain loop left to the compiler's auto-vectoriser.
    AutoVectorised,
}

/// Traces every alive ray of `rays` (lens frame, mm, unit directions) through all surfaces in
/// the order of `travel`, in place: survivors end on the last surface crossed with their
/// refracted direction; blocked rays get `alive = false`.
pub fn trace_batch(surfaces: &SurfaceArrays<f32>, rays: &mut RayBatch, travel: Travel) {
    trace_batch_with(surfaces, rays, travel, Kernel::AutoVectorised)
}

/// [`trace_batch`] with a chosen kernel (for benchmarks and cross-checks).
pub fn trace_batch_with(
    surfaces: &SurfaceArrays<f32>,
    rays: &mut RayBatch,
    travel: Travel,
    kernel: Kernel,
) {
    let n = surfaces.len();
    for step in 0..n {
        let i = match travel {
            Travel::SceneToFilm => step,
            Travel::FilmToScene => n - 1 - step,
        };
        let eta = match travel {
            Travel::SceneToFilm => surfaces.index_front[i] / surfaces.index_back[i],
            Travel::FilmToScene => surfaces.index_back[i] / surfaces.index_front[i],
        };
        let forward_sign = match travel {
            Travel::SceneToFilm => 1.0,
            Travel::FilmToScene => -1.0,
        };
        let surface = BatchSurface {
            vertex_z: surfaces.vertex_z[i],
            curvature: surfaces.curvature[i],
            semi_aperture_sq: surfaces.semi_aperture_sq[i],
            eta,
            forward_sign,
        };
        match kernel {
            Kernel::Simd => refract_through_simd(&surface, rays),
            Kernel::AutoVectorised => refract_through(&surface, rays),
        }
    }
}

/// One surface's parameters as the batch kernel needs them.
#[derive(Clone, Copy, Debug)]
pub struct BatchSurface {
    pub vertex_z: f32,
    pub curvature: f32,
    pub semi_aperture_sq: f32,
    /// n_incident / n_transmitted for the direction of travel.
    pub eta: f32,
    /// +1 when rays must leave toward +z, −1 toward −z.
    pub forward_sign: f32,
}

/// Intersects and refracts every ray of the batch at one surface.
pub fn refract_through(s: &BatchSurface, rays: &mut RayBatch) {
    let len = rays.len();
    let (ox, oy, oz) = (
        &mut rays.ox[..len],
        &mut rays.oy[..len],
        &mut rays.oz[..len],
    );
    let (dx, dy, dz) = (
        &mut rays.dx[..len],
        &mut rays.dy[..len],
        &mut rays.dz[..len],
    );
    let alive = &mut rays.alive[..len];
    let c = s.curvature;
    const T_MIN: f32 = 1e-6;
    for i in 0..len {
        let (px, py, pz) = (ox[i], oy[i], oz[i]);
        let (vx, vy, vz) = (dx[i], dy[i], dz[i]);
        let ovz = pz - s.vertex_z;
        let b = c * (px * vx + py * vy + ovz * vz) - vz;
        let k = c * (px * px + py * py + ovz * ovz) - 2.0 * ovz;
        let discriminant = b * b - c * k;
        let root = discriminant.max(0.0).sqrt();
        let q = -b - root.copysign(b);
        // Roots q/c and k/q: k/q is the one that tends to the plane's as c → 0.
        let t_near = k / q;
        let t_far = q / c;
        let cap_near = c * (ovz + t_near * vz) < 1.0;
        let cap_far = c * (ovz + t_far * vz) < 1.0;
        let ok_near = (t_near > T_MIN) & cap_near & t_near.is_finite();
        let ok_far = (t_far > T_MIN) & cap_far & t_far.is_finite();
        let use_near = ok_near & (!ok_far | (t_near <= t_far));
        let t = if use_near { t_near } else { t_far };
        let hit = (discriminant >= 0.0) & (ok_near | ok_far);

        let hx = px + t * vx;
        let hy = py + t * vy;
        let hz = pz + t * vz;
        let inside = hx * hx + hy * hy <= s.semi_aperture_sq;

        // Normal (c·x, c·y, c·(z − z_v) − 1), then faced against the incoming ray.
        let mut nx = c * hx;
        let mut ny = c * hy;
        let mut nz = c * (hz - s.vertex_z) - 1.0;
        let inv_len = 1.0 / (nx * nx + ny * ny + nz * nz).sqrt();
        nx *= inv_len;
        ny *= inv_len;
        nz *= inv_len;
        let cos_raw = -(vx * nx + vy * ny + vz * nz);
        let flip = if cos_raw < 0.0 { -1.0 } else { 1.0 };
        let cos_i = cos_raw * flip;
        let k2 = 1.0 - s.eta * s.eta * (1.0 - cos_i * cos_i);
        let no_tir = k2 >= 0.0;
        let cos_t = k2.max(0.0).sqrt();
        let along_normal = (s.eta * cos_i - cos_t) * flip;
        let mut rx = s.eta * vx + along_normal * nx;
        let mut ry = s.eta * vy + along_normal * ny;
        let mut rz = s.eta * vz + along_normal * nz;
        let inv_r = 1.0 / (rx * rx + ry * ry + rz * rz).sqrt();
        rx *= inv_r;
        ry *= inv_r;
        rz *= inv_r;
        let forward = rz * s.forward_sign > 0.0;

        let survives = alive[i] & hit & inside & no_tir & forward;
        alive[i] = survives;
        // Blocked rays keep their last state, so no NaN from a miss ever propagates.
        ox[i] = if survives { hx } else { px };
        oy[i] = if survives { hy } else { py };
        oz[i] = if survives { hz } else { pz };
        dx[i] = if survives { rx } else { vx };
        dy[i] = if survives { ry } else { vy };
        dz[i] = if survives { rz } else { vz };
    }
}

const LANES: usize = 8;

/// [`refract_through`] written with explicit 8-wide SIMD; the same arithmetic lane by lane.
pub fn refract_through_simd(s: &BatchSurface, rays: &mut RayBatch) {
    let len = rays.len();
    let zero = f32x8::ZERO;
    let one = f32x8::ONE;
    let c = f32x8::splat(s.curvature);
    let vertex_z = f32x8::splat(s.vertex_z);
    let semi_aperture_sq = f32x8::splat(s.semi_aperture_sq);
    let eta = f32x8::splat(s.eta);
    let forward_sign = f32x8::splat(s.forward_sign);
    let t_min = f32x8::splat(1e-6);
    let infinity = f32x8::splat(f32::INFINITY);
    let mut start = 0;
    while start < len {
        let n = (len - start).min(LANES);
        let load = |v: &[f32]| {
            let mut lanes = [0.0f32; LANES];
            lanes[..n].copy_from_slice(&v[start..start + n]);
            f32x8::from(lanes)
        };
        let (px, py, pz) = (load(&rays.ox), load(&rays.oy), load(&rays.oz));
        let (vx, vy, vz) = (load(&rays.dx), load(&rays.dy), load(&rays.dz));
        let mut alive_lanes = [0.0f32; LANES];
        for (lane, &a) in alive_lanes.iter_mut().zip(&rays.alive[start..start + n]) {
            *lane = if a { 1.0 } else { 0.0 };
        }
        let alive = f32x8::from(alive_lanes).simd_gt(zero);

        let ovz = pz - vertex_z;
        let b = c * (px * vx + py * vy + ovz * vz) - vz;
        let k = c * (px * px + py * py + ovz * ovz) - f32x8::splat(2.0) * ovz;
        let discriminant = b * b - c * k;
        let root = discriminant.max(zero).sqrt();
        let q = b.simd_lt(zero).bitselect(root - b, -b - root);
        let t_near = k / q;
        let t_far = q / c;
        let cap_near = (c * (ovz + t_near * vz)).simd_lt(one);
        let cap_far = (c * (ovz + t_far * vz)).simd_lt(one);
        let ok_near = t_near.simd_gt(t_min) & cap_near & t_near.abs().simd_lt(infinity);
        let ok_far = t_far.simd_gt(t_min) & cap_far & t_far.abs().simd_lt(infinity);
        let use_near = ok_near & (!ok_far | t_near.simd_le(t_far));
        let t = use_near.bitselect(t_near, t_far);
        let hit = discriminant.simd_ge(zero) & (ok_near | ok_far);

        let hx = px + t * vx;
        let hy = py + t * vy;
        let hz = pz + t * vz;
        let inside = (hx * hx + hy * hy).simd_le(semi_aperture_sq);

        let nx0 = c * hx;
        let ny0 = c * hy;
        let nz0 = c * (hz - vertex_z) - one;
        let inv_len = one / (nx0 * nx0 + ny0 * ny0 + nz0 * nz0).sqrt();
        let (nx, ny, nz) = (nx0 * inv_len, ny0 * inv_len, nz0 * inv_len);
        let cos_raw = -(vx * nx + vy * ny + vz * nz);
        let flip = cos_raw.simd_lt(zero).bitselect(-one, one);
        let cos_i = cos_raw * flip;
        let k2 = one - eta * eta * (one - cos_i * cos_i);
        let no_tir = k2.simd_ge(zero);
        let cos_t = k2.max(zero).sqrt();
        let along_normal = (eta * cos_i - cos_t) * flip;
        let rx0 = eta * vx + along_normal * nx;
        let ry0 = eta * vy + along_normal * ny;
        let rz0 = eta * vz + along_normal * nz;
        let inv_r = one / (rx0 * rx0 + ry0 * ry0 + rz0 * rz0).sqrt();
        let (rx, ry, rz) = (rx0 * inv_r, ry0 * inv_r, rz0 * inv_r);
        let forward = (rz * forward_sign).simd_gt(zero);

        let survives = alive & hit & inside & no_tir & forward;
        let store = |v: &mut [f32], new: f32x8, old: f32x8| {
            v[start..start + n].copy_from_slice(&survives.bitselect(new, old).to_array()[..n]);
        };
        store(&mut rays.ox, hx, px);
        store(&mut rays.oy, hy, py);
        store(&mut rays.oz, hz, pz);
        store(&mut rays.dx, rx, vx);
        store(&mut rays.dy, ry, vy);
        store(&mut rays.dz, rz, vz);
        let mask = survives.to_bitmask();
        for (lane, a) in rays.alive[start..start + n].iter_mut().enumerate() {
            *a = mask & (1 << lane) != 0;
        }
        start += n;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::trace::{Ray, trace};
    use crate::lens::{LensSystem, Prescription};
    use crate::sampling::Rng;
    use std::path::Path;

    fn bundled(name: &str) -> LensSystem {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("lenses")
            .join(name);
        let p = Prescription::load(&path, None).unwrap();
        LensSystem::new(&p.rows, None)
    }

    /// Random rays from the film plane toward the rear element: the render path's rays.
    fn film_rays(system: &LensSystem, film_distance: f64, count: usize) -> Vec<Ray<f64>> {
        let mut rng = Rng::new(42, 7);
        let rear = system.rear_semi_aperture() * 1.1;
        let film_z = system.rear_z() + film_distance;
        (0..count)
            .map(|_| {
                let film = [
                    (rng.next_f64() - 0.5) * 30.0,
                    (rng.next_f64() - 0.5) * 30.0,
                    film_z,
                ];
                let target = [
                    (rng.next_f64() - 0.5) * 2.0 * rear,
                    (rng.next_f64() - 0.5) * 2.0 * rear,
                    system.rear_z(),
                ];
                let d = crate::lens::trace::normalize([
                    target[0] - film[0],
                    target[1] - film[1],
                    target[2] - film[2],
                ]);
                Ray {
                    origin: film,
                    direction: d,
                }
            })
            .collect()
    }

    #[test]
    fn batch_agrees_with_scalar_reference_on_every_bundled_lens() {
        for (name, _) in crate::lens::bundled::BUNDLED {
            let system = bundled(&format!("{name}.dat"));
            let rays = film_rays(&system, system.rear_z() * 0.6, 4000);
            let mut batch = RayBatch::with_capacity(rays.len());
            for r in &rays {
                let f = |a: [f64; 3]| [a[0] as f32, a[1] as f32, a[2] as f32];
                batch.push(f(r.origin), f(r.direction), 0, 0);
            }
            let mut simd = batch.clone();
            trace_batch(&system.f32s, &mut batch, Travel::FilmToScene);
            trace_batch_with(&system.f32s, &mut simd, Travel::FilmToScene, Kernel::Simd);
            assert_eq!(
                batch.alive, simd.alive,
                "{name}: SIMD and plain kernels disagree"
            );
            assert_eq!(batch.dx, simd.dx, "{name}: SIMD and plain kernels disagree");
            let mut passed = 0;
            let mut disagreements = 0;
            for (i, r) in rays.iter().enumerate() {
                match trace(&system.f64s, *r, Travel::FilmToScene) {
                    Ok(out) => {
                        if !batch.alive[i] {
                            disagreements += 1;
                            continue;
                        }
                        passed += 1;
                        let p = batch.origin(i);
                        let d = batch.direction(i);
                        for k in 0..3 {
                            assert!(
                                (p[k] as f64 - out.origin[k]).abs() < 2e-3,
                                "{name}: point {k}: {} vs {}",
                                p[k],
                                out.origin[k]
                            );
                            assert!(
                                (d[k] as f64 - out.direction[k]).abs() < 2e-4,
                                "{name}: direction {k}"
                            );
                        }
                    }
                    Err(_) => disagreements += usize::from(batch.alive[i]),
                }
            }
            // f32 vs f64 may only differ for rays grazing an aperture edge.
            assert!(
                disagreements <= rays.len() / 500,
                "{name}: {disagreements} disagreements"
            );
            assert!(passed > 100, "{name}: only {passed} rays passed");
        }
    }
}
