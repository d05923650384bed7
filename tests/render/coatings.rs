//! The surfaces' losses in renders (`realcam::lens::reflectance`): a lens whose every surface
//! reflects nothing renders the lossless lens bit for bit, and a white furnace seen through bare
//! or single-coated glass is dimmed by the axial transmission that Fresnel's and Airy's closed
//! forms give, computed here from the lens's indices.

use glam::Vec3;
use realcam::film::Image;
use realcam::lens::Prescription;
use realcam::lens::aperture::ApertureSetting;
use realcam::lens::coating::{Coating, CoatingModel};
use realcam::lens::elements::{CoatingChoice, Dispersion, Flare, FocusSetting};
use realcam::lens::focus::FocusMode;
use realcam::lens::io::bundled::load_lens;
use realcam::lens::pupil::PupilSampling;
use realcam::pipeline::{RenderSettings, Renderer, SceneSource};
use realcam::scene::look_at;
use realcam::shade::Environment;

use crate::support::{GltfBuilder, emitter, matte, quad};

const SIDE: u32 = 24;

/// Emitters and a grey patch on a dark wall, or with `furnace` nothing in view but the sky.
fn scene(furnace: bool) -> &'static [u8] {
    let mut gltf = GltfBuilder::default();
    let dark = matte(&mut gltf, [0.05, 0.05, 0.05]);
    let grey = matte(&mut gltf, [0.5, 0.5, 0.5]);
    let light = emitter(&mut gltf, 20.0);
    let nodes = if furnace {
        // Behind the camera, out of view: the scene needs something to hold.
        vec![quad(&mut gltf, [0.0, 0.0, 50.0], 0.01, grey, 1.0)]
    } else {
        vec![
            quad(&mut gltf, [0.0, 0.0, -3.0], 40.0, dark, 1.0),
            quad(&mut gltf, [0.3, 0.2, -2.9], 0.4, light, 1.0),
            quad(&mut gltf, [-1.2, -0.6, -2.95], 0.8, grey, 1.0),
        ]
    };
    gltf.scene(&nodes);
    Box::leak(gltf.glb().into_boxed_slice())
}

fn render(
    scene: &'static [u8],
    prescription: &Prescription,
    choice: CoatingChoice,
    dispersion: Dispersion,
    aperture: ApertureSetting,
) -> Image {
    let mut renderer = Renderer::new();
    renderer.set_scene(SceneSource {
        path: "coatings.glb".into(),
        embedded: Some(scene),
    });
    renderer.set_environment(Environment::Uniform(Vec3::ONE));
    renderer.set_camera(look_at(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), Vec3::Y));
    renderer.set_film(35.0, PupilSampling::Bounds);
    renderer.set_settings(RenderSettings {
        width: SIDE,
        height: SIDE,
        seed: 3,
        max_depth: 2,
        tile_size: 8,
        ..RenderSettings::default()
    });
    let focus = FocusSetting::Distance {
        metres: 3.0,
        mode: FocusMode::Paraxial,
    };
    let lens = renderer.add_lens(prescription, focus, aperture);
    // The ghosts' light aside (the ghost estimator has its own tests): the losses alone.
    renderer
        .world
        .entity_mut(lens)
        .insert((dispersion, Flare::Off));
    renderer.set_coating_choice(lens, choice);
    renderer.set_active_lens(lens);
    renderer.render(8, |_, _| true).unwrap()
}

fn bits(image: &Image) -> Vec<[u32; 3]> {
    image.mean().iter().map(|p| p.map(f32::to_bits)).collect()
}

