//! Exit-pupil bounds and the sampling of camera rays through them.
//!
//! From a point on the film, only rays aimed at part of the rear element pass the whole lens
//! (the exit pupil as seen from that point, cat's-eye shaped off axis). Sampling only there
//! wastes few rays. As in pbrt, the film radius is cut into radial segments and for each the
//! rear-vertex-plane bounds of the passing rays are stored for a film point on the +x axis;
//! rotational symmetry gives every other film point.
//!
//! pbrt traces 2²⁰ rays per segment (6–8 s a lens). Here a coarse grid finds the pupil, a fine
//! grid over it finds the edges, only the y ≥ 0 half is traced (mirror symmetry about the
//! meridional plane), rays run in SoA batches, and segments run in parallel.
//!
//! A stop so small (f/500, f/1000) that its pupil could slip between the coarse grid's
//! points is found through wider stops: the rays that pass a smaller circle at the stop pass
//! every wider one too, so the pupil of a stop [`STOP_ZOOM`] times wider, found first, holds
//! the small stop's pupil, and a fine grid over it finds that.

use rayon::prelude::*;

use super::first_order::FirstOrder;
use super::movements::FilmMovements;
use super::system::LensSystem;
use super::trace::Travel;
use super::trace_batch::trace_batch;
use crate::batch::RayBatch;

/// Runs `$body` with the constants `$bounds` (the sampler draws within the exit pupil's
/// bounds, not over the rear element) and `$flat` (the film is normal to the axis) set to
/// `$sampler`'s (a [`PupilSampler`]), so that code generic over them is picked once, for a whole
/// batch, rather than branching per ray.
macro_rules! with_sampler_kind {
    (@as $bounds:ident = $b:literal, $flat:ident = $f:literal, $body:expr) => {{
        const $bounds: bool = $b;
        const $flat: bool = $f;
        $body
    }};
    ($sampler:expr, |$bounds:ident, $flat:ident| $body:expr) => {{
        use $crate::lens::pupil::PupilSampling::{Bounds, RearElement};
        match ($sampler.sampling, $sampler.is_flat()) {
            (Bounds, true) => with_sampler_kind!(@as $bounds = true, $flat = true, $body),
            (Bounds, false) => with_sampler_kind!(@as $bounds = true, $flat = false, $body),
            (RearElement, true) => with_sampler_kind!(@as $bounds = false, $flat = true, $body),
            (RearElement, false) => with_sampler_kind!(@as $bounds = false, $flat = false, $body),
        }
    }};
}
pub(crate) use with_sampler_kind;

/// Number of radial film segments (pbrt uses 64 as well).
pub const SEGMENTS: usize = 64;
// A segment index is masked with SEGMENTS − 1 before a look-up (a no-op that spares a bounds
// check, which stops a loop vectorising).
const _: () = assert!(SEGMENTS.is_power_of_two());
/// Coarse cells across the paraxial exit pupil, at least: fine enough that no pupil slips
/// between grid points, however small the stop.
const COARSE_CELLS_PER_PUPIL: f64 = 6.0;
const COARSE_GRID: std::ops::RangeInclusive<usize> = 32..=384;
const FINE_GRID: usize = 48;
/// How much wider each stop in the search for a small stop's pupil is than the next smaller
/// one: its pupil then spans FINE_GRID / STOP_ZOOM = 6 cells of the fine grid laid over the
/// wider one's.
pub const STOP_ZOOM: f64 = 8.0;

/// How camera rays pick their point on the rear element.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum PupilSampling {
    /// Uniformly within the exit-pupil bounds of the film point's segment (pbrt-v3/v4).
    #[default]
    Bounds,
    /// Uniformly over the whole rear element (the CS348b course's scheme): simple, wasteful.
    RearElement,
}

impl std::str::FromStr for PupilSampling {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "bounds" => Ok(PupilSampling::Bounds),
            "rear-element" => Ok(PupilSampling::RearElement),
            other => Err(format!(
                "unknown pupil sampling '{other}': use bounds or rear-element"
            )),
        }
    }
}

/// An axis-aligned box in the rear-vertex plane (mm); empty when min > max.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    pub min: [f64; 2],
    pub max: [f64; 2],
}

impl Rect {
    pub const EMPTY: Rect = Rect {
        min: [f64::INFINITY; 2],
        max: [f64::NEG_INFINITY; 2],
    };

    pub fn is_empty(&self) -> bool {
        self.min[0] > self.max[0] || self.min[1] > self.max[1]
    }

    pub fn area(&self) -> f64 {
        if self.is_empty() {
            0.0
        } else {
            (self.max[0] - self.min[0]) * (self.max[1] - self.min[1])
        }
    }

    pub fn include(&mut self, x: f64, y: f64) {
        self.min = [self.min[0].min(x), self.min[1].min(y)];
        self.max = [self.max[0].max(x), self.max[1].max(y)];
    }

    pub fn union(&self, other: &Rect) -> Rect {
        Rect {
            min: [self.min[0].min(other.min[0]), self.min[1].min(other.min[1])],
            max: [self.max[0].max(other.max[0]), self.max[1].max(other.max[1])],
        }
    }

    pub fn expanded(&self, margin: f64) -> Rect {
        if self.is_empty() {
            return *self;
        }
        Rect {
            min: [self.min[0] - margin, self.min[1] - margin],
            max: [self.max[0] + margin, self.max[1] + margin],
        }
    }
}

/// A point chosen on the rear-vertex plane for a film point, with the camera-measurement
/// weight of the ray through it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PupilSample {
    pub point: [f32; 3],
    /// cos⁴θ · A / z² (A: area sampled, z: film distance): the ray's contribution to the
    /// film's irradiance per unit scene radiance (pbrt-v4's weighting).
    pub weight: f32,
}

