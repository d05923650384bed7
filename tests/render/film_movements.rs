//! Film movements and focusing on a pixel, checked against geometry: a shifted frame is the
//! crop of a larger film, a pixel's focus is the focus at the depth it sees, a tilted film
//! focuses on the plane the hinge rule predicts, and the camera weight on a moved film is the
//! irradiance integral over the rear element.

use crate::support;

use support::cli::realcam;

use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3};
use realcam::film::Image;
use realcam::film::filter::Filter;
use realcam::lens::LensSystem;
use realcam::lens::aperture::ApertureSetting;
use realcam::lens::camera::FilmGeometry;
use realcam::lens::elements::{FilmPlacement, FocusSetting, Lens, LensGeometry, build_geometry};
use realcam::lens::focus::{FocusMode, best_film_distance, paraxial_film_distance};
use realcam::lens::focus_probe::{FocusOnPixel, FocusProbe};
use realcam::lens::hero_wavelengths::{DEFAULT_WAVELENGTHS, SPLAT_RADIUS};
use realcam::lens::io::bundled::load_lens;
use realcam::lens::movements::{FilmMovements, check_coverage, light_reaches};
use realcam::lens::pupil::{ExitPupil, PupilSampling};
use realcam::lens::trace::{Ray, Travel, normalize, trace};
use realcam::pipeline::{RenderSettings, Renderer};
use realcam::sampling::Rng;
use realcam::shade::Environment;
use support::{GltfBuilder, matte, quad};

/// Coloured squares at several depths around the view of a camera at the origin looking down
/// −z, over a sky.
fn patchwork(dir: &Path) -> PathBuf {
    let mut gltf = GltfBuilder::default();
    let mut nodes = Vec::new();
    let patches = [
        ([0.0, 0.0, -3.0], 0.25, [0.9, 0.2, 0.2]),
        ([0.12, 0.1, -2.0], 0.1, [0.2, 0.9, 0.2]),
        ([-0.15, 0.12, -4.0], 0.2, [0.2, 0.2, 0.9]),
        ([0.2, -0.15, -2.5], 0.15, [0.9, 0.9, 0.2]),
        ([-0.1, -0.12, -1.5], 0.08, [0.9, 0.3, 0.9]),
    ];
    for (centre, size, colour) in patches {
        let m = matte(&mut gltf, colour);
        nodes.push(quad(&mut gltf, centre, size, m, 1.0));
    }
    gltf.scene(&nodes);
    gltf.write(dir, "patchwork")
}

/// A wall filling the view `distance` m in front of a camera at the origin.
fn wall(dir: &Path, distance: f32) -> PathBuf {
    let mut gltf = GltfBuilder::default();
    let m = matte(&mut gltf, [0.7, 0.7, 0.7]);
    let node = quad(&mut gltf, [0.0, 0.0, -distance], 40.0, m, 1.0);
    gltf.scene(&[node]);
    gltf.write(dir, &format!("wall-{distance}"))
}

struct Shot<'a> {
    scene: &'a Path,
    width: u32,
    height: u32,
    diagonal: f64,
    sampling: PupilSampling,
    movements: FilmMovements,
    spp: u32,
    /// Wavelengths per camera sample (dgauss.50mm has glass data).
    wavelengths: u32,
}

impl Shot<'_> {
    fn renderer(&self) -> (Renderer, bevy_ecs::entity::Entity) {
        let mut renderer = Renderer::new();
        renderer.set_environment(Environment::Uniform(Vec3::splat(0.5)));
        renderer.load_scene(self.scene).unwrap();
        renderer.set_camera(Mat4::IDENTITY);
        renderer.set_film(self.diagonal, self.sampling);
        renderer.set_settings(RenderSettings {
            width: self.width,
            height: self.height,
            seed: 5,
            max_depth: 2,
            tile_size: 16,
            wavelengths: self.wavelengths,
            filter: Filter::Box,
        });
        let lens = renderer.add_lens(
            &load_lens("dgauss.50mm", None).unwrap(),
            FocusSetting::Distance {
                metres: 2.5,
                mode: FocusMode::Paraxial,
            },
            ApertureSetting::FNumber(4.0),
        );
        if !self.movements.is_none() {
            renderer.world.entity_mut(lens).insert(self.movements);
        }
        renderer.set_active_lens(lens);
        (renderer, lens)
    }

    fn render(&self) -> Image {
        let (mut renderer, _) = self.renderer();
        renderer.render(self.spp, |_, _| true).unwrap()
    }
}

/// The pixel pitch is 1/8 mm in both films: 32 × 32 px over 4 × 4 mm (diagonal 4√2 mm) and
/// 64 × 48 px over 8 × 6 mm (diagonal 10 mm), exact in f32.
const PITCH_MM: f64 = 0.125;

