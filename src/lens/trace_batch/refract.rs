//! One surface of the lens for a group of lanes: intersection, clear aperture, Snell's law.
//!
//! The physics of [`crate::lens::trace`] (the per-ray reference) in the curvature form of the
//! sphere, so flat surfaces (c = 0) need no special case, and without branches: every lane
//! computes both roots, the cap test, the aperture test and the refraction, and blocked lanes
//! are masked off.
//!
//! The surface through vertex z_v is c(x² + y² + (z − z_v)²) − 2(z − z_v) = 0; along o + t·d
//! (|d| = 1) this is c·t² + 2b·t + k = 0 with b = c(o'·d) − d_z, k = c|o'|² − 2o'_z,
//! o' = o − z_v ẑ.

use super::lanes::Lanes;
use crate::lens::system::SurfaceArrays;
use crate::lens::trace::Travel;

/// Smallest distance along a ray accepted as a hit, mm (so a ray never re-hits the surface it
/// starts on).
const T_MIN: f32 = 1e-6;

/// One surface's parameters for the direction of travel, worked out once per batch.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceConstants<L> {
    pub vertex_z: L,
    pub curvature: L,
    /// 1/c (infinite for flat surfaces): the far root q/c becomes a multiplication.
    pub radius: L,
    pub semi_aperture_sq: L,
    /// n_incident / n_transmitted for the direction of travel, and its square.
    pub eta: L,
    pub eta_sq: L,
    /// +1 when rays must leave toward +z, −1 toward −z.
    pub forward_sign: L,
}

impl SurfaceConstants<f32> {
    /// The surfaces in the order rays meet them travelling `travel`.
    pub fn in_travel_order(surfaces: &SurfaceArrays<f32>, travel: Travel) -> Vec<Self> {
        let n = surfaces.len();
        (0..n)
            .map(|step| {
                let (i, eta, forward_sign) = match travel {
                    Travel::SceneToFilm => (
                        step,
                        surfaces.index_front[step] / surfaces.index_back[step],
                        1.0,
                    ),
                    Travel::FilmToScene => {
                        let i = n - 1 - step;
                        (i, surfaces.index_back[i] / surfaces.index_front[i], -1.0)
                    }
                };
                let curvature = surfaces.curvature[i];
                SurfaceConstants {
                    vertex_z: surfaces.vertex_z[i],
                    curvature,
                    radius: 1.0 / curvature,
                    semi_aperture_sq: surfaces.semi_aperture_sq[i],
                    eta,
                    eta_sq: eta * eta,
                    forward_sign,
                }
            })
            .collect()
    }

    /// The same constants broadcast to every lane of `L`.
    #[inline(always)]
    pub fn splat<L: Lanes>(&self) -> SurfaceConstants<L> {
        SurfaceConstants {
            vertex_z: L::splat(self.vertex_z),
            curvature: L::splat(self.curvature),
            radius: L::splat(self.radius),
            semi_aperture_sq: L::splat(self.semi_aperture_sq),
            eta: L::splat(self.eta),
            eta_sq: L::splat(self.eta_sq),
            forward_sign: L::splat(self.forward_sign),
        }
    }
}

/// Origin and unit direction of a group of rays, lens frame, mm.
#[derive(Clone, Copy, Debug)]
pub struct LaneRay<L> {
    pub origin: [L; 3],
    pub direction: [L; 3],
}

