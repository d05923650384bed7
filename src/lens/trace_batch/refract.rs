//! One surface of the lens for a group of lanes: intersection, clear aperture, Snell's law.
//!
//! The physics of [`crate::lens::trace`] (the per-ray reference) without branches: every lane
//! computes the roots, the sheet test, the aperture test and the refraction, and blocked lanes
//! are masked off. The shapes are those of [`crate::lens::shape`], in three kernels chosen per
//! surface (not per ray), so an all-spherical lens runs exactly the sphere kernel:
//!
//! * [`SPHERE`]: c(x² + y² + z²) − 2z = 0 (z from the vertex); along o + t·d (|d| = 1) this is
//!   c·t² + 2b·t + k = 0 with b = c(o·d) − d_z, k = c|o|² − 2o_z. Planes are c = 0.
//! * [`CONIC`]: c(x² + y²) + κc·z² − 2z = 0, i.e. a·t² + 2b·t + k = 0 with a = c(1 + (κ−1)d_z²),
//!   b = c(o_x d_x + o_y d_y + κ o_z d_z) − d_z, k = c(o_x² + o_y² + κ o_z²) − 2o_z.
//! * [`POLYNOMIAL`]: Newton's method on z − sag(ρ) from the base conic's root.

use crate::lanes::Lanes;
use crate::lens::shape::ASPHERIC_TERMS;
use crate::lens::system::SurfaceArrays;
use crate::lens::trace::Travel;

/// Smallest distance along a ray accepted as a hit, mm (so a ray never re-hits the surface it
/// starts on).
const T_MIN: f32 = 1e-6;

/// Newton steps before a lane that has not converged counts as a miss: started from the base
/// conic, real aspheres converge in 3–6 steps in f32.
pub const NEWTON_STEPS: usize = 16;

/// The kernel shapes (const-generic parameters of [`refract_at`]).
pub const SPHERE: u8 = 0;
pub const CONIC: u8 = 1;
pub const POLYNOMIAL: u8 = 2;

/// One surface's parameters for the direction of travel, worked out once per batch.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceConstants<L> {
    /// [`SPHERE`], [`CONIC`] or [`POLYNOMIAL`].
    pub shape: u8,
    pub vertex_z: L,
    pub curvature: L,
    /// 1/c (infinite for flat surfaces): the sphere's far root q/c becomes a multiplication.
    pub radius: L,
    /// κ = 1 + k, and κ − 1 = k.
    pub conic_factor: L,
    pub conic: L,
    /// A₂ … A₁₆, and i·A_{2i} for the slope.
    pub coefficients: [L; ASPHERIC_TERMS],
    pub slope_coefficients: [L; ASPHERIC_TERMS],
    pub semi_aperture_sq: L,
    /// n_incident / n_transmitted for the direction of travel (at the lens's own indices; a
    /// spectral batch passes each lane's own ratio to [`refract_at`] instead).
    pub eta: L,
    /// +1 when rays must leave toward +z, −1 toward −z.
    pub forward_sign: L,
}

