//! Optics of the bundled lenses checked against independent numbers: published focal lengths,
//! pbrt's thick-lens focus, exact real-ray fits, reversibility and energy bookkeeping.

use std::path::{Path, PathBuf};

use realcam::lens::aperture::{ApertureSetting, stop_diameter};
use realcam::lens::first_order::{FirstOrder, thick_lens_from_real_rays};
use realcam::lens::focus::{
    FocusError, best_film_distance, closest_focus_mm, paraxial_film_distance, rms_spot_radius,
};
use realcam::lens::pupil::{ExitPupil, PupilSampling};
use realcam::lens::trace::{Ray, Travel, normalize, trace};
use realcam::lens::{LensSystem, Prescription};
use realcam::sampling::Rng;

fn lens_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("lenses")
        .join(name)
}

fn load(name: &str) -> (LensSystem, FirstOrder) {
    let p = Prescription::load(&lens_path(name), None).unwrap();
    let system = LensSystem::new(&p.rows, None);
    let first_order = FirstOrder::compute(&system).unwrap();
    (system, first_order)
}

fn close(actual: f64, expected: f64, relative: f64) -> bool {
    (actual - expected).abs() <= relative * expected.abs()
}

/// EFL and BFL from the independent optical-design numbers (mm).
const PUBLISHED: &[(&str, f64, f64)] = &[
    ("dgauss.50mm.dat", 50.358, 36.106),
    ("wide.22mm.dat", 22.024, 14.318),
    ("telephoto.250mm.dat", 249.57, 105.07),
    ("fisheye.10mm.dat", 9.991, 23.160),
];

#[test]
fn focal_lengths_match_published_values() {
    for &(name, efl, bfl) in PUBLISHED {
        let (_, fo) = load(name);
        assert!(
            close(fo.focal_length, efl, 5e-4),
            "{name}: EFL {} vs {efl}",
            fo.focal_length
        );
        assert!(
            close(fo.back_focal_length, bfl, 5e-4),
            "{name}: BFL {} vs {bfl}",
            fo.back_focal_length
        );
    }
}

#[test]
fn kolb_designs_are_the_same_lenses_at_100mm() {
    // The Kolb files are the 100 mm originals of the pbrt files (scaled by 2, 4.545, 0.4, 10).
    for (kolb, scaled, scale) in [
        ("dgauss.dat", "dgauss.50mm.dat", 2.0),
        ("wide.dat", "wide.22mm.dat", 100.0 / 22.0),
        ("fisheye.dat", "fisheye.10mm.dat", 10.0),
    ] {
        let (_, a) = load(kolb);
        let (_, b) = load(scaled);
        assert!(
            close(a.focal_length, b.focal_length * scale, 2e-3),
            "{kolb}: {} vs {}",
            a.focal_length,
            b.focal_length * scale
        );
    }
    // The Kolb telephoto is Sigler's design at 100 mm: 0.4 × the 250 mm file.
    let (_, tele) = load("telephoto.dat");
    let (_, tele250) = load("telephoto.250mm.dat");
    assert!(
        close(tele.focal_length, tele250.focal_length * 0.4, 2e-2),
        "{}",
        tele.focal_length
    );
}

#[test]
fn matrix_optics_agree_with_real_near_axis_rays() {
    for name in [
        "dgauss.50mm.dat",
        "wide.22mm.dat",
        "telephoto.250mm.dat",
        "fisheye.10mm.dat",
        "dgauss.dat",
        "wide.dat",
        "telephoto.dat",
        "fisheye.dat",
    ] {
        let (system, fo) = load(name);
        let (efl, bfl) =
            thick_lens_from_real_rays(&system, 1e-3 * system.front_semi_aperture()).unwrap();
        assert!(
            close(efl, fo.focal_length, 1e-5),
            "{name}: real {efl} vs paraxial {}",
            fo.focal_length
        );
        assert!(
            close(bfl, fo.back_focal_length, 1e-5),
            "{name}: real {bfl} vs paraxial {}",
            fo.back_focal_length
        );
        // Principal planes sit one focal length from their focal points.
        assert!(close(
            fo.rear_focal_z - fo.rear_principal_z,
            fo.focal_length,
            1e-12
        ));
        assert!(close(
            fo.front_principal_z - fo.front_focal_z,
            fo.focal_length,
            1e-12
        ));
    }
}

