//! Lens entities: derived data follows every kind of edit, and only what an edit invalidates
//! is recomputed (change detection).

use realcam::lens::Asphere;
use realcam::lens::aperture::ApertureSetting;
use realcam::lens::chromatic::axial_colour;
use realcam::lens::elements::{
    FilmFormat, FilmPlacement, FocusSetting, LensDerivationStats, LensFault, LensGeometry,
    LensSurface, SurfaceAsphere, SurfaceGlass, activate_lens, spawn_lens,
};
use realcam::lens::focus::FocusMode;
use realcam::lens::io::bundled::load_lens;
use realcam::lens::pupil::ExitPupil;
use realcam::pipeline::Renderer;

fn runs(renderer: &Renderer) -> (u64, u64, u64) {
    let s = renderer.world.resource::<LensDerivationStats>();
    (s.geometry_runs, s.placement_runs, s.pupil_runs)
}

fn focus(metres: f64) -> FocusSetting {
    FocusSetting::Distance {
        metres,
        mode: FocusMode::Paraxial,
    }
}

#[test]
fn derivation_reruns_only_what_an_edit_invalidates() {
    let mut renderer = Renderer::new();
    let lens = spawn_lens(
        &mut renderer.world,
        &load_lens("dgauss.50mm", None).unwrap(),
        focus(10.0),
        ApertureSetting::Full,
    );
    activate_lens(&mut renderer.world, lens);
    renderer.update().unwrap();
    assert_eq!(runs(&renderer), (1, 1, 1));
    let film_at_10m = renderer
        .world
        .get::<FilmPlacement>(lens)
        .unwrap()
        .film_distance;

    // Nothing changed: nothing reruns.
    renderer.update().unwrap();
    assert_eq!(runs(&renderer), (1, 1, 1));

    // Focus: film distance and pupil bounds (the film moved), not the geometry.
    *renderer.world.get_mut::<FocusSetting>(lens).unwrap() = focus(2.0);
    renderer.update().unwrap();
    assert_eq!(runs(&renderer), (1, 2, 2));
    let film_at_2m = renderer
        .world
        .get::<FilmPlacement>(lens)
        .unwrap()
        .film_distance;
    assert!(film_at_2m > film_at_10m, "closer focus moves the film back");

    // Aperture: everything.
    *renderer.world.get_mut::<ApertureSetting>(lens).unwrap() = ApertureSetting::FNumber(8.0);
    renderer.update().unwrap();
    assert_eq!(runs(&renderer), (2, 3, 3));
    let f_number = renderer
        .world
        .get::<LensGeometry>(lens)
        .unwrap()
        .first_order
        .f_number;
    assert!((f_number - 8.0).abs() < 1e-9);

    // Film size: pupil bounds only.
    renderer.world.resource_mut::<FilmFormat>().diagonal_mm = 43.0;
    renderer.update().unwrap();
    assert_eq!(runs(&renderer), (2, 3, 4));
    assert_eq!(
        renderer.world.get::<ExitPupil>(lens).unwrap().film_radius,
        21.5
    );
}

#[test]
fn editing_an_element_and_back_restores_the_lens() {
    let mut renderer = Renderer::new();
    let lens = spawn_lens(
        &mut renderer.world,
        &load_lens("dgauss.50mm", None).unwrap(),
        focus(5.0),
        ApertureSetting::Full,
    );
    activate_lens(&mut renderer.world, lens);
    renderer.update().unwrap();
    let before = renderer
        .world
        .get::<LensGeometry>(lens)
        .unwrap()
        .first_order;
    let pupil_before = renderer.world.get::<ExitPupil>(lens).unwrap().clone();

    let mut surfaces = renderer.world.query::<&mut LensSurface>();
    let original = surfaces
        .iter(&renderer.world)
        .find(|s| s.order == 0)
        .unwrap()
        .base;
    for mut s in surfaces.iter_mut(&mut renderer.world) {
        if s.order == 0 {
            s.base.radius *= 1.1;
        }
    }
    renderer.update().unwrap();
    let edited = renderer
        .world
        .get::<LensGeometry>(lens)
        .unwrap()
        .first_order;
    assert!(
        (edited.focal_length - before.focal_length).abs() > 0.1,
        "a flatter front element changes the focal length"
    );

    for mut s in surfaces.iter_mut(&mut renderer.world) {
        if s.order == 0 {
            s.base = original;
        }
    }
    renderer.update().unwrap();
    assert_eq!(
        renderer
            .world
            .get::<LensGeometry>(lens)
            .unwrap()
            .first_order,
        before
    );
    assert_eq!(
        renderer.world.get::<ExitPupil>(lens).unwrap(),
        &pupil_before
    );
}

