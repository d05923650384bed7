//! First-order (paraxial) optics: the lens as a 2×2 ray-transfer matrix.
//!
//! A paraxial ray is (y, w): height and *reduced* angle w = n·u (index times slope). Refraction
//! at a surface of power φ = (n' − n)·c is `[[1, 0], [−φ, 1]]`; travelling a distance t in a
//! medium of index n is `[[1, t/n], [0, 1]]`. Object and image space are air, so the system
//! matrix [[A, B], [C, D]] from the front vertex to the rear vertex gives EFL = −1/C directly.
//! An asphere's c is its curvature at the vertex, c + 2·A₂ (see [`super::shape`]).
//! All z are lens-frame z (mm, origin at the front vertex, +z toward the film).

use super::system::LensSystem;
use super::trace::{Ray, Travel, trace};

/// A paraxial ray-transfer matrix acting on (y, n·u).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transfer {
    pub a: f64,
    pub b: f64,
    pub c: f64,
    pub d: f64,
}

impl Transfer {
    pub const IDENTITY: Transfer = Transfer {
        a: 1.0,
        b: 0.0,
        c: 0.0,
        d: 1.0,
    };

    pub fn refraction(power: f64) -> Transfer {
        Transfer {
            a: 1.0,
            b: 0.0,
            c: -power,
            d: 1.0,
        }
    }

    pub fn translation(distance: f64, index: f64) -> Transfer {
        Transfer {
            a: 1.0,
            b: distance / index,
            c: 0.0,
            d: 1.0,
        }
    }

    /// `self` applied after `first`.
    pub fn then(self, second: Transfer) -> Transfer {
        let f = self;
        Transfer {
            a: second.a * f.a + second.b * f.c,
            b: second.a * f.b + second.b * f.d,
            c: second.c * f.a + second.d * f.c,
            d: second.c * f.b + second.d * f.d,
        }
    }

    pub fn apply(&self, y: f64, w: f64) -> (f64, f64) {
        (self.a * y + self.b * w, self.c * y + self.d * w)
    }
}

/// Matrix from just before surface `from` to just after surface `to - 1` (vertex planes).
pub fn transfer_between(system: &LensSystem, from: usize, to: usize) -> Transfer {
    let s = &system.f64s;
    let mut m = Transfer::IDENTITY;
    for i in from..to {
        if i > from {
            let gap = s.vertex_z[i] - s.vertex_z[i - 1];
            m = m.then(Transfer::translation(gap, s.index_front[i]));
        }
        // Paraxial rays see the curvature at the vertex: an asphere's base curvature plus
        // twice its r² coefficient (the conic constant and higher terms act at order r⁴).
        let power = (s.index_back[i] - s.index_front[i]) * s.profile(i).vertex_curvature();
        m = m.then(Transfer::refraction(power));
    }
    m
}

/// A pupil: an image of the stop, with its lens-frame position and diameter.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Pupil {
    pub z_mm: f64,
    pub diameter_mm: f64,
}

/// Cardinal points and pupils of a lens (for its current stop).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstOrder {
    pub focal_length: f64,
    /// Rear vertex → rear focal point.
    pub back_focal_length: f64,
    /// Lens-frame z of the front focal point (negative: in front of the lens).
    pub front_focal_z: f64,
    pub front_principal_z: f64,
    pub rear_principal_z: f64,
    pub rear_focal_z: f64,
    pub entrance_pupil: Pupil,
    pub exit_pupil: Pupil,
    /// EFL / entrance-pupil diameter.
    pub f_number: f64,
    /// The system matrix, front vertex → rear vertex.
    pub system: Transfer,
}