impl SurfaceConstants<f32> {
    /// The surfaces in the order rays meet them travelling `travel`.
    pub fn in_travel_order(
        surfaces: &SurfaceArrays<f32>,
        travel: Travel,
    ) -> impl Iterator<Item = Self> + '_ {
        let n = surfaces.len();
        (0..n).map(move |step| {
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
            Self::of(surfaces, i, eta, forward_sign)
        })
    }

    /// Surface `i`'s constants for rays crossing it with index ratio `eta` and leaving toward
    /// the sign of z `forward_sign`.
    pub fn of(surfaces: &SurfaceArrays<f32>, i: usize, eta: f32, forward_sign: f32) -> Self {
        let curvature = surfaces.curvature[i];
        let conic_factor = surfaces.conic_factor[i];
        let shape = if surfaces.polynomial[i] {
            POLYNOMIAL
        } else if conic_factor != 1.0 {
            CONIC
        } else {
            SPHERE
        };
        let coefficients = surfaces.aspheric[i];
        let mut slope_coefficients = coefficients;
        for (k, a) in slope_coefficients.iter_mut().enumerate() {
            *a *= (k + 1) as f32;
        }
        SurfaceConstants {
            shape,
            vertex_z: surfaces.vertex_z[i],
            curvature,
            radius: 1.0 / curvature,
            conic_factor,
            conic: conic_factor - 1.0,
            coefficients,
            slope_coefficients,
            semi_aperture_sq: surfaces.semi_aperture_sq[i],
            eta,
            forward_sign,
        }
    }

    /// The same constants broadcast to every lane of `L`.
    #[inline(always)]
    pub fn splat<L: Lanes>(&self) -> SurfaceConstants<L> {
        SurfaceConstants {
            shape: self.shape,
            vertex_z: L::splat(self.vertex_z),
            curvature: L::splat(self.curvature),
            radius: L::splat(self.radius),
            conic_factor: L::splat(self.conic_factor),
            conic: L::splat(self.conic),
            coefficients: self.coefficients.map(L::splat),
            slope_coefficients: self.slope_coefficients.map(L::splat),
            semi_aperture_sq: L::splat(self.semi_aperture_sq),
            eta: L::splat(self.eta),
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

/// A block of rays as the plain loops work on them: origins and directions (lens frame, mm),
/// structure of arrays, and which rays are alive.
pub struct RaySlices<'a> {
    pub ox: &'a mut [f32],
    pub oy: &'a mut [f32],
    pub oz: &'a mut [f32],
    pub dx: &'a mut [f32],
    pub dy: &'a mut [f32],
    pub dz: &'a mut [f32],
    pub alive: &'a mut [bool],
}

impl RaySlices<'_> {
    /// Ray `i` as one lane.
    #[inline(always)]
    pub fn ray(&self, i: usize) -> LaneRay<f32> {
        LaneRay {
            origin: [self.ox[i], self.oy[i], self.oz[i]],
            direction: [self.dx[i], self.dy[i], self.dz[i]],
        }
    }

    /// Writes `ray` back as ray `i`.
    #[inline(always)]
    pub fn set_ray(&mut self, i: usize, ray: &LaneRay<f32>) {
        [self.ox[i], self.oy[i], self.oz[i]] = ray.origin;
        [self.dx[i], self.dy[i], self.dz[i]] = ray.direction;
    }
}

/// What one surface step leaves of a group of lanes.
#[derive(Clone, Copy, Debug)]
pub struct Crossing<L: Lanes> {
    /// The lanes still alive.
    pub survives: L::Mask,
    /// Each lane's cosine of its angle to the normal in the less dense of the surface's two
    /// media: the angle coordinate of the reflectance tables
    /// ([`crate::lens::reflectance`]).
    pub cosine: L,
}

/// Moves the `alive` lanes of `ray` onto surface `s` (whose shape is `SHAPE`, the value of
/// `s.shape`) and refracts them with index ratio `eta` (n_incident / n_transmitted: `s.eta`, or
/// each lane's at its wavelength); returns which lanes are still alive, and their angles. Lanes
/// that are or become blocked keep their previous state, so a miss never leaves a NaN behind.
#[inline(always)]
pub fn refract_at<L: Lanes, const SHAPE: u8>(
    s: &SurfaceConstants<L>,
    ray: &mut LaneRay<L>,
    alive: L::Mask,
    eta: L,
) -> Crossing<L> {
    let (t, hit) = match SHAPE {
        SPHERE => hit_sphere(s, ray),
        CONIC => hit_conic(s, ray),
        _ => hit_polynomial(s, ray, alive),
    };
    refract_from_hit::<L, SHAPE>(s, ray, alive, eta, t, hit)
}

/// The second half of [`refract_at`]: moves the `alive` lanes that `hit` the surface at
/// distance `t` onto it and refracts them.
#[inline(always)]
pub fn refract_from_hit<L: Lanes, const SHAPE: u8>(
    s: &SurfaceConstants<L>,
    ray: &mut LaneRay<L>,
    alive: L::Mask,
    eta: L,
    t: L,
    hit: L::Mask,
) -> Crossing<L> {
    let zero = L::splat(0.0);
    let incidence = Incidence::at::<SHAPE>(s, ray, t);
    let refraction = incidence.refraction(ray, eta);
    let forward = (refraction.direction[2] * s.forward_sign).gt(zero);
    let survives = alive & hit & incidence.inside & refraction.passes & forward;
    incidence.move_onto(ray, survives, refraction.direction);
    Crossing {
        survives,
        cosine: refraction.cosine,
    }
}

