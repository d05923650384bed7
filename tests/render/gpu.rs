//! `--device gpu` against `--device cpu`: the same scene, lens, settings and seed give the same
//! image within noise. The two devices draw the same sample sequences (the same Sobol points,
//! wavelengths and shading streams per pixel and sample index), so most pixels agree to f32
//! rounding; a path whose branch a rounding difference flips differs, which the per-tile
//! statistics allow for. On CI the GPU is lavapipe (Mesa's software Vulkan device).

use std::path::{Path, PathBuf};

use realcam::film::samples::SampleSequence;
use realcam::gpu::GpuContext;
use realcam::lens::aperture::ApertureSetting;
use realcam::lens::elements::FocusSetting;
use realcam::lens::focus::FocusMode;
use realcam::lens::io::bundled::load_lens;
use realcam::lens::pupil::PupilSampling;
use realcam::pipeline::{RenderDevice, RenderSettings, Renderer};
use realcam::shade::Environment;

use crate::support::cli::{ok, realcam};

/// Renders `args` on both devices into `dir`; the two linear films, row-major RGB.
fn render_on_both(dir: &Path, name: &str, args: &[&str]) -> [(Vec<f32>, u32, u32); 2] {
    ["cpu", "gpu"].map(|device| {
        let exr = dir.join(format!("{name}-{device}.exr"));
        let png = dir.join(format!("{name}-{device}.png"));
        let mut full: Vec<&str> = vec!["render", "--device", device];
        full.extend_from_slice(args);
        full.extend_from_slice(&[
            "--out",
            png.to_str().unwrap(),
            "--exr",
            exr.to_str().unwrap(),
        ]);
        ok(&realcam(dir, &full));
        let film = image::open(&exr).unwrap().to_rgb32f();
        let (width, height) = film.dimensions();
        (film.into_raw(), width, height)
    })
}

/// How the GPU's film compares with the CPU's.
#[derive(Debug)]
struct Agreement {
    /// Pixels whose RGB agree within 1e-3 relative (+1e-5 absolute): the same paths.
    same_paths: f64,
    /// Tiles of 16×16 pixels whose mean luminance differs by more than four standard errors
    /// of the mean pixel difference (plus 0.5 % of the mean for f32 rounding).
    tiles_apart: Vec<String>,
    mean_cpu: f64,
    mean_gpu: f64,
}

fn luminance(rgb: &[f32]) -> f64 {
    0.2126 * rgb[0] as f64 + 0.7152 * rgb[1] as f64 + 0.0722 * rgb[2] as f64
}

fn compare(films: &[(Vec<f32>, u32, u32); 2]) -> Agreement {
    let [(cpu, width, height), (gpu, w2, h2)] = films;
    assert_eq!((width, height), (w2, h2));
    let (width, height) = (*width as usize, *height as usize);
    let pixels = width * height;
    assert!(
        gpu.iter().all(|v| v.is_finite()),
        "the GPU film has non-finite values"
    );
    let same = (0..pixels)
        .filter(|&p| {
            (0..3).all(|c| {
                let (a, b) = (cpu[3 * p + c], gpu[3 * p + c]);
                (a - b).abs() <= 1e-3 * a.abs().max(b.abs()) + 1e-5
            })
        })
        .count();
    let mut tiles_apart = Vec::new();
    for ty in (0..height).step_by(16) {
        for tx in (0..width).step_by(16) {
            let mut differences = Vec::new();
            let mut mean = 0.0;
            for y in ty..(ty + 16).min(height) {
                for x in tx..(tx + 16).min(width) {
                    let p = 3 * (y * width + x);
                    let (a, b) = (luminance(&cpu[p..p + 3]), luminance(&gpu[p..p + 3]));
                    differences.push(b - a);
                    mean += a;
                }
            }
            let n = differences.len() as f64;
            mean /= n;
            let difference = differences.iter().sum::<f64>() / n;
            let variance = differences
                .iter()
                .map(|d| (d - difference).powi(2))
                .sum::<f64>()
                / (n - 1.0);
            let allowed = 4.0 * (variance / n).sqrt() + 0.005 * mean.abs() + 1e-6;
            if difference.abs() > allowed {
                tiles_apart.push(format!(
                    "tile at ({tx}, {ty}): mean {mean:.5}, GPU − CPU {difference:.5} > {allowed:.5}"
                ));
            }
        }
    }
    let mean = |film: &[f32]| film.chunks(3).map(luminance).sum::<f64>() / pixels as f64;
    Agreement {
        same_paths: same as f64 / pixels as f64,
        tiles_apart,
        mean_cpu: mean(cpu),
        mean_gpu: mean(gpu),
    }
}

