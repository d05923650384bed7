//! What a lens swap costs next to a frame: spawning a lens entity set and deriving it (packed
//! surfaces, first-order data, focus, exit-pupil bounds) against rendering a 64 spp 512×512
//! frame of the default scene. Target: a swap under 5 % of a frame.

use bevy_ecs::entity::Entity;
use divan::Bencher;
use glam::Vec3;
use realcam::lens::Prescription;
use realcam::lens::aperture::ApertureSetting;
use realcam::lens::elements::FocusSetting;
use realcam::lens::focus::FocusMode;
use realcam::lens::io::bundled::load_lens;
use realcam::lens::pupil::PupilSampling;
use realcam::pipeline::{RenderSettings, Renderer, SceneSource};
use realcam::scene::default_scene::{DEFAULT_SCENE_GLB, DEFAULT_SCENE_PATH};
use realcam::scene::look_at;
use realcam::shade::Environment;

const LENSES: &[&str] = &[
    "dgauss.50mm",
    "wide.22mm",
    "telephoto.250mm",
    "fisheye.10mm",
];

fn main() {
    divan::main();
}

fn default_scene(width: u32, height: u32) -> Renderer {
    let mut renderer = Renderer::new();
    renderer.set_scene(SceneSource {
        path: DEFAULT_SCENE_PATH.into(),
        embedded: Some(DEFAULT_SCENE_GLB),
    });
    renderer.set_environment(Environment::Uniform(Vec3::ZERO));
    renderer.update().unwrap();
    renderer.set_camera(look_at(
        Vec3::new(11.5, 0.25, 2.5),
        Vec3::new(10.713, 0.198, 1.885),
        Vec3::Y,
    ));
    renderer.set_film(70.0, PupilSampling::Bounds);
    renderer.set_settings(RenderSettings {
        width,
        height,
        seed: 0,
        max_depth: 8,
        tile_size: 32,
        ..RenderSettings::default()
    });
    renderer
}

fn focus() -> FocusSetting {
    FocusSetting::Distance {
        metres: 3.9,
        mode: FocusMode::Paraxial,
    }
}

/// Spawns `prescription`'s lens entities, makes them the active lens and derives them.
fn activate(renderer: &mut Renderer, prescription: &Prescription) -> Entity {
    let lens = renderer.add_lens(prescription, focus(), ApertureSetting::Full);
    renderer.set_active_lens(lens);
    renderer.update().unwrap();
    lens
}

/// Despawn the active lens set, spawn another, derive everything the renderer needs from it.
#[divan::bench(args = LENSES, sample_count = 20)]
fn swap_lens(bencher: Bencher, lens: &str) {
    let prescription = load_lens(lens, None).unwrap();
    let mut renderer = default_scene(512, 512);
    let mut current = activate(&mut renderer, &prescription);
    bencher.bench_local(|| {
        renderer.world.despawn(current);
        current = activate(&mut renderer, &prescription);
    });
}

/// A focus pull on the active lens: film distance and pupil bounds re-derived.
#[divan::bench(sample_count = 20)]
fn refocus(bencher: Bencher) {
    let mut renderer = default_scene(512, 512);
    let lens = activate(&mut renderer, &load_lens("dgauss.50mm", None).unwrap());
    let mut metres = 3.0;
    bencher.bench_local(|| {
        metres = if metres == 3.0 { 5.0 } else { 3.0 };
        *renderer.world.get_mut::<FocusSetting>(lens).unwrap() = FocusSetting::Distance {
            metres,
            mode: FocusMode::Paraxial,
        };
        renderer.update().unwrap();
    });
}

/// The frame a swap is measured against: 64 spp at 512×512 through dgauss.50mm.
#[divan::bench(sample_count = 2, sample_size = 1)]
fn frame_64spp_512(bencher: Bencher) {
    let mut renderer = default_scene(512, 512);
    activate(&mut renderer, &load_lens("dgauss.50mm", None).unwrap());
    bencher.bench_local(|| renderer.render(64, |_, _| true).unwrap());
}
