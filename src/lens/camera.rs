//! From film pixels to world-space camera rays through the lens.
//!
//! **Camera frame**: metres, origin at the centre of the film, looking down −z, +y up, +x to
//! the image's right (glTF's camera convention). The lens frame (see [`crate::lens`]) maps to
//! it by `camera = (x, y, z − film_z) / 1000`: the lens sits in front of the film, toward −z.
//!
//! **Pixels**: (0, 0) is the top-left corner of the image, +x right, +y down. Since the lens
//! inverts the image, the pixel at the image's top right is the film point at bottom left
//! (−x, −y); mapping pixels that way gives an upright, unmirrored picture.

use glam::{Mat4, Vec3};

use super::pupil::ExitPupil;
use super::system::LensSystem;
use super::trace::Travel;
use super::trace_batch::trace_batch;
use crate::batch::RayBatch;
use crate::sampling::{Rng, correlated_multi_jitter};

/// The film's size in pixels and millimetres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilmGeometry {
    pub width: u32,
    pub height: u32,
    pub width_mm: f32,
    pub height_mm: f32,
}

impl FilmGeometry {
    /// A film of `width` × `height` square pixels whose diagonal is `diagonal_mm`.
    pub fn new(width: u32, height: u32, diagonal_mm: f64) -> FilmGeometry {
        let aspect = width as f64 / height as f64;
        let height_mm = diagonal_mm / (1.0 + aspect * aspect).sqrt();
        FilmGeometry {
            width,
            height,
            width_mm: (height_mm * aspect) as f32,
            height_mm: height_mm as f32,
        }
    }

    /// Lens-frame film point (x, y, mm) of the continuous pixel position (`px`, `py`).
    pub fn film_point(&self, px: f32, py: f32) -> [f32; 2] {
        let u = px / self.width as f32 - 0.5;
        let v = py / self.height as f32 - 0.5;
        [-u * self.width_mm, v * self.height_mm]
    }
}

/// The active lens as the ray generator sees it.
#[derive(Clone, Copy, Debug)]
pub struct LensCamera<'a> {
    pub system: &'a LensSystem,
    pub pupil: &'a ExitPupil,
    pub film: FilmGeometry,
    /// Rigid transform from the camera frame (see module docs) to the world.
    pub world_from_camera: Mat4,
    /// The render's target spp: samples 0..this are stratified together; beyond it (or when
    /// 0) samples are independent.
    pub samples_per_pixel: u32,
}

/// Camera rays of one batch: rays in the world frame and the lens weight of each.
#[derive(Clone, Debug, Default)]
pub struct CameraRays {
    pub rays: RayBatch,
    /// Camera-measurement weight (see [`super::pupil::PupilSample`]); 0 for blocked rays.
    pub weight: Vec<f32>,
}

impl LensCamera<'_> {
    fn film_z(&self) -> f32 {
        (self.system.rear_z() + self.pupil.film_distance) as f32
    }

    /// Generates sample `sample` of each pixel in `pixels` (x, y) into `out`, replacing its
    /// contents: film point and pupil point from the sample's own random stream, traced through
    /// the lens as one SoA batch, then moved to the world frame.
    pub fn generate(
        &self,
        pixels: impl IntoIterator<Item = (u32, u32)>,
        sample: u32,
        seed: u64,
        out: &mut CameraRays,
    ) {
        let film_z = self.film_z();
        let rays = &mut out.rays;
        rays.clear();
        out.weight.clear();
        for (x, y) in pixels {
            let pixel = y * self.film.width + x;
            let (jitter, pupil_u) = self.camera_sample(seed, pixel, sample);
            let [fx, fy] = self
                .film
                .film_point(x as f32 + jitter[0], y as f32 + jitter[1]);
            match self.pupil.sample(fx, fy, pupil_u) {
                Some(s) => {
                    let d = [s.point[0] - fx, s.point[1] - fy, s.point[2] - film_z];
                    let inv = 1.0 / (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    rays.push(
                        [fx, fy, film_z],
                        [d[0] * inv, d[1] * inv, d[2] * inv],
                        pixel,
                        sample,
                    );
                    out.weight.push(s.weight);
                }
                None => {
                    rays.push([fx, fy, film_z], [0.0, 0.0, -1.0], pixel, sample);
                    let last = rays.len() - 1;
                    rays.alive[last] = false;
                    out.weight.push(0.0);
                }
            }
        }
        trace_batch(&self.system.f32s, rays, Travel::FilmToScene);
        self.to_world(film_z, out);
    }

    /// The 4D camera sample (film jitter, pupil point) of `sample` in `pixel`: two correlated
    /// multi-jittered 2D patterns over the planned samples, keyed per pixel and per pair of
    /// dimensions; independent random numbers past the plan.
    fn camera_sample(&self, seed: u64, pixel: u32, sample: u32) -> ([f32; 2], [f32; 2]) {
        const CAMERA_KEY: u64 = 0x4341_4d45_5241_5f4b; // "CAMERA_K"
        if sample < self.samples_per_pixel {
            let mut keys = Rng::for_sample(seed ^ CAMERA_KEY, pixel, u32::MAX);
            let (film_key, pupil_key) = (keys.next_u32(), keys.next_u32());
            let count = self.samples_per_pixel;
            (
                correlated_multi_jitter(sample, count, film_key),
                correlated_multi_jitter(sample, count, pupil_key),
            )
        } else {
            let mut rng = Rng::for_sample(seed, pixel, sample);
            (rng.next_2d(), rng.next_2d())
        }
    }

    /// Lens frame (mm) → camera frame (m) → world, for every ray; zero weight for the blocked.
    fn to_world(&self, film_z: f32, out: &mut CameraRays) {
        let m = self.world_from_camera;
        let (cx, cy, cz, ct) = (m.x_axis, m.y_axis, m.z_axis, m.w_axis);
        let rays = &mut out.rays;
        for i in 0..rays.len() {
            let p = Vec3::new(rays.ox[i], rays.oy[i], rays.oz[i] - film_z) * 1e-3;
            let d = Vec3::new(rays.dx[i], rays.dy[i], rays.dz[i]);
            let wp =
                cx.truncate() * p.x + cy.truncate() * p.y + cz.truncate() * p.z + ct.truncate();
            let wd = cx.truncate() * d.x + cy.truncate() * d.y + cz.truncate() * d.z;
            rays.ox[i] = wp.x;
            rays.oy[i] = wp.y;
            rays.oz[i] = wp.z;
            rays.dx[i] = wd.x;
            rays.dy[i] = wd.y;
            rays.dz[i] = wd.z;
            if !rays.alive[i] {
                out.weight[i] = 0.0;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn film_has_requested_diagonal_and_aspect() {
        let film = FilmGeometry::new(300, 200, 36.0);
        let diagonal = (film.width_mm.powi(2) + film.height_mm.powi(2)).sqrt();
        assert!((diagonal - 36.0).abs() < 1e-4);
        assert!((film.width_mm / film.height_mm - 1.5).abs() < 1e-6);
    }

    #[test]
    fn pixels_map_to_inverted_film_points() {
        let film = FilmGeometry::new(100, 100, 10.0);
        // Top-right pixel corner → film bottom-left (the lens flips it back upright).
        let [x, y] = film.film_point(100.0, 0.0);
        assert!(x < 0.0 && y < 0.0);
        let [x, y] = film.film_point(50.0, 50.0);
        assert_eq!((x, y), (0.0, 0.0));
    }
}
