//! Zoom positions and focus groups against first-order optics computed here, independently of
//! realcam's ABCD matrices: a paraxial y-nu trace of each position's surfaces, written out in
//! this file.
//!
//! The test zoom is two positive groups, a 3 mm equiconvex singlet of radius 100 mm (f₁ ≈
//! 100.5 mm) and a 4 mm one of radius 50 mm (f₂ ≈ 50.7 mm), both of index 1.5, the stop 2 mm
//! before the second; the gap after the first group is 20, 50 or 90 mm, so by
//! f = f₁f₂ / (f₁ + f₂ − d), with d between the principal planes (each about mid-element,
//! d ≈ gap + 5.5 mm), the focal length runs from about 40 to about 90 mm.

use std::path::Path;

use bevy_ecs::schedule::Schedule;
use bevy_ecs::world::World;
use realcam::lens::Prescription;
use realcam::lens::aperture::ApertureSetting;
use realcam::lens::camera::FilmResolution;
use realcam::lens::elements::{
    FilmFormat, FocusSetting, LensDerivationStats, LensGeometry, add_lens_systems,
    set_zoom_position, spawn_lens,
};
use realcam::lens::io::toml::write_lens_file;
use realcam::lens::report::LensReport;
use realcam::lens::settings::LensSettings;
use serde_json::json;

/// The test zoom as realcam's `.toml`; the stop opens 10, 9 and 8 mm at the three positions.
use crate::support::TWO_GROUP_ZOOM as ZOOM_TOML;

/// The gap after the first group at each position, mm.
const GAPS: [f64; 3] = [20.0, 50.0, 90.0];

/// The same zoom as a Zemax multi-configuration file: an f-number per configuration (`APER`
/// under `FNUM`), the stop sized by OpticStudio's rule, the image distance (`THIC 5`) and the
/// first surface's semi-diameter (`SDIA 1`) per configuration too, and the fields (ignored).
const ZOOM_ZMX: &str = "VERS 190513 80 123457 L123457
MODE SEQ
UNIT MM X W X CM MR CPMM
FNUM 4 0
SURF 0
  TYPE STANDARD
  CURV 0.0
  DISZ INFINITY
SURF 1
  TYPE STANDARD
  CURV 0.01
  DISZ 3
  GLAS ___BLANK 1 0 1.5 0
  DIAM 15
SURF 2
  TYPE STANDARD
  CURV -0.01
  DISZ 20
  DIAM 15
SURF 3
  STOP
  TYPE STANDARD
  CURV 0.0
  DISZ 2
SURF 4
  TYPE STANDARD
  CURV 0.02
  DISZ 4
  GLAS ___BLANK 1 0 1.5 0
  DIAM 12
SURF 5
  TYPE STANDARD
  CURV -0.02
  DISZ 40
  DIAM 12
SURF 6
  TYPE STANDARD
  CURV 0.0
  DISZ 0
TOL TOFF   0   0              0              0   0 0 0
MNUM 3 1
APER 0 1 4 0 0 0 1 1 1 0 0 \"\" 0
APER 0 2 5.6 0 0 0 1 1 1 0 0 \"\" 0
APER 0 3 8 0 0 0 1 1 1 0 0 \"\" 0
THIC 2 1 20 0 0 0 1 1 1 0 0 \"\" 0
THIC 2 2 50 0 0 0 1 1 1 0 0 \"\" 0
THIC 2 3 90 0 0 0 1 1 1 0 0 \"\" 0
THIC 5 1 40 0 0 0 1 1 1 0 0 \"\" 0
THIC 5 2 35 0 0 0 1 1 1 0 0 \"\" 0
THIC 5 3 30 0 0 0 1 1 1 0 0 \"\" 0
SDIA 1 1 15 0 0 0 1 1 1 0 0 \"\" 0
SDIA 1 2 15.5 0 0 0 1 1 1 0 0 \"\" 0
SDIA 1 3 15.2 0 0 0 1 1 1 0 0 \"\" 0
YFIE 2 1 10 0 0 0 1 1 1 0 0 \"\" 0
YFIE 2 2 8 0 0 0 1 1 1 0 0 \"\" 0
YFIE 2 3 5 0 0 0 1 1 1 0 0 \"\" 0
";