#[test]
fn focus_matches_pbrt_thick_lens_answers() {
    for (name, metres, expected) in [
        ("wide.22mm.dat", 1.0, 14.831),
        ("dgauss.50mm.dat", 10.0, 36.362),
    ] {
        let (system, fo) = load(name);
        let film = paraxial_film_distance(&system, &fo, metres * 1000.0).unwrap();
        assert!(
            close(film, expected, 1e-4),
            "{name} at {metres} m: {film} vs {expected}"
        );
    }
}

#[test]
fn focused_paraxial_ray_lands_on_the_film() {
    // Independent of the quadratic: trace a near-axis real ray from the object point and see
    // where it crosses the axis.
    for name in [
        "dgauss.50mm.dat",
        "wide.22mm.dat",
        "telephoto.250mm.dat",
        "fisheye.10mm.dat",
    ] {
        let (system, fo) = load(name);
        for metres in [2.0, 5.0, 30.0] {
            let Ok(film) = paraxial_film_distance(&system, &fo, metres * 1000.0) else {
                continue;
            };
            let film_z = system.rear_z() + film;
            let object_z = film_z - metres * 1000.0;
            let h = 1e-4 * system.front_semi_aperture();
            let ray = Ray {
                origin: [0.0, 0.0, object_z],
                direction: normalize([h, 0.0, -object_z]),
            };
            let out = trace(&system.f64s, ray, Travel::SceneToFilm).unwrap();
            let axis_z = out.origin[2] - out.origin[0] * out.direction[2] / out.direction[0];
            assert!(
                close(axis_z - system.rear_z(), film, 1e-4),
                "{name} at {metres} m: image at {} vs film {film}",
                axis_z - system.rear_z()
            );
        }
    }
}

#[test]
fn too_close_focus_reports_closest_distance() {
    let (system, fo) = load("telephoto.250mm.dat");
    let err = paraxial_film_distance(&system, &fo, 1000.0).unwrap_err();
    let FocusError::TooClose { closest_m, .. } = err else {
        panic!("{err}")
    };
    assert!(closest_m > 1.0 && closest_m.is_finite(), "{closest_m}");
    // Just beyond the closest distance focusing works, and the film is finite.
    let film =
        paraxial_film_distance(&system, &fo, closest_focus_mm(&system, &fo) * 1.001).unwrap();
    assert!(film.is_finite() && film > fo.back_focal_length);
    assert!(err.to_string().contains("closest"));
}

#[test]
fn focus_at_infinity_limit_is_back_focal_length() {
    let (system, fo) = load("dgauss.50mm.dat");
    let film = paraxial_film_distance(&system, &fo, 1e9).unwrap();
    assert!(close(film, fo.back_focal_length, 1e-5));
    // Infinity itself, and distances whose (C·L)² would overflow, focus on the published BFL.
    for distance_mm in [f64::INFINITY, 1e300, f64::MAX] {
        for (name, _, bfl) in PUBLISHED {
            let (system, fo) = load(name);
            let film = paraxial_film_distance(&system, &fo, distance_mm).unwrap();
            assert!(
                close(film, *bfl, 5e-4),
                "{name} at {distance_mm} mm: {film} vs {bfl}"
            );
        }
    }
}

#[test]
fn best_focus_beats_paraxial_focus_for_a_fast_lens() {
    let (system, fo) = load("dgauss.50mm.dat");
    let distance = 5000.0;
    let paraxial = paraxial_film_distance(&system, &fo, distance).unwrap();
    let best = best_film_distance(&system, distance, paraxial).unwrap();
    let spot_paraxial = rms_spot_radius(&system, distance, paraxial).unwrap();
    let spot_best = rms_spot_radius(&system, distance, best).unwrap();
    assert!(
        spot_best < spot_paraxial,
        "best {spot_best} vs paraxial {spot_paraxial}"
    );
    // Undercorrected spherical aberration pulls the best focus toward the lens.
    assert!((best - paraxial).abs() > 1e-3, "{best} vs {paraxial}");
    for delta in [-0.05, 0.05] {
        let nearby = rms_spot_radius(&system, distance, best + delta).unwrap();
        assert!(
            nearby >= spot_best * 0.999,
            "{delta}: {nearby} < {spot_best}"
        );
    }
}