/// Per-segment exit-pupil bounds of a lens at one film distance and film size.
#[derive(bevy_ecs::component::Component, Clone, Debug, PartialEq)]
pub struct ExitPupil {
    pub sampling: PupilSampling,
    /// Farthest film point from the axis, mm: half the film diagonal, plus the shift of a
    /// shifted frame.
    pub film_radius: f64,
    /// Rear vertex → the frame centre, mm.
    pub film_distance: f64,
    /// Unit normal of the film plane (+z; tilted with the film, see
    /// [`crate::lens::movements`]): the camera weight's film cosine is taken against it.
    pub film_normal: [f64; 3],
    pub rear_z: f64,
    pub rear_radius: f64,
    /// Bounds for film points at radius in [k, k+1)·film_radius/SEGMENTS on the +x axis.
    pub segments: Vec<Rect>,
    /// Rays traced to find the bounds (for reports and benchmarks).
    pub rays_traced: u64,
}

impl ExitPupil {
    /// The bounds of `system` at its own indices.
    pub fn compute(
        system: &LensSystem,
        film_distance: f64,
        film_diagonal: f64,
        sampling: PupilSampling,
    ) -> ExitPupil {
        ExitPupil::compute_over(system, film_distance, film_diagonal, sampling, false)
    }

    /// As [`compute`](Self::compute); with `all_wavelengths` (a spectral render of a lens with
    /// glass data) the bounds hold for every rendered wavelength: the union of the bounds at
    /// the rendered range's ends and at d (the pupil's size and place move monotonically with
    /// the indices between them).
    pub fn compute_over(
        system: &LensSystem,
        film_distance: f64,
        film_diagonal: f64,
        sampling: PupilSampling,
        all_wavelengths: bool,
    ) -> ExitPupil {
        ExitPupil::compute_moved(
            system,
            film_distance,
            film_diagonal,
            sampling,
            all_wavelengths,
            &FilmMovements::NONE,
        )
    }

    /// As [`compute_over`](Self::compute_over), for a film shifted and tilted by `movements`:
    /// the segments reach the farthest shifted film point, and for a tilted film each
    /// segment's bounds are the union of those from film points at the nearest, the middle
    /// and the farthest z the tilted film reaches (a pupil's projection onto the rear plane
    /// moves monotonically with the film point's z).
    pub fn compute_moved(
        system: &LensSystem,
        film_distance: f64,
        film_diagonal: f64,
        sampling: PupilSampling,
        all_wavelengths: bool,
        movements: &FilmMovements,
    ) -> ExitPupil {
        let mut systems = vec![system.clone()];
        if all_wavelengths && system.is_dispersive() {
            systems.push(system.at_wavelength(crate::spectral::LAMBDA_MIN));
            systems.push(system.at_wavelength(crate::spectral::LAMBDA_MAX));
        }
        // The search asks only which rays pass: what the surfaces reflect away changes a
        // ray's throughput, never whether it passes, so it traces the lossless lens.
        let systems: Vec<LensSystem> = systems
            .into_iter()
            .map(|system| system.with_reflectance(None))
            .collect();
        let reach = movements.reach(film_diagonal);
        let film_radius = reach.radius;
        let rear_z = system.rear_z();
        let film_z = rear_z + film_distance;
        let film_zs: Vec<f64> = if movements.is_tilted() {
            vec![film_z + reach.dz[0], film_z, film_z + reach.dz[1]]
        } else {
            vec![film_z]
        };
        let rear_radius = system.rear_semi_aperture();
        let pupil_diameter =
            FirstOrder::compute(system).map_or(rear_radius, |fo| fo.exit_pupil.diameter_mm);
        let wanted_grid = ((3.0 * rear_radius / pupil_diameter.max(1e-9)) * COARSE_CELLS_PER_PUPIL)
            .ceil() as usize;
        let coarse_grid = wanted_grid.clamp(*COARSE_GRID.start(), *COARSE_GRID.end());
        // The pupil grows with the stop: from this stop diameter on, the coarse grid has its
        // cells across the pupil, so a search that finds nothing there means no light passes.
        let resolved_stop = system.stop_diameter() * (wanted_grid as f64 / coarse_grid as f64);
        let resolved_stop = resolved_stop.max(system.stop_diameter());
        let results: Vec<(Rect, u64)> = (0..SEGMENTS)
            .into_par_iter()
            .map(|k| {
                let r0 = film_radius * k as f64 / SEGMENTS as f64;
                let r1 = film_radius * (k + 1) as f64 / SEGMENTS as f64;
                systems
                    .iter()
                    .map(|system| {
                        let search = PupilSearch {
                            film_zs: &film_zs,
                            radii: [r0, r1],
                            coarse_grid,
                            resolved_stop,
                        };
                        segment_bounds(system, rear_radius, &search)
                    })
                    .fold((Rect::EMPTY, 0), |(bounds, traced), (b, t)| {
                        (bounds.union(&b), traced + t)
                    })
            })
            .collect();
        ExitPupil {
            sampling,
            film_radius,
            film_distance,
            film_normal: movements.film_normal(),
            rear_z,
            rear_radius,
            rays_traced: results.iter().map(|r| r.1).sum(),
            segments: results.into_iter().map(|r| r.0).collect(),
        }
    }

    /// Bounds used for a film point at distance `r` from the axis.
    pub fn segment_for(&self, r: f64) -> &Rect {
        let k = ((r / self.film_radius) * SEGMENTS as f64) as usize;
        &self.segments[k.min(SEGMENTS - 1)]
    }

    /// Picks the rear-plane point for film point (`x`, `y`) (lens frame, mm) from uniform `u`.
    /// `None` when no ray from that film point can pass the lens.
    pub fn sample(&self, x: f32, y: f32, u: [f32; 2]) -> Option<PupilSample> {
        self.sample_at(x, y, self.film_distance as f32, u)
    }