impl FirstOrder {
    /// The working f-number with the film at lens-frame `film_z`: the image-side cone's
    /// length over its width, exit pupil to film ÷ exit-pupil diameter (paraxial). It is what
    /// sets the film's exposure and depth of field. Focused at infinity (the film at the rear
    /// focal point) it is the f-number EFL/EPD; focused closer it is N·(1 + |m|/P), m the
    /// magnification and P the pupil magnification (the bellows factor). A lens focused by a
    /// group in front of its stop (internal focus) keeps its exit pupil and film where they
    /// are, and so its working f-number, while its EFL, and with it EFL/EPD, shrinks.
    pub fn working_f_number(&self, film_z: f64) -> f64 {
        (film_z - self.exit_pupil.z_mm).abs() / self.exit_pupil.diameter_mm
    }
}

/// Errors that make first-order quantities meaningless.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FirstOrderError {
    #[error("the lens has no optical power (an afocal system): it cannot form an image")]
    Afocal,
    #[error("the lens has negative power (focal length {0:.3} mm): it forms no real image on film")]
    Diverging(f64),
}

impl FirstOrder {
    pub fn compute(system: &LensSystem) -> Result<FirstOrder, FirstOrderError> {
        let n = system.surface_count();
        let m = transfer_between(system, 0, n);
        if m.c.abs() < 1e-12 {
            return Err(FirstOrderError::Afocal);
        }
        let focal_length = -1.0 / m.c;
        if focal_length < 0.0 {
            return Err(FirstOrderError::Diverging(focal_length));
        }
        let rear_z = system.rear_z();
        // A ray (1, 0) from infinity leaves at height A, angle C: it crosses the axis −A/C later.
        let back_focal_length = -m.a / m.c;
        let rear_focal_z = rear_z + back_focal_length;
        // A ray leaving parallel came from the front focal point: −C·z_F + D = 0.
        let front_focal_z = m.d / m.c;
        let stop = system.stop;
        let stop_diameter = system.stop_diameter();

        // Entrance pupil: plane in object space imaged onto the stop. From z_E to the stop the
        // matrix is M_front · T(−z_E); it images when its B vanishes.
        let front = transfer_between(system, 0, stop);
        let front = if stop > 0 {
            front.then(Transfer::translation(
                system.f64s.vertex_z[stop] - system.f64s.vertex_z[stop - 1],
                system.f64s.index_front[stop],
            ))
        } else {
            front
        };
        let entrance_pupil = Pupil {
            z_mm: front.b / front.a,
            diameter_mm: stop_diameter / front.a.abs(),
        };
        // Exit pupil: image of the stop through the surfaces behind it, in image space; from the
        // stop to a plane v behind the rear vertex the matrix is T(v) · M_back, imaging when B = 0.
        let back_m = transfer_between(system, stop, n);
        let v = -back_m.b / back_m.d;
        let magnification = back_m.a + v * back_m.c;
        let exit_pupil = Pupil {
            z_mm: rear_z + v,
            diameter_mm: stop_diameter * magnification.abs(),
        };
        Ok(FirstOrder {
            focal_length,
            back_focal_length,
            front_focal_z,
            front_principal_z: front_focal_z + focal_length,
            rear_principal_z: rear_focal_z - focal_length,
            rear_focal_z,
            f_number: focal_length / entrance_pupil.diameter_mm,
            entrance_pupil,
            exit_pupil,
            system: m,
        })
    }
}

/// Focal length and back focal length fitted from *real* rays near the axis, as pbrt's
/// `ComputeThickLensApproximation` does: a ray parallel to the axis at a small height, traced
/// exactly, crosses the axis at the focal point; its incoming and outgoing lines meet on the
/// principal plane. Independent of the matrix code, so the two check each other.
pub fn thick_lens_from_real_rays(system: &LensSystem, height: f64) -> Option<(f64, f64)> {
    let ray = Ray {
        origin: [height, 0.0, -1.0],
        direction: [0.0, 0.0, 1.0],
    };
    let out = trace(&system.f64s, ray, Travel::SceneToFilm).ok()?;
    let [x, _, z] = out.origin;
    let [dx, _, dz] = out.direction;
    let to_axis = -x / dx;
    let focal_z = z + to_axis * dz;
    let to_height = (height - x) / dx;
    let principal_z = z + to_height * dz;
    Some((focal_z - principal_z, focal_z - system.rear_z()))
}
