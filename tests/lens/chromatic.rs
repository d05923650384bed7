//! Colour from glass: axial colour against thin-lens theory, an achromat, the figures
//! `realcam lens` reports, renders that part blue and red where the optics says they part, and
//! lenses without glass data rendering exactly what they did before glass existed.

use crate::support;

use support::cli::realcam_texts;

use std::path::Path;

use glam::{Mat4, Vec3};
use realcam::film::Image;
use realcam::glass::{FRAUNHOFER_F_NM, Glass, catalogue};
use realcam::lens::aiming::ObjectSource;
use realcam::lens::aperture::ApertureSetting;
use realcam::lens::camera::FilmGeometry;
use realcam::lens::chromatic::axial_colour;
use realcam::lens::elements::{FilmPlacement, FocusSetting, LensGeometry};
use realcam::lens::first_order::FirstOrder;
use realcam::lens::focus::FocusMode;
use realcam::lens::io::bundled::load_lens;
use realcam::lens::pupil::PupilSampling;
use realcam::lens::trace::{Travel, trace_with};
use realcam::lens::{LensSystem, Prescription, SurfaceRow};
use realcam::pipeline::{RenderSettings, Renderer};
use realcam::shade::Environment;
use realcam::spectral::{XYZ_FROM_SRGB, cmf, spectral_film};
use serde_json::Value;
use support::{GltfBuilder, emitter, quad};

fn glass(name: &str) -> Glass {
    Glass::Catalogue(catalogue().find(name).unwrap())
}

/// A thin cemented achromat of focal length `f` (N-BK7 crown, F2 flint): the crown's and
/// flint's powers φ·V₁/(V₁ − V₂) and −φ·V₂/(V₁ − V₂) cancel their colour, so F and C focus
/// together; the crown alone, of the same focal length, parts them by f/V.
#[test]
fn an_achromatic_doublet_brings_f_and_c_to_one_focus() {
    let f = 100.0;
    let (crown, flint) = (glass("N-BK7"), glass("F2"));
    let (v1, v2) = (crown.v_d(), flint.v_d());
    let (n1, n2) = (crown.n_d(), flint.n_d());
    let phi = 1.0 / f;
    let phi1 = phi * v1 / (v1 - v2);
    let phi2 = -phi * v2 / (v1 - v2);
    // Equi-convex crown: c₁ − c₂ = φ₁/(n₁ − 1), c₁ = −c₂; the flint shares c₂.
    let c1 = phi1 / (n1 - 1.0) / 2.0;
    let c2 = -c1;
    let c3 = c2 - phi2 / (n2 - 1.0);
    let stop = SurfaceRow::new(0.0, 0.0, 1.0, 20.0);
    let rows = [
        stop,
        SurfaceRow {
            glass: Some(crown),
            ..SurfaceRow::new(1.0 / c1, 0.4, n1, 20.0)
        },
        SurfaceRow {
            glass: Some(flint),
            ..SurfaceRow::new(1.0 / c2, 0.3, n2, 20.0)
        },
        SurfaceRow::new(1.0 / c3, 0.0, 1.0, 20.0),
    ];
    let doublet = LensSystem::new(&rows, None);
    let fo = FirstOrder::compute(&doublet).unwrap();
    assert!((fo.focal_length - f).abs() < 1.0, "{}", fo.focal_length);
    let singlet_colour = f / v1;
    let doublet_colour = axial_colour(&doublet).unwrap();
    assert!(
        doublet_colour.abs() < 0.02 * singlet_colour,
        "achromat parts F and C by {doublet_colour} mm; a singlet would by {singlet_colour}"
    );
    // The secondary spectrum remains: d focuses apart from F and C (normal glasses).
    let bfl = |nm| {
        FirstOrder::compute(&doublet.at_wavelength(nm))
            .unwrap()
            .back_focal_length
    };
    let secondary = bfl(587.5618) - bfl(FRAUNHOFER_F_NM);
    eprintln!("F − C {doublet_colour} mm, d − F {secondary} mm, singlet F − C {singlet_colour}");
    assert!(secondary.abs() > 3.0 * doublet_colour.abs(), "{secondary}");
}