/// A 32 × 32 frame shifted by (2, 1) mm = (16, 8) pixels lies in the unshifted 64 × 48 film
/// centred on the axis that just contains it, from x = 32 (its right half: more of the scene
/// to the right) and y = 0 (its top: more above).
fn small_and_large(
    sampling: PupilSampling,
    scene: &Path,
    spp: u32,
    wavelengths: u32,
) -> (Image, Image) {
    let shift = [16.0 * PITCH_MM, 8.0 * PITCH_MM];
    let small = Shot {
        scene,
        width: 32,
        height: 32,
        diagonal: 4.0 * 2f64.sqrt(),
        sampling,
        movements: FilmMovements {
            shift_mm: shift,
            ..FilmMovements::NONE
        },
        spp,
        wavelengths,
    }
    .render();
    let large = Shot {
        scene,
        width: 64,
        height: 48,
        diagonal: 10.0,
        sampling,
        movements: FilmMovements::NONE,
        spp,
        wavelengths,
    }
    .render();
    (small, large)
}

const CROP: [u32; 2] = [32, 0];

/// With rays aimed over the whole rear element, nothing about a camera sample depends on the
/// film's size: pixel keys follow the film lattice, so the shifted frame is the crop bit for
/// bit. (With exit-pupil bounds the pupil's radial segments span the film's reach, which
/// differs between the two films, so the two draw different, equally valid, pupil points:
/// there the crop agrees within noise, below.) With several wavelengths per sample, a
/// companion wavelength landing beyond the frame's edge is off the small film but on the
/// large one, which changes the weights of samples within a few pixels of the edge (within
/// noise, as any estimator's): bit for bit from 3 × the splat radius in.
#[test]
fn shifted_frame_is_exactly_the_crop_of_a_larger_film() {
    let dir = tempfile::tempdir().unwrap();
    let scene = patchwork(dir.path());
    let mut shifted = Vec::new();
    for (wavelengths, margin) in [(1, 0), (DEFAULT_WAVELENGTHS, 3 * SPLAT_RADIUS as u32)] {
        let (small, large) = small_and_large(PupilSampling::RearElement, &scene, 4, wavelengths);
        shifted.push(small.mean());
        let (small_mean, large_mean) = (small.mean(), large.mean());
        let mut lit = 0;
        for y in margin..32 - margin {
            for x in margin..32 - margin {
                let s = small_mean[(y * 32 + x) as usize];
                let l = large_mean[((y + CROP[1]) * 64 + x + CROP[0]) as usize];
                assert_eq!(s, l, "pixel {x},{y}, {wavelengths} wavelengths");
                lit += usize::from(s[0] + s[1] + s[2] > 0.0);
            }
        }
        assert!(
            lit > 200,
            "{lit} lit pixels: the comparison must see the scene"
        );
    }
    // And the shift moved the frame: the unshifted small frame is another region.
    let unshifted = Shot {
        scene: &scene,
        width: 32,
        height: 32,
        diagonal: 4.0 * 2f64.sqrt(),
        sampling: PupilSampling::RearElement,
        movements: FilmMovements::NONE,
        spp: 4,
        wavelengths: 1,
    }
    .render();
    let small_film = FilmGeometry::new(32, 32, 4.0 * 2f64.sqrt());
    let large_film = FilmGeometry::new(64, 48, 10.0);
    assert_eq!(small_film.width_mm / 32.0, large_film.width_mm / 64.0);
    assert_eq!(small_film.height_mm / 32.0, large_film.height_mm / 48.0);
    assert_ne!(unshifted.mean(), shifted[0]);
}

#[test]
fn shifted_frame_matches_the_crop_within_noise_with_pupil_bounds() {
    let dir = tempfile::tempdir().unwrap();
    let scene = patchwork(dir.path());
    let (small, large) = small_and_large(PupilSampling::Bounds, &scene, 64, DEFAULT_WAVELENGTHS);
    let (small_mean, large_mean) = (small.mean(), large.mean());
    // 8 × 8 blocks of the frame: means agree to the noise of 64 samples × 64 pixels.
    for by in 0..4 {
        for bx in 0..4 {
            let (mut s, mut l) = (0.0f64, 0.0f64);
            for y in by * 8..by * 8 + 8 {
                for x in bx * 8..bx * 8 + 8 {
                    let a = small_mean[(y * 32 + x) as usize];
                    let b = large_mean[((y + CROP[1]) * 64 + x + CROP[0]) as usize];
                    s += (a[0] + a[1] + a[2]) as f64;
                    l += (b[0] + b[1] + b[2]) as f64;
                }
            }
            assert!(
                (s / l - 1.0).abs() < 0.03,
                "block {bx},{by}: shifted {s} vs crop {l}"
            );
        }
    }
}

