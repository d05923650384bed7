//! One scene, many lenses: swapping lens entity sets and editing them never reloads the
//! scene or rebuilds the BVH, and gives back exactly the image it gave before.

use crate::support;

use bevy_ecs::entity::Entity;
use glam::Vec3;
use realcam::film::Image;
use realcam::lens::aperture::ApertureSetting;
use realcam::lens::elements::{FocusSetting, LensSurface};
use realcam::lens::focus::FocusMode;
use realcam::lens::io::bundled::load_lens;
use realcam::lens::pupil::PupilSampling;
use realcam::pipeline::{RenderSettings, RenderStats, Renderer};
use realcam::scene::look_at;
use realcam::shade::Environment;

fn focus(metres: f64) -> FocusSetting {
    FocusSetting::Distance {
        metres,
        mode: FocusMode::Paraxial,
    }
}

fn duck_renderer() -> Renderer {
    let mut renderer = Renderer::new();
    renderer.set_environment(Environment::Uniform(Vec3::ONE));
    renderer
        .load_scene(support::sample_scene("Duck/Duck.gltf"))
        .unwrap();
    renderer.set_camera(look_at(
        Vec3::new(0.0, 1.0, 4.0),
        Vec3::new(0.0, 0.8, 0.0),
        Vec3::Y,
    ));
    renderer.set_film(35.0, PupilSampling::Bounds);
    renderer.set_settings(RenderSettings {
        width: 32,
        height: 24,
        seed: 3,
        max_depth: 3,
        tile_size: 16,
        ..RenderSettings::default()
    });
    renderer
}

/// The duck scene through dgauss.50mm focused at 4 m, wide open: the lens entity is active.
fn duck_through_dgauss() -> (Renderer, Entity) {
    let mut renderer = duck_renderer();
    let lens = renderer.add_lens(
        &load_lens("dgauss.50mm", None).unwrap(),
        focus(4.0),
        ApertureSetting::Full,
    );
    renderer.set_active_lens(lens);
    (renderer, lens)
}

fn render(renderer: &mut Renderer) -> Image {
    renderer.render(3, |_, _| true).unwrap()
}

fn builds(renderer: &Renderer) -> (u64, u64) {
    let stats = renderer.world.resource::<RenderStats>();
    (stats.scene_loads, stats.bvh_builds)
}

#[test]
fn a_then_b_then_a_gives_a_bit_for_bit() {
    let mut renderer = duck_renderer();
    let a = renderer.add_lens(
        &load_lens("dgauss.50mm", None).unwrap(),
        focus(4.0),
        ApertureSetting::Full,
    );
    let b = renderer.add_lens(
        &load_lens("wide.22mm", None).unwrap(),
        focus(4.0),
        ApertureSetting::Full,
    );
    renderer.set_active_lens(a);
    let first = render(&mut renderer);
    renderer.set_active_lens(b);
    let through_b = render(&mut renderer);
    renderer.set_active_lens(a);
    let again = render(&mut renderer);
    assert_eq!(first, again);
    assert_ne!(
        first, through_b,
        "a different lens makes a different picture"
    );
    assert_eq!(
        builds(&renderer),
        (1, 1),
        "one scene load and one BVH build for the whole session"
    );

    // Despawning a lens set and spawning a fresh copy of it is the same lens.
    renderer.world.despawn(a);
    let a2 = renderer.add_lens(
        &load_lens("dgauss.50mm", None).unwrap(),
        focus(4.0),
        ApertureSetting::Full,
    );
    renderer.set_active_lens(a2);
    assert_eq!(render(&mut renderer), first);
    assert_eq!(builds(&renderer), (1, 1));
}

#[test]
fn editing_an_element_and_back_gives_the_same_image() {
    let (mut renderer, lens) = duck_through_dgauss();
    let before = render(&mut renderer);
    let mut surfaces = renderer.world.query::<&mut LensSurface>();
    let original = surfaces
        .iter(&renderer.world)
        .find(|s| s.order == 3)
        .unwrap()
        .base;
    for mut s in surfaces.iter_mut(&mut renderer.world) {
        if s.order == 3 {
            s.base.index = 1.75;
        }
    }
    let edited = render(&mut renderer);
    assert_ne!(before, edited, "a different glass changes the image");
    for mut s in surfaces.iter_mut(&mut renderer.world) {
        if s.order == 3 {
            s.base = original;
        }
    }
    assert_eq!(render(&mut renderer), before);
    // Focus and aperture edits and back, likewise.
    *renderer.world.get_mut::<FocusSetting>(lens).unwrap() = focus(1.5);
    *renderer.world.get_mut::<ApertureSetting>(lens).unwrap() = ApertureSetting::FNumber(8.0);
    let _ = render(&mut renderer);
    *renderer.world.get_mut::<FocusSetting>(lens).unwrap() = focus(4.0);
    *renderer.world.get_mut::<ApertureSetting>(lens).unwrap() = ApertureSetting::Full;
    assert_eq!(render(&mut renderer), before);
    assert_eq!(builds(&renderer), (1, 1));
}

/// A pass abandoned through `PassCancel` leaves the film as it was, and the passes after it
/// give the image an uninterrupted render gives.
#[test]
fn a_cancelled_pass_leaves_the_film_untouched() {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};
    let (mut renderer, _) = duck_through_dgauss();
    let reference = render(&mut renderer);

    let flag = Arc::new(AtomicBool::new(false));
    renderer
        .world
        .insert_resource(realcam::pipeline::PassCancel(Arc::clone(&flag)));
    renderer.begin_film(None).unwrap();
    assert!(renderer.render_pass_unless_cancelled(0).unwrap());
    let one = renderer.image().unwrap();
    flag.store(true, Ordering::Relaxed);
    assert!(!renderer.render_pass_unless_cancelled(1).unwrap());
    assert_eq!(
        renderer.image().unwrap(),
        one,
        "a cancelled pass reached the film"
    );
    flag.store(false, Ordering::Relaxed);
    for sample in 1..3 {
        assert!(renderer.render_pass_unless_cancelled(sample).unwrap());
    }
    assert_eq!(renderer.image().unwrap(), reference);
}