#[test]
fn f_number_sizes_the_entrance_pupil() {
    for name in ["dgauss.50mm.dat", "wide.22mm.dat", "telephoto.250mm.dat"] {
        let (full, fo) = load(name);
        for n in [4.0, 8.0, 16.0] {
            let (d, warning) = stop_diameter(ApertureSetting::FNumber(n), &full, &fo, 1.0).unwrap();
            if warning.is_some() {
                continue;
            }
            let p = Prescription::load(&lens_path(name), None).unwrap();
            let stopped = LensSystem::new(&p.rows, Some(d));
            let fo2 = FirstOrder::compute(&stopped).unwrap();
            assert!(
                close(fo2.f_number, n, 1e-9),
                "{name} f/{n}: got f/{}",
                fo2.f_number
            );
            // Independent check with real near-axis rays: EFL from the thick-lens fit, and the
            // entrance pupil from how much a ray from infinity shrinks on its way to the stop.
            let (efl, _) = thick_lens_from_real_rays(&stopped, 1e-3).unwrap();
            let h = 1e-4;
            let front = stopped.f64s.slice(0..stopped.stop);
            let out = trace(
                &front,
                Ray {
                    origin: [h, 0.0, -1.0],
                    direction: [0.0, 0.0, 1.0],
                },
                Travel::SceneToFilm,
            )
            .unwrap();
            let stop_z = stopped.f64s.vertex_z[stopped.stop];
            let y_stop =
                out.origin[0] + (stop_z - out.origin[2]) * out.direction[0] / out.direction[2];
            let entrance_pupil = d * h / y_stop;
            assert!(
                close(efl / entrance_pupil, n, 1e-4),
                "{name} f/{n}: real rays give f/{}",
                efl / entrance_pupil
            );
        }
    }
    let (full, fo) = load("dgauss.50mm.dat");
    let (d, warning) = stop_diameter(ApertureSetting::Diameter(40.0), &full, &fo, 1.0).unwrap();
    assert_eq!(d, 17.1);
    assert!(warning.unwrap().contains("wider"));
}

#[test]
fn pupils_are_images_of_the_stop() {
    // A ray through the centre of the stop appears, in object space, to aim at the entrance
    // pupil centre, and in image space to come from the exit pupil centre.
    for name in ["dgauss.50mm.dat", "wide.22mm.dat", "telephoto.250mm.dat"] {
        let (system, fo) = load(name);
        let stop_z = system.f64s.vertex_z[system.stop];
        let u = 1e-5;
        // From the stop centre toward the front (reverse) and toward the back.
        let back = Ray {
            origin: [0.0, 0.0, stop_z],
            direction: normalize([u, 0.0, -1.0]),
        };
        let front_only = system.f64s.slice(0..system.stop);
        let out = trace(&front_only, back, Travel::FilmToScene).unwrap();
        let ep_z = out.origin[2] - out.origin[0] * out.direction[2] / out.direction[0];
        assert!(
            (ep_z - fo.entrance_pupil.z_mm).abs() < 1e-3,
            "{name}: EP {ep_z} vs {}",
            fo.entrance_pupil.z_mm
        );
        let fwd = Ray {
            origin: [0.0, 0.0, stop_z],
            direction: normalize([u, 0.0, 1.0]),
        };
        let back_only = system.f64s.slice(system.stop + 1..system.surface_count());
        let out = trace(&back_only, fwd, Travel::SceneToFilm).unwrap();
        let xp_z = out.origin[2] - out.origin[0] * out.direction[2] / out.direction[0];
        assert!(
            (xp_z - fo.exit_pupil.z_mm).abs() < 1e-3,
            "{name}: XP {xp_z} vs {}",
            fo.exit_pupil.z_mm
        );
    }
}

