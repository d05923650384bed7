//! Ghosts: light that reflects twice inside the lens on its way to the film.
//!
//! # The paths
//!
//! Surfaces are numbered from the front (0). A camera ray leaving the film meets the surfaces
//! back to front; a ghost path of the pair (a, b), a < b, refracts through the surfaces behind
//! `a`, **reflects at `a`** back toward the film, refracts through the surfaces between, **reflects
//! at `b`** toward the scene again, and refracts out through the surfaces in front of `b`:
//!
//! ```text
//! film → n−1 … a+1 → (a) → a+1 … b−1 → (b) → b−1 … 0 → scene
//! ```
//!
//! Every surface crossed keeps 1 − R of the light and every reflection R (R = 1 beyond the
//! critical angle), R the coating's reflectance at the ray's angle and wavelength
//! ([`super::reflectance`]); every clear aperture and the stop clip the path as they clip any
//! ray. These are the only two-reflection paths that reach the scene: a path reflects an
//! even number of times to leave the front.
//!
//! # The estimator
//!
//! One camera sample in [`GHOST_EVERY`] (which ones: a random offset per block of 8 × 4 pixels,
//! so each sample is a ghost sample with probability 1/[`GHOST_EVERY`] and a GPU warp's lanes
//! take theirs together) is a ghost sample; the others are the
//! ordinary camera samples, their weight divided by 1 − 1/[`GHOST_EVERY`]. A ghost sample draws
//! its rear-plane point uniformly over the rear element (every ghost path crosses it, where an
//! exit pupil's bounds would miss some), a pair with probability p ∝ its strength (R_a·R_b on the
//! axis at the d line), traces that ghost path, and weighs what it sees by
//! W·T/(p/[`GHOST_EVERY`]), W the camera weight of the rear-element point and T the path's
//! transmission. The sum of both kinds is unbiased for the image made by every path that
//! reflects inside the lens never or twice (an odd number of reflections sends light back out
//! of the rear); paths with four reflections or more (R⁴ ~ 10⁻⁸ coated) are left out.

use num_traits::Float;

use super::ray::{Ray, add, dot, scale};
use super::reflectance::SurfaceReflectance;
use super::system::SurfaceArrays;
use super::trace::refract;

/// One camera sample in this many is a ghost sample.
pub const GHOST_EVERY: u32 = 16;

/// A lens's ghost paths: every pair of surfaces where the index changes, with its strength.
#[derive(Clone, Debug, PartialEq)]
pub struct Ghosts {
    /// (a, b), a < b, front = 0.
    pub pairs: Vec<[usize; 2]>,
    /// R_a·R_b on the axis at the d line, per pair.
    pub strength: Vec<f64>,
    /// The running sum of the pairs' probabilities (∝ strength), ending at 1.
    cumulative: Vec<f32>,
    /// Each pair's steps from the film ([`ghost_steps`]).
    film_steps: Vec<Vec<(usize, Step)>>,
}

impl Ghosts {
    /// The ghost paths of a lens with these `reflectance`s, its indices at the d line from
    /// `index_before` and `index_after` of each surface; `None` when no pair reflects.
    pub fn new(
        reflectance: &SurfaceReflectance,
        index_before: &[f64],
        index_after: &[f64],
        wavelength_nm: f64,
    ) -> Option<Ghosts> {
        let axial: Vec<f64> = (0..index_before.len())
            .map(|i| {
                reflectance.exact(i, index_before[i], index_after[i], 1.0, wavelength_nm, true)
            })
            .collect();
        let mut pairs = Vec::new();
        let mut strength = Vec::new();
        for b in 0..axial.len() {
            for a in 0..b {
                let s = axial[a] * axial[b];
                if s > 0.0 {
                    pairs.push([a, b]);
                    strength.push(s);
                }
            }
        }
        let total: f64 = strength.iter().sum();
        if total.is_nan() || total <= 0.0 {
            return None;
        }
        let mut sum = 0.0;
        let mut cumulative: Vec<f32> = strength
            .iter()
            .map(|s| {
                sum += s / total;
                sum as f32
            })
            .collect();
        if let Some(last) = cumulative.last_mut() {
            *last = 1.0;
        }
        let film_steps = pairs
            .iter()
            .map(|&pair| ghost_steps(axial.len(), pair, false))
            .collect();
        Some(Ghosts {
            pairs,
            strength,
            cumulative,
            film_steps,
        })
    }