    /// As [`sample`](Self::sample) for a film point `depth` (mm) behind the rear-vertex plane
    /// (a tilted film's points lie off the frame centre's plane).
    pub fn sample_at(&self, x: f32, y: f32, depth: f32, u: [f32; 2]) -> Option<PupilSample> {
        let (px, py, area) = match self.sampling {
            PupilSampling::Bounds => {
                let r = (x * x + y * y).sqrt();
                let rect = self.segment_for(r as f64);
                if rect.is_empty() {
                    return None;
                }
                let bx = rect.min[0] + (rect.max[0] - rect.min[0]) * u[0] as f64;
                let by = rect.min[1] + (rect.max[1] - rect.min[1]) * u[1] as f64;
                // The bounds were found for a film point on +x: rotate by the point's angle.
                let (sin, cos) = if r > 0.0 { (y / r, x / r) } else { (0.0, 1.0) };
                let (bx, by) = (bx as f32, by as f32);
                (cos * bx - sin * by, sin * bx + cos * by, rect.area() as f32)
            }
            PupilSampling::RearElement => {
                let radius = self.rear_radius as f32;
                let [dx, dy] = concentric_disk(u);
                (
                    dx * radius,
                    dy * radius,
                    std::f32::consts::PI * radius * radius,
                )
            }
        };
        let to = [px - x, py - y, -depth];
        let weight = if self.film_normal == [0.0, 0.0, 1.0] {
            camera_weight(to, area, 1.0 / (depth * depth))
        } else {
            tilted_camera_weight(to, self.film_normal.map(|v| v as f32), area, depth)
        };
        Some(PupilSample {
            point: [px, py, self.rear_z as f32],
            weight,
        })
    }

    /// The f32 sampler of this pupil, for the loops of camera-ray generation.
    pub fn sampler(&self) -> PupilSampler {
        let mut segments = [[0.0; 4]; SEGMENTS];
        let mut areas = [0.0; SEGMENTS];
        for (k, rect) in self.segments.iter().enumerate() {
            if !rect.is_empty() {
                let extent = [rect.max[0] - rect.min[0], rect.max[1] - rect.min[1]];
                segments[k] = [rect.min[0], rect.min[1], extent[0], extent[1]].map(|v| v as f32);
                areas[k] = rect.area() as f32;
            }
        }
        let z = self.film_distance as f32;
        PupilSampler {
            sampling: self.sampling,
            segment_scale: (SEGMENTS as f64 / self.film_radius) as f32,
            segments,
            areas,
            rear_radius: self.rear_radius as f32,
            film_distance: z,
            inv_z2: 1.0 / (z * z),
            film_normal: self.film_normal.map(|v| v as f32),
        }
    }
}

/// cos⁴θ · A / z² for a ray along `to` (film point → rear-plane point, any length) out of an
/// area `A` sampled uniformly, with `inv_z2` = 1 / z²: see [`PupilSample::weight`].
#[inline(always)]
fn camera_weight(to: [f32; 3], area: f32, inv_z2: f32) -> f32 {
    camera_factor(to) * area * inv_z2
}

/// cos⁴θ for a ray along `to`: [`camera_weight`] per unit area and 1/z².
#[inline(always)]
fn camera_factor(to: [f32; 3]) -> f32 {
    let cos2 = to[2] * to[2] / (to[0] * to[0] + to[1] * to[1] + to[2] * to[2]);
    cos2 * cos2
}

/// The camera weight on a tilted film, from a film point `depth` behind the rear-vertex plane:
/// E = ∫ L cos θ_film cos θ_rear / d² dA over the rear plane, with d = depth / cos θ_rear, so a
/// ray along `to` out of an area `area` sampled uniformly weighs
/// |cos θ_film| · cos³θ_rear · A / depth² (cos⁴θ · A / z² when the film is not tilted).
#[inline(always)]
fn tilted_camera_weight(to: [f32; 3], normal: [f32; 3], area: f32, depth: f32) -> f32 {
    tilted_camera_factor(to, normal) * area / (depth * depth)
}

/// |cos θ_film| · cos³θ_rear for a ray along `to`: [`tilted_camera_weight`] per unit area and
/// 1/depth².
#[inline(always)]
fn tilted_camera_factor(to: [f32; 3], normal: [f32; 3]) -> f32 {
    let inv_len = 1.0 / (to[0] * to[0] + to[1] * to[1] + to[2] * to[2]).sqrt();
    let cos_rear = (to[2] * inv_len).abs();
    let cos_film = ((to[0] * normal[0] + to[1] * normal[1] + to[2] * normal[2]) * inv_len).abs();
    cos_film * cos_rear * cos_rear * cos_rear
}

/// [`ExitPupil::sample`] in f32 over whole batches, with what depends only on the lens worked
/// out once: the segment found with a multiply, each segment's bounds as corner and extent.
/// Rays from the same film point and `u` agree with the f64 sampler to f32 rounding, except
/// within rounding of a segment boundary, where either neighbour's bounds are valid.
#[derive(Clone, Debug)]
pub struct PupilSampler {
    pub(crate) sampling: PupilSampling,
    /// SEGMENTS / film radius.
    pub(crate) segment_scale: f32,
    /// Per segment: min x, min y, extent x, extent y (all 0 when no ray passes).
    pub(crate) segments: [[f32; 4]; SEGMENTS],
    /// Per segment: the bounds' area, 0 when no ray passes.
    pub(crate) areas: [f32; SEGMENTS],
    pub(crate) rear_radius: f32,
    pub(crate) film_distance: f32,
    pub(crate) inv_z2: f32,
    pub(crate) film_normal: [f32; 3],
}

/// A ray [`PupilSampler::drawn_weight`] is asked about, worked out as far as it goes without
/// the sampler's tables (see [`PupilSampler::drawn_ray`]).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct DrawnRay {
    /// The film point's segment (bounds sampling; 0 otherwise).
    pub segment: u32,
    /// The rear-plane point, in the frame of a film point on +x where the bounds were found
    /// (bounds sampling) or as it is (rear element).
    pub point: [f32; 2],
    /// The camera weight per unit area, less 1/z² (flat film) or 1/depth² (tilted).
    pub factor: f32,
    /// The film point's depth behind the rear-vertex plane, mm.
    pub depth: f32,
}