fn assert_alike(films: &[(Vec<f32>, u32, u32); 2], what: &str) {
    let agreement = compare(films);
    assert!(agreement.tiles_apart.is_empty(), "{what}: {agreement:#?}");
    assert!(
        agreement.same_paths > 0.9,
        "{what}: only {:.1} % of the pixels took the same paths on both devices: {agreement:#?}",
        100.0 * agreement.same_paths
    );
    assert!(
        agreement.mean_cpu > 0.0,
        "{what}: a black image proves nothing"
    );
    assert!(
        (agreement.mean_gpu - agreement.mean_cpu).abs() <= 0.01 * agreement.mean_cpu,
        "{what}: the image means differ by more than 1 %: {agreement:#?}"
    );
}

fn gpu() -> bool {
    GpuContext::for_tests().is_some()
}

fn data(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(relative)
}

#[test]
fn the_default_scene_renders_alike_on_both_devices_spectral_and_not() {
    if !gpu() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    // The default coating, then bare glass (its losses are ten times larger: a device that
    // skipped them would be 40 % too bright); the default filter (tent), then the others, each
    // with several wavelengths per sample (a share per wavelength) and with RGB (one per
    // sample), and one wavelength per sample.
    for (seed, dispersion, coating, filter, wavelengths) in [
        ("1", "on", "single", "tent", "4"),
        ("2", "on", "none", "tent", "4"),
        ("3", "off", "single", "tent", "4"),
        ("4", "off", "none", "tent", "4"),
        ("5", "on", "single", "gaussian", "4"),
        ("6", "off", "single", "gaussian", "4"),
        ("7", "on", "single", "box", "4"),
        ("8", "off", "single", "box", "4"),
        ("9", "on", "single", "tent", "1"),
    ] {
        let films = render_on_both(
            dir.path(),
            &format!("default-{seed}"),
            &[
                "--width",
                "96",
                "--height",
                "64",
                "--spp",
                "8",
                "--seed",
                seed,
                "--dispersion",
                dispersion,
                "--coating",
                coating,
                "--filter",
                filter,
                "--wavelengths",
                wavelengths,
            ],
        );
        assert_alike(
            &films,
            &format!(
                "default scene, seed {seed}, dispersion {dispersion}, coating {coating}, \
                 filter {filter}, {wavelengths} wavelengths per sample"
            ),
        );
    }
}

#[test]
fn a_textured_gltf_renders_alike_on_both_devices() {
    if !gpu() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let duck = data("Duck/Duck.gltf");
    let films = render_on_both(
        dir.path(),
        "duck",
        &[
            duck.to_str().unwrap(),
            "--lens",
            "wide.22mm",
            "--width",
            "64",
            "--height",
            "64",
            "--spp",
            "8",
        ],
    );
    assert_alike(&films, "the textured duck through wide.22mm");
}

#[test]
fn a_lens_swap_and_a_focus_pull_on_the_gpu_match_the_cpu() {
    if !gpu() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    // Two lenses in one run: the second is swapped in on the same scene and BVH; each renders a
    // rack focus, so the lens buffer is rewritten between frames.
    let args = [
        "--lens",
        "dgauss.50mm",
        "--lens",
        "wide.22mm",
        "--focus-sweep",
        "1:4:2",
        "--width",
        "64",
        "--height",
        "48",
        "--spp",
        "4",
    ];
    let mut frames = Vec::new();
    for device in ["cpu", "gpu"] {
        let out = dir.path().join(device).join("frame.png");
        std::fs::create_dir_all(out.parent().unwrap()).unwrap();
        let mut full = vec![
            "render",
            "--device",
            device,
            "--out",
            out.to_str().unwrap(),
            "--exr",
        ];
        let exr = dir.path().join(device).join("frame.exr");
        full.push(exr.to_str().unwrap());
        full.extend_from_slice(&args);
        ok(&realcam(dir.path(), &full));
        let mut names: Vec<PathBuf> = std::fs::read_dir(dir.path().join(device))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "exr"))
            .collect();
        names.sort();
        frames.push(names);
    }
    assert_eq!(frames[0].len(), 4, "{:?}", frames[0]);
    for (cpu, gpu) in frames[0].iter().zip(&frames[1]) {
        let read = |path: &Path| {
            let film = image::open(path).unwrap().to_rgb32f();
            let (w, h) = film.dimensions();
            (film.into_raw(), w, h)
        };
        assert_alike(
            &[read(cpu), read(gpu)],
            &cpu.file_name().unwrap().to_string_lossy(),
        );
    }
}