/// An independent integral of the camera weight for a film point: the irradiance per unit
/// radiance, ∫ cos θ_film cos θ_rear / d² dA over a fine grid on the rear-vertex plane, rays
/// traced exactly in f64 (none of the exit-pupil code).
fn irradiance_integral(system: &LensSystem, point: [f64; 3], normal: [f64; 3]) -> f64 {
    const GRID: usize = 500;
    let half = 1.5 * system.rear_semi_aperture();
    let cell = 2.0 * half / GRID as f64;
    let rear_z = system.rear_z();
    let mut sum = 0.0;
    for iy in 0..GRID {
        for ix in 0..GRID {
            let p = [
                -half + (ix as f64 + 0.5) * cell,
                -half + (iy as f64 + 0.5) * cell,
                rear_z,
            ];
            let to = [p[0] - point[0], p[1] - point[1], p[2] - point[2]];
            let d2 = to[0] * to[0] + to[1] * to[1] + to[2] * to[2];
            let direction = normalize(to);
            let ray = Ray {
                origin: point,
                direction,
            };
            if trace(&system.f64s, ray, Travel::FilmToScene).is_err() {
                continue;
            }
            let cos_film =
                (direction[0] * normal[0] + direction[1] * normal[1] + direction[2] * normal[2])
                    .abs();
            let cos_rear = direction[2].abs();
            sum += cos_film * cos_rear / d2 * cell * cell;
        }
    }
    sum
}

fn dgauss(aperture: ApertureSetting) -> LensGeometry {
    let prescription = load_lens("dgauss.50mm", None).unwrap();
    build_geometry(&Lens::of(&prescription), &prescription.rows, aperture).unwrap()
}

/// The camera weight's mean over pupil samples (rays the lens blocks weigh 0) against the
/// irradiance integral, at film points of a shifted and tilted film: the pupil bounds must
/// cover points beyond the unshifted film's radius and off the frame centre's plane, and the
/// film cosine must be taken against the tilted normal (which the untilted formula, cos⁴θ,
/// misses by far more than the tolerance at 25°).
#[test]
fn camera_weight_on_a_moved_film_is_the_irradiance_integral() {
    let geometry = dgauss(ApertureSetting::FNumber(2.8));
    let system = &geometry.system;
    let film_distance = paraxial_film_distance(system, &geometry.first_order, 3000.0).unwrap();
    let film_z = system.rear_z() + film_distance;
    let movements = FilmMovements {
        shift_mm: [6.0, -4.0],
        tilt_deg: [25.0, -10.0],
    };
    let diagonal = 24.0;
    let pupil = ExitPupil::compute_moved(
        system,
        film_distance,
        diagonal,
        PupilSampling::Bounds,
        false,
        &movements,
    );
    let normal = movements.film_normal();
    let mut rng = Rng::new(9, 1);
    let mut separation = 0.0f64;
    for [a, b] in [[0.0, 0.0], [-8.0, 6.0], [-9.0, -5.5], [-5.0, 8.0]] {
        let point = movements.film_point(a, b, film_z);
        assert!(
            point[0].hypot(point[1]) > diagonal / 2.0 || a == 0.0,
            "the film point must lie beyond the unshifted film"
        );
        let expected = irradiance_integral(system, point, normal);
        const N: usize = 40_000;
        let depth = (point[2] - system.rear_z()) as f32;
        let (x, y) = (point[0] as f32, point[1] as f32);
        let mut sum = 0.0f64;
        for _ in 0..N {
            let Some(s) = pupil.sample_at(x, y, depth, rng.next_2d()) else {
                continue;
            };
            let to = [s.point[0] - x, s.point[1] - y, s.point[2] - point[2] as f32];
            let ray = Ray {
                origin: point,
                direction: normalize(to.map(f64::from)),
            };
            if trace(&system.f64s, ray, Travel::FilmToScene).is_ok() {
                sum += s.weight as f64;
            }
        }
        let measured = sum / N as f64;
        assert!(
            (measured / expected - 1.0).abs() < 0.03,
            "film point ({a}, {b}): sampled {measured} vs integral {expected}"
        );
        let untilted = irradiance_integral(system, point, [0.0, 0.0, 1.0]);
        separation = separation.max((untilted / expected - 1.0).abs());
        eprintln!(
            "film point ({a}, {b}): sampled {measured:.5}, integral {expected:.5}, untilted cosine {untilted:.5}"
        );
    }
    assert!(
        separation > 0.1,
        "the test must tell the tilted cosine from the untilted one: at most {separation} apart"
    );
}

