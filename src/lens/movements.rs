//! View-camera movements of the film: shift and tilt of the frame behind a fixed lens.
//!
//! **Shift** `(X, Y)` mm moves the frame across the image circle, in the film plane: positive
//! Y shows more of the scene above, positive X more to the right, as a shift lens raised or
//! moved right does. The lens inverts the image, so the frame's centre is the lens-frame film
//! point (−X, −Y).
//!
//! **Tilt** `(X, Y)` degrees rotates the film plane about the frame centre: right-handed
//! rotations of the lens frame (+z toward the film) by X about +x, then by Y about +y. Positive
//! X moves the bottom of the picture (film +y) away from the lens, so the bottom focuses nearer
//! and the plane of sharp focus tips down toward the ground ahead; positive Y moves the
//! picture's right (film −x) away, so the right focuses nearer. The plane of sharp focus then
//! follows Scheimpflug's rule: it is the lens's image of the tilted film plane, and meets the
//! film plane's extension where that crosses the lens (the hinge rule).
//!
//! Film-plane coordinates (a, b) are measured in the film's own plane from the frame centre,
//! along the lens frame's x and y before the rotation; a pixel's area is the same on a tilted
//! film, and the camera weight takes its cosine against the tilted normal (see
//! [`crate::lens::pupil`]).

use bevy_ecs::component::Component;

use super::system::LensSystem;
use super::trace::Travel;
use super::trace_batch::trace_batch;
use crate::batch::RayBatch;

/// Tilts at or beyond this (degrees) turn the film nearly edge-on to the lens: refused.
pub const MAX_TILT_DEG: f64 = 60.0;
/// Largest shift, mm, either way: the widest image circles of large-format lenses are some
/// 500 mm across, so a frame shifted further than this lies in the dark behind any lens.
pub const MAX_SHIFT_MM: f64 = 1000.0;

/// Shift and tilt of the film behind a lens: a component of the lens entity (absent = none).
#[derive(Component, Clone, Copy, Debug, PartialEq, Default)]
pub struct FilmMovements {
    /// Frame shift in the film plane, mm (see the module docs for the signs).
    pub shift_mm: [f64; 2],
    /// Film tilt about the frame centre's horizontal (X) and vertical (Y) axes, degrees.
    pub tilt_deg: [f64; 2],
}

/// How far a moved film reaches: what the exit-pupil bounds must cover.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilmReach {
    /// Largest distance of a film point from the axis, mm.
    pub radius: f64,
    /// Range of film points' z relative to the frame centre's, mm (0, 0 untilted).
    pub dz: [f64; 2],
}

impl FilmMovements {
    pub const NONE: FilmMovements = FilmMovements {
        shift_mm: [0.0; 2],
        tilt_deg: [0.0; 2],
    };

    pub fn is_none(&self) -> bool {
        *self == FilmMovements::NONE
    }

    pub fn is_tilted(&self) -> bool {
        self.tilt_deg != [0.0; 2]
    }

    /// Checks the values themselves (what the lens can cover is checked by
    /// [`check_coverage`]).
    pub fn validate(&self) -> Result<(), String> {
        if !self
            .shift_mm
            .iter()
            .all(|v| v.is_finite() && v.abs() <= MAX_SHIFT_MM)
        {
            // `{:e}` for a huge value: `{}` would spell out all its 300 digits.
            let shown = |v: f64| {
                if v.abs() < 1e9 {
                    format!("{v}")
                } else {
                    format!("{v:e}")
                }
            };
            return Err(format!(
                "shift {},{} mm: each component must be a number of mm between −{MAX_SHIFT_MM} and {MAX_SHIFT_MM} (further, the frame lies outside any lens's image circle)",
                shown(self.shift_mm[0]),
                shown(self.shift_mm[1])
            ));
        }
        if !self
            .tilt_deg
            .iter()
            .all(|v| v.is_finite() && v.abs() < MAX_TILT_DEG)
        {
            return Err(format!(
                "tilt {},{}°: each component must be a number of degrees between −{MAX_TILT_DEG} and {MAX_TILT_DEG} (beyond, the film turns edge-on to the lens)",
                self.tilt_deg[0], self.tilt_deg[1]
            ));
        }
        Ok(())
    }

    /// Lens-frame (x, y) of the frame centre, mm.
    pub fn frame_centre(&self) -> [f64; 2] {
        [-self.shift_mm[0], -self.shift_mm[1]]
    }

    /// The rotation R = Ry(tilt Y)·Rx(tilt X) as rows.
    fn rotation(&self) -> [[f64; 3]; 3] {
        let [tx, ty] = self.tilt_deg.map(f64::to_radians);
        let (sx, cx) = tx.sin_cos();
        let (sy, cy) = ty.sin_cos();
        [
            [cy, sx * sy, cx * sy],
            [0.0, cx, -sx],
            [-sy, sx * cy, cx * cy],
        ]
    }

