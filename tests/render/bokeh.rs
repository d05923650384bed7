//! The diaphragm at the stop (issue 12, item 1), checked against geometry computed here
//! independently of the renderer: paraxial blur sizes, polygon areas and corner angles, the
//! light a hexagon passes; and from the command line: bad values, fingerprints, lens runs.

use crate::support;

use support::cli::{ok, realcam, refused, refused_by_parser};

use std::f64::consts::PI;
use std::path::Path;
use std::sync::Arc;

use glam::{Mat4, Vec3};
use realcam::batch::RayBatch;
use realcam::film::checkpoint::read_checkpoint;
use realcam::lens::LensSystem;
use realcam::lens::aperture::ApertureSetting;
use realcam::lens::diaphragm::{ApertureMask, Blades, Diaphragm};
use realcam::lens::elements::{FocusSetting, LensGeometry};
use realcam::lens::first_order::FirstOrder;
use realcam::lens::focus::{FocusMode, paraxial_film_distance};
use realcam::lens::io::bundled::load_lens;
use realcam::lens::pupil::PupilSampling;
use realcam::lens::trace::Travel;
use realcam::lens::trace_batch::trace_batch;
use realcam::pipeline::{RenderSettings, Renderer};
use realcam::sampling::Rng;
use realcam::shade::Environment;
use support::{GltfBuilder, matte, quad};

fn blades(count: u32, rotation_deg: f64, curvature: f64) -> Diaphragm {
    Diaphragm {
        blades: Some(Blades::new(count, rotation_deg, curvature).unwrap()),
        mask: None,
    }
}

/// Where rays from a point at lens-frame `point` (mm), spread uniformly over the front
/// element, land on the film plane at `film_z` (the batch kernel the renderer uses).
fn landing_points(
    system: &LensSystem,
    point: [f64; 3],
    film_z: f64,
    count: usize,
) -> Vec<[f64; 2]> {
    let mut rng = Rng::new(5, 12);
    let front = system.front_semi_aperture();
    let mut batch = RayBatch::with_capacity(count);
    for _ in 0..count {
        let (r, phi) = (front * rng.next_f64().sqrt(), 2.0 * PI * rng.next_f64());
        let target = [r * phi.cos(), r * phi.sin(), 0.0];
        let d = [
            target[0] - point[0],
            target[1] - point[1],
            target[2] - point[2],
        ];
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        batch.push(point.map(|v| v as f32), d.map(|v| (v / len) as f32), 0, 0);
    }
    trace_batch(&system.f32s, &mut batch, Travel::SceneToFilm);
    (0..batch.len())
        .filter(|&i| batch.alive[i])
        .map(|i| {
            let [ox, oy, oz] = batch.origin(i).map(f64::from);
            let [dx, dy, dz] = batch.direction(i).map(f64::from);
            let t = (film_z - oz) / dz;
            [ox + t * dx, oy + t * dy]
        })
        .collect()
}