/// Focusing on a pixel of a wall 2.5 m away gives the film distance that --focus-distance
/// 2.5 gives, within the depth of focus (2·N·c, c = 0.03 mm), and the real-ray best focus
/// almost exactly on the axis; off the axis the pixel sees the same depth.
#[test]
fn focusing_on_a_pixel_gives_the_focus_at_the_depth_it_sees() {
    let dir = tempfile::tempdir().unwrap();
    let scene = wall(dir.path(), 2.5);
    let shot = Shot {
        scene: &scene,
        width: 48,
        height: 32,
        diagonal: 35.0,
        sampling: PupilSampling::Bounds,
        movements: FilmMovements::NONE,
        spp: 1,
        wavelengths: DEFAULT_WAVELENGTHS,
    };
    let (mut renderer, lens) = shot.renderer();
    let geometry = dgauss(ApertureSetting::FNumber(4.0));
    let paraxial = paraxial_film_distance(&geometry.system, &geometry.first_order, 2500.0).unwrap();
    let best = best_film_distance(&geometry.system, 2500.0, paraxial).unwrap();
    let depth_of_focus = 2.0 * geometry.first_order.f_number * 0.03;
    for (pixel, tight) in [([24, 16], true), ([3, 28], false), ([40, 2], false)] {
        renderer.world.entity_mut(lens).insert(FocusOnPixel {
            x: pixel[0],
            y: pixel[1],
        });
        renderer.update().unwrap();
        renderer.check_active_lens().unwrap();
        let probe = *renderer.world.get::<FocusProbe>(lens).unwrap();
        assert!(
            (probe.object_distance_mm - 2500.0).abs() < 0.5,
            "pixel {pixel:?} sees {probe:?}"
        );
        assert!(
            (probe.film_distance - paraxial).abs() < depth_of_focus,
            "pixel {pixel:?}: {} vs --focus-distance's {paraxial} (depth of focus {depth_of_focus})",
            probe.film_distance
        );
        if tight {
            assert!(
                (probe.film_distance - best).abs() < 2e-3,
                "on axis: {} vs best focus {best}",
                probe.film_distance
            );
        }
        // The render uses the solved placement.
        let placed = renderer
            .world
            .get::<realcam::lens::elements::FilmPlacement>(lens)
            .unwrap()
            .film_distance;
        assert_eq!(placed, probe.film_distance);
    }
    // Dropping the target focuses by the focus setting again.
    renderer.world.entity_mut(lens).remove::<FocusOnPixel>();
    renderer.update().unwrap();
    let placed = renderer
        .world
        .get::<realcam::lens::elements::FilmPlacement>(lens)
        .unwrap()
        .film_distance;
    assert_eq!(placed, paraxial);
}

#[test]
fn focusing_on_sky_or_outside_the_image_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let mut gltf = GltfBuilder::default();
    let m = matte(&mut gltf, [0.7, 0.7, 0.7]);
    let node = quad(&mut gltf, [0.0, 0.0, -3.0], 0.05, m, 1.0);
    gltf.scene(&[node]);
    let scene = gltf.write(dir.path(), "speck");
    let shot = Shot {
        scene: &scene,
        width: 32,
        height: 32,
        diagonal: 35.0,
        sampling: PupilSampling::Bounds,
        movements: FilmMovements::NONE,
        spp: 1,
        wavelengths: DEFAULT_WAVELENGTHS,
    };
    let (mut renderer, lens) = shot.renderer();
    for (pixel, expected) in [
        ([1, 1], "sees only the sky"),
        ([32, 0], "outside the 32×32 image"),
    ] {
        renderer.world.entity_mut(lens).insert(FocusOnPixel {
            x: pixel[0],
            y: pixel[1],
        });
        renderer.update().unwrap();
        let error = renderer.check_active_lens().unwrap_err().to_string();
        assert!(error.contains(expected), "{pixel:?}: {error}");
    }
}