/// Film points and the camera rays out of them, structure of arrays (lens frame, mm).
pub struct FilmRays<'a> {
    pub x: &'a [f32],
    pub y: &'a [f32],
    /// Each film point's depth behind the rear-vertex plane, mm, on a tilted film; `None`:
    /// all at the pupil's film distance.
    pub depth: Option<&'a [f32]>,
    /// Uniform numbers choosing each ray's point in the pupil.
    pub u: &'a [f32],
    pub v: &'a [f32],
    /// Out: unit direction toward the rear-plane point; (0, 0, −1) where no ray passes.
    pub dx: &'a mut [f32],
    pub dy: &'a mut [f32],
    pub dz: &'a mut [f32],
    /// Out: [`PupilSample::weight`]; 0 where no ray passes.
    pub weight: &'a mut [f32],
    /// Out: false for film points no ray leaves.
    pub passes: &'a mut [bool],
}

impl PupilSampler {
    /// One camera ray per film point of `rays`, as [`ExitPupil::sample`] picks them, in loops
    /// without branches, so they vectorise (in the bounds scheme: the rear-element scheme's
    /// disk mapping calls sin and cos).
    #[inline(always)]
    pub fn sample(&self, rays: FilmRays) {
        match (self.sampling, rays.depth) {
            (PupilSampling::Bounds, None) => self.sample_in_bounds(rays),
            (PupilSampling::Bounds, Some(_)) => {
                self.sample_with(rays, |x, y, u, v| self.in_bounds(x, y, u, v))
            }
            (PupilSampling::RearElement, _) => {
                self.sample_with(rays, |_, _, u, v| self.on_rear_element(u, v))
            }
        }
    }

    #[inline(always)]
    fn sample_with(&self, rays: FilmRays, point: impl Fn(f32, f32, f32, f32) -> ([f32; 2], f32)) {
        if let Some(depth) = rays.depth {
            return self.sample_tilted(rays, depth, point);
        }
        let n = rays.x.len();
        let (x, y, u, v) = (&rays.x[..n], &rays.y[..n], &rays.u[..n], &rays.v[..n]);
        let (dx, dy, dz) = (&mut rays.dx[..n], &mut rays.dy[..n], &mut rays.dz[..n]);
        let (weight, passes) = (&mut rays.weight[..n], &mut rays.passes[..n]);
        for i in 0..n {
            let (point, area) = point(x[i], y[i], u[i], v[i]);
            let ray = self.flat_ray([x[i], y[i]], point, area);
            ([dx[i], dy[i], dz[i]], weight[i], passes[i]) = ray;
        }
    }

    /// [`Self::sample`] in the bounds scheme on a flat film, a chunk of rays at a time in three
    /// loops: each film point's segment and angle, then the segments' bounds looked up, then
    /// the rays. The first and last have no look-ups and vectorise; one loop doing all of it
    /// (a look-up a ray) does not. The same operations as [`Self::in_bounds`], so the same
    /// bits.
    #[inline(always)]
    fn sample_in_bounds(&self, rays: FilmRays) {
        const CHUNK: usize = 64;
        let n = rays.x.len();
        let (x, y, u, v) = (&rays.x[..n], &rays.y[..n], &rays.u[..n], &rays.v[..n]);
        let (dx, dy, dz) = (&mut rays.dx[..n], &mut rays.dy[..n], &mut rays.dz[..n]);
        let (weight, passes) = (&mut rays.weight[..n], &mut rays.passes[..n]);
        let mut start = 0;
        while start < n {
            let m = CHUNK.min(n - start);
            let chunk = start..start + m;
            let (x, y, u, v) = (
                &x[chunk.clone()],
                &y[chunk.clone()],
                &u[chunk.clone()],
                &v[chunk.clone()],
            );
            let mut segment = [0u32; CHUNK];
            let mut angle = [[0.0f32; 2]; CHUNK];
            for j in 0..m {
                (segment[j], angle[j]) = self.segment_and_angle(x[j], y[j]);
            }
            let mut bounds = [[0.0f32; 4]; CHUNK];
            let mut area = [0.0f32; CHUNK];
            for j in 0..m {
                (bounds[j], area[j]) = self.segment_bounds(segment[j]);
            }
            let (dx, dy, dz) = (
                &mut dx[chunk.clone()],
                &mut dy[chunk.clone()],
                &mut dz[chunk.clone()],
            );
            let (weight, passes) = (&mut weight[chunk.clone()], &mut passes[chunk]);
            for j in 0..m {
                let point = point_in_segment(bounds[j], angle[j], u[j], v[j]);
                let ray = self.flat_ray([x[j], y[j]], point, area[j]);
                ([dx[j], dy[j], dz[j]], weight[j], passes[j]) = ray;
            }
            start += m;
        }
    }

    /// The camera ray from film point `film` (flat film) toward rear-plane point `point`,
    /// drawn from an area `area` (0: no ray passes there): its unit direction ((0, 0, −1)
    /// where none passes), its weight and whether it passes.
    #[inline(always)]
    fn flat_ray(&self, film: [f32; 2], point: [f32; 2], area: f32) -> ([f32; 3], f32, bool) {
        let to = [point[0] - film[0], point[1] - film[1], -self.film_distance];
        let inv_len = 1.0 / (to[0] * to[0] + to[1] * to[1] + to[2] * to[2]).sqrt();
        let passing = area > 0.0;
        let d = to.map(|c| c * inv_len);
        let direction = [
            if passing { d[0] } else { 0.0 },
            if passing { d[1] } else { 0.0 },
            if passing { d[2] } else { -1.0 },
        ];
        (direction, camera_weight(d, area, self.inv_z2), passing)
    }