/// The convex hull (counter-clockwise, Andrew's monotone chain).
fn convex_hull(points: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut p = points.to_vec();
    p.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut hull: Vec<[f64; 2]> = Vec::new();
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &[f64; 2]>> = if pass == 0 {
            Box::new(p.iter())
        } else {
            Box::new(p.iter().rev())
        };
        for &q in iter {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0
            {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    hull
}

fn area(polygon: &[[f64; 2]]) -> f64 {
    let n = polygon.len();
    (0..n)
        .map(|i| {
            let (a, b) = (polygon[i], polygon[(i + 1) % n]);
            a[0] * b[1] - a[1] * b[0]
        })
        .sum::<f64>()
        / 2.0
}

/// The polygon's corners: hull vertices where the boundary turns by more than `min_turn`
/// (radians) within `span` of the perimeter, one per corner, as angles about `centre`.
fn corner_angles(hull: &[[f64; 2]], centre: [f64; 2], span: f64, min_turn: f64) -> Vec<f64> {
    let n = hull.len();
    let heading = |i: usize| {
        let (a, b) = (hull[i % n], hull[(i + 1) % n]);
        (b[1] - a[1]).atan2(b[0] - a[0])
    };
    let length = |i: usize| {
        let (a, b) = (hull[i % n], hull[(i + 1) % n]);
        (b[0] - a[0]).hypot(b[1] - a[1])
    };
    let wrap = |a: f64| (a + PI).rem_euclid(2.0 * PI) - PI;
    let mut corners: Vec<(f64, f64)> = Vec::new(); // (distance from the centre, angle)
    for (i, &v) in hull.iter().enumerate() {
        // Turning from the edge `span` of perimeter before vertex i to the one after it.
        let (mut back, mut walked) = (i + n - 1, 0.0);
        while walked < span && back > i {
            walked += length(back);
            back -= 1;
        }
        let (mut ahead, mut walked) = (i, 0.0);
        while walked < span && ahead < i + n - 1 {
            walked += length(ahead);
            ahead += 1;
        }
        let turn = wrap(heading(ahead) - heading(back + 1));
        let angle = (v[1] - centre[1]).atan2(v[0] - centre[0]);
        // Of the vertices near a corner, the corner itself lies farthest from the centre.
        let reach = (v[0] - centre[0]).hypot(v[1] - centre[1]);
        if turn > min_turn {
            match corners
                .iter_mut()
                .find(|(_, a)| wrap(*a - angle).abs() < 0.2)
            {
                Some(c) if reach > c.0 => *c = (reach, angle),
                Some(_) => {}
                None => corners.push((reach, angle)),
            }
        }
    }
    corners.into_iter().map(|(_, a)| a).collect()
}

/// A point far behind the focused plane, on the axis: its bokeh on the film is the exit pupil
/// (the blades' polygon) scaled by the paraxial blur; five blades turned 90° give five corners
/// where the blades put them (turned by 180°: the image is inverted), and the polygon's area.
#[test]
fn defocused_point_through_n_blades_has_n_corners_and_the_polygons_area() {
    let p = load_lens("dgauss.50mm", None).unwrap();
    // Stopped down and far out of focus, so the blur is the pupil's shadow to within the
    // lens's spherical aberration (which grows as the stop's square).
    let stop = 5.0;
    let round = LensSystem::new(&p.rows, Some(stop));
    let fo = FirstOrder::compute(&round).unwrap();
    let film_distance = paraxial_film_distance(&round, &fo, 500.0).unwrap();
    let film_z = round.rear_z() + film_distance;
    let distance = 20_000.0;
    let image_z = round.rear_z() + paraxial_film_distance(&round, &fo, distance).unwrap();
    // Paraxial blur: the cone from the exit pupil to the image point, cut by the film.
    let blur_diameter =
        fo.exit_pupil.diameter_mm * (film_z - image_z) / (image_z - fo.exit_pupil.z_mm);
    let r = blur_diameter / 2.0;
    let circle = area(&convex_hull(&landing_points(
        &round,
        [0.0, 0.0, film_z - distance],
        film_z,
        400_000,
    )));
    println!(
        "round stop: bokeh {circle} mm², paraxial {} mm²",
        PI * r * r
    );
    assert!((circle / (PI * r * r) - 1.0).abs() < 0.03);
    for (count, rotation) in [(5u32, 90.0), (6, 0.0), (9, 20.0)] {
        let diaphragm = blades(count, rotation, 0.0);
        let system = round.clone().with_diaphragm(Some(&diaphragm));
        let points = landing_points(&system, [0.0, 0.0, film_z - distance], film_z, 400_000);
        let hull = convex_hull(&points);
        let measured = area(&hull);
        // The regular N-gon inscribed in the blur circle: N/2 · r² sin(2π/N).
        let expected = count as f64 / 2.0 * r * r * (2.0 * PI / count as f64).sin();
        println!("{count} blades: bokeh {measured} mm², polygon {expected} mm²");
        assert!(
            (measured / expected - 1.0).abs() < 0.03,
            "{count} blades: bokeh {measured} mm² vs polygon {expected} mm²"
        );
        let corners = corner_angles(&hull, [0.0, 0.0], 0.05 * r, 0.5 * 2.0 * PI / count as f64);
        assert_eq!(
            corners.len(),
            count as usize,
            "{count} blades: corners at {corners:?}"
        );
        for angle in corners {
            let nearest = (0..count)
                .map(|k| {
                    let expected =
                        (rotation + 180.0).to_radians() + 2.0 * PI * k as f64 / count as f64;
                    ((angle - expected + PI).rem_euclid(2.0 * PI) - PI).abs()
                })
                .fold(f64::INFINITY, f64::min);
            assert!(
                nearest < 2f64.to_radians(),
                "{count} blades: corner at {angle}"
            );
        }
    }
}

/// Near the corner of a 35 mm frame the other elements' rims cut the (eight-bladed, so
/// otherwise square-symmetric) bokeh into a cat's eye: narrower across the radius than along
/// it, with less area than on the axis.
#[test]
fn near_the_frame_corner_the_bokeh_is_a_cats_eye() {
    let p = load_lens("dgauss.50mm", None).unwrap();
    let full = LensSystem::new(&p.rows, None);
    let diaphragm = blades(8, 0.0, 0.0);
    let system = full.with_diaphragm(Some(&diaphragm));
    let fo = FirstOrder::compute(&system).unwrap();
    let film_distance = paraxial_film_distance(&system, &fo, 1000.0).unwrap();
    let film_z = system.rear_z() + film_distance;
    let distance = 20_000.0;
    let extent = |points: &[[f64; 2]], axis: usize| {
        let values = points.iter().map(|p| p[axis]);
        values.clone().fold(f64::NEG_INFINITY, f64::max) - values.fold(f64::INFINITY, f64::min)
    };
    let centre = landing_points(&system, [0.0, 0.0, film_z - distance], film_z, 200_000);
    // A point 19° off axis, along +x: its image lands ~17 mm from the centre.
    let x = distance * 19f64.to_radians().tan();
    let corner = landing_points(&system, [x, 0.0, film_z - distance], film_z, 400_000);
    let (radial, tangential) = (extent(&corner, 0), extent(&corner, 1));
    let centre_width = extent(&centre, 0);
    assert!(
        (extent(&centre, 1) / centre_width - 1.0).abs() < 0.02,
        "the axial bokeh is as wide as high"
    );
    assert!(
        radial < 0.85 * tangential,
        "cat's eye: {radial} mm across the radius, {tangential} mm along the tangent"
    );
    assert!(
        tangential > 0.5 * centre_width,
        "a cut, not a vanishing: {tangential} vs {centre_width}"
    );
    let (a_centre, a_corner) = (area(&convex_hull(&centre)), area(&convex_hull(&corner)));
    assert!(a_corner < 0.85 * a_centre, "{a_corner} vs {a_centre}");
}

/// Renders the centre of a uniform sky through dgauss.50mm stopped to `stop` mm with
/// `diaphragm`; returns the mean of the central 8 × 8 pixels.
fn sky_through(
    dir: &Path,
    stop: f64,
    diaphragm: Option<Diaphragm>,
    f_number: Option<f64>,
) -> (f64, LensGeometry) {
    let mut gltf = GltfBuilder::default();
    let m = matte(&mut gltf, [0.5, 0.5, 0.5]);
    let node = quad(&mut gltf, [0.0, 0.0, 50.0], 0.01, m, 1.0);
    gltf.scene(&[node]);
    let scene = gltf.write(dir, "empty");
    let mut renderer = Renderer::new();
    renderer.set_environment(Environment::Uniform(Vec3::splat(1.0)));
    renderer.load_scene(&scene).unwrap();
    renderer.set_camera(Mat4::IDENTITY);
    renderer.set_film(35.0, PupilSampling::Bounds);
    renderer.set_settings(RenderSettings {
        width: 32,
        height: 32,
        seed: 3,
        max_depth: 1,
        tile_size: 16,
        ..RenderSettings::default()
    });
    let aperture = f_number.map_or(ApertureSetting::Diameter(stop), ApertureSetting::FNumber);
    let lens = renderer.add_lens(
        &load_lens("dgauss.50mm", None).unwrap(),
        FocusSetting::Distance {
            metres: 5.0,
            mode: FocusMode::Paraxial,
        },
        aperture,
    );
    renderer.set_diaphragm(lens, diaphragm);
    renderer.set_active_lens(lens);
    let image = renderer.render(256, |_, _| true).unwrap();
    let means = image.mean();
    let mut sum = 0.0;
    for y in 12..20 {
        for x in 12..20 {
            let p = means[(y * 32 + x) as usize];
            sum += (p[0] + p[1] + p[2]) as f64 / 3.0;
        }
    }
    let geometry = renderer.world.get::<LensGeometry>(lens).unwrap().clone();
    (sum / 64.0, geometry)
}

/// A hexagonal stop passes 3√3/(2π) of its circle's light, a mask half open half of it, and
/// f/5.6 with blades passes the light of the round f/5.6 (the area-equivalent circle).
#[test]
fn a_hexagon_passes_three_root_three_over_two_pi_of_the_circles_light() {
    let dir = tempfile::tempdir().unwrap();
    let (round, _) = sky_through(dir.path(), 8.0, None, None);
    let (hexagon, _) = sky_through(dir.path(), 8.0, Some(blades(6, 0.0, 0.0)), None);
    let expected = 3.0 * 3f64.sqrt() / (2.0 * PI);
    let ratio = hexagon / round;
    println!("hexagon / circle = {ratio:.4} (3√3/(2π) = {expected:.4})");
    assert!(
        (ratio / expected - 1.0).abs() < 0.015,
        "{ratio} vs {expected}"
    );
    // Left half black, right half white: whatever the bilinear ramp between, t(x) + t(−x) = 1.
    let mask = ApertureMask::from_values(Path::new("half"), 2, 1, vec![0.0, 1.0]).unwrap();
    let half = Diaphragm {
        blades: None,
        mask: Some(Arc::new(mask)),
    };
    let (masked, _) = sky_through(dir.path(), 8.0, Some(half), None);
    println!("half mask / circle = {:.4}", masked / round);
    assert!((masked / round - 0.5).abs() < 0.01, "{}", masked / round);
    // f/5.6: round, and with five blades sized to the same area.
    let (round_f, round_geometry) = sky_through(dir.path(), 0.0, None, Some(5.6));
    let (bladed_f, bladed_geometry) =
        sky_through(dir.path(), 0.0, Some(blades(5, 0.0, 0.0)), Some(5.6));
    println!("f/5.6 five blades / round = {:.4}", bladed_f / round_f);
    assert!(
        (bladed_f / round_f - 1.0).abs() < 0.015,
        "{bladed_f} vs {round_f}"
    );
    assert!((bladed_geometry.f_number() - 5.6).abs() < 1e-9);
    assert!(bladed_geometry.system.stop_diameter() > round_geometry.system.stop_diameter());
    assert!(
        bladed_geometry.notes.iter().any(|n| n.contains("area")),
        "{:?}",
        bladed_geometry.notes
    );
}

/// Stops far smaller than the exit-pupil search's grid resolves (f/500, f/1000) still pass
/// camera rays: the sky only darkens, as 1/N² (the irradiance of a uniform sky through
/// an f/N lens is πL / (4N²), so N twice as large passes a quarter of the light).
#[test]
fn very_small_stops_darken_the_image_as_one_over_n_squared() {
    let dir = tempfile::tempdir().unwrap();
    let (f256, _) = sky_through(dir.path(), 0.0, None, Some(256.0));
    assert!(f256 > 0.0, "f/256 is black");
    for n in [500.0, 1000.0] {
        let (small, geometry) = sky_through(dir.path(), 0.0, None, Some(n));
        assert!((geometry.f_number() - n).abs() < 1e-6 * n);
        let expected = (n / 256.0f64).powi(2);
        let ratio = f256 / small;
        println!("f/256 over f/{n}: {ratio:.3} ((N/256)² = {expected:.3})");
        assert!(small > 0.0, "f/{n} is black");
        assert!(
            (ratio / expected - 1.0).abs() < 0.05,
            "{ratio} vs {expected}"
        );
    }
}

/// Adding, changing and removing the stop's diaphragm re-derives the lens (change detection
/// on the stop surface's entity), and removing it restores the round stop exactly.
#[test]
fn the_diaphragm_is_a_component_of_the_stop_surface() {
    let mut renderer = Renderer::new();
    let prescription = load_lens("dgauss.50mm", None).unwrap();
    let lens = renderer.add_lens(
        &prescription,
        FocusSetting::default(),
        ApertureSetting::Full,
    );
    renderer.set_active_lens(lens);
    renderer.update().unwrap();
    let geometry = |r: &Renderer| r.world.get::<LensGeometry>(lens).unwrap().clone();
    let round = geometry(&renderer);
    assert!(round.system.diaphragm.is_none());
    renderer.set_diaphragm(lens, Some(blades(7, 0.0, 0.2)));
    renderer.update().unwrap();
    let bladed = geometry(&renderer);
    assert_eq!(bladed.system.diaphragm, Some(blades(7, 0.0, 0.2)));
    assert!(bladed.system.f32s.stop_clip.is_some());
    assert!(bladed.open_fraction < 1.0);
    // The stop's own surface entity carries it.
    let children = renderer
        .world
        .get::<bevy_ecs::hierarchy::Children>(lens)
        .unwrap()
        .to_vec();
    let carriers: Vec<_> = children
        .iter()
        .filter(|&&c| renderer.world.get::<Diaphragm>(c).is_some())
        .map(|&c| {
            renderer
                .world
                .get::<realcam::lens::elements::LensSurface>(c)
                .unwrap()
                .base
                .stop
        })
        .collect();
    assert_eq!(carriers, vec![true]);
    renderer.set_diaphragm(lens, None);
    renderer.update().unwrap();
    let back = geometry(&renderer);
    assert!(back.system.diaphragm.is_none());
    assert_eq!(back.system, round.system);
}

#[test]
fn bad_diaphragm_values_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("garbage.png"), b"not a png").unwrap();
    let black = image::GrayImage::from_pixel(4, 4, image::Luma([0]));
    black.save(d.join("black.png")).unwrap();
    for command in [
        &["lens", "dgauss.50mm"][..],
        &["render", "--spp", "1", "--width", "8", "--height", "8"][..],
    ] {
        let run = |extra: &[&str]| {
            let mut args = command.to_vec();
            args.extend(extra);
            realcam(d, &args)
        };
        refused(&run(&["--blades", "2"]), &["at least 3 blades"]);
        refused_by_parser(&run(&["--blades", "-4"]), &["out of range"]);
        refused(
            &run(&["--blades", "6", "--blade-curvature", "1.5"]),
            &["--blade-curvature 1.5"],
        );
        refused(
            &run(&["--blades", "6", "--blade-curvature", "-0.1"]),
            &["between 0"],
        );
        refused_by_parser(&run(&["--blade-rotation", "10"]), &["--blades"]);
        refused(&run(&["--aperture-image", "missing.png"]), &["missing.png"]);
        refused(&run(&["--aperture-image", "garbage.png"]), &["garbage.png"]);
        refused(&run(&["--aperture-image", "black.png"]), &["no light"]);
    }
    assert!(!d.join("render.png").exists(), "nothing written");
}

