//! Environment maps: mapping convention, sampling density, agreement with a uniform sky, files.

use std::f64::consts::PI;
use std::sync::Arc;

use glam::{Vec2, Vec3};

use super::*;
use crate::shade::bsdf::luminance;
use crate::shade::environment::{
    EnvironmentMap, direction_to_image, image_to_direction, load_environment,
};
use crate::shade::warp::{UNIFORM_SPHERE_PDF, uniform_sphere};

fn image_environment(width: u32, height: u32, pixel: impl Fn(u32, u32) -> Vec3) -> Environment {
    let pixels: Vec<Vec3> = (0..height)
        .flat_map(|y| (0..width).map(move |x| (x, y)))
        .map(|(x, y)| pixel(x, y))
        .collect();
    Environment::Image(Arc::new(
        EnvironmentMap::new(width, height, &pixels).expect("map"),
    ))
}

/// An uneven sky: a gradient, a bright sun-like pixel block, and a black ground whose top
/// row the bilinear lookup still lights a little (so sampling must reach it too).
fn uneven_sky() -> Environment {
    image_environment(64, 32, |x, y| {
        let sun = if (40..43).contains(&x) && (8..10).contains(&y) {
            500.0
        } else {
            0.0
        };
        if y >= 20 {
            Vec3::ZERO
        } else {
            Vec3::new(
                0.2 + 0.01 * x as f32 + sun,
                0.5 + 0.02 * y as f32 + sun,
                1.0 + sun,
            )
        }
    })
}

#[test]
fn mapping_convention() {
    let close = |a: Vec3, b: Vec3| (a - b).length() < 1e-6;
    assert!(
        close(image_to_direction(Vec2::new(0.5, 0.5)), Vec3::NEG_Z),
        "image centre = −Z"
    );
    assert!(
        close(image_to_direction(Vec2::new(0.75, 0.5)), Vec3::X),
        "right of centre = +X"
    );
    assert!(close(image_to_direction(Vec2::new(0.25, 0.5)), Vec3::NEG_X));
    assert!(
        close(image_to_direction(Vec2::new(0.0, 0.5)), Vec3::Z),
        "edges = +Z"
    );
    assert!(
        close(image_to_direction(Vec2::new(0.3, 0.0)), Vec3::Y),
        "top row = +Y"
    );
    assert!(close(image_to_direction(Vec2::new(0.3, 1.0)), Vec3::NEG_Y));
    let mut rng = Rng::new(4, 4);
    for _ in 0..1000 {
        let uv = Vec2::new(rng.next_f32(), 0.001 + 0.998 * rng.next_f32());
        assert!((direction_to_image(image_to_direction(uv)) - uv).length() < 1e-4);
    }
    // A pixel lit in the middle of the image is seen looking down −Z.
    let env = image_environment(8, 4, |x, y| {
        if (x, y) == (4, 2) || (x, y) == (3, 2) || (x, y) == (4, 1) || (x, y) == (3, 1) {
            Vec3::ONE
        } else {
            Vec3::ZERO
        }
    });
    assert_eq!(env.radiance(Vec3::NEG_Z), Vec3::ONE);
    assert_eq!(env.radiance(Vec3::Z), Vec3::ZERO);
}

#[test]
fn sampling_density_integrates_to_one_and_matches_samples() {
    let env = uneven_sky();
    let total = integrate_directions(false, 1000, |w| env.pdf(w) as f64);
    assert!((total - 1.0).abs() < 5e-3, "∫ pdf dω = {total}");

    // Importance-sampled ∫ Y(L) dω against quadrature of the same (bilinear) radiance.
    let reference = integrate_directions(false, 1000, |w| luminance(env.radiance(w)) as f64);
    let mut rng = Rng::new(8, 8);
    let n = 200_000;
    let mut importance = Tally::default();
    let mut inconsistent = 0;
    for _ in 0..n {
        let s = env.sample(rng.next_2d()).expect("sample");
        // Rounding can move a sample on a pixel border into the neighbour: allow a few.
        if (s.pdf - env.pdf(s.direction)).abs() > 1e-3 * s.pdf {
            inconsistent += 1;
        }
        assert_eq!(s.radiance, env.radiance(s.direction));
        importance.add((luminance(s.radiance) / s.pdf) as f64);
    }
    assert!(
        inconsistent < n / 10_000,
        "{inconsistent} samples with a density other than pdf()"
    );
    importance.assert_matches(reference, 4.0, 0.01, "importance-sampled ∫ Y dω");
    // The importance sampling works: far less noise than uniform sphere sampling gives.
    let mut uniform = Tally::default();
    for _ in 0..n {
        uniform.add(
            (luminance(env.radiance(uniform_sphere(rng.next_2d()))) / UNIFORM_SPHERE_PDF) as f64,
        );
    }
    assert!(
        importance.std_error() < 0.15 * uniform.std_error(),
        "importance sampling ± {}, uniform ± {}",
        importance.std_error(),
        uniform.std_error()
    );
    // Mean luminance over the sphere matches too.
    assert!((env.mean_luminance() as f64 * 4.0 * PI / reference - 1.0).abs() < 2e-3);
}