#[test]
fn a_broken_edit_or_impossible_focus_faults_the_lens_clearly() {
    let mut renderer = Renderer::new();
    let lens = spawn_lens(
        &mut renderer.world,
        &load_lens("telephoto.250mm", None).unwrap(),
        focus(1.0),
        ApertureSetting::Full,
    );
    activate_lens(&mut renderer.world, lens);
    renderer.update().unwrap();
    let fault = renderer
        .world
        .get::<LensFault>(lens)
        .expect("1 m is too close for this telephoto");
    assert!(fault.0.contains("closest"), "{}", fault.0);
    assert!(renderer.check_active_lens().is_err());

    *renderer.world.get_mut::<FocusSetting>(lens).unwrap() = focus(20.0);
    renderer.update().unwrap();
    assert!(renderer.world.get::<LensFault>(lens).is_none());
    assert!(renderer.check_active_lens().is_ok());

    let mut surfaces = renderer.world.query::<&mut LensSurface>();
    for mut s in surfaces.iter_mut(&mut renderer.world) {
        if s.order == 1 {
            s.base.thickness = -3.0;
        }
    }
    renderer.update().unwrap();
    let fault = renderer
        .world
        .get::<LensFault>(lens)
        .expect("negative thickness is invalid");
    assert!(fault.0.contains("negative thickness"), "{}", fault.0);
}

#[test]
fn lenses_are_independent_entity_sets() {
    let mut renderer = Renderer::new();
    let a = spawn_lens(
        &mut renderer.world,
        &load_lens("dgauss.50mm", None).unwrap(),
        focus(5.0),
        ApertureSetting::Full,
    );
    let b = spawn_lens(
        &mut renderer.world,
        &load_lens("wide.22mm", None).unwrap(),
        focus(5.0),
        ApertureSetting::Full,
    );
    activate_lens(&mut renderer.world, b);
    renderer.update().unwrap();
    let efl = |r: &Renderer, e| {
        r.world
            .get::<LensGeometry>(e)
            .unwrap()
            .first_order
            .focal_length
    };
    assert!((efl(&renderer, a) - 50.358).abs() < 0.01);
    assert!((efl(&renderer, b) - 22.024).abs() < 0.01);
    // Despawning a lens removes its surfaces with it.
    renderer.world.despawn(a);
    let left = renderer
        .world
        .query::<&LensSurface>()
        .iter(&renderer.world)
        .count();
    assert_eq!(left, 13, "only wide.22mm's 13 surfaces remain");
}

/// The entities of `lens`'s surfaces, front to back.
fn surface_entities(
    renderer: &Renderer,
    lens: bevy_ecs::entity::Entity,
) -> Vec<bevy_ecs::entity::Entity> {
    let children: Vec<_> = renderer
        .world
        .get::<bevy_ecs::hierarchy::Children>(lens)
        .unwrap()
        .iter()
        .copied()
        .collect();
    let mut ordered: Vec<(usize, bevy_ecs::entity::Entity)> = children
        .into_iter()
        .map(|c| (renderer.world.get::<LensSurface>(c).unwrap().order, c))
        .collect();
    ordered.sort();
    ordered.into_iter().map(|(_, c)| c).collect()
}

