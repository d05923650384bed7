//! Aspheric surfaces against exact geometric optics: a conic that images infinity without
//! aberration, paraxial data that see only the vertex curvature, and clear load errors.

use std::path::Path;

use realcam::lens::first_order::{FirstOrder, thick_lens_from_real_rays};
use realcam::lens::trace::{Ray, Travel, trace};
use realcam::lens::{Asphere, LensSystem, Prescription, SurfaceRow};

/// Axial crossings of a collimated beam refracted into glass of index `n` by one surface of
/// radius `radius` and conic `conic`, for entrance heights up to `semi` (mm).
fn axial_crossings(radius: f64, conic: f64, n: f64, semi: f64) -> Vec<f64> {
    let row = SurfaceRow {
        asphere: Asphere {
            conic,
            ..Asphere::NONE
        },
        ..SurfaceRow::new(radius, 0.0, n, 2.0 * semi)
    };
    let system = LensSystem::new(&[row], None);
    (1..=40)
        .map(|k| {
            let h = semi * k as f64 / 40.0;
            let out = trace(
                &system.f64s,
                Ray {
                    origin: [0.0, h, -10.0],
                    direction: [0.0, 0.0, 1.0],
                },
                Travel::SceneToFilm,
            )
            .unwrap();
            // Where the refracted ray crosses the axis.
            out.origin[2] - out.origin[1] * out.direction[2] / out.direction[1]
        })
        .collect()
}

/// A single refracting surface with k = −1/n² (an ellipsoid whose far focus lies in the
/// glass) brings a collimated beam to one point, the paraxial focus n·R/(n − 1); a sphere of
/// the same radius does not (spherical aberration).
#[test]
fn a_conic_with_k_minus_one_over_n_squared_focuses_stigmatically() {
    let (radius, n, semi) = (20.0, 1.5, 10.0);
    let focus = n * radius / (n - 1.0);
    let spread = |crossings: &[f64]| {
        (crossings.iter().map(|z| (z - focus).powi(2)).sum::<f64>() / crossings.len() as f64).sqrt()
    };
    let conic = axial_crossings(radius, -1.0 / (n * n), n, semi);
    let sphere = axial_crossings(radius, 0.0, n, semi);
    assert!(spread(&conic) < 1e-9, "conic RMS {}", spread(&conic));
    // The sphere's marginal focus falls short by ~1.3 mm at this aperture.
    assert!(spread(&sphere) > 0.1, "sphere RMS {}", spread(&sphere));
    assert!(sphere.last().unwrap() < &(focus - 1.0));
}

/// A lens made aspheric with higher-order terms only has its base sphere's paraxial data;
/// an r² term acts as extra vertex curvature, c + 2·A₂, for paraxial matrices and for real
/// rays near the axis alike.
#[test]
fn paraxial_data_see_only_the_vertex_curvature() {
    let base = vec![
        SurfaceRow::new(30.0, 6.0, 1.6, 24.0),
        SurfaceRow::new(-80.0, 3.0, 1.0, 24.0),
        SurfaceRow::new(0.0, 3.0, 1.0, 14.0),
        SurfaceRow::new(-25.0, 2.0, 1.7, 18.0),
        SurfaceRow::new(-60.0, 0.0, 1.0, 20.0),
    ];
    let mut aspheric = base.clone();
    aspheric[0].asphere = Asphere {
        conic: -0.7,
        coefficients: [0.0, 2e-5, -3e-8, 1e-11, 0.0, 0.0, 0.0, 0.0],
    };
    aspheric[4].asphere.conic = 3.0;
    let base_fo = FirstOrder::compute(&LensSystem::new(&base, None)).unwrap();
    let asph_fo = FirstOrder::compute(&LensSystem::new(&aspheric, None)).unwrap();
    assert_eq!(base_fo, asph_fo);

    // With A₂ = 1e-3 mm⁻¹ the first surface's vertex curvature is 1/30 + 2e-3.
    aspheric[0].asphere.coefficients[0] = 1e-3;
    let mut equivalent = base.clone();
    equivalent[0].base.radius = 1.0 / (1.0 / 30.0 + 2e-3);
    let a2 = LensSystem::new(&aspheric, None);
    let a2_fo = FirstOrder::compute(&a2).unwrap();
    let eq_fo = FirstOrder::compute(&LensSystem::new(&equivalent, None)).unwrap();
    assert!((a2_fo.focal_length - eq_fo.focal_length).abs() < 1e-12 * eq_fo.focal_length);
    assert!((a2_fo.back_focal_length - eq_fo.back_focal_length).abs() < 1e-10);
    // Real rays 10 µm from the axis agree with the matrices.
    let (efl, bfl) = thick_lens_from_real_rays(&a2, 1e-2).unwrap();
    assert!(
        (efl - a2_fo.focal_length).abs() < 1e-5 * efl,
        "{efl} vs {}",
        a2_fo.focal_length
    );
    assert!((bfl - a2_fo.back_focal_length).abs() < 1e-4, "{bfl}");
}

fn parse(text: &str) -> Result<Prescription, String> {
    Prescription::parse(text, Path::new("test.toml"), None).map_err(|e| e.to_string())
}

#[test]
fn aspheres_that_cannot_exist_are_load_errors_naming_the_surface() {
    // An oblate ellipsoid (k = 1) of vertex radius 10 closes at r = 10/√2 ≈ 7.07 mm: a 16 mm
    // clear aperture cannot be on it.
    let closed = r#"surfaces = [
      { radius = 10, thickness = 4, glass = { n = 1.5 }, diameter = 16, conic = 1.0 },
      { stop = true, thickness = 4, diameter = 8 },
      { radius = -40, thickness = 30, diameter = 16 },
    ]"#;
    let e = parse(closed).unwrap_err();
    assert!(e.contains("test.toml:2"), "{e}");
    assert!(
        e.contains("surface 1") && e.contains("sag is undefined"),
        "{e}"
    );
    assert!(e.contains("7.07"), "{e}");
    // A strong r⁴ term bends the first surface back through the second inside the aperture.
    let crossing = r#"surfaces = [
      { radius = 50, thickness = 4.0, glass = { n = 1.5 }, diameter = 20, aspheric = [0, 2e-3] },
      { radius = -50, thickness = 5, diameter = 20 },
      { stop = true, thickness = 5, diameter = 10 },
      { radius = 100, thickness = 3, glass = { n = 1.5 }, diameter = 20 },
      { radius = -100, thickness = 30, diameter = 20 },
    ]"#;
    let e = parse(crossing).unwrap_err();
    assert!(e.contains("test.toml:3") && e.contains("surface 2"), "{e}");
    assert!(e.contains("crosses the one before it"), "{e}");
    // The same lens with a gentle term loads.
    assert!(parse(&crossing.replace("2e-3", "2e-6")).is_ok());
}