#[test]
fn constant_image_lights_like_a_uniform_sky() {
    let sky = 3.0f32;
    let expected = {
        let uniform = TestScene::new(
            &[horizontal_square(Vec3::ZERO, 1000.0, true, 0)],
            vec![rough_floor(0.7)],
            &[],
            Environment::Uniform(Vec3::splat(sky)),
        );
        estimate(
            &uniform.shader(3, 5),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::NEG_Y,
            Strategy::Mis,
            40_000,
        )
    };
    let image = image_environment(32, 16, |_, _| Vec3::splat(sky));
    let scene = TestScene::new(
        &[horizontal_square(Vec3::ZERO, 1000.0, true, 0)],
        vec![rough_floor(0.7)],
        &[],
        image,
    );
    for strategy in [Strategy::Mis, Strategy::LightOnly] {
        let e = estimate(
            &scene.shader(3, 6),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::NEG_Y,
            strategy,
            40_000,
        );
        let tolerance = 4.0 * (e.std_error().powi(2) + expected.std_error().powi(2)).sqrt();
        assert!(
            (e.mean() - expected.mean()).abs() < tolerance,
            "{strategy:?}: {} vs uniform {}",
            e.mean(),
            expected.mean()
        );
        assert!(e.std_error() < 0.01 * e.mean());
    }
    // And the camera sees the sky itself at full value.
    let direct = estimate(
        &scene.shader(3, 6),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::Y,
        Strategy::Mis,
        4,
    );
    assert!((direct.mean() - sky as f64).abs() < 1e-5);
}

#[test]
fn loads_exr_and_hdr_files_and_names_bad_ones() {
    let dir = tempfile::tempdir().expect("tempdir");
    let (width, height) = (16u32, 8u32);
    let image = image::Rgb32FImage::from_fn(width, height, |x, y| {
        image::Rgb([x as f32 * 0.5, y as f32, 2.0])
    });
    for extension in ["exr", "hdr"] {
        let path = dir.path().join(format!("sky.{extension}"));
        image.save(&path).expect("write test image");
        let env = load_environment(&path).expect("load");
        // Centre of pixel (12, 2): u = 12.5/16, v = 2.5/8.
        let direction = image_to_direction(Vec2::new(12.5 / 16.0, 2.5 / 8.0));
        let radiance = env.radiance(direction);
        // .hdr stores RGBE (8-bit mantissas shared over the pixel): ~1 % precision.
        assert!(
            (radiance - Vec3::new(6.0, 2.0, 2.0)).abs().max_element() < 0.05,
            "{extension}: {radiance}"
        );
    }
    let missing = dir.path().join("no-such-sky.exr");
    let message = format!(
        "{:#}",
        load_environment(&missing).expect_err("missing file")
    );
    assert!(message.contains("no-such-sky.exr"), "{message}");
    let garbage = dir.path().join("garbage.hdr");
    std::fs::write(&garbage, b"not an image").expect("write");
    let message = format!("{:#}", load_environment(&garbage).expect_err("garbage"));
    assert!(message.contains("garbage.hdr"), "{message}");
}

#[test]
fn black_and_broken_images_are_harmless() {
    let black = image_environment(4, 2, |_, _| Vec3::ZERO);
    assert!(black.sample([0.5, 0.5]).is_none());
    assert_eq!(black.pdf(Vec3::Y), 0.0);
    let broken = image_environment(4, 2, |x, _| {
        if x == 0 {
            Vec3::NAN
        } else {
            Vec3::new(-1.0, f32::INFINITY, 1.0)
        }
    });
    let s = broken
        .sample([0.3, 0.7])
        .expect("the finite blue channel still lights");
    assert!(s.radiance.is_finite() && s.pdf.is_finite());
    assert!(EnvironmentMap::new(0, 0, &[]).is_err());
    assert!(EnvironmentMap::new(2, 2, &[Vec3::ONE]).is_err());
}
