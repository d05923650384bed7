//! One scene, many lenses: load the scene and build its BVH once, then look through lens after
//! lens, pull focus and stop down, re-deriving only what each change invalidates.
//!
//! ```sh
//! cargo run --release --example lens_swap            # writes swap-*.png in the current folder
//! ```

use std::time::Instant;

use glam::Vec3;
use realcam::film::output::{auto_exposure, write_png};
use realcam::lens::aperture::ApertureSetting;
use realcam::lens::elements::{FocusSetting, LensDerivationStats};
use realcam::lens::focus::FocusMode;
use realcam::lens::io::bundled::load_lens;
use realcam::lens::pupil::PupilSampling;
use realcam::pipeline::{RenderSettings, RenderStats, Renderer, SceneSource};
use realcam::scene::default_scene::{DEFAULT_SCENE_GLB, DEFAULT_SCENE_PATH};
use realcam::scene::look_at;
use realcam::shade::Environment;

fn main() -> anyhow::Result<()> {
    let mut renderer = Renderer::new();
    // The built-in scene; `renderer.load_scene("scene.gltf")` loads a file instead.
    renderer.set_scene(SceneSource {
        path: DEFAULT_SCENE_PATH.into(),
        embedded: Some(DEFAULT_SCENE_GLB),
    });
    renderer.set_environment(Environment::Uniform(Vec3::splat(0.2)));
    renderer.update()?;
    renderer.set_camera(look_at(
        Vec3::new(11.5, 0.25, 2.5),
        Vec3::new(11.5 - 0.787, 0.25 - 0.052, 2.5 - 0.615),
        Vec3::Y,
    ));
    renderer.set_film(35.0, PupilSampling::Bounds);
    renderer.set_settings(RenderSettings {
        width: 256,
        height: 256,
        seed: 1,
        max_depth: 4,
        tile_size: 32,
        ..RenderSettings::default()
    });

    // Several lens entity sets side by side in one world; only the active one renders.
    let focus = FocusSetting::Distance {
        metres: 4.0,
        mode: FocusMode::Paraxial,
    };
    let lenses = ["dgauss.50mm", "wide.22mm", "telephoto.250mm"]
        .into_iter()
        .map(|name| {
            Ok((
                name,
                renderer.add_lens(&load_lens(name, None)?, focus, ApertureSetting::Full),
            ))
        })
        .collect::<anyhow::Result<Vec<_>>>()?;

    let frame = |renderer: &mut Renderer, name: &str| -> anyhow::Result<()> {
        let derived_before = renderer.world.resource::<LensDerivationStats>().total_time;
        let start = Instant::now();
        let image = renderer.render(16, |_, _| true)?;
        let derived = renderer.world.resource::<LensDerivationStats>().total_time - derived_before;
        let path = format!("swap-{name}.png");
        write_png(path.as_ref(), &image, auto_exposure(&image.mean()))?;
        println!(
            "{path}: {:.2} s, of which {:.3} s re-deriving lens data",
            start.elapsed().as_secs_f64(),
            derived.as_secs_f64()
        );
        Ok(())
    };
    for &(name, lens) in &lenses {
        renderer.set_active_lens(lens);
        frame(&mut renderer, name)?;
    }
    // Pull focus on the 50 mm and stop it down: the film distance and pupil are re-derived,
    // the scene and BVH are not.
    let (_, dgauss) = lenses[0];
    renderer.set_active_lens(dgauss);
    *renderer
        .world
        .get_mut::<FocusSetting>(dgauss)
        .expect("lens entity") = FocusSetting::Distance {
        metres: 10.0,
        mode: FocusMode::Paraxial,
    };
    frame(&mut renderer, "dgauss.50mm-at-10m")?;
    *renderer
        .world
        .get_mut::<ApertureSetting>(dgauss)
        .expect("lens entity") = ApertureSetting::FNumber(8.0);
    frame(&mut renderer, "dgauss.50mm-f8")?;

    let stats = renderer.world.resource::<RenderStats>();
    println!(
        "scene loads: {}, BVH builds: {}",
        stats.scene_loads, stats.bvh_builds
    );
    Ok(())
}