/// Scheimpflug: with the film tilted, the plane of sharp focus passes through the line where
/// the film plane meets the rear principal plane, carried to the same height in the front
/// principal plane (the hinge rule, from the principal planes' unit magnification), and
/// through the on-axis conjugate of the frame centre. Object points on that predicted plane,
/// over a range of depths, image to small real-ray spots on the tilted film, and to large
/// ones on the untilted film.
#[test]
fn tilted_film_focuses_on_the_plane_the_hinge_rule_predicts() {
    let geometry = dgauss(ApertureSetting::FNumber(8.0));
    let system = &geometry.system;
    let fo = &geometry.first_order;
    let focus = 3000.0;
    let film_distance = paraxial_film_distance(system, fo, focus).unwrap();
    let film_z = system.rear_z() + film_distance;
    let tilt = 6.0f64;
    let movements = FilmMovements {
        tilt_deg: [tilt, 0.0],
        ..FilmMovements::NONE
    };
    // The film plane in (y, z): through (0, film_z) along (cos, sin): it meets the rear
    // principal plane at height h.
    let (sin, cos) = tilt.to_radians().sin_cos();
    let h = (fo.rear_principal_z - film_z) / sin * cos;
    let object_z0 = film_z - focus;
    // The plane of focus: through (h, front principal z) and (0, object_z0).
    let on_plane = |z: f64| h * (z - object_z0) / (fo.front_principal_z - object_z0);
    let spread_on = |object: [f64; 3], tilted: bool| -> f64 {
        // Rays from the object over the entrance pupil, met with the film plane.
        let normal = if tilted {
            movements.film_normal()
        } else {
            [0.0, 0.0, 1.0]
        };
        let aim = system.front_semi_aperture();
        let mut hits = Vec::new();
        for iy in 0..48 {
            for ix in 0..48 {
                let x = aim * ((ix as f64 + 0.5) / 24.0 - 1.0);
                let y = aim * ((iy as f64 + 0.5) / 24.0 - 1.0);
                let direction = normalize([x - object[0], y - object[1], -object[2]]);
                let Ok(out) = trace(
                    &system.f64s,
                    Ray {
                        origin: object,
                        direction,
                    },
                    Travel::SceneToFilm,
                ) else {
                    continue;
                };
                // The film plane through (0, 0, film_z) with `normal`.
                let o = out.origin;
                let d = out.direction;
                let t = ((film_z - o[2]) * normal[2] - o[0] * normal[0] - o[1] * normal[1])
                    / (d[0] * normal[0] + d[1] * normal[1] + d[2] * normal[2]);
                hits.push([o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]]);
            }
        }
        assert!(hits.len() > 50, "{object:?}: {} rays", hits.len());
        let n = hits.len() as f64;
        let c = hits.iter().fold([0.0; 3], |c, p| {
            [c[0] + p[0] / n, c[1] + p[1] / n, c[2] + p[2] / n]
        });
        (hits
            .iter()
            .map(|p| (p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2) + (p[2] - c[2]).powi(2))
            .sum::<f64>()
            / n)
            .sqrt()
    };
    let mut checked = 0;
    for depth in [1500.0, 2000.0, 4000.0, 8000.0, 20000.0] {
        let z = film_z - depth;
        let object = [0.0, on_plane(z), z];
        let sharp = spread_on(object, true);
        let flat = spread_on(object, false);
        assert!(
            sharp < 0.012 && sharp < flat / 4.0,
            "depth {depth} mm, height {:.1} mm: spot {sharp} mm on the tilted film vs {flat} mm untilted",
            object[1]
        );
        checked += 1;
    }
    assert_eq!(checked, 5);
    // Positive X tilt lays the plane toward the ground: nearer points lie lower.
    assert!(on_plane(film_z - 1500.0) < 0.0 && on_plane(film_z - 20000.0) > 0.0);
}

/// Coverage: a frame shifted out of the image circle is a warning, tilted or not; a tilt that
/// darkens a real part of what the untilted frame has light on (or that drives the film into
/// the lens) an error.
#[test]
fn coverage_warns_for_shift_and_refuses_an_uncoverable_tilt() {
    let geometry = dgauss(ApertureSetting::Full);
    let system = &geometry.system;
    let film_distance = paraxial_film_distance(system, &geometry.first_order, 5000.0).unwrap();
    let (w, h) = (36.0, 24.0);
    let shifted = |shift_mm: [f64; 2], tilt_deg: [f64; 2]| {
        check_coverage(
            system,
            film_distance,
            &FilmMovements { shift_mm, tilt_deg },
            w,
            h,
        )
    };
    assert_eq!(shifted([3.0, 2.0], [0.0, 0.0]), Ok(None));
    let far = shifted([40.0, 0.0], [0.0, 0.0]).unwrap().unwrap();
    assert!(
        far.contains("image circle") && far.contains("corner"),
        "{far}"
    );
    // A small tilt loses nothing the shift had not lost: the same warning, not a refusal.
    assert_eq!(shifted([40.0, 0.0], [2.0, 0.0]), Ok(Some(far.clone())));
    // Swung 30° with its far side out near the edge of the image circle, a frame loses light
    // the untilted frame has: refused.
    let (shift, tilt) = ([10.0, 0.0], [0.0, -30.0]);
    let error = shifted(shift, tilt).unwrap_err();
    assert!(
        error.contains("beyond what this lens can cover") && error.contains("% of the frame"),
        "{error}"
    );
    // The lens itself says so: on a grid of its own over the frame, edges included, points
    // with light untilted have none tilted.
    let film_z = system.rear_z() + film_distance;
    let (untilted, tilted) = (
        FilmMovements {
            shift_mm: shift,
            tilt_deg: [0.0; 2],
        },
        FilmMovements {
            shift_mm: shift,
            tilt_deg: tilt,
        },
    );
    let lost = (0..=12)
        .flat_map(|i| (0..=12).map(move |j| (i as f64 / 12.0 - 0.5, j as f64 / 12.0 - 0.5)))
        .filter(|&(u, v)| {
            light_reaches(system, untilted.film_point(u * w, v * h, film_z))
                && !light_reaches(system, tilted.film_point(u * w, v * h, film_z))
        })
        .count();
    assert!(lost > 3, "{lost} of 169 points lost: {error}");
    // A large format steeply tilted: its edge swings into the lens.
    let steep = FilmMovements {
        tilt_deg: [0.0, 59.0],
        ..FilmMovements::NONE
    };
    let error = check_coverage(system, film_distance, &steep, 120.0, 80.0).unwrap_err();
    assert!(error.contains("into the lens"), "{error}");
    assert!(shifted([0.0, 0.0], [5.0, -3.0]).unwrap().is_none());
}