#[test]
fn lens_json_reports_the_colour_and_first_order_data_at_a_wavelength() {
    let json = |extra: &[&str]| -> Value {
        let mut args = vec!["lens", "dgauss.50mm", "--json"];
        args.extend(extra);
        let (code, out, err) = realcam_texts(&args, None);
        assert_eq!(code, 0, "{err}");
        serde_json::from_str(&out).unwrap()
    };
    let d = json(&[]);
    let chromatic = &d["chromatic"];
    let bfl_at = |nm: &str| {
        json(&["--wavelength", nm])["back_focal_length_mm"]
            .as_f64()
            .unwrap()
    };
    let axial = chromatic["axial_colour_mm"].as_f64().unwrap();
    assert!((axial - (bfl_at("486.1327") - bfl_at("656.2725"))).abs() < 1e-9);
    assert!(chromatic["lateral_colour_mm"].as_f64().unwrap().is_finite());
    let glasses = chromatic["glasses"].as_array().unwrap();
    assert_eq!(glasses.len(), d["surfaces"].as_array().unwrap().len());
    assert_eq!(glasses[0]["glass"], "N-BAF10 (Schott)");
    assert_eq!(glasses[1]["glass"], Value::Null);
    // --trace takes a wavelength per ray: blue and red leave in different directions.
    let rays = r#"[{"origin":[0,6,-10],"direction":[0,0,1],"wavelength_nm":450},
                   {"origin":[0,6,-10],"direction":[0,0,1],"wavelength_nm":650},
                   {"origin":[0,6,-10],"direction":[0,0,1]}]"#;
    let (code, out, err) = realcam_texts(&["lens", "dgauss.50mm", "--trace"], Some(rays));
    assert_eq!(code, 0, "{err}");
    let traced: Value = serde_json::from_str(&out).unwrap();
    let dy = |i: usize| traced[i]["direction"][1].as_f64().unwrap();
    assert!(dy(0) < dy(2) && dy(2) < dy(1), "{traced}");
    let (code, _, err) = realcam_texts(
        &["lens", "dgauss.50mm", "--trace"],
        Some(r#"[{"origin":[0,6,-10],"direction":[0,0,1],"wavelength_nm":-3}]"#),
    );
    assert!(code != 0 && err.contains("wavelength_nm -3"), "{err}");
    let (code, _, err) = realcam_texts(&["lens", "dgauss.50mm", "--wavelength", "nan"], None);
    assert!(code != 0 && err.contains("--wavelength"), "{err}");
}

fn png_pixels(path: &Path) -> Vec<u8> {
    image::open(path).unwrap().to_rgb8().into_raw()
}

/// A lens without glass data renders exactly what `--dispersion off` renders through its glassy
/// twin where nothing but the glass's index enters: both trace every ray at the file's indices,
/// with no wavelength drawn (checked with `--coating ideal`). With the default coating the two
/// differ only by rounding: a coating's reflectance takes its substrate's index from the glass
/// catalogue where there is one (N-BAF10's n_d is 1.67003, the file rounds it to 1.67), so
/// the linear images agree to 1e-6 of their brightest pixel, not bit for bit. (Until 2026-11-26
/// both also matched a picture from the release before glass support; the camera's samples
/// became progressive then, which changed every picture's noise.)
#[test]
fn lenses_without_glass_render_as_dispersion_off() {
    let dir = tempfile::tempdir().unwrap();
    let glass_free: String = load_lens("dgauss.50mm", None)
        .unwrap()
        .rows
        .iter()
        .map(|r| {
            format!(
                "{} {} {} {}\n",
                r.base.radius, r.base.thickness, r.base.index, r.base.aperture
            )
        })
        .collect();
    let lens = dir.path().join("dgauss-without-glass.dat");
    std::fs::write(&lens, glass_free).unwrap();
    let common = [
        "render", "--width", "64", "--height", "48", "--spp", "4", "--seed", "3",
    ];
    let render = |name: &str, extra: &[&str]| {
        let out = dir.path().join(format!("{name}.png"));
        let exr = dir.path().join(format!("{name}.exr"));
        let mut args: Vec<&str> = common.to_vec();
        args.extend(extra);
        args.extend(["--out", out.to_str().unwrap()]);
        args.extend(["--exr", exr.to_str().unwrap()]);
        let (code, _, err) = realcam_texts(&args, None);
        assert_eq!(code, 0, "{err}");
        (
            png_pixels(&out),
            image::open(&exr).unwrap().into_rgb32f().into_raw(),
        )
    };
    let glass_free = lens.to_str().unwrap();
    let ideal_off = render("ideal-off", &["--dispersion", "off", "--coating", "ideal"]);
    let ideal_free = render("ideal-free", &["--lens", glass_free, "--coating", "ideal"]);
    assert!(
        ideal_off.1 == ideal_free.1,
        "glass-free pixels differ from --dispersion off (no coating)"
    );
    let coated_off = render("coated-off", &["--dispersion", "off"]);
    let coated_free = render("coated-free", &["--lens", glass_free]);
    let brightest = coated_off.1.iter().fold(0.0f32, |m, &v| m.max(v));
    let worst = (coated_off.1.iter().zip(&coated_free.1))
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f32, f32::max);
    assert!(
        brightest > 0.0 && worst <= 1e-6 * brightest,
        "coated: the glass-free render differs by {worst} (brightest {brightest})"
    );
    let spectral = render("spectral", &[]);
    assert!(
        spectral.0 != coated_off.0,
        "a spectral render draws wavelengths: it differs"
    );
}