/// Every surface given a coating that reflects nothing (so the renderer builds and reads its
/// reflectance tables, all zero) renders exactly what the lossless lens renders, spectrally
/// with several wavelengths per sample and at the lens's own indices: the losses multiply by
/// exactly one.
#[test]
fn surfaces_that_reflect_nothing_render_the_lossless_lens_bit_for_bit() {
    let dgauss = load_lens("dgauss.50mm", None).unwrap();
    let nothing = Some(Coating::Measured(vec![(400.0, 0.0), (700.0, 0.0)]));
    let reflecting_nothing = dgauss
        .clone()
        .with_coatings(vec![nothing; dgauss.rows.len()])
        .unwrap();
    let file = CoatingChoice::AsFileSays {
        default: CoatingModel::Single,
    };
    for dispersion in [Dispersion::On, Dispersion::Off] {
        let lossless = render(
            scene(false),
            &dgauss,
            CoatingChoice::Everywhere(CoatingModel::Ideal),
            dispersion,
            ApertureSetting::Full,
        );
        let zero = render(
            scene(false),
            &reflecting_nothing,
            file,
            dispersion,
            ApertureSetting::Full,
        );
        assert!(bits(&lossless) == bits(&zero), "{dispersion:?}");
        // And the losses are really applied when the surfaces reflect.
        let single = render(
            scene(false),
            &dgauss,
            file,
            dispersion,
            ApertureSetting::Full,
        );
        assert!(bits(&lossless) != bits(&single), "{dispersion:?}");
    }
}

/// Normal-incidence reflectance of a quarter-wave layer of index `nc` (thickness 550/(4·nc)
/// nm) on glass `ns`, from air, at `nm`: Airy's sum of the two interfaces' amplitudes
/// r₁ = (1 − nc)/(1 + nc), r₂ = (nc − ns)/(nc + ns) with the layer's round-trip phase 2δ,
/// δ = 2π·nc·d/λ (Hecht, *Optics*, §9.7).
fn quarter_wave_reflectance(nc: f64, ns: f64, nm: f64) -> f64 {
    let r1 = (1.0 - nc) / (1.0 + nc);
    let r2 = (nc - ns) / (nc + ns);
    let delta = 2.0 * std::f64::consts::PI * nc * (550.0 / (4.0 * nc)) / nm;
    let c = (2.0 * delta).cos();
    (r1 * r1 + r2 * r2 + 2.0 * r1 * r2 * c) / (1.0 + r1 * r1 * r2 * r2 + 2.0 * r1 * r2 * c)
}

/// A white furnace through dgauss.50mm stopped to f/11 (rays within 3° of the axis at the
/// film's centre, where a surface's reflectance is its normal-incidence value within 1e-4
/// relative), at the lens's own indices: the centre of the image with bare glass, and with a
/// single MgF₂ layer on the air–glass surfaces, over the lossless image is the product of
/// 1 − R over the surfaces, R from Fresnel, ((n₁ − n₂)/(n₁ + n₂))², on bare and cemented
/// surfaces and from Airy's formula on coated ones. The same rays are traced each time (same
/// seed), so the ratio carries almost no noise.
#[test]
fn a_white_furnace_is_dimmed_by_the_axial_transmission_of_the_coatings() {
    let dgauss = load_lens("dgauss.50mm", None).unwrap();
    let d_line = 587.5618;
    let centre_mean = |image: &Image| {
        let mean = image.mean();
        let mut sum = [0.0f64; 3];
        for y in SIDE / 2 - 2..SIDE / 2 + 2 {
            for x in SIDE / 2 - 2..SIDE / 2 + 2 {
                for c in 0..3 {
                    sum[c] += mean[(y * SIDE + x) as usize][c] as f64;
                }
            }
        }
        sum
    };
    let shot = |model| {
        render(
            scene(true),
            &dgauss,
            CoatingChoice::Everywhere(model),
            Dispersion::Off,
            ApertureSetting::FNumber(11.0),
        )
    };
    let lossless = centre_mean(&shot(CoatingModel::Ideal));
    for model in [CoatingModel::None, CoatingModel::Single] {
        let mut expected = 1.0;
        let mut before = 1.0f64;
        for row in &dgauss.rows {
            let after = row.base.index;
            let air = |n: f64| (n - 1.0).abs() < 1e-3;
            let glass = if air(before) { after } else { before };
            let r = if model == CoatingModel::Single && air(before) != air(after) {
                quarter_wave_reflectance(1.38, glass, d_line)
            } else {
                ((before - after) / (before + after)).powi(2)
            };
            expected *= 1.0 - r;
            before = after;
        }
        let dimmed = centre_mean(&shot(model));
        for c in 0..3 {
            let ratio = dimmed[c] / lossless[c];
            assert!(
                (ratio / expected - 1.0).abs() < 1e-3,
                "{model:?} channel {c}: {ratio} vs {expected}"
            );
        }
    }
}