/// A white mask saved as RGB, as most image editors save it, opens the whole stop (its
/// luminance weights' rounding is no "grey level 1.0000001"), and a note says how it was read.
#[test]
fn a_white_rgb_mask_opens_the_whole_stop() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    image::RgbImage::from_pixel(8, 8, image::Rgb([255, 255, 255]))
        .save(d.join("white_rgb.png"))
        .unwrap();
    image::RgbaImage::from_pixel(8, 8, image::Rgba([255, 255, 255, 255]))
        .save(d.join("white_rgba.png"))
        .unwrap();
    for (mask, read_as) in [
        ("white_rgb.png", "8×8 8-bit RGB: Rec. 709 luminance"),
        (
            "white_rgba.png",
            "8×8 8-bit RGBA: Rec. 709 luminance × alpha",
        ),
    ] {
        let output = realcam(
            d,
            &["lens", "dgauss.50mm", "--json", "--aperture-image", mask],
        );
        let stderr = ok(&output);
        assert!(
            stderr.contains(&format!("note: aperture image {mask}: {read_as}")),
            "{stderr}"
        );
        let report: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
        let open = report["diaphragm"]["open_fraction"].as_f64().unwrap();
        assert!((open - 1.0).abs() < 1e-3, "{mask}: {open}");
    }
}