#[test]
fn a_gpu_render_is_the_same_bytes_every_time_and_resumes_to_the_direct_render() {
    if !gpu() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let args = [
        "--width", "24", "--height", "16", "--seed", "5", "--spp", "4",
    ];
    let [(_, _, _), (gpu_first, _, _)] = render_on_both(dir.path(), "first", &args);
    let [(_, _, _), (gpu_again, _, _)] = render_on_both(dir.path(), "again", &args);
    assert_eq!(gpu_first, gpu_again, "the same seed gave another image");

    // A film resumed from sums the CPU holds (a checkpoint) goes up to the GPU, and the passes
    // continue on it: samples 0–1, then 2–3 from that film, equal samples 0–3 in one go.
    let mut renderer = duck_renderer();
    renderer.set_device(RenderDevice::Gpu).unwrap();
    let direct = renderer
        .render_samples(None, &[0, 1, 2, 3], |_, _| true)
        .unwrap();
    let half = renderer.render_samples(None, &[0, 1], |_, _| true).unwrap();
    let resumed = renderer
        .render_samples(Some(&half), &[2, 3], |_, _| true)
        .unwrap();
    assert_eq!(resumed.samples, 4);
    assert!(
        direct.mean().iter().any(|p| p[1] > 0.0),
        "a black image proves nothing"
    );
    assert_eq!(
        direct.sums, resumed.sums,
        "resuming on the GPU changed the image"
    );

    // The four samples in one dispatch (in parallel, then added in index order) give the same
    // film as four single-sample passes.
    renderer.begin_film(None).unwrap();
    renderer.render_passes(SampleSequence::all(4)).unwrap();
    let batched = renderer.image().unwrap();
    assert_eq!(batched.samples, 4);
    assert_eq!(
        direct.sums, batched.sums,
        "one dispatch of four samples changed the image"
    );
}

/// The duck through dgauss.50mm, as a library user sets up a renderer.
fn duck_renderer() -> Renderer {
    let mut renderer = Renderer::new();
    renderer.load_scene(data("Duck/Duck.gltf")).unwrap();
    renderer.set_environment(Environment::Uniform(glam::Vec3::ONE));
    let camera = renderer.scene_cameras()[0].world_from_camera;
    renderer.set_camera(camera);
    let lens = load_lens("dgauss.50mm", None).unwrap();
    let focus = FocusSetting::Distance {
        metres: 5.0,
        mode: FocusMode::Paraxial,
    };
    let entity = renderer.add_lens(&lens, focus, ApertureSetting::FNumber(4.0));
    renderer.set_active_lens(entity);
    renderer.set_film(35.0, PupilSampling::Bounds);
    renderer.set_settings(RenderSettings {
        width: 24,
        height: 16,
        seed: 3,
        max_depth: 3,
        tile_size: 32,
        ..RenderSettings::default()
    });
    renderer.check_active_lens().unwrap();
    renderer
}

/// `realcam` with the Vulkan loader pointed at no driver: as on a machine without a GPU.
fn without_gpu(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_realcam"))
        .args(args)
        .env("VK_DRIVER_FILES", "/nonexistent/icd.json")
        .env("VK_ICD_FILENAMES", "/nonexistent/icd.json")
        .current_dir(std::env::temp_dir())
        .output()
        .unwrap()
}

#[test]
fn without_a_gpu_the_device_is_refused_in_words_and_devices_says_none() {
    let render = without_gpu(&["render", "--device", "gpu", "--out", "-"]);
    let stderr = String::from_utf8_lossy(&render.stderr);
    assert_eq!(render.status.code(), Some(1), "{stderr}");
    assert!(render.stdout.is_empty(), "an image went out");
    assert!(
        stderr.contains("--device gpu: no GPU adapter found") && stderr.contains("--device cpu"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    let devices = without_gpu(&["devices"]);
    let stdout = String::from_utf8_lossy(&devices.stdout);
    assert!(devices.status.success());
    assert!(stdout.contains("gpu: none found"), "{stdout}");
}

/// A film whose buffers no GPU can bind (8192² with eight wavelengths per sample: 8 GiB of
/// shares per pass, over wgpu's 4 GiB ceiling) is refused in words before anything renders,
/// with what to change; no output is written.
#[test]
fn a_film_too_large_for_the_gpu_is_refused_in_words() {
    if !gpu() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("big.png");
    let output = realcam(
        dir.path(),
        &[
            "render",
            "--device",
            "gpu",
            "--width",
            "8192",
            "--height",
            "8192",
            "--spp",
            "1",
            "--wavelengths",
            "8",
            "--out",
            out.to_str().unwrap(),
        ],
    );
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("8192×8192 film with 8 wavelengths per sample needs a 8192 MiB buffer")
            && stderr.contains("fewer --wavelengths")
            && stderr.contains("--device cpu"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(!out.exists(), "an image was written");
}
