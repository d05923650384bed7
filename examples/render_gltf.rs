//! The library in a page: load a glTF scene, look through a bundled lens from the scene's own
//! camera, focus at a distance, render and write a PNG.
//!
//! ```sh
//! cargo run --release --example render_gltf                       # tests/data/Duck → duck.png
//! cargo run --release --example render_gltf -- scene.gltf out.png wide.22mm
//! ```

use std::path::PathBuf;

use glam::Vec3;
use realcam::film::output::{auto_exposure, write_png};
use realcam::lens::aperture::ApertureSetting;
use realcam::lens::elements::FocusSetting;
use realcam::lens::focus::FocusMode;
use realcam::lens::io::bundled::load_lens;
use realcam::lens::pupil::PupilSampling;
use realcam::pipeline::{RenderSettings, Renderer, SceneBounds};
use realcam::shade::Environment;

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let scene = args.next().map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/Duck/Duck.gltf"),
        PathBuf::from,
    );
    let out = PathBuf::from(args.next().unwrap_or_else(|| "duck.png".into()));
    let lens_name = args.next().unwrap_or_else(|| "dgauss.50mm".into());

    // The scene loads and its BVH builds once; lenses and settings can change afterwards.
    let mut renderer = Renderer::new();
    renderer.load_scene(&scene)?;
    renderer.set_environment(Environment::Uniform(Vec3::ONE));
    let camera = renderer
        .scene_cameras()
        .first()
        .map(|camera| camera.world_from_camera)
        .ok_or_else(|| anyhow::anyhow!("{}: the scene has no camera", scene.display()))?;
    renderer.set_camera(camera);

    // Focus on the plane through the middle of the scene: its distance from the camera
    // (metres, measured from the film as pbrt does).
    let centre = renderer.world.resource::<SceneBounds>().0.center();
    let metres = camera.inverse().transform_point3(centre).z.abs() as f64;
    let lens = load_lens(&lens_name, None)?;
    let focus = FocusSetting::Distance {
        metres,
        mode: FocusMode::Paraxial,
    };
    let entity = renderer.add_lens(&lens, focus, ApertureSetting::FNumber(4.0));
    renderer.set_active_lens(entity);
    renderer.set_film(35.0, PupilSampling::Bounds);
    renderer.set_settings(RenderSettings {
        width: 192,
        height: 128,
        seed: 1,
        max_depth: 4,
        tile_size: 32,
        ..RenderSettings::default()
    });
    renderer.check_active_lens()?;

    let image = renderer.render(16, |_, _| true)?;
    write_png(&out, &image, auto_exposure(&image.mean()))?;
    println!(
        "{}: {} through {lens_name} at f/4, focused at {metres:.2} m",
        out.display(),
        scene.display()
    );
    Ok(())
}