/// The same verdicts derived on the lens entity (no caller has to ask): an uncoverable tilt
/// faults the lens until the tilt is taken back, dark corners are a warning on it, tilted or
/// not, and taking the movements away judges the unmoved film (a film larger than the lens
/// covers warns without any movement).
#[test]
fn coverage_is_derived_on_the_lens_entity() {
    use realcam::lens::coverage::FilmCoverage;
    let mut renderer = Renderer::new();
    renderer.set_settings(RenderSettings {
        width: 36,
        height: 24,
        ..RenderSettings::default()
    });
    renderer.set_film(43.27, PupilSampling::Bounds);
    let lens = renderer.add_lens(
        &load_lens("dgauss.50mm", None).unwrap(),
        FocusSetting::Distance {
            metres: 5.0,
            mode: FocusMode::Paraxial,
        },
        ApertureSetting::Full,
    );
    renderer.set_active_lens(lens);
    let mut moved = |shift_mm: [f64; 2], tilt_deg: [f64; 2]| {
        renderer
            .world
            .entity_mut(lens)
            .insert(FilmMovements { shift_mm, tilt_deg });
        renderer.update().unwrap();
        let coverage = renderer.world.get::<FilmCoverage>(lens).cloned();
        (
            coverage,
            renderer.check_active_lens().map_err(|e| e.to_string()),
        )
    };
    assert_eq!(
        moved([3.0, 2.0], [0.0, 0.0]),
        (Some(FilmCoverage::Covered), Ok(()))
    );
    let (coverage, active) = moved([40.0, 0.0], [0.0, 0.0]);
    assert!(
        coverage
            .as_ref()
            .unwrap()
            .warning()
            .unwrap()
            .contains("image circle")
    );
    assert!(active.is_ok());
    assert_eq!(moved([40.0, 0.0], [2.0, 0.0]), (coverage, Ok(())));
    let (coverage, active) = moved([10.0, 0.0], [0.0, -30.0]);
    assert!(matches!(coverage, Some(FilmCoverage::Uncovered(_))));
    assert!(
        active
            .unwrap_err()
            .contains("beyond what this lens can cover")
    );
    assert_eq!(
        moved([0.0, 0.0], [5.0, -3.0]),
        (Some(FilmCoverage::Covered), Ok(()))
    );
    renderer.world.entity_mut(lens).remove::<FilmMovements>();
    renderer.update().unwrap();
    assert_eq!(
        renderer.world.get::<FilmCoverage>(lens),
        Some(&FilmCoverage::Covered)
    );
    assert!(renderer.check_active_lens().is_ok());
    // A 70 mm film, unmoved: its corners lie outside dgauss.50mm's image circle (no light
    // reaches a point 35 mm off the axis), so it renders with a warning.
    renderer.set_film(70.0, PupilSampling::Bounds);
    renderer.update().unwrap();
    let system = &renderer.world.get::<LensGeometry>(lens).unwrap().system;
    let film_z = system.rear_z()
        + renderer
            .world
            .get::<FilmPlacement>(lens)
            .unwrap()
            .film_distance;
    assert!(!light_reaches(
        system,
        [35.0 * 36.0 / 43.27, 35.0 * 24.0 / 43.27, film_z]
    ));
    let warning = renderer
        .world
        .get::<FilmCoverage>(lens)
        .unwrap()
        .warning()
        .unwrap();
    assert!(
        warning.contains("larger than the lens covers") && warning.contains("image circle"),
        "{warning}"
    );
    assert!(renderer.check_active_lens().is_ok());
}

