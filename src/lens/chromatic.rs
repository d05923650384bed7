//! A lens's colour errors from its glass data: how far apart blue and red light focus on the
//! axis (axial colour), and how far apart they land at a field point (lateral colour).
//!
//! * **Axial colour**: the paraxial back focal length at the F line (486.1327 nm) minus at the
//!   C line (656.2725 nm), mm. Negative for an undercorrected lens: blue focuses nearer.
//! * **Lateral colour**: the chief ray whose d-line (587.5618 nm) image lands at 70 % of the
//!   film's half-diagonal, with the film where the focus puts it; the image heights of the
//!   chief rays of the same object point at F and at C, through the centre of the stop at
//!   their own wavelengths, F minus C, mm (positive when blue lands farther out).

use super::aiming::ObjectSource;
use super::field::chief_ray;
use super::first_order::FirstOrder;
use super::system::LensSystem;
use super::trace::{Ray, Travel, trace_with};
use crate::glass::{FRAUNHOFER_C_NM, FRAUNHOFER_D_NM, FRAUNHOFER_F_NM};

/// Where on the film (fraction of the half-diagonal) lateral colour is measured.
pub const LATERAL_FIELD: f64 = 0.7;

/// Paraxial back focal length at F minus at C, mm; `None` when the lens has no focus at one
/// of them.
pub fn axial_colour(system: &LensSystem) -> Option<f64> {
    let bfl = |nm: f64| {
        FirstOrder::compute(&system.at_wavelength(nm))
            .ok()
            .map(|fo| fo.back_focal_length)
    };
    Some(bfl(FRAUNHOFER_F_NM)? - bfl(FRAUNHOFER_C_NM)?)
}

/// Image height at F minus at C (mm) of the object point whose d-line chief ray lands at
/// [`LATERAL_FIELD`] of the film's half-diagonal. The object lies `focus_distance_mm` from the
/// film (∞: at infinity). `None` when some chief ray does not exist (beyond a fisheye's image
/// circle).
pub fn lateral_colour(
    system: &LensSystem,
    film_distance: f64,
    film_diagonal: f64,
    focus_distance_mm: f64,
) -> Option<f64> {
    let film_z = system.rear_z() + film_distance;
    let height = LATERAL_FIELD * film_diagonal / 2.0;
    let d_line = system.at_wavelength(FRAUNHOFER_D_NM);
    // The d chief ray of the film point (height, 0), turned into the meridional y–z plane
    // (the lens is rotationally symmetric), leaving the front surface toward the scene.
    let chief = chief_ray(&d_line, film_distance, height)?;
    let turn = |v: [f64; 3]| [v[1], v[0], v[2]];
    let (origin, toward_scene) = (turn(chief.origin), turn(chief.direction));
    let into_lens = toward_scene.map(|c| -c);
    let object = if focus_distance_mm.is_finite() {
        let object_z = film_z - focus_distance_mm;
        let t = (object_z - origin[2]) / toward_scene[2];
        Some([
            origin[0] + t * toward_scene[0],
            origin[1] + t * toward_scene[1],
            object_z,
        ])
    } else {
        None
    };
    let image_height = |nm: f64| -> Option<f64> {
        let at = system.at_wavelength(nm);
        let pupil_z = FirstOrder::compute(&at).ok()?.entrance_pupil.z_mm;
        let source = ObjectSource {
            point: object,
            direction: into_lens,
            pupil_z,
        };
        let aim = source.chief_aim(&at)?;
        // A chief ray need not clear every element's rim to define where the image is.
        let out = trace_with(
            &at.f64s,
            source.ray_through(aim),
            Travel::SceneToFilm,
            false,
        )
        .ok()?;
        Some(film_height(&out, film_z))
    };
    Some(image_height(FRAUNHOFER_F_NM)? - image_height(FRAUNHOFER_C_NM)?)
}

/// Where `ray` (leaving the lens) crosses the film plane, as a signed height on the y axis.
fn film_height(ray: &Ray<f64>, film_z: f64) -> f64 {
    let t = (film_z - ray.origin[2]) / ray.direction[2];
    ray.origin[1] + t * ray.direction[1]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::glass::{Glass, catalogue};
    use crate::lens::SurfaceRow;

    /// A thin singlet's axial colour is −f/V_d (its focal length moves by f/V between F and C:
    /// 1/f ∝ n − 1), to the order of its thickness.
    #[test]
    fn a_thin_singlet_has_axial_colour_f_over_v() {
        let glass = Glass::Catalogue(catalogue().find("N-BK7").unwrap());
        let n = glass.n_d();
        // Equi-convex, f ≈ 100 mm: R = 2(n − 1)f.
        let radius = 2.0 * (n - 1.0) * 100.0;
        let front = SurfaceRow {
            glass: Some(glass),
            ..SurfaceRow::new(radius, 0.5, n, 20.0)
        };
        let rows = [
            SurfaceRow::new(0.0, 0.0, 1.0, 20.0),
            front,
            SurfaceRow::new(-radius, 0.0, 1.0, 20.0),
        ];
        let system = LensSystem::new(&rows, None);
        let fo = FirstOrder::compute(&system).unwrap();
        let expected = -fo.focal_length / glass.v_d();
        let axial = axial_colour(&system).unwrap();
        assert!(
            (axial - expected).abs() < 0.01 * expected.abs(),
            "{axial} vs {expected}"
        );
    }
}