/// A shard's fingerprint records the diaphragm when one is set (so shards or checkpoints of
/// another diaphragm do not merge or resume), and has no such entry when none is.
#[test]
fn fingerprints_record_the_diaphragm_only_when_set() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let common = [
        "render",
        "--spp",
        "2",
        "--width",
        "16",
        "--height",
        "16",
        "--max-depth",
        "1",
    ];
    let run = |name: &str, extra: &[&str]| {
        let mut args = common.to_vec();
        let out = format!("{name}.png");
        args.extend(["--out", &out, "--shard", "0/2"]);
        args.extend(extra);
        ok(&realcam(d, &args));
        read_checkpoint(&d.join(format!("{name}.shard-0-of-2.exr")))
            .unwrap()
            .1
            .settings
    };
    let round = run("round", &[]);
    assert!(round.get("diaphragm").is_none(), "{round}");
    let six = run("six", &["--blades", "6", "--blade-rotation", "15"]);
    assert_eq!(six["diaphragm"]["blades"]["count"], 6);
    assert_eq!(six["diaphragm"]["blades"]["rotation_deg"], 15.0);
    let seven = run("seven", &["--blades", "7"]);
    assert_ne!(six["diaphragm"], seven["diaphragm"]);
    // Merging shards of different diaphragms is refused.
    ok(&realcam(
        d,
        &[
            &common[..],
            &[
                "--out",
                "six.png",
                "--shard",
                "1/2",
                "--blades",
                "6",
                "--blade-rotation",
                "15",
            ],
        ]
        .concat(),
    ));
    let merged = realcam(
        d,
        &[
            "merge",
            "--out",
            "m.png",
            "six.shard-0-of-2.exr",
            "six.shard-1-of-2.exr",
        ],
    );
    ok(&merged);
    let refused_merge = realcam(
        d,
        &[
            "merge",
            "--out",
            "m2.png",
            "seven.shard-0-of-2.exr",
            "six.shard-1-of-2.exr",
        ],
    );
    assert!(!refused_merge.status.success());
}