/// The default scene's 70 mm film is larger than dgauss.50mm covers (its corners are dark by
/// design): every render of it warns so, tilted or not, and a tilt is refused only for what it
/// loses — README's `--tilt 8,0 --focus-on 256,400` (here scaled to 64 pixels) renders.
#[test]
fn default_scene_tilts_are_judged_by_what_they_lose() {
    let dir = tempfile::tempdir().unwrap();
    let render = |extra: &[&str]| {
        let mut args = vec![
            "render",
            "--width",
            "64",
            "--height",
            "64",
            "--spp",
            "1",
            "--max-depth",
            "1",
            "--out",
            "x.png",
        ];
        args.extend(extra);
        let output = realcam(dir.path(), &args);
        let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
        (output.status.success(), stderr)
    };
    let dark_corners = |stderr: &str| -> Vec<String> {
        stderr
            .lines()
            .filter(|line| {
                line.starts_with("warning: ") && line.contains("out of the lens's image circle")
            })
            .map(str::to_string)
            .collect()
    };
    let (ok, stderr) = render(&[]);
    assert!(ok, "{stderr}");
    let untilted = dark_corners(&stderr);
    assert_eq!(untilted.len(), 1, "{stderr}");
    assert!(
        untilted[0].contains("larger than the lens covers") && untilted[0].contains("corners"),
        "{stderr}"
    );
    for tilt in [
        &["--tilt", "0.01,0"][..],
        &["--tilt", "8,0", "--focus-on", "32,50"],
    ] {
        let (ok, stderr) = render(tilt);
        assert!(ok, "{tilt:?}: {stderr}");
        assert_eq!(dark_corners(&stderr), untilted, "{tilt:?}: {stderr}");
    }
    // A steep tilt darkens a real part of what the untilted film has light on: refused.
    let (ok, stderr) = render(&["--tilt", "40,0"]);
    assert!(!ok, "{stderr}");
    assert!(
        stderr.contains("tilt 40,0° (shift 0,0 mm) is beyond what this lens can cover: it darkens"),
        "{stderr}"
    );
}

/// `realcam render SCENE` of a tiny, one-bounce frame from the origin looking down −z (at a
/// [`wall`]).
fn facing_the_wall(scene: &str) -> Vec<&str> {
    vec![
        "render",
        scene,
        "--width",
        "24",
        "--height",
        "16",
        "--spp",
        "1",
        "--max-depth",
        "1",
        "--look-from",
        "0,0,0",
        "--look-at",
        "0,0,-1",
    ]
}

