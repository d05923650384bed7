//! Field of view from real chief rays.
//!
//! The chief ray of a film point passes through the centre of the stop (and, to count, through
//! every clear aperture: a vignetted corner sees nothing). Its angle to the axis
//! in object space is the field angle that point sees: exact for a fisheye, where the paraxial
//! 2·atan(h/f) is meaningless.

use super::system::LensSystem;
use super::trace::{Ray, Travel, normalize, trace_with};

/// Field angle (radians, from the axis) seen by the film point at height `height` (mm) on a
/// film `film_distance` behind the rear vertex; `None` if no chief ray exists.
pub fn field_angle(system: &LensSystem, film_distance: f64, height: f64) -> Option<f64> {
    chief_ray(system, film_distance, height).map(|out| (-out.direction[2]).acos())
}

/// The chief ray of the film point (`height`, 0) on a film `film_distance` behind the rear
/// vertex, as it leaves the front surface toward the scene (lens frame, direction toward −z).
pub fn chief_ray(system: &LensSystem, film_distance: f64, height: f64) -> Option<Ray<f64>> {
    let film_z = system.rear_z() + film_distance;
    let stop_z = system.f64s.vertex_z[system.stop];
    let rear_group = system.f64s.slice(system.stop + 1..system.surface_count());
    let ray_towards = |aim_x: f64| Ray {
        origin: [height, 0.0, film_z],
        direction: normalize([aim_x - height, 0.0, system.rear_z() - film_z]),
    };
    // Height at which the ray aimed at `aim_x` on the rear vertex plane crosses the stop plane.
    let stop_height = |aim_x: f64| -> Option<f64> {
        let out = trace_with(&rear_group, ray_towards(aim_x), Travel::FilmToScene, true).ok()?;
        let t = (stop_z - out.origin[2]) / out.direction[2];
        Some(out.origin[0] + t * out.direction[0])
    };
    // Bracket the root by scanning aim points across the rear element (some aims miss a
    // surface's cap entirely), then bisect: robust where secant steps can wander off.
    let reach = 3.0 * system.rear_semi_aperture().max(height.abs());
    const SCAN: usize = 240;
    let aims: Vec<(f64, Option<f64>)> = (0..=SCAN)
        .map(|k| {
            let x = -reach + 2.0 * reach * k as f64 / SCAN as f64;
            (x, stop_height(x))
        })
        .collect();
    let (mut lo, mut hi) = aims.windows(2).find_map(|w| match (w[0].1, w[1].1) {
        (Some(a), Some(b)) if a.signum() != b.signum() => Some(((w[0].0, a), (w[1].0, b))),
        _ => None,
    })?;
    for _ in 0..80 {
        let mid = 0.5 * (lo.0 + hi.0);
        let f = stop_height(mid)?;
        if f.signum() == lo.1.signum() {
            lo = (mid, f)
        } else {
            hi = (mid, f)
        }
    }
    let x1 = 0.5 * (lo.0 + hi.0);
    trace_with(&system.f64s, ray_towards(x1), Travel::FilmToScene, true).ok()
}

/// The largest film height up to `film_radius` (mm) that still has a chief ray, and its field
/// angle: the film corner, or the edge of the image circle of a lens (a fisheye's) whose image
/// does not cover the corners.
pub fn field_edge(system: &LensSystem, film_distance: f64, film_radius: f64) -> Option<(f64, f64)> {
    const STEPS: usize = 64;
    (1..=STEPS).rev().find_map(|k| {
        let h = film_radius * k as f64 / STEPS as f64;
        field_angle(system, film_distance, h).map(|a| (h, a))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::first_order::FirstOrder;
    use crate::lens::io::bundled::load_lens;

    #[test]
    fn small_fields_follow_the_paraxial_focal_length() {
        let p = load_lens("dgauss.50mm", None).unwrap();
        let system = LensSystem::new(&p.rows, None);
        let fo = FirstOrder::compute(&system).unwrap();
        let angle = field_angle(&system, fo.back_focal_length, 0.05).unwrap();
        assert!(
            (angle.tan() * fo.focal_length - 0.05).abs() < 1e-5,
            "{}",
            angle.tan() * fo.focal_length
        );
    }

    #[test]
    fn fisheye_sees_a_very_wide_field() {
        let p = load_lens("fisheye.10mm", None).unwrap();
        let system = LensSystem::new(&p.rows, None);
        let fo = FirstOrder::compute(&system).unwrap();
        // Its design half-field is 77.95°; the image circle is about 23 mm across.
        let angle = field_angle(&system, fo.back_focal_length, 11.0)
            .unwrap()
            .to_degrees();
        assert!(angle > 60.0 && angle < 90.0, "{angle}");
    }
}
