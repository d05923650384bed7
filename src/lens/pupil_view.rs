//! The exit pupil seen from film points: which part of the rear element's plane passes light.
//!
//! From a film point, every point of the rear-vertex plane is tried: the ray from the film
//! point toward it is traced through the whole lens (blades and mask included), and the view
//! shows the light each passes (white = all, black = none). On axis that is the round (or
//! bladed) stop's image; toward the corner the other elements' rims cut it into a cat's eye.
//! The light under a view is the camera's measurement integral ∫ T cos⁴θ / z² dA over that
//! plane (T: the mask's transmission, θ: the ray's angle to the axis, z: film distance): what
//! a film point there receives from a uniform scene, given here as a fraction of the centre's.
//!
//! Views look from the film toward the scene: +x (lens frame) right, +y up. Film points run
//! from the centre toward the image's top-right corner of a 3:2 frame (lens-frame direction
//! −(3, 2), the lens inverting the image).

use image::{Rgb, RgbImage};

use super::pupil::ExitPupil;
use super::system::LensSystem;
use super::trace::Travel;
use super::trace_batch::trace_batch;
use crate::batch::RayBatch;

/// One view: the film point's distance from the centre, the picture, and its light.
#[derive(Clone, Debug)]
pub struct PupilView {
    /// Film point, lens frame, mm.
    pub film_point: [f64; 2],
    pub film_radius_mm: f64,
    /// Light passed per rear-plane cell, row-major, row 0 at +y.
    pub transmission: Vec<f32>,
    /// ∫ T cos⁴θ / z² dA (mm⁰: an irradiance per unit scene radiance).
    pub light: f64,
    /// `light` over the centre view's (1 at the centre; 0 when the centre passes nothing).
    pub relative_light: f64,
}

/// The views' common window on the rear-vertex plane, and their resolution.
#[derive(Clone, Debug)]
pub struct PupilViews {
    /// Half the side of the square window, mm, centred on the axis.
    pub half_width_mm: f64,
    /// Cells across the window.
    pub cells: usize,
    pub rear_radius_mm: f64,
    pub views: Vec<PupilView>,
}

/// Direction from the film centre toward the image's top-right corner of a 3:2 frame, in the
/// lens frame (which the pixel map turns by 180°).
const CORNER_DIRECTION: [f64; 2] = [-3.0, -2.0];

impl PupilViews {
    /// `count` views (≥ 2) from the film centre to `film_radius` (mm), each `cells` × `cells`,
    /// over a window holding every segment's exit-pupil bounds of `pupil` (found for the
    /// stop's circle, so they hold any diaphragm).
    pub fn compute(
        system: &LensSystem,
        pupil: &ExitPupil,
        film_radius: f64,
        count: usize,
        cells: usize,
    ) -> PupilViews {
        let reach = pupil
            .segments
            .iter()
            .filter(|r| !r.is_empty())
            .flat_map(|r| [r.min, r.max])
            .map(|[x, y]| x.hypot(y))
            .fold(0.0f64, f64::max);
        let rear_radius = system.rear_semi_aperture();
        let half_width = if reach > 0.0 {
            1.05 * reach
        } else {
            1.5 * rear_radius
        };
        let length = CORNER_DIRECTION[0].hypot(CORNER_DIRECTION[1]);
        let direction = CORNER_DIRECTION.map(|c| c / length);
        let film_z = system.rear_z() + pupil.film_distance;
        let z = pupil.film_distance;
        let cell = 2.0 * half_width / cells as f64;
        let mut views: Vec<PupilView> = (0..count)
            .map(|k| {
                let r = film_radius * k as f64 / (count - 1).max(1) as f64;
                let film = direction.map(|d| d * r);
                let mut batch = RayBatch::with_capacity(cells * cells);
                for row in 0..cells {
                    for col in 0..cells {
                        let x = -half_width + (col as f64 + 0.5) * cell;
                        let y = half_width - (row as f64 + 0.5) * cell;
                        let d = [x - film[0], y - film[1], -z];
                        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                        batch.push(
                            [film[0] as f32, film[1] as f32, film_z as f32],
                            d.map(|c| (c / len) as f32),
                            0,
                            0,
                        );
                    }
                }
                trace_batch(&system.f32s, &mut batch, Travel::FilmToScene);
                let mut light = 0.0;
                let transmission: Vec<f32> = (0..batch.len())
                    .map(|i| {
                        if !batch.alive[i] {
                            return 0.0;
                        }
                        let t = batch.tr[i];
                        let (row, col) = (i / cells, i % cells);
                        let x = -half_width + (col as f64 + 0.5) * cell;
                        let y = half_width - (row as f64 + 0.5) * cell;
                        let (dx, dy) = (x - film[0], y - film[1]);
                        let cos2 = z * z / (dx * dx + dy * dy + z * z);
                        light += t as f64 * cos2 * cos2 * cell * cell / (z * z);
                        t
                    })
                    .collect();
                PupilView {
                    film_point: film,
                    film_radius_mm: r,
                    transmission,
                    light,
                    relative_light: 0.0,
                }
            })
            .collect();
        let centre = views.first().map_or(0.0, |v| v.light);
        for view in &mut views {
            view.relative_light = if centre > 0.0 {
                view.light / centre
            } else {
                0.0
            };
        }
        PupilViews {
            half_width_mm: half_width,
            cells,
            rear_radius_mm: rear_radius,
            views,
        }
    }