/// One surface for the y-nu trace: curvature (1/mm), thickness after (mm), index after.
type Surface = (f64, f64, f64);

/// The test zoom's surfaces with `gap` after the first group (the stop is a plane, no power).
fn zoom_surfaces(gap: f64) -> Vec<Surface> {
    vec![
        (0.01, 3.0, 1.5),
        (-0.01, gap, 1.0),
        (0.0, 2.0, 1.0),
        (0.02, 4.0, 1.5),
        (-0.02, 0.0, 1.0),
    ]
}

/// Paraxial y-nu trace from height `y` and reduced angle `nu` (in air) in front of the first
/// vertex: the height and reduced angle after the last surface. Refraction: n'u' = nu − y·φ
/// with φ = (n' − n)·c; transfer: y' = y + t·u'.
fn y_nu(surfaces: &[Surface], mut y: f64, mut nu: f64) -> (f64, f64) {
    let mut n = 1.0;
    for (i, &(c, t, n_after)) in surfaces.iter().enumerate() {
        nu -= y * (n_after - n) * c;
        n = n_after;
        if i + 1 < surfaces.len() {
            y += t * nu / n;
        }
    }
    (y, nu)
}

/// Effective focal length: a ray parallel to the axis at height 1 leaves at angle u', and
/// f = −1 / u'.
fn efl(surfaces: &[Surface]) -> f64 {
    let (_, nu) = y_nu(surfaces, 1.0, 0.0);
    -1.0 / nu
}

/// The image distance (last vertex to image, mm) of the axial point `metres` from the image
/// plane, for the test zoom with `gap` after its first group: the object lies
/// `d − span − v` in front of the first vertex, so v is found by fixed-point iteration (each
/// round shrinks the error by the magnification squared, ≪ 1 here).
fn focused_image_distance(gap: f64, metres: f64) -> f64 {
    let surfaces = zoom_surfaces(gap);
    let span: f64 = surfaces[..4].iter().map(|s| s.1).sum();
    let (y, nu) = y_nu(&surfaces, 1.0, 0.0);
    if metres.is_infinite() {
        return -y / nu;
    }
    let mut v = -y / nu;
    for _ in 0..200 {
        let object = metres * 1000.0 - span - v;
        let u = 1e-3;
        let (y, nu) = y_nu(&surfaces, object * u, u);
        v = -y / nu;
    }
    v
}

/// The focus-group law (spacing's module docs), checked with this file's y-nu trace: the
/// reported gap `gap` lies between `infinity` and `close` (travel τ in [0, 1]), and the film
/// `film` mm behind the lens is where the lens body puts it at that travel, the image distances
/// of the two tabulated states interpolated by τ: `v∞ + (v_close − v∞)·τ`.
fn assert_focus_law(gap: f64, film: f64, infinity: f64, close_gap: f64, close_focus_m: f64) {
    let travel = (gap - infinity) / (close_gap - infinity);
    assert!((-1e-12..=1.0 + 1e-12).contains(&travel), "travel {travel}");
    let v_infinity = focused_image_distance(infinity, f64::INFINITY);
    let v_close = focused_image_distance(close_gap, close_focus_m);
    let expected = v_infinity + (v_close - v_infinity) * travel;
    assert!(
        (film - expected).abs() < 1e-6 * expected,
        "gap {gap} (travel {travel}): film {film} mm, the lens body's {expected} mm"
    );
}

fn close(a: f64, b: f64, relative: f64) -> bool {
    (a - b).abs() <= relative * b.abs()
}

fn zoom() -> Prescription {
    Prescription::parse(ZOOM_TOML, Path::new("test-zoom.toml"), None).unwrap()
}

fn report(lens: &Prescription, settings: LensSettings) -> LensReport {
    LensReport::derive(lens.clone(), &settings).unwrap()
}

