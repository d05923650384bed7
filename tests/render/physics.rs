//! Whole renders checked against physical facts computed independently of the renderer.

use crate::support;

use std::path::Path;

use glam::{Mat4, Vec3};
use realcam::film::Image;
use realcam::lens::LensSystem;
use realcam::lens::aperture::ApertureSetting;
use realcam::lens::camera::FilmGeometry;
use realcam::lens::coating::CoatingModel;
use realcam::lens::elements::{
    CoatingChoice, Dispersion, FilmPlacement, FocusSetting, LensGeometry,
};
use realcam::lens::focus::FocusMode;
use realcam::lens::io::bundled::load_lens;
use realcam::lens::pupil::PupilSampling;
use realcam::lens::trace::{Ray, Travel, normalize, trace};
use realcam::pipeline::{RenderSettings, RenderStats, Renderer};
use realcam::sampling::Rng;
use realcam::scene::look_at;
use realcam::shade::Environment;
use serde_json::json;
use support::{GltfBuilder, emitter, matte, quad};

/// A quad of `size` × `size` m centred at `centre`, facing +Z, with `material`.
struct Shot<'a> {
    scene: &'a Path,
    lens: &'a str,
    focus_m: f64,
    aperture: ApertureSetting,
    film_diagonal: f64,
    width: u32,
    height: u32,
    spp: u32,
    camera: Mat4,
    environment: Environment,
    /// Whether a lens with glass data renders each ray at its own wavelength.
    dispersion: Dispersion,
}

impl Shot<'_> {
    fn render(&self) -> (Image, Renderer) {
        let mut renderer = Renderer::new();
        renderer.set_environment(self.environment.clone());
        renderer.load_scene(self.scene).unwrap();
        renderer.set_camera(self.camera);
        renderer.set_film(self.film_diagonal, PupilSampling::Bounds);
        renderer.set_settings(RenderSettings {
            width: self.width,
            height: self.height,
            seed: 7,
            max_depth: 4,
            tile_size: 16,
            ..RenderSettings::default()
        });
        let lens = renderer.add_lens(
            &load_lens(self.lens, None).unwrap(),
            FocusSetting::Distance {
                metres: self.focus_m,
                mode: FocusMode::Paraxial,
            },
            self.aperture,
        );
        renderer.world.entity_mut(lens).insert(self.dispersion);
        // The lossless lens: these figures are the lens weight's (coatings.rs has the losses).
        renderer.set_coating_choice(lens, CoatingChoice::Everywhere(CoatingModel::Ideal));
        renderer.set_active_lens(lens);
        let image = renderer.render(self.spp, |_, _| true).unwrap();
        (image, renderer)
    }
}

/// Mean of the image over the pixel rectangle [x0, x1) × [y0, y1), per channel averaged.
fn region_mean(image: &Image, x0: u32, y0: u32, x1: u32, y1: u32) -> f64 {
    let means = image.mean();
    let mut sum = 0.0;
    for y in y0..y1 {
        for x in x0..x1 {
            let p = means[(y * image.width + x) as usize];
            sum += (p[0] + p[1] + p[2]) as f64 / 3.0;
        }
    }
    sum / ((x1 - x0) * (y1 - y0)) as f64
}

fn camera_at_origin() -> Mat4 {
    Mat4::IDENTITY
}

/// A scene with nothing in view: one tiny triangle far behind the camera.
fn empty_view_scene(dir: &Path) -> std::path::PathBuf {
    let mut gltf = GltfBuilder::default();
    let m = matte(&mut gltf, [0.5, 0.5, 0.5]);
    let node = quad(&mut gltf, [0.0, 0.0, 50.0], 0.01, m, 1.0);
    gltf.scene(&[node]);
    gltf.write(dir, "empty")
}

