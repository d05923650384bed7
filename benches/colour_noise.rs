//! Colour noise of spectral camera rays: a flat grey wall filling the view under a white sky,
//! 128², through lenses with glass data, rendered spectrally and at the lens files' indices
//! (`--dispersion off`) at 64 spp. Noise is each channel's RMS difference, over the central
//! half of the frame, from a 1024-spp render of the same setting, relative to its mean.
//! Prints a table (no timing): `cargo bench --bench colour_noise`.

use glam::{Mat4, Vec3};
use realcam::film::Image;
use realcam::lens::aperture::ApertureSetting;
use realcam::lens::elements::{Dispersion, FocusSetting};
use realcam::lens::focus::FocusMode;
use realcam::lens::io::bundled::load_lens;
use realcam::lens::pupil::PupilSampling;
use realcam::pipeline::{RenderSettings, Renderer, SceneSource};
use realcam::scene::look_at;
use realcam::shade::Environment;

const SIZE: u32 = 128;
const SPP: u32 = 64;
const REFERENCE_SPP: u32 = 1024;

/// A 20 m grey (albedo 0.5) square at z = 0 facing +z, as an embedded glTF.
fn grey_wall() -> &'static [u8] {
    let positions: [[f32; 3]; 4] = [
        [-10.0, -10.0, 0.0],
        [10.0, -10.0, 0.0],
        [10.0, 10.0, 0.0],
        [-10.0, 10.0, 0.0],
    ];
    let mut buffer: Vec<u8> = Vec::new();
    for p in positions {
        for v in p {
            buffer.extend(v.to_le_bytes());
        }
    }
    for _ in 0..4 {
        for v in [0.0f32, 0.0, 1.0] {
            buffer.extend(v.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        buffer.extend(i.to_le_bytes());
    }
    let uri = format!("data:application/octet-stream;base64,{}", base64(&buffer));
    let gltf = serde_json::json!({
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}],
        "buffers": [{"byteLength": buffer.len(), "uri": uri}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 48},
            {"buffer": 0, "byteOffset": 96, "byteLength": 12}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-10.0, -10.0, 0.0], "max": [10.0, 10.0, 0.0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}]
    });
    Box::leak(serde_json::to_vec(&gltf).expect("json").into_boxed_slice())
}

fn base64(bytes: &[u8]) -> String {
    const TABLE: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(TABLE[((n >> (18 - 6 * k)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

fn render(lens: &str, dispersion: Dispersion, spp: u32) -> Image {
    let mut renderer = Renderer::new();
    renderer.set_scene(SceneSource {
        path: "grey-wall.gltf".into(),
        embedded: Some(grey_wall()),
    });
    renderer.update().expect("the wall loads");
    renderer.set_environment(Environment::Uniform(Vec3::ONE));
    let camera: Mat4 = look_at(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y);
    renderer.set_camera(camera);
    renderer.set_film(24.0, PupilSampling::Bounds);
    renderer.set_settings(RenderSettings {
        width: SIZE,
        height: SIZE,
        seed: 5,
        max_depth: 3,
        tile_size: 32,
    });
    let prescription = load_lens(lens, None).expect("bundled lens");
    let entity = renderer.add_lens(
        &prescription,
        FocusSetting::Distance {
            metres: 3.0,
            mode: FocusMode::Paraxial,
        },
        ApertureSetting::Full,
    );
    renderer.world.entity_mut(entity).insert(dispersion);
    renderer.set_active_lens(entity);
    renderer.render(spp, |_, _| true).expect("renders")
}

/// Per channel: RMS of (image − reference) over the central half, relative to the mean there.
fn noise(image: &Image, reference: &Image) -> [f64; 3] {
    let (a, r) = (image.mean(), reference.mean());
    let (mut squares, mut means, mut count) = ([0.0f64; 3], [0.0f64; 3], 0.0);
    for y in SIZE / 4..3 * SIZE / 4 {
        for x in SIZE / 4..3 * SIZE / 4 {
            let i = (y * SIZE + x) as usize;
            for k in 0..3 {
                squares[k] += (a[i][k] as f64 - r[i][k] as f64).powi(2);
                means[k] += r[i][k] as f64;
            }
            count += 1.0;
        }
    }
    std::array::from_fn(|k| (squares[k] / count).sqrt() / (means[k] / count))
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    println!(
        "colour noise, grey wall under a white sky, {SIZE}², {SPP} spp (relative RMS vs {REFERENCE_SPP} spp)"
    );
    println!(
        "{:<20} {:>24} {:>24} {:>20}",
        "lens", "fixed index (R G B)", "spectral (R G B)", "ratio (R G B)"
    );
    for lens in ["dgauss.50mm", "canon-ef-35mm-f2"] {
        let fixed = noise(
            &render(lens, Dispersion::Off, SPP),
            &render(lens, Dispersion::Off, REFERENCE_SPP),
        );
        let spectral = noise(
            &render(lens, Dispersion::On, SPP),
            &render(lens, Dispersion::On, REFERENCE_SPP),
        );
        let show = |v: [f64; 3]| format!("{:.4} {:.4} {:.4}", v[0], v[1], v[2]);
        let ratio: [f64; 3] = std::array::from_fn(|k| spectral[k] / fixed[k]);
        println!(
            "{lens:<20} {:>24} {:>24} {:>20}",
            show(fixed),
            show(spectral),
            format!("{:.2} {:.2} {:.2}", ratio[0], ratio[1], ratio[2])
        );
    }
}