#[test]
fn each_zoom_position_has_the_focal_length_of_its_gaps() {
    let lens = zoom();
    let all = report(&lens, LensSettings::default());
    assert_eq!(all.zoom_positions.len(), 3);
    for (k, gap) in GAPS.into_iter().enumerate() {
        let expected = efl(&zoom_surfaces(gap));
        let at = report(
            &lens,
            LensSettings {
                zoom_position: Some(k + 1),
                ..LensSettings::default()
            },
        );
        let f = at.geometry.first_order.focal_length;
        assert!(
            close(f, expected, 1e-3),
            "position {}: EFL {f} mm, the y-nu trace's {expected} mm",
            k + 1
        );
        assert!(close(all.zoom_positions[k].focal_length_mm, expected, 1e-3));
        assert!(close(at.geometry.system.rows[1].base.thickness, gap, 1e-12));
        assert_eq!(at.geometry.system.stop_diameter(), [10.0, 9.0, 8.0][k]);
        // The list reports each position as that position's own report does.
        assert!(close(
            all.zoom_positions[k].f_number,
            at.geometry.first_order.f_number,
            1e-9
        ));
        assert_eq!(
            all.zoom_positions[k].field_of_view_deg,
            at.field_of_view_degrees()
        );
        assert_eq!(
            json!(all.zoom_positions[k].close_focus_m),
            at.to_json()["closest_focus_m"]
        );
    }
    // The focal length grows as the groups part, as f₁f₂/(f₁ + f₂ − d) says of thin groups
    // (to 3 %: the groups are thick, their principal planes only about mid-element).
    let (f1, f2) = (efl(&zoom_surfaces(0.0)[..2]), efl(&zoom_surfaces(0.0)[3..]));
    for (k, gap) in GAPS.into_iter().enumerate() {
        let thin = f1 * f2 / (f1 + f2 - (gap + 5.5));
        let f = all.zoom_positions[k].focal_length_mm;
        assert!(
            close(f, thin, 0.03),
            "position {}: {f} mm, thin groups {thin} mm",
            k + 1
        );
    }
    let f: Vec<f64> = all
        .zoom_positions
        .iter()
        .map(|p| p.focal_length_mm)
        .collect();
    assert!(
        (39.0..41.0).contains(&f[0])
            && (51.0..54.0).contains(&f[1])
            && (88.0..91.0).contains(&f[2]),
        "{f:?}"
    );
    let e = LensReport::derive(
        lens,
        &LensSettings {
            zoom_position: Some(4),
            ..LensSettings::default()
        },
    )
    .err()
    .unwrap()
    .to_string();
    assert!(e.contains("zoom position 4") && e.contains("1 to 3"), "{e}");
}

/// A zoom change re-derives the lens entity's geometry (once) without respawning it.
#[test]
fn a_zoom_change_re_derives_the_lens_in_place() {
    let lens = zoom();
    let mut world = World::new();
    world.init_resource::<LensDerivationStats>();
    world.insert_resource(FilmResolution {
        width: 64,
        height: 64,
    });
    world.insert_resource(FilmFormat::default());
    let mut schedule = Schedule::default();
    add_lens_systems(&mut schedule);
    let entity = spawn_lens(
        &mut world,
        &lens,
        FocusSetting::Distance {
            metres: f64::INFINITY,
            mode: Default::default(),
        },
        ApertureSetting::Full,
    );
    let focal_length = |world: &World| {
        world
            .get::<LensGeometry>(entity)
            .unwrap()
            .first_order
            .focal_length
    };
    schedule.run(&mut world);
    // No zoom setting: the lens as its surfaces are written (the 20 mm gap).
    assert!(close(focal_length(&world), efl(&zoom_surfaces(20.0)), 1e-3));
    for (k, gap) in [(2, 90.0), (1, 50.0), (0, 20.0)] {
        let runs = world.resource::<LensDerivationStats>().geometry_runs;
        set_zoom_position(&mut world, entity, Some(k));
        schedule.run(&mut world);
        assert_eq!(
            world.resource::<LensDerivationStats>().geometry_runs,
            runs + 1
        );
        assert!(close(focal_length(&world), efl(&zoom_surfaces(gap)), 1e-3));
    }
    // Nothing changed: nothing re-derived.
    let runs = world.resource::<LensDerivationStats>().geometry_runs;
    set_zoom_position(&mut world, entity, Some(0));
    schedule.run(&mut world);
    assert_eq!(world.resource::<LensDerivationStats>().geometry_runs, runs);
}

