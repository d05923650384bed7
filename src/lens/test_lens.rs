//! A bundled lens set up as the render's lens systems derive it, for tests that compare camera
//! rays (the GPU's against the CPU's, backward traces against forward ones).

use crate::lens::camera::{FilmGeometry, LensCamera};
use crate::lens::diaphragm::Diaphragm;
use crate::lens::first_order::FirstOrder;
use crate::lens::focus::paraxial_film_distance;
use crate::lens::io::bundled::load_lens;
use crate::lens::movements::FilmMovements;
use crate::lens::pupil::{ExitPupil, PupilSampling};
use crate::lens::{LensSystem, SurfaceRow};

/// A lens focused at 5 m on a 24×16 film (its design's diagonal, else 35 mm), as the
/// render's lens systems derive it.
pub(crate) struct TestLens {
    pub(crate) system: LensSystem,
    pub(crate) pupil: ExitPupil,
    pub(crate) film: FilmGeometry,
    pub(crate) spectral: bool,
}

/// How a test sets its lens up.
#[derive(Clone)]
pub(crate) struct Setup {
    pub(crate) sampling: PupilSampling,
    pub(crate) movements: FilmMovements,
    pub(crate) diaphragm: Option<Diaphragm>,
    pub(crate) spectral: bool,
}

pub(crate) const PLAIN: Setup = Setup {
    sampling: PupilSampling::Bounds,
    movements: FilmMovements::NONE,
    diaphragm: None,
    spectral: false,
};

impl TestLens {
    /// The bundled lens `name`.
    pub(crate) fn new(name: &str, setup: Setup) -> TestLens {
        let prescription = load_lens(name, None).unwrap();
        let diagonal = prescription.info.film_diagonal_mm.unwrap_or(35.0);
        TestLens::of_rows(&prescription.rows, diagonal, setup)
    }

    pub(crate) fn of_rows(rows: &[SurfaceRow], diagonal: f64, setup: Setup) -> TestLens {
        let system = LensSystem::new(rows, None).with_diaphragm(setup.diaphragm.as_ref());
        let first_order = FirstOrder::compute(&system).unwrap();
        let film_distance = paraxial_film_distance(&system, &first_order, 5000.0).unwrap();
        let pupil = ExitPupil::compute_moved(
            &system,
            film_distance,
            diagonal,
            setup.sampling,
            setup.spectral,
            &setup.movements,
        );
        assert!(
            !setup.spectral || system.dispersion.is_some(),
            "no glass data"
        );
        TestLens {
            system,
            pupil,
            film: FilmGeometry::new(24, 16, diagonal).moved(setup.movements),
            spectral: setup.spectral,
        }
    }

    pub(crate) fn camera(&self) -> LensCamera<'_> {
        LensCamera {
            system: &self.system,
            pupil: &self.pupil,
            film: self.film,
            // A camera turned and placed off the origin, so the world move is exercised.
            world_from_camera: glam::Mat4::from_rotation_translation(
                glam::Quat::from_euler(glam::EulerRot::YXZ, 0.4, -0.2, 0.1),
                glam::Vec3::new(1.5, -0.25, 3.0),
            ),
            dispersion: self.system.dispersion.as_deref().filter(|_| self.spectral),
            wavelengths: 1,
            ghosts: None,
        }
    }
}
