//! Sizing clear apertures a lens file leaves open, as an optical design program does.
//!
//! Design files often give the system aperture instead of the stop's size (an entrance-pupil
//! diameter, an f-number, or "as large as the elements allow") and leave other surfaces'
//! semi-diameters to be computed: each is then the largest height at which a ray of the design's
//! fields, through the stop, crosses it (Zemax's automatic semi-diameter). Here those rays are
//! found exactly: for every field point the real chief ray (through the stop's centre), then in
//! 64 directions around it the ray that grazes the stop's rim, traced with every other surface
//! unlimited.

use super::aiming::ObjectSource;
use super::field::field_angle;
use super::first_order::FirstOrder;
use super::prescription::SurfaceRow;
use super::system::LensSystem;
use super::trace::{Ray, Travel, trace_path};

/// A field point of the design: where the rays whose clear apertures are wanted come from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FieldPoint {
    /// Object-space angle from the axis, radians (an object at infinity, or the chief ray's
    /// angle to a finite object).
    Angle(f64),
    /// Height of a point on a finite object plane, mm.
    ObjectHeight(f64),
    /// Image height by paraxial optics, mm: the angle whose tangent is height / EFL.
    ParaxialImageHeight(f64),
    /// Image height that the real chief ray reaches on a film `film_distance` behind the rear
    /// vertex, mm.
    RealImageHeight { height: f64, film_distance: f64 },
}

/// Directions around each chief ray in which the rim ray is found.
const AZIMUTHS: usize = 64;

/// The lens with its rows' apertures, except that surfaces marked in `unlimited` (and, when
/// `open_stop`, the stop) clip nothing.
fn system_with(rows: &[SurfaceRow], unlimited: &[bool], open_stop: bool) -> LensSystem {
    let mut system = LensSystem::new(rows, None);
    for (i, limit) in system.f64s.semi_aperture_sq.iter_mut().enumerate() {
        if unlimited[i] || (open_stop && i == system.stop) {
            *limit = f64::INFINITY;
        }
    }
    system
}

/// First-order data with the stop at a unit diameter (what scales with it, scales linearly).
fn unit_stop_first_order(rows: &[SurfaceRow], stop: usize) -> Result<FirstOrder, String> {
    let mut rows = rows.to_vec();
    rows[stop].base.aperture = 1.0;
    FirstOrder::compute(&LensSystem::new(&rows, None)).map_err(|e| e.to_string())
}

/// Stop diameter (mm) that gives an entrance pupil `diameter` mm across.
pub fn stop_for_entrance_pupil(
    rows: &[SurfaceRow],
    stop: usize,
    diameter: f64,
) -> Result<f64, String> {
    if !(diameter.is_finite() && diameter > 0.0) {
        return Err(format!(
            "entrance pupil diameter {diameter} mm must be positive"
        ));
    }
    let fo = unit_stop_first_order(rows, stop)?;
    Ok(diameter / fo.entrance_pupil.diameter_mm)
}

/// Stop diameter (mm) that gives the f-number EFL / entrance-pupil diameter = `f_number`.
pub fn stop_for_f_number(rows: &[SurfaceRow], stop: usize, f_number: f64) -> Result<f64, String> {
    if !(f_number.is_finite() && f_number > 0.0) {
        return Err(format!("f-number {f_number} must be positive"));
    }
    let fo = unit_stop_first_order(rows, stop)?;
    Ok(fo.focal_length / f_number / fo.entrance_pupil.diameter_mm)
}

