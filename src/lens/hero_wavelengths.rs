//! Several wavelengths per camera sample, sharing one scene path: colour from the glass without
//! colour grain.
//!
//! A pixel's value in channel c is (film point x in the pixel, rear-plane point u, wavelength λ,
//! and r = R_λ(x, u) the scene ray the lens sends from x through u at λ)
//!
//! ```text
//! I_c = ∫ dλ ∫ dA(x) ∫ dA(u)  G(x, u) · s_c(λ) · T_λ(x, u) · L_λ(R_λ(x, u))
//! ```
//!
//! with G the film's geometric factor (cos⁴θ / z², see [`super::pupil::PupilSample`]), s_c the
//! film's response ([`crate::spectral::upsample`]) and T the diaphragm mask's transmission. A
//! single-wavelength sample draws λ, x and u and traces one scene path: its three channels see
//! one wavelength, so a grey wall comes out in speckles of every colour.
//!
//! The scene is RGB and does not disperse: only the lens makes the scene ray depend on λ. The
//! lens conserves étendue (film and scene are both in air), so G·dA(x)·dA(u) is the same
//! measure dΓ(r) of scene rays at every wavelength, and for each λ the lens maps (x, u) to r
//! one to one. Rewritten over scene rays the integral is
//!
//! ```text
//! I_c = ∫ dλ ∫ dΓ(r)  [x_λ(r) ∈ pixel] · s_c(λ) · T_λ(r) · L_λ(r)
//! ```
//!
//! where x_λ(r) is where the ray r, **traced backwards through the lens at λ**, lands on the
//! film (refraction is reversible: that film point sends exactly r at λ). So one scene path
//! along r serves every wavelength, each counted in the pixel its own backward trace lands in.
//!
//! **The estimator** (hero wavelength sampling, Wilkie et al. 2014, carried through the lens):
//! a sample draws the hero λ₀ from `u` ∈ [0, 1) as before, and its companions
//! λₖ = sample_wavelength((u + k/N) mod 1), k = 1 … N−1, the same set whichever of them is the
//! hero. (`u` itself is drawn by the set's luminance, [`crate::spectral::wavelength_sets`], so
//! that every set adds the same luminance for grey light; that density has period 1/N, is the
//! same for every member, and multiplies each 1/p(λₖ) below.) It draws x and u for λ₀, traces r forward, and each companion backward to its film
//! point x_k. Technique k ("λₖ was the hero") would have drawn r with density q_k(r) = 1 / W_k
//! in dΓ, where W_k = A·G(x_k, u_k) is the camera weight of (x_k, u_k) (A: the area u is drawn
//! from), provided x_k lies on the frame and u_k where the pupil sampler draws. Wavelength i's
//! share goes to the pixel x_i lies in, if that is within [`SPLAT_RADIUS`] of the hero's pixel;
//! the techniques that would have produced that same share are the valid k whose x_k lies
//! within the radius of x_i's pixel (K_i), and with the balance heuristic over them the share
//! is
//!
//! ```text
//! s_c(λ_i) · T_i · L(r) / p(λ_i)   ×   1 / Σ_{j ∈ K_i} (1 / W_j)
//! ```
//!
//! Unbiased: each (λ, r) reaches its pixel through its own technique at least, and the
//! weights of the techniques that reach it sum to one; with N = 1 it is the single-wavelength
//! estimator exactly. Where the lens's colour is small every companion lands in the hero's
//! pixel and the N responses add up to nearly white; where it is larger (a fringe, a defocused
//! edge) a sample's spectrum is shared among the pixels it lands in, and beyond the radius a
//! share drops out (its colour then comes from the neighbours' own samples): noise, not bias.

use super::camera::{FilmMap, FilmTilt};
use super::dispersion::DispersionTable;
use super::pupil::{DrawnRay, PupilSampler, with_sampler_kind};
use super::system::SurfaceArrays;
use super::trace::Travel;
use super::trace_batch::{Wavelengths, trace_batch_spectral};
use crate::batch::RayBatch;
use crate::film::filter::quantise;
use crate::spectral::{
    MAX_SET_SIZE, WavelengthKnots, WavelengthSample, WavelengthSet, sample_wavelength_from,
    wavelength_knots,
};