/// E[weight] of a film region from an independent brute-force integral: uniform points over
/// the whole rear-element square, traced exactly in f64, weight cos⁴θ/z² × area for those that
/// pass. Uses none of the exit-pupil code the renderer samples with.
fn expected_lens_weight(
    system: &LensSystem,
    film_distance: f64,
    film: &FilmGeometry,
    pixels: [u32; 4],
) -> f64 {
    let [x0, y0, x1, y1] = pixels;
    let film_z = system.rear_z() + film_distance;
    let half = 1.5 * system.rear_semi_aperture();
    let area = (2.0 * half) * (2.0 * half);
    let mut rng = Rng::new(11, 3);
    let n = 400_000;
    let mut sum = 0.0;
    for _ in 0..n {
        let px = x0 as f32 + rng.next_f32() * (x1 - x0) as f32;
        let py = y0 as f32 + rng.next_f32() * (y1 - y0) as f32;
        let [fx, fy] = film.film_point(px, py);
        let (fx, fy) = (fx as f64, fy as f64);
        let target = [
            (rng.next_f64() * 2.0 - 1.0) * half,
            (rng.next_f64() * 2.0 - 1.0) * half,
            system.rear_z(),
        ];
        let d = [target[0] - fx, target[1] - fy, target[2] - film_z];
        let direction = normalize(d);
        if trace(
            &system.f64s,
            Ray {
                origin: [fx, fy, film_z],
                direction,
            },
            Travel::FilmToScene,
        )
        .is_ok()
        {
            let cos = direction[2].abs();
            sum += cos.powi(4) * area / (film_distance * film_distance);
        }
    }
    sum / n as f64
}

#[test]
fn uniform_sky_converges_to_radiance_times_expected_lens_weight() {
    let dir = tempfile::tempdir().unwrap();
    let scene = empty_view_scene(dir.path());
    let sky = 2.0f32;
    let shot = Shot {
        scene: &scene,
        lens: "dgauss.50mm",
        focus_m: 5.0,
        aperture: ApertureSetting::Full,
        film_diagonal: 35.0,
        width: 32,
        height: 32,
        spp: 192,
        camera: camera_at_origin(),
        environment: Environment::Uniform(Vec3::splat(sky)),
        dispersion: Dispersion::On,
    };
    let (image, mut renderer) = shot.render();
    let mut query = renderer.world.query::<(&LensGeometry, &FilmPlacement)>();
    let (geometry, placement) = query.iter(&renderer.world).next().unwrap();
    let film = FilmGeometry::new(32, 32, 35.0);
    for region in [[12, 12, 20, 20], [0, 0, 6, 6], [26, 13, 32, 19]] {
        let expected = sky as f64
            * expected_lens_weight(&geometry.system, placement.film_distance, &film, region);
        let measured = region_mean(&image, region[0], region[1], region[2], region[3]);
        assert!(
            (measured / expected - 1.0).abs() < 0.03,
            "region {region:?}: rendered {measured} vs independent {expected}"
        );
    }
}

#[test]
fn white_matte_wall_under_sky_conserves_energy() {
    // A white wall filling the view sees the uniform sky over its hemisphere: it reflects at
    // most what falls on it (glTF's matte dielectric keeps ≈ 97 %, its 4 % specular coat
    // losing a little at grazing angles), and far more than a grey one would.
    let dir = tempfile::tempdir().unwrap();
    let mut gltf = GltfBuilder::default();
    let m = matte(&mut gltf, [1.0, 1.0, 1.0]);
    let node = quad(&mut gltf, [0.0, 0.0, -3.0], 40.0, m, 1.0);
    gltf.scene(&[node]);
    let scene = gltf.write(dir.path(), "wall");
    let sky = Environment::Uniform(Vec3::ONE);
    let base = Shot {
        scene: &scene,
        lens: "dgauss.50mm",
        focus_m: 3.0,
        aperture: ApertureSetting::FNumber(4.0),
        film_diagonal: 20.0,
        width: 16,
        height: 16,
        spp: 256,
        camera: camera_at_origin(),
        environment: sky.clone(),
        dispersion: Dispersion::On,
    };
    let (wall, _) = base.render();
    let empty = empty_view_scene(dir.path());
    let (open_sky, _) = Shot {
        scene: &empty,
        ..base
    }
    .render();
    let ratio = region_mean(&wall, 4, 4, 12, 12) / region_mean(&open_sky, 4, 4, 12, 12);
    assert!(ratio > 0.93 && ratio < 1.0, "wall / sky = {ratio}");
}