    /// The pair chosen by uniform `u` ∈ [0, 1), and the probability it had.
    #[inline(always)]
    pub fn choose(&self, u: f32) -> (usize, f32) {
        let k = self
            .cumulative
            .partition_point(|&c| c <= u)
            .min(self.cumulative.len() - 1);
        let below = if k == 0 { 0.0 } else { self.cumulative[k - 1] };
        (k, self.cumulative[k] - below)
    }

    /// The steps of pair `k`'s path from the film.
    pub fn film_steps(&self, k: usize) -> &[(usize, Step)] {
        &self.film_steps[k]
    }

    /// The running probabilities (what the GPU uploads).
    pub fn cumulative(&self) -> &[f32] {
        &self.cumulative
    }
}

/// What a ghost path does at a surface.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    Refract,
    Reflect,
}

/// The surfaces a ghost path of `pair` meets, in order, and what it does at each: from the film
/// (a camera ray), or with `from_scene` the same path from the scene's side (light coming in).
pub fn ghost_steps(
    surface_count: usize,
    [a, b]: [usize; 2],
    from_scene: bool,
) -> Vec<(usize, Step)> {
    let refract = |i: usize| (i, Step::Refract);
    let mut steps: Vec<(usize, Step)> = (a + 1..surface_count).rev().map(refract).collect();
    steps.push((a, Step::Reflect));
    steps.extend((a + 1..b).map(refract));
    steps.push((b, Step::Reflect));
    steps.extend((0..b).rev().map(refract));
    if from_scene {
        steps.reverse();
    }
    steps
}

/// Traces `ray` (lens frame, mm, unit direction) along `steps`; the media's indices from
/// `index(i)` = (before, after) surface i (front to back), and each surface's reflectance of
/// unpolarised light from `reflectance(i, cosine)`, the cosine of the ray's angle in the less
/// dense of the two media. Returns the ray leaving the last step and the fraction of its light
/// the path passes, or `None` where a clear aperture, the stop, a refraction beyond the
/// critical angle, or a surface missed ends it.
pub fn trace_ghost<T: Float>(
    surfaces: &SurfaceArrays<T>,
    ray: Ray<T>,
    steps: &[(usize, Step)],
    index: impl Fn(usize) -> (T, T),
    reflectance: impl Fn(usize, T) -> T,
) -> Option<(Ray<T>, T)> {
    trace_ghost_path(surfaces, ray, steps, index, reflectance, |_| {})
}

/// As [`trace_ghost`], calling `visit(point)` at every surface the path reaches (for drawing
/// it).
pub fn trace_ghost_path<T: Float>(
    surfaces: &SurfaceArrays<T>,
    mut ray: Ray<T>,
    steps: &[(usize, Step)],
    index: impl Fn(usize) -> (T, T),
    reflectance: impl Fn(usize, T) -> T,
    mut visit: impl FnMut([T; 3]),
) -> Option<(Ray<T>, T)> {
    let to_f64 = |v: T| v.to_f64().unwrap_or(f64::NAN);
    let (zero, one) = (T::zero(), T::one());
    let mut transmission = one;
    for &(i, step) in steps {
        let profile = surfaces.profile(i);
        let vertex_z = surfaces.vertex_z[i];
        let t = profile.intersect(vertex_z, &ray)?;
        let p = add(ray.origin, scale(ray.direction, t));
        visit(p);
        if p[0] * p[0] + p[1] * p[1] > surfaces.semi_aperture_sq[i] {
            return None;
        }
        if let Some(clip) = surfaces.stop_clip.as_deref()
            && clip.surface == i
        {
            let passed = clip.transmission(to_f64(p[0]), to_f64(p[1]));
            if passed.is_nan() || passed <= 0.0 {
                return None;
            }
            transmission = transmission * T::from(passed)?;
        }
        let normal = profile.normal(vertex_z, p)?;
        let toward_film = ray.direction[2] > zero;
        let (before, after) = index(i);
        let (n_in, n_out) = if toward_film {
            (before, after)
        } else {
            (after, before)
        };
        let cos_in = dot(ray.direction, normal).abs();
        let eta = n_in / n_out;
        let sin2_out = eta * eta * (one - cos_in * cos_in);
        let total = sin2_out > one;
        let r = if total {
            one
        } else {
            let cosine = if n_in <= n_out {
                cos_in
            } else {
                (one - sin2_out).sqrt()
            };
            reflectance(i, cosine)
        };
        let (direction, keeps) = match step {
            Step::Reflect => {
                // d − 2(d·n)n: the mirror image of d in the surface's tangent plane.
                let along = dot(ray.direction, normal);
                let mirrored = add(ray.direction, scale(normal, -(along + along)));
                (mirrored, r)
            }
            Step::Refract => (refract(ray.direction, normal, eta)?, one - r),
        };
        let turns = step == Step::Reflect;
        if (direction[2] > zero) != (toward_film != turns) {
            return None;
        }
        transmission = transmission * keeps;
        ray = Ray {
            origin: p,
            direction,
        };
    }
    Some((ray, transmission))
}