/// Wavelengths per camera sample a spectral render traces by default (see BENCHMARKS.md,
/// "Colour grain": the colour noise against the lens-tracing cost). With the film's tent
/// filter three do better than four at equal time on all four course lenses (and as well per
/// sample): one in each third of the wavelength density, one in each of the film's bands.
pub const DEFAULT_WAVELENGTHS: u32 = 3;

/// The most wavelengths per camera sample (the GPU keeps them in registers).
pub const MAX_WAVELENGTHS: u32 = MAX_SET_SIZE;

/// How far (mm) outside the front surface a backward trace starts along the scene ray, so its
/// first intersection is a clean root well above the kernel's minimum distance.
pub(crate) const BACKWARD_START_MM: f32 = 0.01;

/// Wavelength `k` of `count` in a camera sample's `set` (drawn by
/// [`crate::spectral::draw_wavelength_set`]): the hero (k = 0) is `sample_wavelength(set.u)`;
/// the others are the same rotation of `set.u` by k/count in the sampler's primary space, so
/// the set is one and the same whichever member is the hero. Each member's 1/p includes the
/// set's own inverse density.
#[inline(always)]
pub fn wavelength_of_set(set: WavelengthSet, k: u32, count: u32) -> WavelengthSample {
    wavelength_of_set_from(wavelength_knots(), set, k, count)
}

/// [`wavelength_of_set`] with the wavelength sampler's `knots` looked up by the caller: once
/// for a whole loop of draws.
#[inline(always)]
pub fn wavelength_of_set_from(
    knots: &WavelengthKnots,
    set: WavelengthSet,
    k: u32,
    count: u32,
) -> WavelengthSample {
    let shifted = set.u + k as f32 / count as f32;
    let sample = sample_wavelength_from(
        knots,
        if shifted >= 1.0 {
            shifted - 1.0
        } else {
            shifted
        },
    );
    WavelengthSample {
        nm: sample.nm,
        inverse_pdf: sample.inverse_pdf * set.inverse_density,
    }
}

/// How far (pixels, along x or y) from the hero's pixel a companion's contribution may land
/// and still be added there. Measured on the bundled lenses at 512² (BENCHMARKS.md, "Colour
/// grain"): dgauss.50mm's companions all land within 1 pixel, wide.22mm's and the fisheye's
/// 99.9 % within 2; a strongly chromatic telephoto's 88 % within 2. The rest drop out of the
/// sample (both its sums), which costs noise, never bias.
pub const SPLAT_RADIUS: i32 = 2;

/// What the backward traces need of the camera: the lens, its film and pupil sampler.
pub(crate) struct BackwardTrace<'a> {
    pub surfaces: &'a SurfaceArrays<f32>,
    pub table: &'a DispersionTable,
    pub film: FilmMap,
    /// The frame's size in pixels.
    pub size: [u32; 2],
    pub tilt: Option<FilmTilt>,
    pub sampler: &'a PupilSampler,
    /// Lens-frame z of the frame centre, mm.
    pub film_z: f32,
}

/// A batch's heroes as the forward trace left them (lens frame), kept until their companions
/// are landed ([`LensCamera::land_companions`](super::camera::LensCamera::land_companions)). A
/// companion shares its hero's scene path, so a sample whose path found no light adds nothing
/// at any wavelength: the pipeline lands companions only once shading has shown which samples
/// carry light (a black sky's, most of the default scene's frame above its horizon, need none).
#[derive(Clone, Debug, Default)]
pub struct PendingCompanions {
    /// Per ray of the batch, its scene ray on the front surface: origin (mm), direction.
    origin: [Vec<f32>; 3],
    direction: [Vec<f32>; 3],
    /// Its camera weight W₀ if its companions are to land (it passed the lens with a weight),
    /// else 0.
    weight: Vec<f32>,
    /// Its pixel (x, y).
    pixel: [Vec<f32>; 2],
}