    /// Lens-frame offset (x, y, z) from the frame centre of the film point at film-plane
    /// coordinates (`a`, `b`): R·(a, b, 0).
    pub fn film_offset(&self, a: f64, b: f64) -> [f64; 3] {
        let r = self.rotation();
        [
            r[0][0] * a + r[0][1] * b,
            r[1][0] * a + r[1][1] * b,
            r[2][0] * a + r[2][1] * b,
        ]
    }

    /// Unit normal of the film plane, lens frame (R·ẑ: +z untilted).
    pub fn film_normal(&self) -> [f64; 3] {
        let r = self.rotation();
        [r[0][2], r[1][2], r[2][2]]
    }

    /// How far a film of diagonal `film_diagonal` (mm) reaches when moved: its frame, whatever
    /// its aspect, lies within the film-plane disc of half the diagonal about the frame centre.
    pub fn reach(&self, film_diagonal: f64) -> FilmReach {
        let half = film_diagonal / 2.0;
        let [cx, cy] = self.frame_centre();
        let r = self.rotation();
        // Over the disc, |R·(a, b, 0)|'s z is at most half · |(R₂₀, R₂₁)|; x and y stay within
        // half of the centre (rotation shortens them).
        let dz = half * r[2][0].hypot(r[2][1]);
        FilmReach {
            radius: cx.hypot(cy) + half,
            dz: [-dz, dz],
        }
    }

    /// Lens-frame film point (x, y, z) of film-plane coordinates (`a`, `b`) from the frame
    /// centre, on a film whose frame centre is at `film_z`.
    pub fn film_point(&self, a: f64, b: f64, film_z: f64) -> [f64; 3] {
        let [cx, cy] = self.frame_centre();
        let [x, y, z] = self.film_offset(a, b);
        [cx + x, cy + y, film_z + z]
    }
}

/// The rear-vertex-plane points (x, y, mm) of a grid toward the rear element (and pbrt's
/// margin beyond it) whose rays from the lens-frame film point `point` pass the whole lens,
/// traced in one batch.
pub fn passing_rear_points(system: &LensSystem, point: [f64; 3]) -> Vec<[f64; 2]> {
    const GRID: usize = 96;
    let half = 1.5 * system.rear_semi_aperture();
    let rear_z = system.rear_z();
    let cell = |i: usize| -half + (i as f64 + 0.5) / GRID as f64 * 2.0 * half;
    let mut batch = RayBatch::with_capacity(GRID * GRID);
    for iy in 0..GRID {
        for ix in 0..GRID {
            let d = [cell(ix) - point[0], cell(iy) - point[1], rear_z - point[2]];
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            batch.push(point.map(|v| v as f32), d.map(|v| (v / len) as f32), 0, 0);
        }
    }
    trace_batch(&system.f32s, &mut batch, Travel::FilmToScene);
    batch
        .alive
        .iter()
        .enumerate()
        .filter(|(_, alive)| **alive)
        .map(|(i, _)| [cell(i % GRID), cell(i / GRID)])
        .collect()
}

/// Whether any ray from the lens-frame film point `point` passes the whole lens.
pub fn light_reaches(system: &LensSystem, point: [f64; 3]) -> bool {
    !passing_rear_points(system, point).is_empty()
}

/// Film-plane points per side of the frame at which [`check_coverage`] measures what a tilt
/// loses (cell centres, so 1/256 of the frame each).
const COVERAGE_GRID: usize = 16;

/// The share of the whole frame a tilt may darken (points where the same film untilted has
/// light and the tilted one has none) before it is refused. Below it the tilt only moves the edge of the image circle a little (a
/// hundredth of a degree on a film larger than the image circle moves it by a grid point or
/// two), and the dark corners are a warning as they are untilted.
pub const MAX_TILT_LOSS: f64 = 0.02;