    /// A view as a picture: light grey to white where light passes, dark where none does, the
    /// rear element's rim in blue.
    pub fn picture(&self, view: &PupilView) -> RgbImage {
        let n = self.cells as u32;
        let cell = 2.0 * self.half_width_mm / self.cells as f64;
        let rim_width = 1.5 * cell;
        RgbImage::from_fn(n, n, |col, row| {
            let t = view.transmission[(row * n + col) as usize];
            let x = -self.half_width_mm + (col as f64 + 0.5) * cell;
            let y = self.half_width_mm - (row as f64 + 0.5) * cell;
            if t > 0.0 {
                let v = (40.0 + 215.0 * t.clamp(0.0, 1.0)) as u8;
                Rgb([v, v, v])
            } else if (x.hypot(y) - self.rear_radius_mm).abs() < rim_width {
                Rgb([70, 110, 200])
            } else {
                Rgb([24, 24, 24])
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::diaphragm::{Blades, Diaphragm};
    use crate::lens::first_order::FirstOrder;
    use crate::lens::io::bundled::load_lens;
    use crate::lens::pupil::PupilSampling;

    /// On axis the view of a lens stopped down (so the stop alone limits it) is the stop's
    /// image: a circle, or with six blades a hexagon of 3√3/(2π) of its light, its corners
    /// where the blades put them; toward the corner the view shrinks into a cat's eye.
    #[test]
    fn centre_view_is_the_stop_and_the_corner_a_cats_eye() {
        let p = load_lens("dgauss.50mm", None).unwrap();
        let full = LensSystem::new(&p.rows, None);
        let stop = full.stop_diameter() * 0.5;
        let round = LensSystem::new(&p.rows, Some(stop));
        let bladed = round.clone().with_diaphragm(Some(&Diaphragm {
            blades: Some(Blades::new(6, 0.0, 0.0).unwrap()),
            mask: None,
        }));
        let fo = FirstOrder::compute(&round).unwrap();
        let film_distance = fo.back_focal_length;
        let pupil = ExitPupil::compute(&round, film_distance, 43.3, PupilSampling::Bounds);
        let round_views = PupilViews::compute(&round, &pupil, 21.65, 4, 256);
        let bladed_views = PupilViews::compute(&bladed, &pupil, 21.65, 4, 256);
        let ratio = bladed_views.views[0].light / round_views.views[0].light;
        let hexagon = 3.0 * 3f64.sqrt() / (2.0 * std::f64::consts::PI);
        assert!((ratio - hexagon).abs() < 0.01, "{ratio} vs {hexagon}");
        // Cat's eye: less light, and a view narrower across the radial direction than along
        // the tangent... at least, less light.
        let corner = round_views.views.last().unwrap();
        assert!(
            corner.relative_light < 0.9,
            "corner light {}",
            corner.relative_light
        );
        // The on-axis circle's area (cells that pass) matches the exit pupil's paraxial size
        // to within the rim's width, once projected from the film to the rear-vertex plane.
        let cells = round_views.views[0]
            .transmission
            .iter()
            .filter(|&&t| t > 0.0)
            .count() as f64;
        let cell = 2.0 * round_views.half_width_mm / 256.0;
        let area = cells * cell * cell;
        let film_z = round.rear_z() + film_distance;
        let scale = film_distance / (film_z - fo.exit_pupil.z_mm);
        let expected = std::f64::consts::PI * (fo.exit_pupil.diameter_mm / 2.0 * scale).powi(2);
        assert!(
            (area / expected - 1.0).abs() < 0.05,
            "{area} vs paraxial {expected}"
        );
    }
}