/// What one step of a ghost path ([`ghost_step_at`]) leaves of a group of lanes.
#[derive(Clone, Copy, Debug)]
pub struct GhostCrossing<L: Lanes> {
    /// The lanes still alive (those the step did not involve included).
    pub survives: L::Mask,
    /// Each lane's cosine in the less dense medium: the reflectance tables' coordinate.
    pub cosine: L,
    /// The mirrored lanes reflected totally (beyond the critical angle: R = 1).
    pub total: L::Mask,
}

/// One surface of a ghost path ([`crate::lens::ghost`]) for a group of lanes travelling
/// toward the sign of z `s.forward_sign`: the `active` lanes among the `alive` ones meet
/// surface `s` (shape `SHAPE`) and are mirrored in it where `reflect` (d − 2(d·n)n, turning
/// back), refracted with `eta` elsewhere; the other lanes pass untouched (their path does not
/// meet this surface now). `eta` is n on the lanes' side over n beyond the surface for both:
/// it decides total reflection, and the angle the reflectance is looked up at.
#[inline(always)]
pub fn ghost_step_at<L: Lanes, const SHAPE: u8>(
    s: &SurfaceConstants<L>,
    ray: &mut LaneRay<L>,
    alive: L::Mask,
    active: L::Mask,
    reflect: L::Mask,
    eta: L,
) -> GhostCrossing<L> {
    let zero = L::splat(0.0);
    let involved = alive & active;
    let (t, hit) = match SHAPE {
        SPHERE => hit_sphere(s, ray),
        CONIC => hit_conic(s, ray),
        _ => hit_polynomial(s, ray, involved),
    };
    let incidence = Incidence::at::<SHAPE>(s, ray, t);
    let refraction = incidence.refraction(ray, eta);
    let [vx, vy, vz] = ray.direction;
    let [nx, ny, nz] = incidence.normal;
    // −2(d·n) = 2·cos_raw, whichever way n faces.
    let along_normal = incidence.cos_raw + incidence.cos_raw;
    let mirrored = [
        vx + along_normal * nx,
        vy + along_normal * ny,
        vz + along_normal * nz,
    ];
    let [rx, ry, rz] = refraction.direction;
    let direction = [
        L::select(reflect, mirrored[0], rx),
        L::select(reflect, mirrored[1], ry),
        L::select(reflect, mirrored[2], rz),
    ];
    // Refracted lanes go on the way they came; mirrored ones turn back.
    let onward = direction[2] * s.forward_sign;
    let heading = L::select(reflect, -onward, onward).gt(zero);
    let passes = refraction.passes | reflect;
    let crosses = involved & hit & incidence.inside & passes & heading;
    incidence.move_onto(ray, crosses, direction);
    GhostCrossing {
        survives: crosses | (alive & !active),
        cosine: refraction.cosine,
        total: reflect & !refraction.passes,
    }
}

/// Where a group of lanes meets a surface at distance `t`: the point, the unit normal there
/// (facing the scene at the vertex), the cosine of the angle of incidence and whether the
/// point lies within the clear aperture.
#[derive(Clone, Copy, Debug)]
struct Incidence<L: Lanes> {
    point: [L; 3],
    normal: [L; 3],
    /// −d·n with the normal as it faces.
    cos_raw: L,
    /// ±1: the sign that faces the normal against the incoming ray.
    flip: L,
    /// cos_raw · flip ≥ 0.
    cos_i: L,
    inside: L::Mask,
}

/// Snell's law at an [`Incidence`].
#[derive(Clone, Copy, Debug)]
struct Refraction<L: Lanes> {
    direction: [L; 3],
    /// Not reflected totally.
    passes: L::Mask,
    /// The cosine in the less dense medium.
    cosine: L,
}