/// A prime that focuses by moving its rear group: the gap before it shrinks from 20 mm at
/// infinity to 14 mm at 0.5 m. Focused at a distance, the gap moves the groups along their
/// tabulated direction until the image falls where the lens body puts the film (the law of
/// spacing's module docs, checked with this file's trace), near the 1/d interpolation, and the
/// paraxial image of that distance lies on the film.
#[test]
fn a_focus_group_lens_puts_the_image_of_its_focus_distance_on_the_film() {
    let text = ZOOM_TOML.split("[zoom]").next().unwrap().to_string()
        + "[focus]\nclose_focus_m = 0.5\nsurfaces = [2]\ninfinity = [20.0]\nclose = [14.0]\n";
    let lens = Prescription::parse(&text, Path::new("rear-focus.toml"), None).unwrap();
    for metres in [0.5, 0.8, 1.0, 3.0] {
        let at = report(
            &lens,
            LensSettings {
                focus_distance: Some(metres),
                ..LensSettings::default()
            },
        );
        // The lens's closest focus is its groups'.
        assert_eq!(at.to_json()["closest_focus_m"], 0.5);
        let gap = at.geometry.system.rows[1].base.thickness;
        assert_focus_law(gap, at.film_distance, 20.0, 14.0, 0.5);
        // Newton's first-order law, linear in 1/d, is near: within a tenth of the travel.
        let linear = 20.0 + (14.0 - 20.0) * (0.5 / metres);
        assert!(
            (gap - linear).abs() < 0.6,
            "{metres} m: gap {gap}, 1/d law {linear}"
        );
        // The object, `metres` from the film, lies this far in front of the first vertex.
        let surfaces = zoom_surfaces(gap);
        let span: f64 = surfaces[..4].iter().map(|s| s.1).sum();
        let object = metres * 1000.0 - span - at.film_distance;
        // A ray from the axial object point: height `object`·u at the first vertex, angle u.
        let u = 1e-3;
        let (y, nu) = y_nu(&surfaces, object * u, u);
        let image = -y / nu;
        assert!(
            (image - at.film_distance).abs() < 1e-6 * at.film_distance,
            "{metres} m: the image lies {image} mm behind the lens, the film {} mm",
            at.film_distance
        );
    }
    let e = LensReport::derive(
        lens,
        &LensSettings {
            focus_distance: Some(0.4),
            ..LensSettings::default()
        },
    )
    .err()
    .unwrap()
    .to_string();
    assert!(
        e.contains("closer than this lens focuses") && e.contains("0.5 m"),
        "{e}"
    );
}

/// An internal-focus zoom: at each position the gap after the front group closes by its own
/// amount for focus at 1 m (3, 6 and 10 mm), as a patent tabulates such a zoom per position.
/// Focused at a distance, each position's gap follows the focus-group law from its own infinity
/// and close values, and the paraxial image of that distance lies on the film; the close gaps
/// round-trip through the `.toml`.
#[test]
fn a_zoom_whose_focus_travel_depends_on_the_position_focuses_each_position() {
    let text = ZOOM_TOML
        .replace("gaps = [20.0],", "gaps = [20.0], close_gaps = [17.0],")
        .replace("gaps = [50.0],", "gaps = [50.0], close_gaps = [44.0],")
        .replace("gaps = [90.0],", "gaps = [90.0], close_gaps = [80.0],")
        + "\n[focus]\nclose_focus_m = 1.0\n";
    let lens = Prescription::parse(&text, Path::new("if-zoom.toml"), None).unwrap();
    for (position, (infinity, close_gap)) in [(20.0, 17.0), (50.0, 44.0), (90.0, 80.0)]
        .into_iter()
        .enumerate()
    {
        for metres in [f64::INFINITY, 1.0, 2.0, 5.0] {
            let at = report(
                &lens,
                LensSettings {
                    zoom_position: Some(position + 1),
                    focus_distance: Some(metres),
                    ..LensSettings::default()
                },
            );
            let gap = at.geometry.system.rows[1].base.thickness;
            assert_focus_law(gap, at.film_distance, infinity, close_gap, 1.0);
            if metres == 1.0 {
                assert!(close(gap, close_gap, 1e-12), "position {}", position + 1);
            }
            let surfaces = zoom_surfaces(gap);
            let span: f64 = surfaces[..4].iter().map(|s| s.1).sum();
            let object = metres * 1000.0 - span - at.film_distance;
            let image = if metres.is_infinite() {
                let (y, nu) = y_nu(&surfaces, 1.0, 0.0);
                -y / nu
            } else {
                let u = 1e-3;
                let (y, nu) = y_nu(&surfaces, object * u, u);
                -y / nu
            };
            assert!(
                (image - at.film_distance).abs() < 1e-6 * at.film_distance,
                "position {} at {metres} m: image {image} mm, film {} mm",
                position + 1,
                at.film_distance
            );
        }
    }
    let back = Prescription::parse(&write_lens_file(&lens), Path::new("back.toml"), None).unwrap();
    assert_eq!(back.spacings, lens.spacings);
    // A position's close gaps need the lens's close focus distance.
    let without = text.split("\n[focus]").next().unwrap();
    let e = Prescription::parse(without, Path::new("no-close.toml"), None)
        .unwrap_err()
        .to_string();
    assert!(e.contains("close_focus_m"), "{e}");
}