impl PendingCompanions {
    /// Keeps every ray of `rays` with its pixel (`px`, `py`) for
    /// [`BackwardTrace::land_companions`], and makes `weight` and `out` what they are for every
    /// sample whatever its companions: the weight 1 for a hero that passed with a weight (its
    /// W₀, the weight on the way in, goes into the factors), 0 for any other, and no share of
    /// a sample that did not pass.
    #[inline(always)]
    pub(crate) fn keep(
        &mut self,
        rays: &RayBatch,
        [px, py]: [&[f32]; 2],
        weight: &mut [f32],
        out: Combined,
    ) {
        let n = rays.len();
        let count = out.coefficient.len() / n.max(1);
        let from: [&[f32]; 6] = [&rays.ox, &rays.oy, &rays.oz, &rays.dx, &rays.dy, &rays.dz];
        let to = self.origin.iter_mut().chain(&mut self.direction);
        for (kept, v) in to
            .chain(&mut self.pixel)
            .zip(from.into_iter().chain([px, py]))
        {
            kept.clear();
            kept.extend_from_slice(&v[..n]);
        }
        let alive = &rays.alive[..n];
        self.weight.clear();
        self.weight
            .extend(alive.iter().zip(&mut weight[..n]).map(|(&alive, weight)| {
                let lands = alive & (*weight > 0.0);
                let kept = if lands { *weight } else { 0.0 };
                *weight = if lands { 1.0 } else { 0.0 };
                kept
            }));
        // A select per ray and wavelength, not a branch per ray: the loops vectorise.
        for k in 0..count {
            let block = k * n..(k + 1) * n;
            for (coefficient, &alive) in out.coefficient[block.clone()].iter_mut().zip(alive) {
                *coefficient = if alive { *coefficient } else { 0.0 };
            }
            for (offset, &alive) in out.offset[block].iter_mut().zip(alive) {
                // All ones where it passed, else zero (a select on two bytes stays scalar).
                let keep = -i8::from(alive);
                *offset = offset.map(|o| o & keep);
            }
        }
    }

    pub(crate) fn clear(&mut self) {
        self.weight.clear();
    }

    /// Whether nothing is kept: the batch was generated with one wavelength a sample, or
    /// without dispersion.
    pub fn is_empty(&self) -> bool {
        self.weight.is_empty()
    }
}

/// The backward traces' buffers, kept between batches.
#[derive(Clone, Debug, Default)]
pub(crate) struct BackwardScratch {
    rays: RayBatch,
    /// The heroes being landed, by index in their batch.
    passed: Vec<u32>,
    /// The backward rays' wavelengths.
    nm: Vec<f32>,
    /// Per backward ray, where it lands (see [`BackwardTrace::land`]).
    landed_x: Vec<i32>,
    landed_y: Vec<i32>,
    /// The same point in continuous pixel coordinates (pixels from the frame's top-left corner).
    landed_at: Vec<[f32; 2]>,
    /// 1/W there; 0 when that technique could not have drawn the scene ray.
    inverse_weight: Vec<f32>,
    /// Per backward ray, what the pupil sampler makes of it before its look-ups.
    drawn: DrawnRays,
}

/// [`DrawnRay`]s, structure of arrays (so the loop that makes them vectorises).
#[derive(Clone, Debug, Default)]
struct DrawnRays {
    segment: Vec<u32>,
    x: Vec<f32>,
    y: Vec<f32>,
    factor: Vec<f32>,
    depth: Vec<f32>,
}

impl DrawnRays {
    /// `len` rays' worth of zeros.
    fn zeroed(&mut self, len: usize) {
        self.segment.clear();
        self.segment.resize(len, 0);
        for v in [&mut self.x, &mut self.y, &mut self.factor, &mut self.depth] {
            v.clear();
            v.resize(len, 0.0);
        }
    }

    #[inline(always)]
    fn get(&self, j: usize) -> DrawnRay {
        DrawnRay {
            segment: self.segment[j],
            point: [self.x[j], self.y[j]],
            factor: self.factor[j],
            depth: self.depth[j],
        }
    }
}

impl BackwardScratch {
    /// Empties every array, with room for `heroes` heroes and `backward` backward rays: how
    /// many heroes pass varies from pass to pass, and an array grown to each new largest
    /// count would reallocate now and then for many passes.
    fn clear_with_room(&mut self, heroes: usize, backward: usize) {
        self.rays.clear();
        self.rays.reserve(backward);
        self.passed.clear();
        self.passed.reserve(heroes);
        for v in [&mut self.nm, &mut self.inverse_weight] {
            v.clear();
            v.reserve(backward);
        }
        for v in [&mut self.landed_x, &mut self.landed_y] {
            v.clear();
            v.reserve(backward);
        }
        self.landed_at.clear();
        self.landed_at.reserve(backward);
    }
}