impl<L: Lanes> Incidence<L> {
    #[inline(always)]
    fn at<const SHAPE: u8>(s: &SurfaceConstants<L>, ray: &LaneRay<L>, t: L) -> Self {
        let zero = L::splat(0.0);
        let one = L::splat(1.0);
        let [px, py, pz] = ray.origin;
        let [vx, vy, vz] = ray.direction;
        let hx = px + t * vx;
        let hy = py + t * vy;
        let hz = pz + t * vz;
        let inside = (hx * hx + hy * hy).le(s.semi_aperture_sq);

        // The surface normal, facing the scene at the vertex. A hit found from far away (t ~
        // 1000 mm in f32) can sit 1e-3 mm off the surface, and an unnormalised normal would
        // scale the new direction by that error: normalising makes it a tiny tilt instead.
        let (nx, ny, nz) = match SHAPE {
            // (h − centre)/R = (c·x, c·y, c·z − 1).
            SPHERE => (
                s.curvature * hx,
                s.curvature * hy,
                s.curvature * (hz - s.vertex_z) - one,
            ),
            // ∇ of the quadric: (c·x, c·y, κc·z − 1).
            CONIC => (
                s.curvature * hx,
                s.curvature * hy,
                s.conic_factor * s.curvature * (hz - s.vertex_z) - one,
            ),
            // ∇(sag(ρ) − z) = (2x·sag′, 2y·sag′, −1).
            _ => {
                let (_, slope, _) = sag_and_slope(s, hx * hx + hy * hy);
                let two_slope = slope + slope;
                (two_slope * hx, two_slope * hy, -one)
            }
        };
        let inv_length = one / (nx * nx + ny * ny + nz * nz).sqrt();
        let (nx, ny, nz) = (nx * inv_length, ny * inv_length, nz * inv_length);
        // Face the normal against the incoming ray: flip = ±1 multiplies exactly.
        let cos_raw = -(vx * nx + vy * ny + vz * nz);
        let flip = L::select(cos_raw.lt(zero), -one, one);
        Incidence {
            point: [hx, hy, hz],
            normal: [nx, ny, nz],
            cos_raw,
            flip,
            cos_i: cos_raw * flip,
            inside,
        }
    }

    /// The direction `ray` refracts into here with index ratio `eta` (n_incident /
    /// n_transmitted).
    #[inline(always)]
    fn refraction(&self, ray: &LaneRay<L>, eta: L) -> Refraction<L> {
        let zero = L::splat(0.0);
        let one = L::splat(1.0);
        let [vx, vy, vz] = ray.direction;
        let [nx, ny, nz] = self.normal;
        let (flip, cos_i) = (self.flip, self.cos_i);
        let cos_t_sq = one - eta * eta * (one - cos_i * cos_i);
        let cos_t = cos_t_sq.max(zero).sqrt();
        // Snell's law in vector form, η·d + (η·cos_i − cos_t)·n: a unit vector when d and n
        // are, so it is renormalised only once, after the last surface
        // ([`normalise_direction`]); the rounding drift over a whole lens is ~1e-6.
        let along_normal = (eta * cos_i - cos_t) * flip;
        Refraction {
            direction: [
                eta * vx + along_normal * nx,
                eta * vy + along_normal * ny,
                eta * vz + along_normal * nz,
            ],
            passes: cos_t_sq.ge(zero),
            // The less dense medium is the incident one where η = n_i/n_t ≤ 1.
            cosine: L::select(eta.le(one), cos_i, cos_t),
        }
    }

    /// Moves the `survives` lanes of `ray` to the point, heading along `direction`; the others
    /// keep their state, so a miss never leaves a NaN behind.
    #[inline(always)]
    fn move_onto(&self, ray: &mut LaneRay<L>, survives: L::Mask, direction: [L; 3]) {
        let keep = |new: L, old: L| L::select(survives, new, old);
        let ([px, py, pz], [vx, vy, vz]) = (ray.origin, ray.direction);
        let [hx, hy, hz] = self.point;
        let [rx, ry, rz] = direction;
        ray.origin = [keep(hx, px), keep(hy, py), keep(hz, pz)];
        ray.direction = [keep(rx, vx), keep(ry, vy), keep(rz, vz)];
    }
}