/// The Zemax file reads as a zoom whose positions have the f-numbers of its `APER` rows and
/// the focal lengths of their gaps, and round-trips through realcam's `.toml`.
#[test]
fn a_multi_configuration_file_is_a_zoom_and_round_trips_through_the_toml() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("test-zoom.zmx");
    std::fs::write(&path, ZOOM_ZMX).unwrap();
    let zemax = Prescription::load(&path, None).unwrap();
    assert_eq!(zemax.spacings.zoom.len(), 3);
    // A semi-diameter per configuration: the element is as wide as its widest.
    assert_eq!(zemax.rows[0].base.aperture, 31.0);
    assert_eq!(zemax.rows[1].base.aperture, 30.0);
    let all = report(&zemax, LensSettings::default());
    for (k, gap) in GAPS.into_iter().enumerate() {
        let position = &all.zoom_positions[k];
        assert!(close(
            position.focal_length_mm,
            efl(&zoom_surfaces(gap)),
            1e-3
        ));
        assert!(
            close(position.f_number, [4.0, 5.6, 8.0][k], 1e-6),
            "position {}: f/{}",
            k + 1,
            position.f_number
        );
    }

    let toml_path = dir.path().join("test-zoom.toml");
    let text = write_lens_file(&zemax);
    std::fs::write(&toml_path, &text).unwrap();
    let back = Prescription::load(&toml_path, None).unwrap();
    assert_eq!(back.spacings, zemax.spacings, "{text}");
    assert_eq!(back.rows.len(), zemax.rows.len());
    for (a, b) in back.rows.iter().zip(&zemax.rows) {
        // A bare stop is radius 0 in the .toml and a plane (∞) from Zemax: both curvature 0.
        assert_eq!(a.curvature(), b.curvature());
        assert_eq!(
            (a.base.thickness, a.base.index, a.base.aperture, a.base.stop),
            (b.base.thickness, b.base.index, b.base.aperture, b.base.stop)
        );
        assert_eq!((a.asphere, a.glass), (b.asphere, b.glass));
    }
    // And again: the written file is a fixed point.
    assert_eq!(write_lens_file(&back), text);

    // An operand that changes what realcam does not read is refused by name.
    let curvature =
        ZOOM_ZMX.to_string() + "CRVT 4 1 0.02 0 0\nCRVT 4 2 0.025 0 0\nCRVT 4 3 0.02 0 0\n";
    std::fs::write(&path, curvature).unwrap();
    let e = Prescription::load(&path, None).unwrap_err().to_string();
    assert!(e.contains("CRVT") && e.contains("reads THIC, APER"), "{e}");
}