/// Per ray and wavelength, what [`BackwardTrace::land_companions`] makes: the film's factor
/// (`coefficient`, see [`super::camera::CameraRays::wavelength_weight`]) and the pixel offset
/// its contribution goes to.
pub(crate) struct Combined<'a> {
    /// In: 1/p(λ_k), wavelength-major. Out: T_k / (p(λ_k) · Σ_{j ∈ K_k} 1/W_j), 0 where the
    /// wavelength does not count.
    pub coefficient: &'a mut [f32],
    /// Out: (dx, dy) from the ray's pixel to the one wavelength k's contribution goes to.
    pub offset: &'a mut [[i8; 2]],
    /// Out, for every wavelength but the hero's: where it lands relative to the ray's pixel's
    /// corner, pixels, quantised for the film's filter (see [`crate::film::filter`]).
    pub position: &'a mut [[f32; 2]],
}

/// A batch's heroes as [`BackwardTrace::land_companions`] reads them: those `pending` keeps,
/// the hero rays' throughputs `transmission` (what the mask and the surfaces passed), and every
/// ray's wavelengths `nm` (wavelength-major: `count` blocks of one per ray, the heroes first).
pub(crate) struct HeroRays<'a> {
    pub pending: &'a PendingCompanions,
    pub transmission: &'a [f32],
    pub nm: &'a [f32],
}