/// The widest stop the other (known) clear apertures let an axial beam from infinity fill:
/// the stop diameter of the lens wide open.
pub fn widest_stop(rows: &[SurfaceRow], stop: usize, unknown: &[bool]) -> Result<f64, String> {
    let system = system_with(rows, unknown, true);
    let stop_height = |y: f64| -> Option<f64> {
        let mut at_stop = None;
        let ray = Ray {
            origin: [0.0, y, -1.0],
            direction: [0.0, 0.0, 1.0],
        };
        trace_path(&system.f64s, ray, Travel::SceneToFilm, true, |i, p| {
            if i == stop {
                at_stop = Some(p[1].abs())
            }
        })
        .ok()?;
        at_stop
    };
    let front = rows[0].base.aperture / 2.0;
    let mut hi = if front > 0.0 { front } else { 1e3 };
    let mut lo = 0.0;
    if stop_height(hi).is_some() {
        return Err("the elements around the stop never limit the axial beam".into());
    }
    if stop_height(1e-6 * hi).is_none() {
        return Err("no axial ray passes the lens".into());
    }
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if stop_height(mid).is_some() {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    stop_height(lo)
        .map(|h| 2.0 * h)
        .ok_or_else(|| "no axial ray passes the lens".into())
}

/// Fills the apertures of the rows marked `missing` with the largest ray heights of the fields
/// through the stop (whose size must be known). `Err((row, why))` when a surface cannot be sized.
pub fn fill_missing(
    rows: &mut [SurfaceRow],
    missing: &[bool],
    fields: &[FieldPoint],
    object_distance: f64,
) -> Result<(), (usize, String)> {
    let system = system_with(rows, missing, false);
    let first_missing = missing.iter().position(|&m| m).unwrap_or(0);
    let fo = FirstOrder::compute(&system).map_err(|e| (first_missing, e.to_string()))?;
    let mut heights = vec![0.0f64; rows.len()];
    for &field in fields {
        let source =
            ray_source(&system, &fo, field, object_distance).map_err(|why| (first_missing, why))?;
        let traced = |aim: [f64; 2], heights: Option<&mut Vec<f64>>| -> bool {
            let ray = source.ray_through(aim);
            let mut seen = Vec::with_capacity(rows.len());
            let passed = trace_path(&system.f64s, ray, Travel::SceneToFilm, true, |_, p| {
                seen.push(p[0].hypot(p[1]))
            })
            .is_ok();
            if passed && let Some(heights) = heights {
                for (h, s) in heights.iter_mut().zip(&seen) {
                    *h = h.max(*s);
                }
            }
            passed
        };
        let chief = source.chief_aim(&system).ok_or((
            first_missing,
            format!("no chief ray through the stop for the field {field:?}"),
        ))?;
        traced(chief, Some(&mut heights));
        let reach = 4.0 * fo.entrance_pupil.diameter_mm.max(1e-3);
        for k in 0..AZIMUTHS {
            let phi = std::f64::consts::TAU * k as f64 / AZIMUTHS as f64;
            let aim = |s: f64| [chief[0] + s * phi.cos(), chief[1] + s * phi.sin()];
            let (mut lo, mut hi) = (0.0, reach);
            if traced(aim(hi), None) {
                continue; // Some other limit than the stop (the scan grid ends): skip.
            }
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if traced(aim(mid), None) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            traced(aim(lo), Some(&mut heights));
        }
    }
    for (i, row) in rows.iter_mut().enumerate() {
        if missing[i] {
            if heights[i] <= 0.0 {
                return Err((i, "no ray of the design's fields reaches it".into()));
            }
            row.base.aperture = 2.0 * heights[i];
        }
    }
    Ok(())
}

/// The rays of `field` for a lens with first-order data `fo`, the object `object_distance` mm
/// in front of the first vertex (∞ for an object at infinity).
fn ray_source(
    system: &LensSystem,
    fo: &FirstOrder,
    field: FieldPoint,
    object_distance: f64,
) -> Result<ObjectSource, String> {
    let pupil_z = fo.entrance_pupil.z_mm;
    let angle = match field {
        FieldPoint::Angle(a) => Some(a),
        FieldPoint::ParaxialImageHeight(h) => Some((h / fo.focal_length).atan()),
        FieldPoint::RealImageHeight {
            height,
            film_distance,
        } => Some(
            field_angle(system, film_distance, height)
                .ok_or(format!("no chief ray reaches the image height {height} mm"))?,
        ),
        FieldPoint::ObjectHeight(_) => None,
    };
    if object_distance.is_finite() {
        let object_z = -object_distance;
        let height = match (field, angle) {
            (FieldPoint::ObjectHeight(h), _) => h,
            (_, Some(a)) => (pupil_z - object_z) * a.tan(),
            _ => unreachable!("every field kind has an angle or an object height"),
        };
        return Ok(ObjectSource {
            point: Some([0.0, height, object_z]),
            direction: [0.0, 0.0, 1.0],
            pupil_z,
        });
    }
    let angle = angle.ok_or("object-height fields need a finite object distance")?;
    Ok(ObjectSource {
        point: None,
        direction: [0.0, angle.sin(), angle.cos()],
        pupil_z,
    })
}