/// A small white emitter off axis, through a dense-flint singlet behind its stop: in the
/// render, the blue-weighted (Z) image lands where chief rays at the blue wavelengths land,
/// apart from the green-weighted (Y) one, by what independent chief-ray traces at each
/// wavelength, weighted by the CIE observer, predict.
#[test]
fn a_white_point_renders_blue_and_red_apart_by_the_lateral_colour() {
    const LENS: &str = r#"
film_diagonal_mm = 24.0
surfaces = [
  { stop = true, thickness = 25.0, diameter = 3.0 },
  { radius = 80.5, thickness = 4.0, glass = "N-SF6", diameter = 24.0 },
  { radius = -80.5, thickness = 48.0, diameter = 24.0 },
]"#;
    let prescription = Prescription::parse(LENS, Path::new("landscape.toml"), None).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let (object_y, distance) = (0.150f32, 1.0f32);
    let mut gltf = GltfBuilder::default();
    let m = emitter(&mut gltf, 2000.0);
    let node = quad(&mut gltf, [0.0, object_y, -distance], 0.004, m, 1.0);
    gltf.scene(&[node]);
    let scene = gltf.write(dir.path(), "point");
    let (width, height) = (256, 256);
    let mut renderer = Renderer::new();
    renderer.set_environment(Environment::Uniform(Vec3::ZERO));
    renderer.load_scene(&scene).unwrap();
    renderer.set_camera(Mat4::IDENTITY);
    renderer.set_film(24.0, PupilSampling::Bounds);
    renderer.set_settings(RenderSettings {
        width,
        height,
        seed: 11,
        max_depth: 1,
        tile_size: 32,
        ..RenderSettings::default()
    });
    let lens = renderer.add_lens(
        &prescription,
        FocusSetting::Distance {
            metres: distance as f64,
            mode: FocusMode::Paraxial,
        },
        ApertureSetting::Full,
    );
    renderer.set_active_lens(lens);
    let image = renderer.render(256, |_, _| true).unwrap();
    let (system, film_distance) = {
        let entity = renderer.world.entity(lens);
        (
            entity.get::<LensGeometry>().unwrap().system.clone(),
            entity.get::<FilmPlacement>().unwrap().film_distance,
        )
    };

    // Measured: centroids (film y, mm) of the render's Y and Z.
    let film = FilmGeometry::new(width, height, 24.0);
    let centroid = |row: usize| centroid_y(&image, &film, XYZ_FROM_SRGB[row]);
    let measured = centroid(2) - centroid(1);

    // Predicted: the chief ray of the object point at each wavelength, through the stop's
    // centre at that wavelength, lands at y(λ); weight by z̄ and ȳ times the emitter's spectrum.
    let film_z = system.rear_z() + film_distance;
    let object = [
        0.0,
        object_y as f64 * 1000.0,
        film_z - distance as f64 * 1000.0,
    ];
    let mut sums = [[0.0f64; 2]; 2];
    for nm in (380..=780).step_by(2) {
        let nm = nm as f64;
        let at = system.at_wavelength(nm);
        let pupil_z = FirstOrder::compute(&at).unwrap().entrance_pupil.z_mm;
        let source = ObjectSource {
            point: Some(object),
            direction: [0.0, 0.0, 1.0],
            pupil_z,
        };
        let aim = source.chief_aim(&at).unwrap();
        let out = trace_with(
            &at.f64s,
            source.ray_through(aim),
            Travel::SceneToFilm,
            false,
        )
        .unwrap();
        let y = out.origin[1] + (film_z - out.origin[2]) / out.direction[2] * out.direction[1];
        let spectrum = spectral_film().spectrum([1.0; 3], nm);
        for (k, channel) in [1, 2].into_iter().enumerate() {
            let weight = cmf().at(nm)[channel] * spectrum;
            sums[k][0] += weight * y;
            sums[k][1] += weight;
        }
    }
    let predicted = sums[1][0] / sums[1][1] - sums[0][0] / sums[0][1];
    // The lens's own report, F minus C, has the same sign.
    let lateral = realcam::lens::chromatic::lateral_colour(
        &system,
        film_distance,
        24.0,
        distance as f64 * 1000.0,
    );
    assert!(
        predicted.abs() > 0.02,
        "the test needs a measurable shift: {predicted} mm"
    );
    assert!(
        (measured - predicted).abs() < 0.15 * predicted.abs() + 0.005,
        "rendered Z − Y centroid {measured} mm, predicted {predicted} mm"
    );
    // Both say how blue lands relative to the others measured away from the axis; the image
    // here is below it (the lens inverts), the report's above.
    let outward = predicted * centroid(1).signum();
    assert_eq!(
        lateral.unwrap().signum(),
        outward.signum(),
        "{lateral:?} vs {outward}"
    );
    let pixel = film.width_mm as f64 / width as f64;
    eprintln!(
        "Z − Y: rendered {measured:.4} mm, predicted {predicted:.4} mm ({:.2} px)",
        predicted / pixel
    );
}

/// The film-y centroid (mm) of the image's channel `weights`·RGB (an XYZ row).
fn centroid_y(image: &Image, film: &FilmGeometry, weights: [f64; 3]) -> f64 {
    let mean = image.mean();
    let (mut sum, mut total) = (0.0, 0.0);
    for py in 0..image.height {
        for px in 0..image.width {
            let [r, g, b] = mean[(py * image.width + px) as usize];
            let v = weights[0] * r as f64 + weights[1] * g as f64 + weights[2] * b as f64;
            let [_, fy] = film.film_point(px as f32 + 0.5, py as f32 + 0.5);
            sum += v * fy as f64;
            total += v;
        }
    }
    sum / total
}
