//! Focusing: placing the film so that an object plane at a given distance is sharp.
//!
//! The focus distance is measured from the film plane to the object plane (metres at the
//! API, mm here), as in pbrt. Writing L = focus distance − rear-vertex z, an object at distance
//! s in front of the front vertex images at v = L − s behind the rear vertex when
//! T(v)·M·T(s) has no B term (M = [[A, B], [C, D]] the front-to-rear system matrix), i.e.
//!
//! C·v² − (C·L + D − A)·v − (A·L + B) = 0.
//!
//! Its discriminant simplifies (det M = 1) to (C·L + A + D)² − 4, so a real solution needs
//! L ≥ EFL·(2 + A + D): the thick-lens form of the "4f" closest conjugate distance.

use super::first_order::{FirstOrder, Transfer};
use super::system::LensSystem;
use super::trace::{Ray, Travel, normalize, trace};

/// How the film distance is chosen for a focus distance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum FocusMode {
    /// The paraxial image of the on-axis object point lies on the film (pbrt's answer).
    #[default]
    Paraxial,
    /// The film distance that minimises the RMS spot radius of the on-axis object point with
    /// real rays through the current stop (differs from paraxial under spherical aberration).
    Best,
}

impl FocusMode {
    /// The mode as `--focus-mode` names it.
    pub fn name(self) -> &'static str {
        match self {
            FocusMode::Paraxial => "paraxial",
            FocusMode::Best => "best",
        }
    }
}

impl std::str::FromStr for FocusMode {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "paraxial" => Ok(FocusMode::Paraxial),
            "best" => Ok(FocusMode::Best),
            other => Err(format!(
                "unknown focus mode '{other}': use paraxial or best"
            )),
        }
    }
}

#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FocusError {
    #[error(
        "cannot focus at {requested_m:.4} m: the closest this lens can focus is {closest_m:.4} m (film plane to object)"
    )]
    TooClose { requested_m: f64, closest_m: f64 },
    #[error("focus distance {0} m is not a positive number (or inf)")]
    Invalid(f64),
    #[error("no real rays from the on-axis object point pass the lens; cannot find the best focus")]
    NoRays,
}

/// Focus distances at or beyond this (mm; 10⁶ km) are treated as infinity focus.
pub const INFINITY_FOCUS_MM: f64 = 1e12;

/// Closest focus distance (film plane → object), mm.
pub fn closest_focus_mm(system: &LensSystem, first_order: &FirstOrder) -> f64 {
    let m = first_order.system;
    first_order.focal_length * (2.0 + m.a + m.d) + system.rear_z()
}

/// Film distance (rear vertex → film, mm) that puts the paraxial image of the on-axis point at
/// `focus_distance_mm` from the film exactly on the film.
pub fn paraxial_film_distance(
    system: &LensSystem,
    first_order: &FirstOrder,
    focus_distance_mm: f64,
) -> Result<f64, FocusError> {
    if focus_distance_mm.is_nan() || focus_distance_mm <= 0.0 {
        return Err(FocusError::Invalid(focus_distance_mm / 1000.0));
    }
    // Beyond a million kilometres every lens is focused at infinity to far better than f64's
    // precision in the film distance; clamping there lets `inf` mean infinity focus and keeps
    // (C·L)² below overflow for any requested distance.
    let focus_distance_mm = focus_distance_mm.min(INFINITY_FOCUS_MM);
    let too_close = || FocusError::TooClose {
        requested_m: focus_distance_mm / 1000.0,
        closest_m: closest_focus_mm(system, first_order) / 1000.0,
    };
    let Transfer { a, b, c, d } = first_order.system;
    let l = focus_distance_mm - system.rear_z();
    let k = c * l + d - a;
    let discriminant = (c * l + a + d).powi(2) - 4.0;
    if discriminant < 0.0 {
        return Err(too_close());
    }
    // C < 0 for a converging lens (FirstOrder refuses others), so K − √Δ adds two negatives:
    // that root (v ≈ L, object at the lens) has no cancellation. The one we want, which tends
    // to the back focal length as L → ∞, follows from the product of the roots −(A·L + B)/C.
    let far = (k - discriminant.sqrt()) / (2.0 * c);
    let near = -(a * l + b) / c / far;
    let v = near.min(far);
    if !(v > 0.0 && l - v > 0.0) {
        return Err(too_close());
    }
    Ok(v)
}

/// The focus distance (film plane → in-focus object plane, mm) of a film `film_distance` behind
/// the rear vertex: the paraxial conjugate (∞ when the film is at or inside the back focal
/// point, where the object would be at or beyond infinity).
pub fn paraxial_focus_distance(
    system: &LensSystem,
    first_order: &FirstOrder,
    film_distance: f64,
) -> f64 {
    // T(v)·M·T(s) images when its B term vanishes: A·s + B + v·(C·s + D) = 0.
    let Transfer { a, b, c, d } = first_order.system;
    let v = film_distance;
    let denominator = a + v * c;
    let s = -(b + v * d) / denominator;
    if !(s.is_finite() && s > 0.0) {
        return f64::INFINITY;
    }
    v + system.rear_z() + s
}