/// Moves the `alive` lanes of `ray` onto surface `s` and refracts them; returns which lanes
/// are still alive. Lanes that are or become blocked keep their previous state, so a miss
/// never leaves a NaN behind.
#[inline(always)]
pub fn refract_at<L: Lanes>(
    s: &SurfaceConstants<L>,
    ray: &mut LaneRay<L>,
    alive: L::Mask,
) -> L::Mask {
    let zero = L::splat(0.0);
    let one = L::splat(1.0);
    let [px, py, pz] = ray.origin;
    let [vx, vy, vz] = ray.direction;
    let c = s.curvature;

    let ovz = pz - s.vertex_z;
    let b = c * (px * vx + py * vy + ovz * vz) - vz;
    let k = c * (px * px + py * py + ovz * ovz) - (ovz + ovz);
    let discriminant = b * b - c * k;
    let root = discriminant.max(zero).sqrt();
    // q = −b − sign(b)·√Δ adds two terms of one sign (no cancellation); the roots are k/q and
    // q/c, and k/q is the one that tends to the plane's as c → 0.
    let q = L::select(b.lt(zero), root - b, -b - root);
    let t_near = k / q;
    let t_far = q * s.radius;
    // A root counts if it lies ahead, is finite (t < ∞ also rejects NaN) and on the cap next
    // to the vertex, c·(z − z_v) < 1.
    let infinity = L::splat(f32::INFINITY);
    let ok_near =
        t_near.gt(L::splat(T_MIN)) & t_near.lt(infinity) & (c * (ovz + t_near * vz)).lt(one);
    let ok_far = t_far.gt(L::splat(T_MIN)) & t_far.lt(infinity) & (c * (ovz + t_far * vz)).lt(one);
    let use_near = ok_near & (!ok_far | t_near.le(t_far));
    let t = L::select(use_near, t_near, t_far);
    let hit = discriminant.ge(zero) & (ok_near | ok_far);

    let hx = px + t * vx;
    let hy = py + t * vy;
    let hz = pz + t * vz;
    let inside = (hx * hx + hy * hy).le(s.semi_aperture_sq);

    // Normal (c·x, c·y, c·(z − z_v) − 1) = (h − centre)/R. Its squared length is
    // 1 + c·S(h), where S(h) = 0 is the surface equation above: a unit vector at an exact hit,
    // but a hit found from far away (t ~ 1000 mm in f32) can sit 1e-3 mm off the sphere, and
    // that error would scale the refracted direction. Normalising makes it a tiny tilt instead.
    let nx = c * hx;
    let ny = c * hy;
    let nz = c * (hz - s.vertex_z) - one;
    let inv_length = one / (nx * nx + ny * ny + nz * nz).sqrt();
    let (nx, ny, nz) = (nx * inv_length, ny * inv_length, nz * inv_length);
    // Face the normal against the incoming ray: flip = ±1 multiplies exactly.
    let cos_raw = -(vx * nx + vy * ny + vz * nz);
    let flip = L::select(cos_raw.lt(zero), -one, one);
    let cos_i = cos_raw * flip;
    let cos_t_sq = one - s.eta_sq * (one - cos_i * cos_i);
    let no_tir = cos_t_sq.ge(zero);
    let cos_t = cos_t_sq.max(zero).sqrt();
    // Snell's law in vector form, η·d + (η·cos_i − cos_t)·n: a unit vector when d and n are,
    // so it is renormalised only once, after the last surface ([`normalise_direction`]); the
    // rounding drift over a whole lens is ~1e-6.
    let along_normal = (s.eta * cos_i - cos_t) * flip;
    let rx = s.eta * vx + along_normal * nx;
    let ry = s.eta * vy + along_normal * ny;
    let rz = s.eta * vz + along_normal * nz;
    let forward = (rz * s.forward_sign).gt(zero);

    let survives = alive & hit & inside & no_tir & forward;
    let keep = |new: L, old: L| L::select(survives, new, old);
    ray.origin = [keep(hx, px), keep(hy, py), keep(hz, pz)];
    ray.direction = [keep(rx, vx), keep(ry, vy), keep(rz, vz)];
    survives
}

/// Rescales the direction of the `alive` lanes to unit length (after the last surface).
#[inline(always)]
pub fn normalise_direction<L: Lanes>(ray: &mut LaneRay<L>, alive: L::Mask) {
    let [x, y, z] = ray.direction;
    let inv_length = L::splat(1.0) / (x * x + y * y + z * z).sqrt();
    ray.direction = [x, y, z].map(|v| L::select(alive, v * inv_length, v));
}