#[test]
fn rays_are_reversible() {
    let mut rng = Rng::new(3, 4);
    for name in [
        "dgauss.50mm.dat",
        "wide.22mm.dat",
        "telephoto.250mm.dat",
        "fisheye.10mm.dat",
        "wide.dat",
    ] {
        let (system, fo) = load(name);
        let film_z = system.rear_z() + fo.back_focal_length;
        let rear = system.rear_semi_aperture();
        let mut checked = 0;
        for _ in 0..2000 {
            let origin = [
                (rng.next_f64() - 0.5) * 0.3 * fo.focal_length,
                (rng.next_f64() - 0.5) * 0.3 * fo.focal_length,
                film_z,
            ];
            let target = [
                (rng.next_f64() - 0.5) * 2.0 * rear,
                (rng.next_f64() - 0.5) * 2.0 * rear,
                system.rear_z(),
            ];
            let d = normalize([
                target[0] - origin[0],
                target[1] - origin[1],
                target[2] - origin[2],
            ]);
            let Ok(out) = trace(
                &system.f64s,
                Ray {
                    origin,
                    direction: d,
                },
                Travel::FilmToScene,
            ) else {
                continue;
            };
            let back = [-out.direction[0], -out.direction[1], -out.direction[2]];
            // Step back off the front surface so the reverse trace meets it again.
            let start = Ray {
                origin: [
                    out.origin[0] - back[0],
                    out.origin[1] - back[1],
                    out.origin[2] - back[2],
                ],
                direction: back,
            };
            let returned = trace(&system.f64s, start, Travel::SceneToFilm).unwrap();
            // The returned ray lies on the original line, heading the opposite way.
            let t = (origin[2] - returned.origin[2]) / returned.direction[2];
            for ((p, d), start) in returned
                .origin
                .iter()
                .zip(returned.direction)
                .zip(origin)
                .take(2)
            {
                assert!((p + t * d - start).abs() < 1e-6, "{name}");
            }
            for (back, forward) in returned.direction.iter().zip(d) {
                assert!((back + forward).abs() < 1e-9, "{name}");
            }
            checked += 1;
        }
        assert!(checked > 100, "{name}: {checked}");
    }
}

#[test]
fn pupil_bounds_contain_every_passing_ray() {
    // Brute force: rays from film points to random rear-plane points that pass the lens must
    // all lie inside the bounds of their segment (else the renderer would miss light).
    for name in [
        "dgauss.50mm.dat",
        "wide.22mm.dat",
        "fisheye.10mm.dat",
        "telephoto.250mm.dat",
    ] {
        // Wide open, and stopped down to a pupil a coarse grid could miss.
        for stop_scale in [None, Some(0.12)] {
            let (full, fo) = load(name);
            let system = match stop_scale {
                None => full,
                Some(k) => LensSystem::new(&full.rows, Some(full.stop_diameter() * k)),
            };
            let film = paraxial_film_distance(&system, &fo, 5000.0).unwrap();
            let diagonal = 35.0;
            let pupil = ExitPupil::compute(&system, film, diagonal, PupilSampling::Bounds);
            let film_z = system.rear_z() + film;
            let mut rng = Rng::new(9, 1);
            let rear = 1.5 * system.rear_semi_aperture();
            let (mut passed, mut outside) = (0, 0);
            let samples = if stop_scale.is_some() {
                1_500_000
            } else {
                60_000
            };
            for _ in 0..samples {
                let r = rng.next_f64() * diagonal / 2.0;
                let p = [
                    (rng.next_f64() * 2.0 - 1.0) * rear,
                    (rng.next_f64() * 2.0 - 1.0) * rear,
                ];
                let d = normalize([p[0] - r, p[1], system.rear_z() - film_z]);
                if trace(
                    &system.f64s,
                    Ray {
                        origin: [r, 0.0, film_z],
                        direction: d,
                    },
                    Travel::FilmToScene,
                )
                .is_ok()
                {
                    passed += 1;
                    let rect = pupil.segment_for(r);
                    let inside = p[0] >= rect.min[0]
                        && p[0] <= rect.max[0]
                        && p[1] >= rect.min[1]
                        && p[1] <= rect.max[1];
                    outside += usize::from(!inside);
                }
            }
            assert!(passed > 300, "{name} {stop_scale:?}: {passed}");
            assert!(
                outside * 2000 <= passed,
                "{name} {stop_scale:?}: {outside} of {passed} passing rays outside the bounds"
            );
        }
    }
}