/// Mean squared difference between horizontally neighbouring pixels: high when sharp.
fn sharpness(image: &Image) -> f64 {
    let m = image.mean();
    let mut sum = 0.0;
    for y in 0..image.height {
        for x in 1..image.width {
            let a = m[(y * image.width + x) as usize][1] as f64;
            let b = m[(y * image.width + x - 1) as usize][1] as f64;
            sum += (a - b).powi(2);
        }
    }
    sum / (image.width * image.height) as f64
}

#[test]
fn the_focused_plane_is_sharper_than_an_off_focus_one() {
    let dir = tempfile::tempdir().unwrap();
    let mut gltf = GltfBuilder::default();
    // A checkerboard: an 8×8 texel image with nearest filtering, repeated over the wall.
    let mut png = Vec::new();
    let checker = image::RgbImage::from_fn(8, 8, |x, y| {
        if (x + y) % 2 == 0 {
            image::Rgb([255, 255, 255])
        } else {
            image::Rgb([20, 20, 20])
        }
    });
    checker
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let view = gltf.view(&png);
    let img = gltf.add(
        "images",
        json!({"bufferView": view, "mimeType": "image/png"}),
    );
    let sampler = gltf.add("samplers", json!({"magFilter": 9728, "minFilter": 9728}));
    let texture = gltf.add("textures", json!({"source": img, "sampler": sampler}));
    let m = gltf.material(json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": texture}, "metallicFactor": 0.0, "roughnessFactor": 1.0}}));
    let node = quad(&mut gltf, [0.0, 0.0, -2.0], 2.0, m, 16.0);
    gltf.scene(&[node]);
    let scene = gltf.write(dir.path(), "checker");
    let shot = |focus_m| Shot {
        scene: &scene,
        lens: "dgauss.50mm",
        focus_m,
        aperture: ApertureSetting::Full,
        film_diagonal: 8.0,
        width: 48,
        height: 48,
        spp: 64,
        camera: camera_at_origin(),
        environment: Environment::Uniform(Vec3::ONE),
        // Focus is geometry: the colour noise of single-wavelength samples would count as
        // "sharpness" in this neighbour-difference measure.
        dispersion: Dispersion::Off,
    };
    let (focused, _) = shot(2.0).render();
    let (near, _) = shot(0.8).render();
    let (far, _) = shot(20.0).render();
    let (s_focused, s_near, s_far) = (sharpness(&focused), sharpness(&near), sharpness(&far));
    assert!(
        s_focused > 3.0 * s_near && s_focused > 3.0 * s_far,
        "focused {s_focused}, near {s_near}, far {s_far}"
    );
}

/// Brightest pixel of an image.
fn brightest(image: &Image) -> (u32, u32) {
    let m = image.mean();
    let i = (0..m.len())
        .max_by(|&a, &b| m[a][0].total_cmp(&m[b][0]))
        .unwrap();
    (i as u32 % image.width, i as u32 / image.width)
}

#[test]
fn swapping_width_and_height_transposes_the_field_upright_and_unmirrored() {
    // Two small lamps, one 27° right of the axis and one 27° above it. A 96×48 film (35 mm
    // diagonal, wide.22mm: ±35° across, ±20° up) sees only the right one, on the right; the
    // 48×96 film sees only the upper one, at the top.
    let dir = tempfile::tempdir().unwrap();
    let mut gltf = GltfBuilder::default();
    let lamp = emitter(&mut gltf, 50.0);
    let offset = 5.0 * 27f32.to_radians().tan();
    let right = quad(&mut gltf, [offset, 0.0, -5.0], 0.4, lamp, 1.0);
    let up = quad(&mut gltf, [0.0, offset, -5.0], 0.4, lamp, 1.0);
    gltf.scene(&[right, up]);
    let scene = gltf.write(dir.path(), "lamps");
    let shot = |width, height| Shot {
        scene: &scene,
        lens: "wide.22mm",
        focus_m: 5.0,
        aperture: ApertureSetting::Full,
        film_diagonal: 35.0,
        width,
        height,
        spp: 8,
        camera: camera_at_origin(),
        environment: Environment::Uniform(Vec3::ZERO),
        dispersion: Dispersion::On,
    };
    let (landscape, _) = shot(96, 48).render();
    let (portrait, _) = shot(48, 96).render();
    let (x, y) = brightest(&landscape);
    assert!(
        x > 70 && (16..32).contains(&y),
        "landscape lamp at ({x}, {y}): expected right of centre"
    );
    assert!(
        region_mean(&landscape, 0, 0, 96, 4) < 1e-9,
        "the upper lamp is outside the landscape field"
    );
    let (x, y) = brightest(&portrait);
    assert!(
        y < 26 && (16..32).contains(&x),
        "portrait lamp at ({x}, {y}): expected above centre"
    );
    assert!(
        region_mean(&portrait, 44, 0, 48, 96) < 1e-9,
        "the right lamp is outside the portrait field"
    );
}

#[test]
fn emissive_only_scene_has_no_nan_and_no_rejected_samples() {
    let scene = support::sample_scene("CornellBox/cornellBox-2.80-Eevee-gltf.gltf");
    let camera = look_at(Vec3::new(0.0, 1.5, 7.0), Vec3::new(0.0, 1.5, 0.0), Vec3::Y);
    for dispersion in [Dispersion::Off, Dispersion::On] {
        let (image, renderer) = Shot {
            scene: &scene,
            lens: "wide.22mm",
            focus_m: 7.0,
            aperture: ApertureSetting::Full,
            film_diagonal: 35.0,
            width: 32,
            height: 32,
            spp: 8,
            camera,
            environment: Environment::Uniform(Vec3::ZERO),
            dispersion,
        }
        .render();
        assert!(image.sums.iter().flatten().all(|v| v.is_finite()));
        if dispersion == Dispersion::Off {
            assert!(image.sums.iter().flatten().all(|v| *v >= 0.0));
        } else {
            // A single wavelength's sRGB weights go negative outside its colour's gamut, so a
            // channel's sum may too; its luminance (from ȳ ≥ 0) never does.
            for [r, g, b] in &image.sums {
                assert!(0.2126 * r + 0.7152 * g + 0.0722 * b >= -1e-6, "{r} {g} {b}");
            }
        }
        assert!(
            region_mean(&image, 0, 0, 32, 32) > 0.0,
            "the ceiling light lights the box"
        );
        assert_eq!(renderer.world.resource::<RenderStats>().rejected_samples, 0);
    }
}

#[test]
fn same_seed_same_image_whatever_the_thread_count() {
    let scene = support::sample_scene("Duck/Duck.gltf");
    let camera = look_at(Vec3::new(0.0, 1.0, 4.0), Vec3::new(0.0, 0.8, 0.0), Vec3::Y);
    let render = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            Shot {
                scene: &scene,
                lens: "dgauss.50mm",
                focus_m: 4.0,
                aperture: ApertureSetting::Full,
                film_diagonal: 35.0,
                width: 40,
                height: 24,
                spp: 4,
                camera,
                environment: Environment::Uniform(Vec3::ONE),
                dispersion: Dispersion::On,
            }
            .render()
            .0
        })
    };
    let one = render(1);
    let three = render(3);
    assert_eq!(one, three);
    assert!(region_mean(&one, 0, 0, 40, 24) > 0.0);
}