/// An asphere and a glass are components of their surface's entity: taking the aspheres away
/// gives exactly the lens with spherical surfaces (its spherical twin), and a lens whose
/// glasses are taken away has no colour (the F- and C-line foci coincide), each a single
/// re-derivation of the geometry.
#[test]
fn aspheres_and_glasses_are_surface_components() {
    let mut renderer = Renderer::new();
    let aspheric = load_lens("canon-rf-16mm-f2.8", None).unwrap();
    let lens = spawn_lens(
        &mut renderer.world,
        &aspheric,
        focus(3.0),
        ApertureSetting::Full,
    );
    activate_lens(&mut renderer.world, lens);
    renderer.update().unwrap();
    let surfaces = surface_entities(&renderer, lens);
    let with_asphere: Vec<usize> = (0..surfaces.len())
        .filter(|&i| renderer.world.get::<SurfaceAsphere>(surfaces[i]).is_some())
        .collect();
    let in_file: Vec<usize> = (0..aspheric.rows.len())
        .filter(|&i| aspheric.rows[i].asphere != Asphere::NONE)
        .collect();
    assert_eq!(with_asphere, in_file);
    assert!(!in_file.is_empty());
    for (i, &surface) in surfaces.iter().enumerate() {
        assert_eq!(
            renderer.world.get::<SurfaceGlass>(surface).map(|g| g.0),
            aspheric.rows[i].glass
        );
    }

    // Take the aspheres away: the geometry is the spherical twin's, derived once more.
    let (geometry_runs, _, _) = runs(&renderer);
    for &i in &with_asphere {
        renderer
            .world
            .entity_mut(surfaces[i])
            .remove::<SurfaceAsphere>();
    }
    renderer.update().unwrap();
    assert_eq!(runs(&renderer).0, geometry_runs + 1);
    let mut twin = aspheric.clone();
    for row in &mut twin.rows {
        row.asphere = Asphere::NONE;
    }
    let twin_lens = spawn_lens(
        &mut renderer.world,
        &twin,
        focus(3.0),
        ApertureSetting::Full,
    );
    renderer.update().unwrap();
    let geometry = |renderer: &Renderer, e| {
        renderer
            .world
            .get::<LensGeometry>(e)
            .unwrap()
            .system
            .clone()
    };
    assert_eq!(geometry(&renderer, lens), geometry(&renderer, twin_lens));
    assert!(
        geometry(&renderer, lens)
            .rows
            .iter()
            .all(|r| r.asphere == Asphere::NONE)
    );

    // Take the glasses away: no dispersion, so no axial colour.
    let colour = |renderer: &Renderer| axial_colour(&geometry(renderer, lens)).unwrap();
    assert!(
        colour(&renderer).abs() > 1e-3,
        "the lens has colour: {} mm",
        colour(&renderer)
    );
    for &surface in &surfaces {
        renderer.world.entity_mut(surface).remove::<SurfaceGlass>();
    }
    renderer.update().unwrap();
    assert!(
        geometry(&renderer, lens)
            .rows
            .iter()
            .all(|r| r.glass.is_none())
    );
    assert!(colour(&renderer).abs() < 1e-12, "{} mm", colour(&renderer));

    // A glass put back on one surface brings that surface's dispersion back.
    let first_glass = aspheric
        .rows
        .iter()
        .position(|r| r.glass.is_some())
        .unwrap();
    let glass = aspheric.rows[first_glass].glass.unwrap();
    renderer
        .world
        .entity_mut(surfaces[first_glass])
        .insert(SurfaceGlass(glass));
    renderer.update().unwrap();
    assert_eq!(
        geometry(&renderer, lens).rows[first_glass].glass,
        Some(glass)
    );
    assert!(colour(&renderer).abs() > 1e-4);
}