#[test]
fn bounds_and_rear_element_sampling_measure_the_same_irradiance() {
    // Both estimators integrate cos⁴θ/z² over the passing part of the rear plane: same mean,
    // different variance. Checks the weights and pdfs of both schemes against each other.
    let (system, fo) = load("dgauss.50mm.dat");
    let film = paraxial_film_distance(&system, &fo, 5000.0).unwrap();
    for film_x in [0.0f32, 8.0, 15.0] {
        let mut means = Vec::new();
        for sampling in [PupilSampling::Bounds, PupilSampling::RearElement] {
            let pupil = ExitPupil::compute(&system, film, 35.0, sampling);
            let film_z = (system.rear_z() + film) as f32;
            let mut rng = Rng::new(5, 5);
            let n = 400_000;
            let mut sum = 0.0f64;
            for _ in 0..n {
                let Some(s) = pupil.sample(film_x, 0.0, rng.next_2d()) else {
                    continue;
                };
                let d = normalize([
                    (s.point[0] - film_x) as f64,
                    s.point[1] as f64,
                    (s.point[2] - film_z) as f64,
                ]);
                if trace(
                    &system.f64s,
                    Ray {
                        origin: [film_x as f64, 0.0, film_z as f64],
                        direction: d,
                    },
                    Travel::FilmToScene,
                )
                .is_ok()
                {
                    sum += s.weight as f64;
                }
            }
            means.push(sum / n as f64);
        }
        assert!(means[0] > 0.0);
        assert!(
            close(means[0], means[1], 0.02),
            "film x {film_x}: bounds {} vs rear element {}",
            means[0],
            means[1]
        );
    }
}

/// The working f-number is the image-side cone of an on-axis point at the focus distance:
/// checked with a real near-axis ray from that point (its slope behind the lens, scaled by how
/// far it passes from the stop's centre to the stop's edge), focused at 2 and 5 m, and focused
/// at infinity, where it is the f-number EFL/EPD (the exit pupil and the entrance pupil are
/// images of one stop: a paraxial identity between two separate matrix products).
#[test]
fn working_f_number_is_the_image_side_cone() {
    for name in ["dgauss.50mm.dat", "wide.22mm.dat", "telephoto.250mm.dat"] {
        let (system, fo) = load(name);
        assert!(
            close(fo.working_f_number(fo.rear_focal_z), fo.f_number, 1e-9),
            "{name} at infinity: working f/{} against f/{}",
            fo.working_f_number(fo.rear_focal_z),
            fo.f_number
        );
        let whole = system.f64s.slice(0..system.surface_count());
        let front = system.f64s.slice(0..system.stop);
        let stop_z = system.f64s.vertex_z[system.stop];
        let stop_radius = system.stop_diameter() / 2.0;
        for metres in [2.0, 5.0] {
            let film_distance = paraxial_film_distance(&system, &fo, metres * 1000.0).unwrap();
            let film_z = system.rear_z() + film_distance;
            // The focus distance is measured from the film (as pbrt's).
            let ray = Ray {
                origin: [0.0, 0.0, film_z - metres * 1000.0],
                direction: normalize([1e-6, 0.0, 1.0]),
            };
            let at_stop = trace(&front, ray, Travel::SceneToFilm).unwrap();
            let y_stop = at_stop.origin[0]
                + (stop_z - at_stop.origin[2]) * at_stop.direction[0] / at_stop.direction[2];
            let out = trace(&whole, ray, Travel::SceneToFilm).unwrap();
            let slope = (out.direction[0] / out.direction[2]).abs();
            let marginal_slope = slope * stop_radius / y_stop.abs();
            let working = 1.0 / (2.0 * marginal_slope);
            assert!(
                close(fo.working_f_number(film_z), working, 1e-4),
                "{name} at {metres} m: working f/{} against the real ray's f/{working}",
                fo.working_f_number(film_z)
            );
            assert!(working > fo.f_number, "{name}: closer focus, a slower cone");
        }
    }
}