    /// [`Self::sample_with`] for the points of a tilted film, each at its own depth.
    #[inline(always)]
    fn sample_tilted(
        &self,
        rays: FilmRays,
        depth: &[f32],
        point: impl Fn(f32, f32, f32, f32) -> ([f32; 2], f32),
    ) {
        let n = rays.x.len();
        let (x, y, u, v) = (&rays.x[..n], &rays.y[..n], &rays.u[..n], &rays.v[..n]);
        let depth = &depth[..n];
        let (dx, dy, dz) = (&mut rays.dx[..n], &mut rays.dy[..n], &mut rays.dz[..n]);
        let (weight, passes) = (&mut rays.weight[..n], &mut rays.passes[..n]);
        for i in 0..n {
            let ([px, py], area) = point(x[i], y[i], u[i], v[i]);
            let to = [px - x[i], py - y[i], -depth[i]];
            let inv_len = 1.0 / (to[0] * to[0] + to[1] * to[1] + to[2] * to[2]).sqrt();
            let passing = area > 0.0;
            let d = to.map(|c| c * inv_len);
            dx[i] = if passing { d[0] } else { 0.0 };
            dy[i] = if passing { d[1] } else { 0.0 };
            dz[i] = if passing { d[2] } else { -1.0 };
            weight[i] = tilted_camera_weight(to, self.film_normal, area, depth[i]);
            passes[i] = passing;
        }
    }

    /// The camera weight [`Self::sample`] gives the ray from film point `film` (lens-frame x
    /// and y, `depth` mm behind the rear-vertex plane) through rear-plane point `rear`, or 0
    /// when it never draws `rear` from there (outside that film point's bounds, or off the rear
    /// element). Its inverse is the density, in the lens's invariant measure of scene rays,
    /// with which the sampler makes that ray (see [`super::hero_wavelengths`]).
    #[inline(always)]
    pub fn drawn_weight(&self, film: [f32; 2], depth: f32, rear: [f32; 2]) -> f32 {
        with_sampler_kind!(self, |BOUNDS, FLAT| {
            self.weight_of_drawn::<BOUNDS, FLAT>(self.drawn_ray::<BOUNDS, FLAT>(film, depth, rear))
        })
    }

    /// Whether the film is normal to the axis (not tilted).
    #[inline(always)]
    pub(crate) fn is_flat(&self) -> bool {
        self.film_normal == [0.0, 0.0, 1.0]
    }

    /// [`Self::drawn_weight`] as far as it goes without the sampler's tables, for a sampler
    /// drawing within the bounds (`BOUNDS`) or over the rear element, on a film normal to the
    /// axis (`FLAT`) or tilted. [`Self::weight_of_drawn`] finishes it. Split so that a batch
    /// works this part (its divisions and root) out in a loop without look-ups or branches,
    /// which vectorises.
    #[inline(always)]
    pub(crate) fn drawn_ray<const BOUNDS: bool, const FLAT: bool>(
        &self,
        film: [f32; 2],
        depth: f32,
        rear: [f32; 2],
    ) -> DrawnRay {
        let [x, y] = film;
        let (segment, point) = if BOUNDS {
            let r = (x * x + y * y).sqrt();
            let k = self.segment_at(r);
            // Into the frame of a film point on +x, where the bounds were found.
            let (sin, cos) = if r > 0.0 { (y / r, x / r) } else { (0.0, 1.0) };
            let bx = cos * rear[0] + sin * rear[1];
            let by = cos * rear[1] - sin * rear[0];
            (k, [bx, by])
        } else {
            (0, rear)
        };
        let to = [rear[0] - x, rear[1] - y, -depth];
        let factor = if FLAT {
            camera_factor(to)
        } else {
            tilted_camera_factor(to, self.film_normal)
        };
        DrawnRay {
            segment,
            point,
            factor,
            depth,
        }
    }

    /// The camera weight of a [`DrawnRay`] (see [`Self::drawn_ray`]): the area its film
    /// point's sampler draws from, if it draws the ray's rear-plane point, times the weight
    /// per unit area.
    #[inline(always)]
    pub(crate) fn weight_of_drawn<const BOUNDS: bool, const FLAT: bool>(
        &self,
        ray: DrawnRay,
    ) -> f32 {
        let [px, py] = ray.point;
        let area = if BOUNDS {
            let ([min_x, min_y, extent_x, extent_y], area) = self.segment_bounds(ray.segment);
            // The rotation there and back rounds: a point drawn on an edge may come back
            // a few ulps outside it.
            let slack = 1e-5 * (extent_x + extent_y);
            let inside = px >= min_x - slack
                && px <= min_x + extent_x + slack
                && py >= min_y - slack
                && py <= min_y + extent_y + slack;
            if inside { area } else { 0.0 }
        } else {
            let radius = self.rear_radius;
            // A point drawn on the rim may round to just beyond it.
            let reach = radius * (1.0 + 1e-5);
            if px * px + py * py <= reach * reach {
                std::f32::consts::PI * radius * radius
            } else {
                0.0
            }
        };
        if FLAT {
            ray.factor * area * self.inv_z2
        } else {
            ray.factor * area / (ray.depth * ray.depth)
        }
    }

    /// Uniformly in the bounds of the film point's segment: the point and the area sampled (0
    /// in a segment no ray passes).
    #[inline(always)]
    fn in_bounds(&self, x: f32, y: f32, u: f32, v: f32) -> ([f32; 2], f32) {
        let (k, angle) = self.segment_and_angle(x, y);
        let (bounds, area) = self.segment_bounds(k);
        (point_in_segment(bounds, angle, u, v), area)
    }

    /// Segment `k`'s bounds (min x, min y, extent x, extent y) on the rear plane and their
    /// area. The index is masked (a no-op for a segment [`Self::segment_at`] gives) so that the
    /// look-up needs no bounds check.
    #[inline(always)]
    fn segment_bounds(&self, k: u32) -> ([f32; 4], f32) {
        let k = k as usize & (SEGMENTS - 1);
        (self.segments[k], self.areas[k])
    }