/// Where the ghost of a distant point on the axis comes to focus: a ray parallel to the axis at
/// height `height` (mm) traced from the scene along the ghost path (`from_scene` steps), and the
/// lens-frame z where the ray leaving the lens, extended either way, crosses the axis (`None`
/// where the path is blocked or leaves parallel to the axis).
pub fn ghost_focus_z(
    surfaces: &SurfaceArrays<f64>,
    pair: [usize; 2],
    height: f64,
    index: impl Fn(usize) -> (f64, f64),
) -> Option<f64> {
    let steps = ghost_steps(surfaces.len(), pair, true);
    let start = surfaces.vertex_z.first().copied().unwrap_or(0.0) - 1.0;
    let ray = Ray {
        origin: [height, 0.0, start],
        direction: [0.0, 0.0, 1.0],
    };
    let (out, _) = trace_ghost(surfaces, ray, &steps, index, |_, _| 0.0)?;
    if out.direction[0].abs() < 1e-15 {
        return None;
    }
    let t = -out.origin[0] / out.direction[0];
    Some(out.origin[2] + t * out.direction[2])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::coating::{CoatingModel, fresnel};
    use crate::lens::{LensSystem, SurfaceRow};

    /// A plate of n = 1.5, 5 mm thick, in air.
    fn plate() -> (LensSystem, f64, f64) {
        let rows = [
            SurfaceRow::new(f64::INFINITY, 5.0, 1.5, 40.0),
            SurfaceRow::new(f64::INFINITY, 0.0, 1.0, 40.0),
        ];
        (LensSystem::new(&rows, None), 1.5, 5.0)
    }

    #[test]
    fn the_steps_reflect_at_the_pair_and_refract_elsewhere() {
        use Step::{Reflect as L, Refract as R};
        assert_eq!(
            ghost_steps(4, [1, 2], false),
            vec![(3, R), (2, R), (1, L), (2, L), (1, R), (0, R)]
        );
        assert_eq!(
            ghost_steps(3, [0, 2], true),
            vec![(0, R), (1, R), (2, L), (1, R), (0, L), (1, R), (2, R)]
        );
    }

    /// A plate's ghost: the ray leaves parallel to the light that made it, shifted across it by
    /// the double pass, 2·t·tan θ_t·cos θ (θ in air, θ_t in the glass), carrying
    /// (1 − R₁)·R₂·R₁·(1 − R₂) of it with Fresnel's R at those angles.
    #[test]
    fn a_plates_ghost_is_shifted_by_the_double_pass_and_carries_r1_r2() {
        let (system, n, thickness) = plate();
        for degrees in [0.0f64, 10.0, 25.0, 40.0] {
            let theta = degrees.to_radians();
            let theta_t = (theta.sin() / n).asin();
            let d = [theta.sin(), 0.0, theta.cos()];
            let ray = Ray {
                origin: [-3.0 * d[0], 0.0, -3.0 * d[2]],
                direction: d,
            };
            let steps = ghost_steps(2, [0, 1], true);
            let index = |i: usize| if i == 0 { (1.0, n) } else { (n, 1.0) };
            // The reflectance's coordinate is the cosine in air; a surface reflects the same
            // from either side.
            let exact = |_: usize, cosine: f64| fresnel(1.0, n, cosine).unpolarised();
            let (out, t) = trace_ghost(&system.f64s, ray, &steps, index, exact).unwrap();
            for (got, want) in out.direction.iter().zip(d) {
                assert!((got - want).abs() < 1e-12, "{degrees}°");
            }
            // Across the beam: the offset of the exit point from the main ray's line.
            let main = trace_ghost(
                &system.f64s,
                ray,
                &[(0, Step::Refract), (1, Step::Refract)],
                index,
                exact,
            )
            .unwrap()
            .0;
            let gap = add(out.origin, scale(main.origin, -1.0));
            let across = (gap[0] * d[2] - gap[2] * d[0]).abs();
            let expected = 2.0 * thickness * theta_t.tan() * theta.cos();
            assert!(
                (across - expected).abs() < 1e-9,
                "{degrees}°: {across} vs {expected}"
            );
            let r = fresnel(1.0, n, theta.cos()).unpolarised();
            let expected_t = (1.0 - r) * r * r * (1.0 - r);
            assert!(
                (t - expected_t).abs() < 1e-12,
                "{degrees}°: {t} vs {expected_t}"
            );
        }
    }

    /// The pairs of dgauss.50mm's ten index changes: C(10, 2) = 45, each as strong as the
    /// product of its surfaces' normal-incidence reflectances; chosen in proportion to it.
    #[test]
    fn a_lens_has_a_ghost_per_pair_of_reflecting_surfaces_chosen_by_strength() {
        let p = crate::lens::io::bundled::load_lens("dgauss.50mm", None).unwrap();
        let table = SurfaceReflectance::with_model(&p.rows, |_| None, CoatingModel::None).unwrap();
        let before: Vec<f64> = (0..p.rows.len())
            .map(|i| {
                if i == 0 {
                    1.0
                } else {
                    p.rows[i - 1].base.index
                }
            })
            .collect();
        let after: Vec<f64> = p.rows.iter().map(|r| r.base.index).collect();
        let ghosts = Ghosts::new(&table, &before, &after, 587.5618).unwrap();
        assert_eq!(ghosts.pairs.len(), 45);
        for (pair, s) in ghosts.pairs.iter().zip(&ghosts.strength) {
            let r = |i: usize| ((after[i] - before[i]) / (after[i] + before[i])).powi(2);
            let expected = r(pair[0]) * r(pair[1]);
            assert!((s - expected).abs() < 1e-6 * expected, "{pair:?}");
        }
        let total: f64 = ghosts.strength.iter().sum();
        let mut counts = vec![0usize; 45];
        let draws = 200_000;
        for k in 0..draws {
            let (pair, probability) = ghosts.choose((k as f32 + 0.5) / draws as f32);
            assert!((probability as f64 - ghosts.strength[pair] / total).abs() < 1e-5);
            counts[pair] += 1;
        }
        for (count, s) in counts.iter().zip(&ghosts.strength) {
            let expected = s / total * draws as f64;
            assert!((*count as f64 - expected).abs() <= 1.0 + 1e-3 * expected);
        }
    }

    /// The ghost samples' mean against brute force: light leaving one pixel of dgauss.50mm
    /// (bare glass, so the ghosts are strong) into a uniform sky, the brute force reflecting at
    /// every surface at random with Fresnel's probability R (else refracting) and counting the
    /// paths that reach the scene after exactly two reflections, each with its camera weight
    /// cos⁴θ·A/z² for a point drawn uniformly over the pixel and the rear element. Both
    /// estimate the same integral; they agree within their noise.
    #[test]
    fn ghost_samples_agree_with_random_reflection_at_every_surface() {
        use crate::lens::camera::{
            CameraRays, LensCamera, camera_seed, ghost_block_key, is_ghost_sample,
        };
        use crate::lens::pupil::concentric_disk;
        use crate::lens::test_lens::{PLAIN, TestLens};
        use crate::sampling::Rng;

        let lens = TestLens::new("dgauss.50mm", PLAIN);
        let bare = SurfaceReflectance::with_model(&lens.system.rows, |_| None, CoatingModel::None);
        let system = lens.system.clone().with_reflectance(bare);
        let camera = LensCamera {
            system: &system,
            pupil: &lens.pupil,
            world_from_camera: glam::Mat4::IDENTITY,
            ghosts: system.ghosts.as_deref(),
            ..lens.camera()
        };
        let (x, y, seed) = (7u32, 5u32, 11u64);
        let keys = lens.film.pixel_keys();
        let key = ghost_block_key(keys.key(x, y), keys.width as u32, camera_seed(seed));
        let samples = 1u32 << 17;
        let mut out = CameraRays::default();
        let (mut sum, mut sum_sq) = (0.0f64, 0.0f64);
        for sample in 0..samples {
            camera.generate([(x, y)], sample, seed, &mut out);
            if is_ghost_sample(key, sample) && out.rays.alive[0] {
                let w = out.weight[0] as f64;
                sum += w;
                sum_sq += w * w;
            }
        }
        let n = samples as f64;
        let ours = sum / n;
        let ours_variance = (sum_sq / n - ours * ours) / n;

        // Brute force, f64, with its own path logic.
        let f64s = &system.f64s;
        let count = f64s.len();
        let film_distance = lens.pupil.film_distance;
        let film_z = system.rear_z() + film_distance;
        let radius = system.rear_semi_aperture();
        let area = std::f64::consts::PI * radius * radius;
        let map = lens.film.film_map();
        let mut rng = Rng::new(5, 9);
        let paths = 1_500_000;
        let (mut sum, mut sum_sq) = (0.0f64, 0.0f64);
        for _ in 0..paths {
            let [fx, fy] = map.apply(x as f32, y as f32, rng.next_f32(), rng.next_f32());
            let [u, v] = concentric_disk([rng.next_f32(), rng.next_f32()]);
            let (fx, fy) = (fx as f64, fy as f64);
            let to = [
                u as f64 * radius - fx,
                v as f64 * radius - fy,
                -film_distance,
            ];
            let length = (to[0] * to[0] + to[1] * to[1] + to[2] * to[2]).sqrt();
            let cos = film_distance / length;
            let weight = cos.powi(4) * area / (film_distance * film_distance);
            let mut ray = Ray {
                origin: [fx, fy, film_z],
                direction: to.map(|c| c / length),
            };
            let (mut next, mut reflections) = (count - 1, 0);
            let reached_scene = loop {
                let profile = f64s.profile(next);
                let Some(t) = profile.intersect(f64s.vertex_z[next], &ray) else {
                    break false;
                };
                let p = add(ray.origin, scale(ray.direction, t));
                if p[0] * p[0] + p[1] * p[1] > f64s.semi_aperture_sq[next] {
                    break false;
                }
                let Some(normal) = profile.normal(f64s.vertex_z[next], p) else {
                    break false;
                };
                let toward_scene = ray.direction[2] < 0.0;
                let (n_in, n_out) = if toward_scene {
                    (f64s.index_back[next], f64s.index_front[next])
                } else {
                    (f64s.index_front[next], f64s.index_back[next])
                };
                let along = dot(ray.direction, normal);
                let refracted = refract(ray.direction, normal, n_in / n_out);
                let r = fresnel(n_in, n_out, along.abs()).unpolarised();
                let direction = match refracted {
                    Some(d) if rng.next_f64() >= r => d,
                    _ => {
                        reflections += 1;
                        add(ray.direction, scale(normal, -2.0 * along))
                    }
                };
                if reflections > 2 {
                    break false;
                }
                ray = Ray {
                    origin: p,
                    direction,
                };
                if direction[2] < 0.0 {
                    if next == 0 {
                        break true;
                    }
                    next -= 1;
                } else {
                    if next == count - 1 {
                        break false;
                    }
                    next += 1;
                }
            };
            if reached_scene && reflections == 2 {
                sum += weight;
                sum_sq += weight * weight;
            }
        }
        let n = paths as f64;
        let brute = sum / n;
        let brute_variance = (sum_sq / n - brute * brute) / n;
        let z = (ours - brute) / (ours_variance + brute_variance).sqrt();
        eprintln!(
            "ghosts: ours {ours:.4e} ± {:.1e}, brute force {brute:.4e} ± {:.1e}, z = {z:.2}",
            ours_variance.sqrt(),
            brute_variance.sqrt()
        );
        assert!(
            brute > 0.0 && z.abs() < 4.0,
            "ours {ours} vs brute force {brute}: z = {z:.2}"
        );
    }
}