/// Film distance minimising the RMS radius of the real-ray spot of the on-axis point at
/// `focus_distance_mm`, starting from `initial` (the paraxial answer).
///
/// For fixed object position the exiting rays are lines x(z) = x₀ + s·z, so the mean square
/// radius is a quadratic in z with its minimum at z* = −Σ x₀·s / Σ s². Moving the film moves
/// the object (the focus distance is measured from the film), so a few fixed-point rounds
/// settle both.
pub fn best_film_distance(
    system: &LensSystem,
    focus_distance_mm: f64,
    initial: f64,
) -> Result<f64, FocusError> {
    const GRID: usize = 96;
    const ROUNDS: usize = 6;
    let mut film = initial;
    for _ in 0..ROUNDS {
        let object_z = system.rear_z() + film - focus_distance_mm;
        let origin = [0.0, 0.0, object_z];
        let (mut sum_x0s, mut sum_ss, mut count) = (0.0, 0.0, 0usize);
        for [x, y] in front_aim_points(system, GRID) {
            let direction = normalize([x, y, -object_z]);
            let Ok(out) = trace(&system.f64s, Ray { origin, direction }, Travel::SceneToFilm)
            else {
                continue;
            };
            let [px, py, pz] = out.origin;
            let [dx, dy, dz] = out.direction;
            for (p, slope) in [(px, dx / dz), (py, dy / dz)] {
                let x0 = p - slope * pz;
                sum_x0s += x0 * slope;
                sum_ss += slope * slope;
            }
            count += 1;
        }
        if count == 0 || sum_ss == 0.0 {
            return Err(FocusError::NoRays);
        }
        film = -sum_x0s / sum_ss - system.rear_z();
    }
    Ok(film)
}

/// RMS spot radius (mm) of the on-axis point at `focus_distance_mm` on a film at
/// `film_distance`, from real rays: how sharp the focused image is.
pub fn rms_spot_radius(
    system: &LensSystem,
    focus_distance_mm: f64,
    film_distance: f64,
) -> Option<f64> {
    const GRID: usize = 64;
    let aim = system.front_semi_aperture();
    let film_z = system.rear_z() + film_distance;
    let object_z = film_z - focus_distance_mm;
    let (mut sum, mut count) = (0.0, 0usize);
    for iy in 0..GRID {
        for ix in 0..GRID {
            let x = aim * ((ix as f64 + 0.5) / GRID as f64 * 2.0 - 1.0);
            let y = aim * ((iy as f64 + 0.5) / GRID as f64 * 2.0 - 1.0);
            let direction = normalize([x, y, -object_z]);
            let Ok(out) = trace(
                &system.f64s,
                Ray {
                    origin: [0.0, 0.0, object_z],
                    direction,
                },
                Travel::SceneToFilm,
            ) else {
                continue;
            };
            let t = (film_z - out.origin[2]) / out.direction[2];
            let fx = out.origin[0] + t * out.direction[0];
            let fy = out.origin[1] + t * out.direction[1];
            sum += fx * fx + fy * fy;
            count += 1;
        }
    }
    (count > 0).then(|| (sum / count as f64).sqrt())
}

/// Lens-frame z of the plane (across the axis) on which the real-ray image of the object
/// point `object` (lens frame, mm, in front of the lens) is smallest: rays from the point
/// through a grid over the front element, and the z minimising their RMS distance from the
/// spot's centroid. Off axis the image is not on the axis, so the spread is measured about
/// the centroid: with x_i(z) = x₀ᵢ + sᵢ·z and δ the deviation from the mean over rays, the
/// mean square spread is a quadratic in z with its minimum at z* = −Σ δx₀·δs / Σ δs².
/// `None` when fewer than three rays pass.
pub fn sharpest_image_z(system: &LensSystem, object: [f64; 3]) -> Option<f64> {
    const GRID: usize = 96;
    let mut lines: Vec<[f64; 4]> = Vec::new();
    for [x, y] in front_aim_points(system, GRID) {
        let direction = normalize([x - object[0], y - object[1], -object[2]]);
        let ray = Ray {
            origin: object,
            direction,
        };
        let Ok(out) = trace(&system.f64s, ray, Travel::SceneToFilm) else {
            continue;
        };
        let [px, py, pz] = out.origin;
        let [dx, dy, dz] = out.direction;
        let (sx, sy) = (dx / dz, dy / dz);
        lines.push([px - sx * pz, sx, py - sy * pz, sy]);
    }
    if lines.len() < 3 {
        return None;
    }
    let n = lines.len() as f64;
    let mean = lines.iter().fold([0.0; 4], |mut m, l| {
        for k in 0..4 {
            m[k] += l[k] / n;
        }
        m
    });
    let (mut cross, mut slopes) = (0.0, 0.0);
    for l in &lines {
        for axis in [0, 2] {
            let (x0, s) = (l[axis] - mean[axis], l[axis + 1] - mean[axis + 1]);
            cross += x0 * s;
            slopes += s * s;
        }
    }
    (slopes > 0.0).then(|| -cross / slopes)
}

/// Where the focus solvers aim their real rays: the centres of a `grid` × `grid` lattice over
/// the front element's clear aperture, those inside its circle, row by row.
fn front_aim_points(system: &LensSystem, grid: usize) -> impl Iterator<Item = [f64; 2]> {
    let aim = system.front_semi_aperture();
    let coordinate = move |k: usize| aim * ((k as f64 + 0.5) / grid as f64 * 2.0 - 1.0);
    (0..grid)
        .flat_map(move |iy| (0..grid).map(move |ix| [coordinate(ix), coordinate(iy)]))
        .filter(move |[x, y]| x * x + y * y <= aim * aim)
}