    /// The segment of film points `r` mm from the axis. Clamped as a float: one instruction a
    /// lane (`as usize` then `min` saturates in several), the same segment for every finite
    /// `r` (a NaN film point, which never counts, goes to the last instead of the first).
    #[inline(always)]
    fn segment_at(&self, r: f32) -> u32 {
        (r * self.segment_scale).min((SEGMENTS - 1) as f32) as u32
    }

    /// Film point (`x`, `y`)'s segment, and the sine and cosine of its angle about the axis.
    #[inline(always)]
    fn segment_and_angle(&self, x: f32, y: f32) -> (u32, [f32; 2]) {
        let r = (x * x + y * y).sqrt();
        let k = self.segment_at(r);
        let inv_r = 1.0 / r;
        let (sin, cos) = if r > 0.0 {
            (y * inv_r, x * inv_r)
        } else {
            (0.0, 1.0)
        };
        (k, [sin, cos])
    }

    /// Uniformly over the rear element's clear aperture.
    #[inline(always)]
    fn on_rear_element(&self, u: f32, v: f32) -> ([f32; 2], f32) {
        let [dx, dy] = concentric_disk([u, v]);
        let radius = self.rear_radius;
        (
            [dx * radius, dy * radius],
            std::f32::consts::PI * radius * radius,
        )
    }
}

/// Uniformly in a segment's `bounds` (min x, min y, extent x, extent y), for a film point at
/// `angle` (its sine and cosine): the bounds were found for a film point on +x, so the point
/// is rotated by the film point's angle.
#[inline(always)]
fn point_in_segment(bounds: [f32; 4], [sin, cos]: [f32; 2], u: f32, v: f32) -> [f32; 2] {
    let [min_x, min_y, extent_x, extent_y] = bounds;
    let bx = min_x + extent_x * u;
    let by = min_y + extent_y * v;
    [cos * bx - sin * by, sin * bx + cos * by]
}

/// Shirley–Chiu concentric map of the unit square onto the unit disk (area preserving).
pub fn concentric_disk(u: [f32; 2]) -> [f32; 2] {
    let a = 2.0 * u[0] - 1.0;
    let b = 2.0 * u[1] - 1.0;
    if a == 0.0 && b == 0.0 {
        return [0.0, 0.0];
    }
    use std::f32::consts::FRAC_PI_4;
    let (r, phi) = if a.abs() > b.abs() {
        (a, FRAC_PI_4 * (b / a))
    } else {
        (b, 2.0 * FRAC_PI_4 - FRAC_PI_4 * (a / b))
    };
    [r * phi.cos(), r * phi.sin()]
}

/// One segment's search for its pupil: where its film points are and how fine a grid finds a
/// pupil without letting it slip between points.
struct PupilSearch<'a> {
    /// Lens-frame z of the film planes the film points lie in.
    film_zs: &'a [f64],
    /// The film points' distances from the axis (on +x), mm.
    radii: [f64; 2],
    /// Coarse cells across the search window.
    coarse_grid: usize,
    /// The stop diameter (mm) from which the coarse grid resolves the pupil.
    resolved_stop: f64,
}

/// Bounds of the rear-plane points whose rays from the film points of `search` pass the lens.
fn segment_bounds(system: &LensSystem, rear_radius: f64, search: &PupilSearch) -> (Rect, u64) {
    // pbrt's margin: rays aimed past the rear vertex plane's aperture can still meet a curved
    // rear surface inside its clear aperture.
    let half = 1.5 * rear_radius;
    let whole = Rect {
        min: [-half, 0.0],
        max: [half, half],
    };
    let mut traced = 0u64;
    let points: Vec<[f64; 2]> = search
        .film_zs
        .iter()
        .flat_map(|&z| search.radii.map(|r| [r, z]))
        .collect();
    // Square cells over the 2:1 half-window.
    let grid = [search.coarse_grid, search.coarse_grid / 2];
    let (coarse, cell) = locate_pupil(system, &points, &whole, grid, search, &mut traced);
    if coarse.is_empty() {
        // Beyond the image circle (a fisheye's film corners): no light reaches here.
        return (Rect::EMPTY, traced);
    }
    let window = upper_half(coarse.expanded(cell));
    let fine = passing_bounds(
        system,
        &points,
        &window,
        [FINE_GRID, FINE_GRID],
        &mut traced,
    );
    let fine_cell = fine_cell(&window);
    let bounds = if fine.is_empty() {
        coarse.expanded(cell)
    } else {
        fine.expanded(fine_cell)
    };
    // Mirror the y ≥ 0 half.
    let y_max = bounds.max[1];
    (
        Rect {
            min: [bounds.min[0], -y_max],
            max: [bounds.max[0], y_max],
        },
        traced,
    )
}

/// The bounds of the `grid` lattice points of `window` whose rays pass, and the lattice's
/// cell size. Where none pass and the stop is too small for the lattice to resolve its
/// pupil, the pupil of a [`STOP_ZOOM`] times wider stop (found the same way) is searched
/// with a fine lattice instead: it holds every ray the smaller stop passes.
fn locate_pupil(
    system: &LensSystem,
    points: &[[f64; 2]],
    window: &Rect,
    grid: [usize; 2],
    search: &PupilSearch,
    traced: &mut u64,
) -> (Rect, f64) {
    let found = passing_bounds(system, points, window, grid, traced);
    let cell = (window.max[0] - window.min[0]) / grid[0] as f64;
    let stop = system.stop_diameter();
    if !found.is_empty() || stop >= search.resolved_stop {
        return (found, cell);
    }
    let wider = with_circular_stop(system, (stop * STOP_ZOOM).min(search.resolved_stop));
    let (outer, outer_cell) = locate_pupil(&wider, points, window, grid, search, traced);
    if outer.is_empty() {
        return (Rect::EMPTY, cell);
    }
    let within = upper_half(outer.expanded(outer_cell));
    let fine = [FINE_GRID, FINE_GRID];
    let found = passing_bounds(system, points, &within, fine, traced);
    (found, fine_cell(&within))
}