/// Blades combine with several lenses and a stop sweep: every frame renders, each reports the
/// area-equivalent f-number.
#[test]
fn blades_combine_with_lens_runs_and_sweeps() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // One sample of a 16² image, direct light only.
    const TINY: [&str; 9] = [
        "render",
        "--spp",
        "1",
        "--width",
        "16",
        "--height",
        "16",
        "--max-depth",
        "1",
    ];
    let render = |extra: &[&str]| ok(&realcam(d, &[&TINY[..], extra].concat()));
    let stderr = render(&[
        "--lens",
        "dgauss.50mm",
        "--lens",
        "wide.22mm",
        "--blades",
        "5",
        "--f-number",
        "8",
        "--stats",
        "stats.json",
    ]);
    assert!(stderr.contains("note: f/8 with 5 blades"), "{stderr}");
    let stats: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("stats.json")).unwrap()).unwrap();
    let frames = stats["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 2);
    for frame in frames {
        let f = frame["f_number"].as_f64().unwrap();
        assert!((f - 8.0).abs() < 1e-6, "{frame}");
    }
    render(&[
        "--blades",
        "6",
        "--blade-curvature",
        "0.5",
        "--aperture-sweep",
        "4:8:3",
        "--out",
        "sweep.png",
    ]);
    for k in 0..3 {
        assert!(d.join(format!("sweep-{k:03}.png")).exists());
    }
}

/// The bundled bokeh scene loads cleanly: its lamps are emitters at several depths behind and
/// in front of the subject, and its camera focuses on the subject.
#[test]
fn the_bundled_bokeh_scene_loads_with_lamps_in_front_and_behind() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/bokeh/bokeh-lights.gltf");
    let text = std::fs::read_to_string(&path).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let lamps: Vec<f64> = json["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|n| n["name"].as_str().unwrap().starts_with("Lamp"))
        .map(|n| n["translation"][2].as_f64().unwrap())
        .collect();
    let camera_z = 3.0;
    assert!(lamps.iter().any(|z| camera_z - z > 10.0), "far lamps");
    assert!(lamps.iter().any(|z| camera_z - z < 1.0), "near lamps");
    let mut renderer = Renderer::new();
    renderer.load_scene(&path).unwrap();
    let warnings = &renderer
        .world
        .resource::<realcam::pipeline::SceneWarnings>()
        .0;
    assert!(warnings.is_empty(), "{warnings:?}");
}