/// The nearer valid root of a·t² + 2b·t + k = 0 whose far root is `far(q)`: q = −b − sign(b)·√Δ
/// adds two terms of one sign (no cancellation); the roots are k/q (which tends to the plane's
/// as c → 0) and the far one. A root counts if it lies ahead, is finite (t < ∞ also rejects
/// NaN) and on the sheet through the vertex, κc·z < 1.
#[inline(always)]
fn nearer_root<L: Lanes>(
    ovz: L,
    vz: L,
    b: L,
    k: L,
    discriminant: L,
    far: impl Fn(L) -> L,
    sheet: impl Fn(L) -> L,
) -> (L, L::Mask) {
    let zero = L::splat(0.0);
    let one = L::splat(1.0);
    let root = discriminant.max(zero).sqrt();
    let q = L::select(b.lt(zero), root - b, -b - root);
    let t_near = k / q;
    let t_far = far(q);
    let infinity = L::splat(f32::INFINITY);
    let t_min = L::splat(T_MIN);
    let ok_near = t_near.gt(t_min) & t_near.lt(infinity) & sheet(ovz + t_near * vz).lt(one);
    let ok_far = t_far.gt(t_min) & t_far.lt(infinity) & sheet(ovz + t_far * vz).lt(one);
    let use_near = ok_near & (!ok_far | t_near.le(t_far));
    (
        L::select(use_near, t_near, t_far),
        discriminant.ge(zero) & (ok_near | ok_far),
    )
}

/// Distance to a sphere or plane, and which lanes hit it.
#[inline(always)]
fn hit_sphere<L: Lanes>(s: &SurfaceConstants<L>, ray: &LaneRay<L>) -> (L, L::Mask) {
    let [px, py, pz] = ray.origin;
    let [vx, vy, vz] = ray.direction;
    let c = s.curvature;
    let ovz = pz - s.vertex_z;
    let b = c * (px * vx + py * vy + ovz * vz) - vz;
    let k = c * (px * px + py * py + ovz * ovz) - (ovz + ovz);
    let discriminant = b * b - c * k;
    nearer_root(ovz, vz, b, k, discriminant, |q| q * s.radius, |z| c * z)
}

/// Distance to a conic, and which lanes hit it.
#[inline(always)]
fn hit_conic<L: Lanes>(s: &SurfaceConstants<L>, ray: &LaneRay<L>) -> (L, L::Mask) {
    let one = L::splat(1.0);
    let [px, py, pz] = ray.origin;
    let [vx, vy, vz] = ray.direction;
    let c = s.curvature;
    let kappa = s.conic_factor;
    let ovz = pz - s.vertex_z;
    let a = c * (one + s.conic * vz * vz);
    let b = c * (px * vx + py * vy + kappa * ovz * vz) - vz;
    let k = c * (px * px + py * py + kappa * ovz * ovz) - (ovz + ovz);
    let discriminant = b * b - a * k;
    let kappa_c = kappa * c;
    nearer_root(ovz, vz, b, k, discriminant, |q| q / a, |z| kappa_c * z)
}

/// Distance to a polynomial asphere by Newton's method from the base conic's root (or the
/// vertex plane where the conic is missed), and which of the `alive` lanes converged onto it
/// (blocked lanes do not search: a group's iterations end with its last searching lane's).
#[inline(always)]
fn hit_polynomial<L: Lanes>(
    s: &SurfaceConstants<L>,
    ray: &LaneRay<L>,
    alive: L::Mask,
) -> (L, L::Mask) {
    let mut newton = Newton::start(s, ray, alive);
    for _ in 0..NEWTON_STEPS {
        newton.step(s, ray);
        if !L::any(newton.searching) {
            break;
        }
    }
    newton.hit()
}