impl BackwardTrace<'_> {
    /// Traces the pending heroes for which `carries_light` holds (by index in their batch)
    /// backward at each companion wavelength (`hero.nm`'s blocks after the first) and combines
    /// the N techniques with the balance heuristic (see the module docs). Wavelength k counts
    /// when it lands within [`SPLAT_RADIUS`] of the hero's pixel; its techniques K_k are the
    /// valid wavelengths that land within the same radius of *its* pixel (exactly those whose
    /// samples would add this contribution), so the weights of each contribution sum to one.
    /// The other heroes' factors are left as they are: their samples add nothing.
    #[inline(always)]
    pub fn land_companions(
        &self,
        hero: HeroRays,
        carries_light: impl Fn(usize) -> bool,
        out: Combined,
        scratch: &mut BackwardScratch,
    ) {
        let pending = hero.pending;
        let n = hero.transmission.len();
        let count = hero.nm.len() / n.max(1);
        scratch.clear_with_room(n, n * (count - 1));
        // Only the heroes that passed with a weight and carry light are traced back: `passed`
        // lists them, and backward ray (k − 1)·m + p is hero passed[p] at wavelength k.
        // Written without a branch per hero (whether one counts is as good as random): every
        // index is stored, and the count advances past those that count.
        let weight = &pending.weight[..n];
        scratch.passed.resize(n, 0);
        let mut m = 0;
        for (i, &w) in weight.iter().enumerate() {
            scratch.passed[m] = i as u32;
            m += usize::from((w > 0.0) & carries_light(i));
        }
        scratch.passed.truncate(m);
        let backward = &mut scratch.rays;
        backward.resize(m * (count - 1));
        // Every companion starts as the same ray: the first block is built from the heroes,
        // the others are copies of it.
        let ([ox, oy, oz], [dx, dy, dz]) = (&pending.origin, &pending.direction);
        for (p, &i) in scratch.passed.iter().enumerate() {
            let i = i as usize;
            backward.ox[p] = ox[i] + BACKWARD_START_MM * dx[i];
            backward.oy[p] = oy[i] + BACKWARD_START_MM * dy[i];
            backward.oz[p] = oz[i] + BACKWARD_START_MM * dz[i];
            backward.dx[p] = -dx[i];
            backward.dy[p] = -dy[i];
            backward.dz[p] = -dz[i];
        }
        for block in 1..count - 1 {
            for v in [
                &mut backward.ox,
                &mut backward.oy,
                &mut backward.oz,
                &mut backward.dx,
                &mut backward.dy,
                &mut backward.dz,
            ] {
                v.copy_within(0..m, block * m);
            }
        }
        for k in 1..count {
            let wavelengths = &hero.nm[k * n..(k + 1) * n];
            scratch
                .nm
                .extend(scratch.passed.iter().map(|&i| wavelengths[i as usize]));
        }
        let wavelengths = Wavelengths {
            table: self.table,
            nm: &scratch.nm,
        };
        trace_batch_spectral(self.surfaces, wavelengths, backward, Travel::SceneToFilm);
        self.land(scratch);
        // The per-ray loop compiled for the default count too, so that its loops over the
        // wavelengths unroll (one copy for any other count).
        match count {
            3 => combine_rays::<3>(hero, out, scratch, count),
            _ => combine_rays::<0>(hero, out, scratch, count),
        }
    }

    /// Where every backward ray of `scratch` (on the rear surface, heading for the film) meets
    /// the film: the pixel there, and the inverse of the camera weight the pupil sampler would
    /// have drawn it with if the point lies on the frame and the sampler can draw its
    /// rear-plane point (0 otherwise, and for a blocked ray).
    #[inline(always)]
    fn land(&self, scratch: &mut BackwardScratch) {
        // The sampler's kind and the film's tilt are the batch's: picked here once, so that
        // the loops below have no branches.
        with_sampler_kind!(self.sampler, |BOUNDS, FLAT| {
            self.land_as::<BOUNDS, FLAT>(scratch)
        })
    }

    /// [`Self::land`] for one kind of pupil sampler and film (see
    /// [`PupilSampler::drawn_ray`]), in two loops: first where each ray meets the film and the
    /// rear plane and what the sampler makes of it without its tables (the divisions and
    /// roots, in a loop that vectorises), then the segments' look-ups.
    #[inline(always)]
    fn land_as<const BOUNDS: bool, const FLAT: bool>(&self, scratch: &mut BackwardScratch) {
        let rays = &scratch.rays;
        let len = rays.len();
        for v in [&mut scratch.landed_x, &mut scratch.landed_y] {
            v.clear();
            v.resize(len, 0);
        }
        scratch.inverse_weight.clear();
        scratch.inverse_weight.resize(len, 0.0);
        scratch.landed_at.clear();
        scratch.landed_at.resize(len, [0.0; 2]);
        scratch.drawn.zeroed(len);
        let at_out = &mut scratch.landed_at[..len];
        let (ox, oy, oz) = (&rays.ox[..len], &rays.oy[..len], &rays.oz[..len]);
        let (dx, dy, dz) = (&rays.dx[..len], &rays.dy[..len], &rays.dz[..len]);
        let drawn = &mut scratch.drawn;
        let (segment, drawn_x, drawn_y) = (
            &mut drawn.segment[..len],
            &mut drawn.x[..len],
            &mut drawn.y[..len],
        );
        let (factor, drawn_depth) = (&mut drawn.factor[..len], &mut drawn.depth[..len]);
        // The rear-vertex plane, where the pupil sampler draws its points.
        let rear_z = self.film_z - self.sampler.film_distance;
        // `lens_xy` is the film point as the pupil sampler takes it, `plane` where it lies in
        // the film plane's own coordinates (the film map's), `depth` its distance behind the
        // rear plane.
        // A macro, not a closure: the compiler keeps a closure out of line here, and the loop
        // then does not vectorise.
        macro_rules! geometry {
            ($j:expr, $lens_xy:expr, $plane:expr, $depth:expr) => {{
                let j = $j;
                let (o, d) = ([ox[j], oy[j], oz[j]], [dx[j], dy[j], dz[j]]);
                at_out[j] = self.film.pixel_position($plane);
                let t = (rear_z - o[2]) / d[2];
                let rear = [o[0] + t * d[0], o[1] + t * d[1]];
                let ray = self
                    .sampler
                    .drawn_ray::<BOUNDS, FLAT>($lens_xy, $depth, rear);
                (segment[j], drawn_x[j], drawn_y[j]) = (ray.segment, ray.point[0], ray.point[1]);
                (factor[j], drawn_depth[j]) = (ray.factor, ray.depth);
            }};
        }
        // The film plane: through the frame centre, normal to the (tilted) film.
        match self.tilt {
            None => {
                let depth = self.sampler.film_distance;
                for j in 0..len {
                    let t = (self.film_z - oz[j]) / dz[j];
                    let p = [ox[j] + t * dx[j], oy[j] + t * dy[j]];
                    geometry!(j, p, p, depth);
                }
            }
            Some(tilt) => {
                let [[xa, xb], [ya, yb], [za, zb]] = tilt.rotation;
                let normal = self.sampler.film_normal;
                let centre = [tilt.centre[0], tilt.centre[1], self.film_z];
                for j in 0..len {
                    let (o, d) = ([ox[j], oy[j], oz[j]], [dx[j], dy[j], dz[j]]);
                    let to_centre = [centre[0] - o[0], centre[1] - o[1], centre[2] - o[2]];
                    let t = dot(to_centre, normal) / dot(d, normal);
                    let p = [o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]];
                    let offset = [p[0] - centre[0], p[1] - centre[1], p[2] - centre[2]];
                    let plane = [
                        tilt.centre[0] + dot(offset, [xa, ya, za]),
                        tilt.centre[1] + dot(offset, [xb, yb, zb]),
                    ];
                    geometry!(
                        j,
                        [p[0], p[1]],
                        plane,
                        self.sampler.film_distance + offset[2]
                    );
                }
            }
        }
        let alive = &rays.alive[..len];
        let (x_out, y_out) = (&mut scratch.landed_x[..len], &mut scratch.landed_y[..len]);
        let inverse_out = &mut scratch.inverse_weight[..len];
        for j in 0..len {
            let [qx, qy] = scratch.landed_at[j];
            let on_frame =
                qx >= 0.0 && qy >= 0.0 && qx < self.size[0] as f32 && qy < self.size[1] as f32;
            let w = self
                .sampler
                .weight_of_drawn::<BOUNDS, FLAT>(scratch.drawn.get(j));
            let valid = alive[j] && on_frame && w > 0.0 && w.is_finite();
            (x_out[j], y_out[j], inverse_out[j]) = if valid {
                (qx as i32, qy as i32, 1.0 / w)
            } else {
                (0, 0, 0.0)
            };
            if !valid {
                scratch.landed_at[j] = [0.0; 2];
            }
        }
    }
}