/// The larger side of a fine lattice's cells over `window`.
fn fine_cell(window: &Rect) -> f64 {
    ((window.max[0] - window.min[0]).max(window.max[1] - window.min[1])) / FINE_GRID as f64
}

/// `rect` without what lies below y = 0 (the traced half of the meridional mirror symmetry).
fn upper_half(rect: Rect) -> Rect {
    Rect {
        min: [rect.min[0], rect.min[1].max(0.0)],
        max: rect.max,
    }
}

/// `system` with its stop a plain circle `diameter` mm across (indices and every other
/// surface as they are): a wider stop passes every ray a narrower one does.
fn with_circular_stop(system: &LensSystem, diameter: f64) -> LensSystem {
    let mut wider = system.without_diaphragm();
    let stop = wider.stop;
    wider.rows[stop].base.aperture = diameter;
    let semi_sq = (diameter / 2.0).powi(2);
    wider.f64s.semi_aperture_sq[stop] = semi_sq;
    wider.f32s.semi_aperture_sq[stop] = semi_sq as f32;
    wider
}

/// Traces a `grid[0]` × `grid[1]` lattice of cell centres of `window` from each film point
/// (r, 0, z) of `points` ([r, z]) and returns the bounds of the centres whose rays pass.
fn passing_bounds(
    system: &LensSystem,
    points: &[[f64; 2]],
    window: &Rect,
    grid: [usize; 2],
    traced: &mut u64,
) -> Rect {
    let rear_z = system.rear_z() as f32;
    let step = [
        (window.max[0] - window.min[0]) / grid[0] as f64,
        (window.max[1] - window.min[1]) / grid[1] as f64,
    ];
    let centre = |i: usize, axis: usize| window.min[axis] + (i as f64 + 0.5) * step[axis];
    let xs: Vec<f64> = (0..grid[0]).map(|ix| centre(ix, 0)).collect();
    let ys: Vec<f64> = (0..grid[1]).map(|iy| centre(iy, 1)).collect();
    // Ray (point, iy, ix) in that order; every array is written in place, so the batch is
    // made in one pass over each.
    let per_film_point = grid[0] * grid[1];
    let mut batch = RayBatch::default();
    batch.resize(per_film_point * points.len());
    for (p, &[r, film_z]) in points.iter().enumerate() {
        let (r, film_z) = (r as f32, film_z as f32);
        let rays = p * per_film_point..(p + 1) * per_film_point;
        batch.ox[rays.clone()].fill(r);
        batch.oz[rays.clone()].fill(film_z);
        let directions = batch.dx[rays.clone()]
            .iter_mut()
            .zip(&mut batch.dy[rays.clone()])
            .zip(&mut batch.dz[rays]);
        let cells = ys
            .iter()
            .flat_map(|&y| xs.iter().map(move |&x| (x as f32, y as f32)));
        for (((dx, dy), dz), (x, y)) in directions.zip(cells) {
            let d = [x - r, y, rear_z - film_z];
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            (*dx, *dy, *dz) = (d[0] / len, d[1] / len, d[2] / len);
        }
    }
    *traced += batch.len() as u64;
    trace_batch(&system.f32s, &mut batch, Travel::FilmToScene);
    let mut bounds = Rect::EMPTY;
    for film_point in batch.alive.chunks_exact(per_film_point) {
        for (row, &y) in film_point.chunks_exact(grid[0]).zip(&ys) {
            for (&alive, &x) in row.iter().zip(&xs) {
                if alive {
                    bounds.include(x, y);
                }
            }
        }
    }
    bounds
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What the sampler draws and what it says it would draw agree: the weight of every
    /// sampled ray is [`PupilSampler::drawn_weight`] of its rear-plane point, and a point
    /// beyond the bounds (or the rear element) is one it never draws.
    #[test]
    fn drawn_weight_is_the_weight_of_what_the_sampler_draws() {
        let prescription = crate::lens::io::bundled::load_lens("wide.22mm", None).unwrap();
        let system = LensSystem::new(&prescription.rows, None);
        let film_distance = system.rear_semi_aperture().max(20.0);
        for sampling in [PupilSampling::Bounds, PupilSampling::RearElement] {
            let pupil = ExitPupil::compute(&system, film_distance, 43.0, sampling);
            let sampler = pupil.sampler();
            let mut drawn = 0;
            for k in 0..400 {
                let (x, y) = (-20.0 + 0.1 * k as f32, 7.0 - 0.035 * k as f32);
                let u = [
                    ((k * 37) % 101) as f32 / 101.0,
                    ((k * 53) % 103) as f32 / 103.0,
                ];
                let Some(sample) = pupil.sample(x, y, u) else {
                    continue;
                };
                drawn += 1;
                let rear = [sample.point[0], sample.point[1]];
                let w = sampler.drawn_weight([x, y], film_distance as f32, rear);
                assert!((w / sample.weight - 1.0).abs() < 1e-4, "{w} vs {sample:?}");
                let beyond = [rear[0] * 3.0 + 100.0, rear[1] * 3.0 - 100.0];
                assert_eq!(
                    sampler.drawn_weight([x, y], film_distance as f32, beyond),
                    0.0
                );
            }
            assert!(drawn > 100, "{sampling:?}: {drawn}");
        }
    }
    use crate::lens::io::bundled::BUNDLED;
    use crate::lens::workload::LensWorkload;
    use crate::sampling::Rng;

    /// What the camera loop's f32 sampler gives for film points (x, y), at `depth` behind the
    /// rear vertex when the film is tilted, and pupil samples (u, v).
    struct SampledRays {
        dx: Vec<f32>,
        dy: Vec<f32>,
        dz: Vec<f32>,
        weight: Vec<f32>,
        passes: Vec<bool>,
    }

    fn sample_with_camera_loop(
        pupil: &ExitPupil,
        x: &[f32],
        y: &[f32],
        depth: Option<&[f32]>,
        u: &[f32],
        v: &[f32],
    ) -> SampledRays {
        let n = x.len();
        let mut rays = SampledRays {
            dx: vec![0.0; n],
            dy: vec![0.0; n],
            dz: vec![0.0; n],
            weight: vec![0.0; n],
            passes: vec![false; n],
        };
        pupil.sampler().sample(FilmRays {
            x,
            y,
            depth,
            u,
            v,
            dx: &mut rays.dx,
            dy: &mut rays.dy,
            dz: &mut rays.dz,
            weight: &mut rays.weight,
            passes: &mut rays.passes,
        });
        rays
    }

    /// The f32 sampler of the camera loop against the f64 reference: the same ray and weight,
    /// and the same verdict on film points no ray leaves (fisheye corners).
    #[test]
    fn f32_sampler_agrees_with_f64_reference() {
        const N: usize = 2000;
        let mut rng = Rng::new(3, 4);
        let mut compared = 0;
        for lens in BUNDLED.iter().map(|b| b.name) {
            let w = LensWorkload::new(lens, 1).unwrap();
            for sampling in [PupilSampling::Bounds, PupilSampling::RearElement] {
                let diagonal = LensWorkload::FILM_DIAGONAL_MM;
                let pupil = ExitPupil::compute(&w.system, w.film_distance, diagonal, sampling);
                // Beyond the film diagonal too: the last segment's bounds serve there.
                let scale = 1.2 * diagonal as f32;
                let mut film = || (rng.next_f32() - 0.5) * scale;
                let (x, y): (Vec<f32>, Vec<f32>) = (0..N).map(|_| (film(), film())).unzip();
                let (u, v): (Vec<f32>, Vec<f32>) = (0..N).map(|_| rng.next_2d().into()).unzip();
                let SampledRays {
                    dx,
                    dy,
                    dz,
                    weight,
                    passes,
                } = sample_with_camera_loop(&pupil, &x, &y, None, &u, &v);
                for i in 0..N {
                    let k = (x[i] as f64).hypot(y[i] as f64) / pupil.film_radius * SEGMENTS as f64;
                    if (k - k.round()).abs() < 1e-4 {
                        continue; // At a segment boundary either neighbour's bounds are right.
                    }
                    let fast = [dx[i], dy[i], dz[i]];
                    let context = format!("{lens} {sampling:?} ({}, {}): {fast:?}", x[i], y[i]);
                    let Some(reference) = pupil.sample(x[i], y[i], [u[i], v[i]]) else {
                        assert!(!passes[i] && weight[i] == 0.0, "{context}");
                        assert_eq!(fast, [0.0, 0.0, -1.0], "{context}");
                        continue;
                    };
                    assert!(passes[i], "{context}");
                    let [px, py, _] = reference.point;
                    let to = [px - x[i], py - y[i], -pupil.film_distance as f32];
                    let len = (to[0] * to[0] + to[1] * to[1] + to[2] * to[2]).sqrt();
                    for axis in 0..3 {
                        let expected = to[axis] / len;
                        assert!(
                            (fast[axis] - expected).abs() < 1e-5,
                            "{context}: {expected}"
                        );
                    }
                    let relative = (weight[i] - reference.weight).abs() / reference.weight;
                    assert!(relative < 1e-5, "{context}: {} vs {reference:?}", weight[i]);
                    compared += 1;
                }
            }
        }
        assert!(compared > 10_000, "{compared}");
    }

    /// On a shifted, tilted film each point has its own depth: the f32 sampler's rays and
    /// weights agree with the f64 reference at that depth.
    #[test]
    fn f32_sampler_agrees_with_f64_reference_on_a_tilted_film() {
        const N: usize = 2000;
        let w = LensWorkload::new("dgauss.50mm", 1).unwrap();
        let movements = FilmMovements {
            shift_mm: [3.0, -2.0],
            tilt_deg: [8.0, -5.0],
        };
        let pupil = ExitPupil::compute_moved(
            &w.system,
            w.film_distance,
            35.0,
            PupilSampling::Bounds,
            false,
            &movements,
        );
        let film_z = w.system.rear_z() + w.film_distance;
        let mut rng = Rng::new(5, 6);
        let mut points = Vec::new();
        for _ in 0..N {
            let [a, b] = rng.next_2d().map(|v| (v as f64 - 0.5) * 30.0);
            points.push(movements.film_point(a, b, film_z));
        }
        let x: Vec<f32> = points.iter().map(|p| p[0] as f32).collect();
        let y: Vec<f32> = points.iter().map(|p| p[1] as f32).collect();
        let depth: Vec<f32> = points
            .iter()
            .map(|p| (p[2] - w.system.rear_z()) as f32)
            .collect();
        let (u, v): (Vec<f32>, Vec<f32>) = (0..N).map(|_| rng.next_2d().into()).unzip();
        let SampledRays {
            dx,
            dy,
            dz,
            weight,
            passes,
        } = sample_with_camera_loop(&pupil, &x, &y, Some(&depth), &u, &v);
        let mut compared = 0;
        for i in 0..N {
            let k = (x[i] as f64).hypot(y[i] as f64) / pupil.film_radius * SEGMENTS as f64;
            if (k - k.round()).abs() < 1e-4 {
                continue;
            }
            let Some(reference) = pupil.sample_at(x[i], y[i], depth[i], [u[i], v[i]]) else {
                assert!(!passes[i] && weight[i] == 0.0);
                continue;
            };
            let [px, py, _] = reference.point;
            let to = [px - x[i], py - y[i], -depth[i]];
            let len = (to[0] * to[0] + to[1] * to[1] + to[2] * to[2]).sqrt();
            for (axis, fast) in [dx[i], dy[i], dz[i]].into_iter().enumerate() {
                assert!((fast - to[axis] / len).abs() < 1e-5, "ray {i}");
            }
            assert!((weight[i] / reference.weight - 1.0).abs() < 1e-5, "ray {i}");
            compared += 1;
        }
        assert!(compared > N / 2, "{compared}");
    }
}