/// A real ray through spheres and planes in the meridional (y, z) plane, written out here
/// independently of realcam's tracer: from `p` along unit `d`, the point on the last surface
/// and the direction after it. Each surface: the sphere of curvature c about z = vertex + 1/c
/// (the vertex-side intersection), the plane z = vertex for c = 0; vector Snell's law.
fn real_ray(surfaces: &[Surface], mut p: [f64; 2], mut d: [f64; 2]) -> ([f64; 2], [f64; 2]) {
    let (mut vertex, mut n) = (0.0, 1.0);
    for &(c, t, n_after) in surfaces {
        let (q, mut normal) = if c == 0.0 {
            let s = (vertex - p[1]) / d[1];
            ([p[0] + s * d[0], vertex], [0.0, -1.0])
        } else {
            let r = 1.0 / c;
            let centre = vertex + r;
            let (oy, oz) = (p[0], p[1] - centre);
            let b = oy * d[0] + oz * d[1];
            let s = -b - r.signum() * (b * b - (oy * oy + oz * oz - r * r)).sqrt();
            let q = [p[0] + s * d[0], p[1] + s * d[1]];
            (q, [q[0] / r, (q[1] - centre) / r])
        };
        if normal[0] * d[0] + normal[1] * d[1] > 0.0 {
            normal = [-normal[0], -normal[1]];
        }
        let mu = n / n_after;
        let cos_i = -(normal[0] * d[0] + normal[1] * d[1]);
        let cos_t = (1.0 - mu * mu * (1.0 - cos_i * cos_i)).sqrt();
        d = [
            mu * d[0] + (mu * cos_i - cos_t) * normal[0],
            mu * d[1] + (mu * cos_i - cos_t) * normal[1],
        ];
        p = q;
        vertex += t;
        n = n_after;
    }
    (p, d)
}

/// Real rays through each zoom position, as realcam traces the position's geometry, land where
/// the independent trace of that position's gaps puts them.
#[test]
fn real_rays_through_each_zoom_position_follow_its_gaps() {
    use realcam::lens::trace::{Ray, Travel, trace};
    let lens = zoom();
    let oblique = {
        let norm = (0.03f64 * 0.03 + 1.0).sqrt();
        ([-0.6, -20.0], [0.03 / norm, 1.0 / norm])
    };
    for (k, gap) in GAPS.into_iter().enumerate() {
        let at = report(
            &lens,
            LensSettings {
                zoom_position: Some(k + 1),
                ..LensSettings::default()
            },
        );
        for (p, d) in [
            ([2.0, -10.0], [0.0, 1.0]),
            ([3.0, -10.0], [0.0, 1.0]),
            oblique,
        ] {
            let (point, direction) = real_ray(&zoom_surfaces(gap), p, d);
            let out = trace(
                &at.geometry.system.f64s,
                Ray {
                    origin: [0.0, p[0], p[1]],
                    direction: [0.0, d[0], d[1]],
                },
                Travel::SceneToFilm,
            )
            .unwrap_or_else(|e| panic!("position {}: blocked {e:?}", k + 1));
            for (got, expected) in [(out.origin, point), (out.direction, direction)] {
                assert!(
                    got[0].abs() < 1e-12
                        && (got[1] - expected[0]).abs() < 1e-9
                        && (got[2] - expected[1]).abs() < 1e-9,
                    "position {}: {got:?} vs {expected:?}",
                    k + 1
                );
            }
        }
    }
}

/// An internally focused lens (the Nikon 600 mm f/4's group in front of the stop) keeps its
/// exit pupil and its film where they are as it focuses, and so its working f-number, while its
/// EFL shrinks and EFL/EPD with it: the report gives both, so that "f/2.4" at close focus is not
/// taken for the light the film gets.
#[test]
fn an_internally_focused_lens_keeps_its_working_f_number() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("lenses/nikon-af-s-600mm-f4e-fl-if.toml");
    let lens = Prescription::load(&path, None).unwrap();
    let at = |metres: f64| {
        report(
            &lens,
            LensSettings {
                focus_distance: Some(metres),
                ..LensSettings::default()
            },
        )
        .to_json()
    };
    let (far, near) = (at(f64::INFINITY), at(4.81));
    let number = |r: &serde_json::Value, key: &str| r[key].as_f64().unwrap();
    assert_eq!(far["exit_pupil"], near["exit_pupil"]);
    assert!(number(&near, "f_number") < 0.7 * number(&far, "f_number"));
    // Focused at infinity the film is at the rear focal point (to the focus solve's 1e-6 mm).
    assert!(close(
        number(&far, "working_f_number"),
        number(&far, "f_number"),
        1e-6
    ));
    assert!(
        close(
            number(&near, "working_f_number"),
            number(&far, "working_f_number"),
            1e-3
        ),
        "working f/{} at 4.81 m against f/{} at infinity",
        number(&near, "working_f_number"),
        number(&far, "working_f_number")
    );
}