/// Newton's method on f(t) = z(t) − sag(ρ(t)) for a group of lanes, one step at a time (so
/// that the plain kernel can run each step over a whole block of rays, which vectorises,
/// instead of each ray's iterations in turn, which does not).
#[derive(Clone, Copy, Debug)]
pub struct Newton<L: Lanes> {
    pub t: L,
    /// Lanes still iterating.
    pub searching: L::Mask,
    /// Lanes that converged onto the surface.
    pub converged: L::Mask,
}

impl<L: Lanes> Newton<L> {
    /// The start: the base conic's root, or where the conic is missed the vertex plane if it
    /// lies ahead, else the ray's origin (the reference's start,
    /// [`crate::lens::shape::Profile::intersect`]).
    #[inline(always)]
    pub fn start(s: &SurfaceConstants<L>, ray: &LaneRay<L>, alive: L::Mask) -> Self {
        let zero = L::splat(0.0);
        let (conic_t, conic_hit) = hit_conic(s, ray);
        let plane_t = (s.vertex_z - ray.origin[2]) / ray.direction[2];
        let plane_t = L::select(plane_t.gt(zero), plane_t, zero);
        Newton {
            t: L::select(conic_hit, conic_t, plane_t),
            // Every live lane whose start is a number searches (d_z = 0 gives NaN).
            searching: alive & plane_t.ge(zero),
            converged: zero.lt(zero),
        }
    }

    /// One step for the searching lanes. A lane stops converged once its step is within a few
    /// f32 ulps of the lengths it comes from (the distance, the origin's height over the
    /// vertex, the sag), or failed where the sag is undefined or the step not finite; either
    /// way its t no longer moves.
    #[inline(always)]
    pub fn step(&mut self, s: &SurfaceConstants<L>, ray: &LaneRay<L>) {
        let [px, py, pz] = ray.origin;
        let [vx, vy, vz] = ray.direction;
        let ovz = pz - s.vertex_z;
        let t = self.t;
        let x = px + t * vx;
        let y = py + t * vy;
        let z = ovz + t * vz;
        let (sag, slope, defined) = sag_and_slope(s, x * x + y * y);
        let derivative = vz - (slope + slope) * (x * vx + y * vy);
        let step = (z - sag) / derivative;
        let next = t - step;
        let finite = next.abs().lt(L::splat(f32::INFINITY));
        let valid = defined & finite;
        self.t = L::select(self.searching & valid, next, t);
        let scale = next.abs() + ovz.abs() + sag.abs();
        let done = step
            .abs()
            .le(L::splat(1e-7) + L::splat(16.0 * f32::EPSILON) * scale);
        self.converged = self.converged | (self.searching & valid & done);
        self.searching = self.searching & valid & !done;
    }

    /// The distance, and which lanes converged onto the surface ahead of their origin.
    #[inline(always)]
    pub fn hit(&self) -> (L, L::Mask) {
        (self.t, self.converged & self.t.gt(L::splat(T_MIN)))
    }
}

/// sag(ρ), d sag/dρ and where they are defined (1 − κc²ρ ≥ 0), for every lane.
#[inline(always)]
fn sag_and_slope<L: Lanes>(s: &SurfaceConstants<L>, rho: L) -> (L, L, L::Mask) {
    let zero = L::splat(0.0);
    let one = L::splat(1.0);
    let c = s.curvature;
    let under_root = one - s.conic_factor * c * c * rho;
    let defined = under_root.ge(zero);
    let root = under_root.max(zero).sqrt();
    let mut value = zero;
    let mut derivative = zero;
    for k in (0..ASPHERIC_TERMS).rev() {
        derivative = derivative * rho + s.slope_coefficients[k];
        value = value * rho + s.coefficients[k];
    }
    let sag = c * rho / (one + root) + value * rho;
    let slope = c / (root + root) + derivative;
    (sag, slope, defined)
}

/// Rescales the direction of the `alive` lanes to unit length (after the last surface).
#[inline(always)]
pub fn normalise_direction<L: Lanes>(ray: &mut LaneRay<L>, alive: L::Mask) {
    let [x, y, z] = ray.direction;
    let inv_length = L::splat(1.0) / (x * x + y * y + z * z).sqrt();
    ray.direction = [x, y, z].map(|v| L::select(alive, v * inv_length, v));
}