/// Whether the lens covers a moved (or unmoved) frame of `width_mm` × `height_mm` with its
/// frame centre `film_distance` behind the rear vertex.
///
/// A tilt is judged by what it loses: it is an error when the tilted film would reach into
/// the lens, or when it darkens more than [`MAX_TILT_LOSS`] of the frame where the same film
/// untilted (shift kept) has light. Otherwise corners outside the image circle are a warning,
/// the same tilted or not: a frame larger than the image circle, or shifted out of it, renders
/// with those corners black (the user's call).
pub fn check_coverage(
    system: &LensSystem,
    film_distance: f64,
    movements: &FilmMovements,
    width_mm: f64,
    height_mm: f64,
) -> Result<Option<String>, String> {
    let film_z = system.rear_z() + film_distance;
    let (w, h) = (width_mm / 2.0, height_mm / 2.0);
    let corners = [[-w, -h], [w, -h], [-w, h], [w, h]];
    let points = corners.map(|[a, b]| movements.film_point(a, b, film_z));
    let [tx, ty] = movements.tilt_deg;
    if let Some(p) = points.iter().find(|p| p[2] <= system.rear_z()) {
        return Err(format!(
            "tilt {tx},{ty}°: the tilted film's corner at ({:.1}, {:.1}) mm would reach {:.2} mm in front of the rear vertex, into the lens; use a smaller tilt",
            p[0],
            p[1],
            system.rear_z() - p[2]
        ));
    }
    // Corners as the picture shows them: the lens inverts, film −x, −y is the top right.
    let names = ["top right", "top left", "bottom right", "bottom left"];
    let dark: Vec<&str> = points
        .iter()
        .zip(names)
        .filter(|(p, _)| !light_reaches(system, **p))
        .map(|(_, name)| name)
        .collect();
    let [sx, sy] = movements.shift_mm;
    let corner_list = |dark: &[&str]| {
        format!(
            "{} corner{}",
            dark.join(", "),
            if dark.len() == 1 { "" } else { "s" }
        )
    };
    // A tilted frame whose corners all have light has it everywhere (the image circle is
    // round about the axis and the corners lie farthest out), so only a dark corner is measured.
    if movements.is_tilted() && !dark.is_empty() {
        let lost = tilt_loss(system, film_z, movements, w, h);
        if lost > MAX_TILT_LOSS {
            return Err(format!(
                "tilt {tx},{ty}° (shift {sx},{sy} mm) is beyond what this lens can cover: it darkens {:.1} % of the frame where the untilted film has light (no light reaches its {}); use a smaller tilt or shift",
                lost * 100.0,
                corner_list(&dark)
            ));
        }
    }
    if dark.is_empty() {
        return Ok(None);
    }
    let cause = if movements.shift_mm == [0.0; 2] {
        format!(
            "the {width_mm:.1} × {height_mm:.1} mm film is larger than the lens covers: it puts"
        )
    } else {
        format!("shift {sx},{sy} mm moves")
    };
    Ok(Some(format!(
        "{cause} the frame's {} out of the lens's image circle: {} black",
        corner_list(&dark),
        if dark.len() == 1 {
            "it will be"
        } else {
            "they will be"
        }
    )))
}

/// The share of a `2w` × `2h` mm frame (its centre at `film_z`) that has light with the film
/// untilted but none with the tilt of `movements`, point for point in the film plane; the
/// shift is the same in both.
fn tilt_loss(system: &LensSystem, film_z: f64, movements: &FilmMovements, w: f64, h: f64) -> f64 {
    let untilted = FilmMovements {
        tilt_deg: [0.0; 2],
        ..*movements
    };
    let cell = |i: usize, half: f64| -half + (i as f64 + 0.5) / COVERAGE_GRID as f64 * 2.0 * half;
    let lost = (0..COVERAGE_GRID * COVERAGE_GRID)
        .map(|i| (cell(i % COVERAGE_GRID, w), cell(i / COVERAGE_GRID, h)))
        .filter(|&(a, b)| {
            light_reaches(system, untilted.film_point(a, b, film_z))
                && !light_reaches(system, movements.film_point(a, b, film_z))
        })
        .count();
    lost as f64 / (COVERAGE_GRID * COVERAGE_GRID) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-12)
    }

    #[test]
    fn tilts_rotate_about_the_frame_axes_with_the_stated_signs() {
        let down = FilmMovements {
            tilt_deg: [30.0, 0.0],
            ..FilmMovements::NONE
        };
        // Film +y (the picture's bottom) moves away from the lens (+z).
        let p = down.film_offset(0.0, 1.0);
        assert!(close(p, [0.0, 3f64.sqrt() / 2.0, 0.5]));
        assert!(close(down.film_offset(1.0, 0.0), [1.0, 0.0, 0.0]));
        let right = FilmMovements {
            tilt_deg: [0.0, 30.0],
            ..FilmMovements::NONE
        };
        // Film −x (the picture's right) moves away from the lens.
        let p = right.film_offset(-1.0, 0.0);
        assert!(close(p, [-(3f64.sqrt()) / 2.0, 0.0, 0.5]));
        // The normal is perpendicular to both film axes.
        let both = FilmMovements {
            tilt_deg: [12.0, -7.0],
            shift_mm: [3.0, 1.0],
        };
        let n = both.film_normal();
        for axis in [both.film_offset(1.0, 0.0), both.film_offset(0.0, 1.0)] {
            let dot: f64 = axis.iter().zip(&n).map(|(a, b)| a * b).sum();
            assert!(dot.abs() < 1e-12);
        }
        assert_eq!(both.frame_centre(), [-3.0, -1.0]);
    }

    #[test]
    fn reach_bounds_every_frame_point() {
        let m = FilmMovements {
            tilt_deg: [10.0, 20.0],
            shift_mm: [-4.0, 6.0],
        };
        let reach = m.reach(43.3);
        for k in 0..360 {
            let angle = (k as f64).to_radians();
            let (a, b) = (21.65 * angle.cos(), 21.65 * angle.sin());
            let p = m.film_point(a, b, 0.0);
            assert!(p[0].hypot(p[1]) <= reach.radius + 1e-9);
            assert!(p[2] >= reach.dz[0] - 1e-9 && p[2] <= reach.dz[1] + 1e-9);
        }
    }
}