/// [`BackwardTrace::land_companions`]' per-ray loop, once the backward rays have landed:
/// `FIXED` wavelengths per ray, or `count` when `FIXED` is 0.
#[inline(always)]
fn combine_rays<const FIXED: usize>(
    hero: HeroRays,
    out: Combined,
    scratch: &mut BackwardScratch,
    count: usize,
) {
    let count = if FIXED > 0 { FIXED } else { count };
    let n = hero.transmission.len();
    let pending = hero.pending;
    let BackwardScratch {
        rays: backward,
        passed,
        landed_x,
        landed_y,
        landed_at,
        inverse_weight,
        ..
    } = scratch;
    let m = passed.len();
    // Per wavelength of one ray: its pixel, 1/W (0: not a technique) and transmission.
    let mut pixel = [[0i32; 2]; MAX_WAVELENGTHS as usize];
    let mut inverse = [0.0f32; MAX_WAVELENGTHS as usize];
    let mut transmission = [0.0f32; MAX_WAVELENGTHS as usize];
    for (p, &i) in passed.iter().enumerate() {
        let i = i as usize;
        let (px, py) = (pending.pixel[0][i], pending.pixel[1][i]);
        let hero_pixel = [px as i32, py as i32];
        pixel[0] = hero_pixel;
        inverse[0] = 1.0 / pending.weight[i];
        transmission[0] = hero.transmission[i];
        for k in 1..count {
            let j = (k - 1) * m + p;
            let [qx, qy] = landed_at[j];
            out.position[k * n + i] = [quantise(qx - px), quantise(qy - py)];
            (pixel[k], inverse[k], transmission[k]) = (
                [landed_x[j], landed_y[j]],
                inverse_weight[j],
                backward.tr[j],
            );
        }
        // Most often every wavelength is a technique landing in the hero's pixel: then
        // every share has the same techniques.
        let all_home = (0..count).all(|k| inverse[k] > 0.0 && pixel[k] == hero_pixel);
        if all_home {
            let inverse_sum: f32 = inverse[..count].iter().sum();
            for (k, t) in transmission[..count].iter().enumerate() {
                out.coefficient[k * n + i] *= t / inverse_sum;
                out.offset[k * n + i] = [0, 0];
            }
            continue;
        }
        for k in 0..count {
            let c = &mut out.coefficient[k * n + i];
            if inverse[k] > 0.0 && within_radius(pixel[k], hero_pixel) {
                let mut inverse_sum = 0.0;
                for j in 0..count {
                    if inverse[j] > 0.0 && within_radius(pixel[j], pixel[k]) {
                        inverse_sum += inverse[j];
                    }
                }
                *c *= transmission[k] / inverse_sum;
                out.offset[k * n + i] = [
                    (pixel[k][0] - hero_pixel[0]) as i8,
                    (pixel[k][1] - hero_pixel[1]) as i8,
                ];
            } else {
                *c = 0.0;
                out.offset[k * n + i] = [0, 0];
            }
        }
    }
}