/// From the command line: --focus-on with two lenses and an aperture sweep prints and records
/// each frame's object and film distance; with --shift and --tilt too, and the fingerprint
/// of a checkpoint records the movements; bad values are clear errors.
#[test]
fn cli_focus_on_with_lenses_sweeps_and_movements() {
    let dir = tempfile::tempdir().unwrap();
    let scene = wall(dir.path(), 2.5);
    let scene = scene.to_str().unwrap();
    let common = facing_the_wall(scene);
    let mut args: Vec<&str> = common.clone();
    args.extend([
        "--lens",
        "dgauss.50mm",
        "--lens",
        "wide.22mm",
        "--focus-on",
        "20,3",
        "--aperture-sweep",
        "4:8:2",
        "--shift",
        "1,-0.5",
        "--tilt",
        "2,1",
        "--stats",
        "stats.json",
        "--out",
        "f.png",
    ]);
    let output = realcam(dir.path(), &args);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert_eq!(stderr.matches("focus on pixel 20,3").count(), 4, "{stderr}");
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("stats.json")).unwrap()).unwrap();
    let frames = stats["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 4);
    for frame in frames {
        let metres = frame["focus_distance_m"].as_f64().unwrap();
        // The tilted film's pixel sees the wall at 2.5 m depth.
        assert!((metres - 2.5).abs() < 1e-3, "{frame}");
        assert!(frame["film_distance_mm"].as_f64().unwrap() > 0.0);
        assert_eq!(frame["focus_on"], serde_json::json!([20, 3]));
    }
    for (extra, expected) in [
        (vec!["--focus-on", "24,0"], "outside the 24×16 image"),
        (vec!["--focus-on", "-1,2"], "is not a pixel"),
        (vec!["--tilt", "75,0"], "--tilt 75,0°"),
        (vec!["--shift", "nan,1"], "not two finite numbers"),
        (
            vec!["--shift", "1e308,0"],
            "--shift 1e308,0 mm: each component must be a number of mm between −1000 and 1000",
        ),
        // A tilt that darkens a real part of what the untilted 70 mm film has light on (the
        // film is larger than the lens covers: that alone is a warning).
        (
            vec!["--tilt", "40,0", "--film-diagonal", "70"],
            "beyond what this lens can cover",
        ),
    ] {
        let mut args: Vec<&str> = common.clone();
        args.extend(extra.iter().copied());
        args.extend(["--out", "bad.png"]);
        let output = realcam(dir.path(), &args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(!output.status.success(), "{extra:?} succeeded");
        assert!(stderr.contains(expected), "{extra:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(!dir.path().join("bad.png").exists());
    }
    // A frame shifted out of the image circle renders, with a warning.
    let mut args: Vec<&str> = common.clone();
    args.extend(["--shift", "30,0", "--out", "shifted.png"]);
    let output = realcam(dir.path(), &args);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(output.status.success(), "{stderr}");
    assert!(
        stderr.contains("out of the lens's image circle"),
        "{stderr}"
    );
}

/// Shards and checkpoints: the fingerprint records the movements and the pixel focused on only
/// when they are set (an unmoved render keeps the fingerprint it always had), so shards
/// rendered with different shifts are refused by `realcam merge`, and those with the same
/// merge.
#[test]
fn shards_record_movements_only_when_set() {
    let dir = tempfile::tempdir().unwrap();
    let scene = wall(dir.path(), 2.5);
    let scene = scene.to_str().unwrap();
    let shard = |index: &str, extra: &[&str], partial: &str| {
        let mut args = vec![
            "render",
            scene,
            "--width",
            "8",
            "--height",
            "8",
            "--spp",
            "4",
            "--max-depth",
            "1",
            "--look-from",
            "0,0,0",
            "--look-at",
            "0,0,-1",
            "--shard",
            index,
            "--partial",
            partial,
        ];
        args.extend(extra);
        let output = realcam(dir.path(), &args);
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        realcam::film::checkpoint::read_checkpoint(&dir.path().join(partial))
            .unwrap()
            .1
            .settings
    };
    let plain = shard("0/2", &[], "plain.exr");
    for key in ["shift_mm", "tilt_deg", "focus_on"] {
        assert!(plain.get(key).is_none(), "{key} in {plain}");
    }
    let moved = ["--shift", "1,0", "--tilt", "1,0", "--focus-on", "4,4"];
    let a = shard("0/2", &moved, "a.exr");
    assert_eq!(a["shift_mm"], serde_json::json!([1.0, 0.0]));
    assert_eq!(a["focus_on"], serde_json::json!([4, 4]));
    shard("1/2", &moved, "b.exr");
    shard(
        "1/2",
        &["--shift", "2,0", "--tilt", "1,0", "--focus-on", "4,4"],
        "c.exr",
    );
    let merge = |parts: [&str; 2]| {
        realcam(
            dir.path(),
            &["merge", parts[0], parts[1], "--out", "merged.exr"],
        )
    };
    let refused = merge(["a.exr", "c.exr"]);
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(
        !refused.status.success() && stderr.contains("shift_mm"),
        "{stderr}"
    );
    let merged = merge(["a.exr", "b.exr"]);
    assert!(
        merged.status.success(),
        "{}",
        String::from_utf8_lossy(&merged.stderr)
    );
}

/// A lens that focuses by moving groups focuses on a pixel with them: the internal-focus
/// Samyang 85 mm, looking at a wall 1.5 m away, moves its groups for that distance and keeps
/// its film where the patent's back focus is (16.854 mm in air at infinity, 17.045 mm at its
/// 0.9 m close focus, WO 2021/085655 A1 Ex. 3), where moving the whole lens would have put the
/// film about f²/(d − f) ≈ 5 mm further back. A wall closer than its close focus is refused.
#[test]
fn a_focus_group_lens_focuses_on_a_pixel_with_its_groups() {
    let dir = tempfile::tempdir().unwrap();
    let render = |scene: &Path| {
        let mut args = facing_the_wall(scene.to_str().unwrap());
        args.extend([
            "--lens",
            "samyang-af-85mm-f1.4-if",
            "--focus-on",
            "12,8",
            // Stopped down, the real rays' sharpest focus (where --focus-on puts the film) is
            // the paraxial one the patent's back focus gives, to well under its 0.2 mm travel.
            "--f-number",
            "11",
            "--stats",
            "stats.json",
            "--out",
            "f.png",
        ]);
        let output = realcam(dir.path(), &args);
        (
            output.status.success(),
            String::from_utf8_lossy(&output.stderr).into_owned(),
        )
    };
    let (ok, stderr) = render(&wall(dir.path(), 1.5));
    assert!(ok, "{stderr}");
    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("stats.json")).unwrap()).unwrap();
    let frame = &stats["frames"][0];
    let metres = frame["focus_distance_m"].as_f64().unwrap();
    assert!((metres - 1.5).abs() < 2e-3, "{frame}");
    let film = frame["film_distance_mm"].as_f64().unwrap();
    assert!(film > 16.8 && film < 17.05, "film {film} mm: {frame}");

    let (ok, stderr) = render(&wall(dir.path(), 0.5));
    assert!(!ok, "{stderr}");
    assert!(
        stderr.contains("closer than this lens focuses") && stderr.contains("0.9 m"),
        "{stderr}"
    );
}