/// Whether pixels `a` and `b` are within [`SPLAT_RADIUS`] of each other along both axes.
#[inline(always)]
fn within_radius(a: [i32; 2], b: [i32; 2]) -> bool {
    (a[0] - b[0]).abs() <= SPLAT_RADIUS && (a[1] - b[1]).abs() <= SPLAT_RADIUS
}

#[inline(always)]
fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::filter::POSITION_STEP;
    use crate::lens::camera::{CameraRays, LensCamera};
    use crate::lens::movements::FilmMovements;
    use crate::lens::pupil::PupilSampling;
    use crate::lens::test_lens::{PLAIN, Setup, TestLens};

    /// Refraction is reversible: a camera ray's scene ray traced back at the ray's own
    /// wavelength lands on the film point it left, in its pixel, and the pupil sampler would
    /// draw it there with the weight it was drawn with. With that wavelength as the only
    /// companion, the balance heuristic gives each half of the sample. Checked on a plain and a
    /// shifted and tilted film, with both pupil samplers, on spherical and aspheric designs.
    #[test]
    fn a_ray_traced_back_at_its_own_wavelength_lands_where_it_left() {
        let shifted_and_tilted = FilmMovements {
            shift_mm: [2.0, -1.5],
            tilt_deg: [4.0, -3.0],
        };
        let spectral = Setup {
            spectral: true,
            ..PLAIN
        };
        let rear_element = Setup {
            sampling: PupilSampling::RearElement,
            ..spectral.clone()
        };
        let moved = Setup {
            movements: shifted_and_tilted,
            ..spectral.clone()
        };
        let cases = [
            ("dgauss.50mm", spectral),
            ("wide.22mm", rear_element.clone()),
            ("fisheye.10mm", rear_element),
            ("canon-rf-16mm-f2.8", moved),
        ];
        for (name, setup) in cases {
            let lens = TestLens::new(name, setup.clone());
            let table = lens.system.dispersion.as_deref().expect("glass data");
            // The identity pose: the world frame is the camera frame, lens / 1000 with the
            // film at z = 0.
            let camera = LensCamera {
                world_from_camera: glam::Mat4::IDENTITY,
                ..lens.camera()
            };
            let film_z = camera.film_z();
            let (width, height) = (lens.film.width, lens.film.height);
            let pixels: Vec<(u32, u32)> = (0..height)
                .flat_map(|y| (0..width).map(move |x| (x, y)))
                .collect();
            let px: Vec<f32> = pixels.iter().map(|p| p.0 as f32).collect();
            let py: Vec<f32> = pixels.iter().map(|p| p.1 as f32).collect();
            let sampler = lens.pupil.sampler();
            let backward = BackwardTrace {
                surfaces: &lens.system.f32s,
                table,
                film: lens.film.film_map(),
                size: [width, height],
                tilt: FilmTilt::of(&setup.movements),
                sampler: &sampler,
                film_z,
            };
            let (mut passed, mut agree) = (0, 0);
            let mut out = CameraRays::default();
            for sample in 0..6 {
                camera.generate(pixels.iter().copied(), sample, 11, &mut out);
                let mut rays = out.rays.clone();
                for i in 0..rays.len() {
                    rays.ox[i] *= 1e3;
                    rays.oy[i] *= 1e3;
                    rays.oz[i] = rays.oz[i] * 1e3 + film_z;
                }
                let n = rays.len();
                let nm = [out.wavelength.clone(), out.wavelength.clone()].concat();
                let mut coefficient =
                    [out.wavelength_weight.clone(), out.wavelength_weight.clone()].concat();
                let mut weight = out.weight.clone();
                let mut offset = vec![[0i8; 2]; 2 * n];
                let mut position = vec![[0f32; 2]; 2 * n];
                let mut pending = PendingCompanions::default();
                let kept = Combined {
                    coefficient: &mut coefficient,
                    offset: &mut offset,
                    position: &mut position,
                };
                pending.keep(&rays, [&px, &py], &mut weight, kept);
                let hero = HeroRays {
                    pending: &pending,
                    transmission: &rays.tr,
                    nm: &nm,
                };
                let combined = Combined {
                    coefficient: &mut coefficient,
                    offset: &mut offset,
                    position: &mut position,
                };
                let scratch = &mut BackwardScratch::default();
                backward.land_companions(hero, |_| true, combined, scratch);
                for i in (0..n).filter(|&i| out.rays.alive[i]) {
                    passed += 1;
                    // Each technique gets half: W₀ / 2 times the wavelength's 1/p.
                    let half = out.weight[i] * out.wavelength_weight[i] / 2.0;
                    let close = |c: f32| (c / half - 1.0).abs() < 1e-3;
                    // Back on the hero's own film point, to the film filter's grid step.
                    let [hx, hy] = out.film_position[i];
                    let [bx, by] = position[n + i];
                    let home = (bx - hx).abs() <= POSITION_STEP && (by - hy).abs() <= POSITION_STEP;
                    if offset[n + i] == [0, 0]
                        && home
                        && close(coefficient[i])
                        && close(coefficient[n + i])
                    {
                        agree += 1;
                    }
                    assert_eq!(weight[i], 1.0, "{name}: ray {i}");
                }
            }
            assert!(passed >= 50, "{name}: {passed} rays passed");
            // All but rays within rounding of a pixel edge or a pupil-bounds edge.
            assert!(
                agree as f64 >= 0.995 * passed as f64,
                "{name}: {agree} of {passed} rays came back to their film point"
            );
        }
    }

    /// The pipeline lands the companions only of the samples that carry light, once shading
    /// has run. A hero's landing depends on nothing but its own ray, so landing some of them
    /// gives each of those exactly the factors, pixels and film points that landing them all
    /// does, and the samples' weights do not depend on it.
    #[test]
    fn landing_some_companions_gives_them_what_landing_all_does() {
        let spectral = Setup {
            spectral: true,
            ..PLAIN
        };
        for name in ["dgauss.50mm", "fisheye.10mm"] {
            let lens = TestLens::new(name, spectral.clone());
            let camera = LensCamera {
                wavelengths: 3,
                ..lens.camera()
            };
            let (width, height) = (lens.film.width, lens.film.height);
            let pixels: Vec<(u32, u32)> = (0..height)
                .flat_map(|y| (0..width).map(move |x| (x, y)))
                .collect();
            let lit = |i: usize| i % 3 != 1;
            let mut compared = 0;
            for sample in 0..4 {
                let (mut all, mut some) = (CameraRays::default(), CameraRays::default());
                camera.generate(pixels.iter().copied(), sample, 7, &mut all);
                camera.generate_heroes(pixels.iter().copied(), sample, 7, &mut some);
                camera.land_companions(&mut some, lit);
                assert_eq!(all.weight, some.weight, "{name}");
                let n = all.weight.len();
                assert_eq!(all.wavelength.len(), 3 * n);
                for i in (0..n).filter(|&i| lit(i) && all.rays.alive[i]) {
                    for k in 0..3 {
                        let j = k * n + i;
                        let (a, b) = (all.wavelength_weight[j], some.wavelength_weight[j]);
                        assert_eq!(a.to_bits(), b.to_bits(), "{name}: ray {i}, wavelength {k}");
                        assert_eq!(all.wavelength_offset[j], some.wavelength_offset[j]);
                        assert_eq!(all.film_position[j], some.film_position[j]);
                    }
                    // A companion that counts (the comparison above is not of zeros alone).
                    compared += usize::from(all.wavelength_weight[n + i] > 0.0);
                }
            }
            assert!(compared >= 50, "{name}: {compared} companions compared");
        }
    }

    /// The set of wavelengths is the same whichever member is the hero, and each member is
    /// drawn with the sampler's density.
    #[test]
    fn every_member_of_a_set_could_have_been_its_hero() {
        let uniform = |u| WavelengthSet {
            u,
            inverse_density: 1.0,
        };
        for count in [2, 3, 4, 8] {
            for j in 0..97 {
                let u = (j as f32 + 0.37) / 97.0;
                let set: Vec<f32> = (0..count)
                    .map(|k| wavelength_of_set(uniform(u), k, count).nm)
                    .collect();
                for k in 1..count {
                    let other_u = (u + k as f32 / count as f32).fract();
                    let mut other: Vec<f32> = (0..count)
                        .map(|m| wavelength_of_set(uniform(other_u), m, count).nm)
                        .collect();
                    let mut sorted = set.clone();
                    sorted.sort_by(f32::total_cmp);
                    other.sort_by(f32::total_cmp);
                    for (a, b) in sorted.iter().zip(&other) {
                        // f32 rounding of u + k/N, steepest in the far red's thin tail.
                        assert!((a - b).abs() < 0.05, "{count}: {sorted:?} vs {other:?}");
                    }
                }
            }
        }
    }
}
