//! End-to-end smoke runs on the shared sample scenes (`../shared/scenes`), ignored by default:
//! `cargo test --release gltf_smoke -- --ignored --nocapture`. They print BVH build time and
//! ray throughput and write a small pinhole render to the temp directory for a look.
//!
//! The glTF reading here is a bare minimum for these runs (triangle lists, node transforms,
//! material factors, 8-bit textures); the project's loader lives in `crate::scene`.

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use glam::{Mat4, Vec2, Vec3, Vec4};

use super::*;
use crate::batch::{HitBatch, RayBatch};
use crate::scene::{AlphaMode, Mesh, Texture, TextureRef, WrapMode};
use crate::shade::{RadianceBatch, ShadeStats};

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn load(path: &Path) -> (Vec<MeshInstance>, MaterialLibrary) {
    let (document, buffers, images) = gltf::import(path).expect("glTF");
    let srgb_images: std::collections::HashSet<usize> = document
        .materials()
        .flat_map(|m| {
            [
                m.pbr_metallic_roughness()
                    .base_color_texture()
                    .map(|t| t.texture().source().index()),
                m.emissive_texture().map(|t| t.texture().source().index()),
            ]
        })
        .flatten()
        .collect();
    let textures = images
        .iter()
        .enumerate()
        .map(|(i, image)| {
            let channels = match image.format {
                gltf::image::Format::R8G8B8 => 3,
                gltf::image::Format::R8G8B8A8 => 4,
                _ => {
                    return Arc::new(Texture {
                        width: 1,
                        height: 1,
                        texels: vec![[1.0; 4]],
                        wrap_s: WrapMode::Repeat,
                        wrap_t: WrapMode::Repeat,
                        nearest: false,
                    });
                }
            };
            let decode = |c: u8, k: usize| {
                if k < 3 && srgb_images.contains(&i) {
                    srgb_to_linear(c as f32 / 255.0)
                } else {
                    c as f32 / 255.0
                }
            };
            let texels = image
                .pixels
                .chunks(channels)
                .map(|p| {
                    [
                        decode(p[0], 0),
                        decode(p[1], 1),
                        decode(p[2], 2),
                        if channels == 4 { decode(p[3], 3) } else { 1.0 },
                    ]
                })
                .collect();
            Arc::new(Texture {
                width: image.width,
                height: image.height,
                texels,
                wrap_s: WrapMode::Repeat,
                wrap_t: WrapMode::Repeat,
                nearest: false,
            })
        })
        .collect();
    let reference = |info: Option<gltf::texture::Info>| {
        info.map(|t| TextureRef {
            texture: t.texture().source().index(),
            tex_coord: t.tex_coord(),
        })
    };
    let materials = document
        .materials()
        .map(|m| {
            let pbr = m.pbr_metallic_roughness();
            Material {
                name: m.name().map(str::to_owned),
                base_color: Vec4::from_array(pbr.base_color_factor()),
                base_color_texture: reference(pbr.base_color_texture()),
                metallic: pbr.metallic_factor(),
                roughness: pbr.roughness_factor(),
                metallic_roughness_texture: reference(pbr.metallic_roughness_texture()),
                normal_texture: m.normal_texture().map(|t| TextureRef {
                    texture: t.texture().source().index(),
                    tex_coord: t.tex_coord(),
                }),
                normal_scale: m.normal_texture().map_or(1.0, |t| t.scale()),
                emissive: Vec3::from_array(m.emissive_factor())
                    * m.emissive_strength().unwrap_or(1.0),
                emissive_texture: reference(m.emissive_texture()),
                alpha_mode: match m.alpha_mode() {
                    gltf::material::AlphaMode::Mask => {
                        AlphaMode::Mask(m.alpha_cutoff().unwrap_or(0.5))
                    }
                    gltf::material::AlphaMode::Blend => AlphaMode::Blend,
                    gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
                },
                double_sided: m.double_sided(),
            }
        })
        .collect();
    let mut instances = Vec::new();
    let mut stack: Vec<(gltf::Node, Mat4)> = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .expect("scene")
        .nodes()
        .map(|n| (n, Mat4::IDENTITY))
        .collect();
    while let Some((node, parent)) = stack.pop() {
        let transform = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if let Some(mesh) = node.mesh() {
            for primitive in mesh
                .primitives()
                .filter(|p| p.mode() == gltf::mesh::Mode::Triangles)
            {
                let reader = primitive.reader(|b| Some(&buffers[b.index()]));
                let positions: Vec<Vec3> = reader
                    .read_positions()
                    .expect("positions")
                    .map(Vec3::from_array)
                    .collect();
                let indices: Vec<u32> = reader.read_indices().map_or_else(
                    || (0..positions.len() as u32).collect(),
                    |i| i.into_u32().collect(),
                );
                let mesh = Mesh {
                    normals: reader
                        .read_normals()
                        .map_or_else(Vec::new, |n| n.map(Vec3::from_array).collect()),
                    tangents: reader
                        .read_tangents()
                        .map_or_else(Vec::new, |t| t.map(Vec4::from_array).collect()),
                    uvs: reader
                        .read_tex_coords(0)
                        .map_or_else(Vec::new, |t| t.into_f32().map(Vec2::from_array).collect()),
                    triangles: indices
                        .chunks_exact(3)
                        .map(|t| [t[0], t[1], t[2]])
                        .collect(),
                    material: primitive.material().index(),
                    positions,
                };
                instances.push(MeshInstance {
                    mesh: Arc::new(mesh),
                    world_from_local: transform,
                    node_name: node.name().map(str::to_owned),
                });
            }
        }
        stack.extend(node.children().map(|c| (c, transform)));
    }
    (
        instances,
        MaterialLibrary {
            materials,
            textures,
            ..Default::default()
        },
    )
}

/// Renders `width`×`height` pixels at `spp` through a pinhole at `eye` looking at `target`
/// (vertical field of view `fov_y`), prints timings and writes a PNG.
#[allow(clippy::too_many_arguments)]
fn render(
    name: &str,
    scene: &TestScene,
    eye: Vec3,
    target: Vec3,
    fov_y: f32,
    (width, height): (u32, u32),
    spp: u32,
    max_depth: u32,
) {
    let forward = (target - eye).normalize();
    let right = forward.cross(Vec3::Y).normalize();
    let up = right.cross(forward);
    let half_height = (fov_y * 0.5).tan();
    let half_width = half_height * width as f32 / height as f32;
    let mut rays = RayBatch::with_capacity((width * height * spp) as usize);
    for pixel in 0..width * height {
        let (x, y) = (pixel % width, pixel / width);
        for sample in 0..spp {
            let mut rng = Rng::for_sample(0xCA3E, pixel, sample);
            let (sx, sy) = (
                (x as f32 + rng.next_f32()) / width as f32,
                (y as f32 + rng.next_f32()) / height as f32,
            );
            let direction = (forward
                + right * (2.0 * sx - 1.0) * half_width
                + up * (1.0 - 2.0 * sy) * half_height)
                .normalize();
            rays.push(eye.into(), direction.into(), pixel, sample);
        }
    }
    let start = Instant::now();
    let mut hits = HitBatch::default();
    scene.accel.intersect_batch(&rays, &mut hits);
    let primary = start.elapsed();
    let start = Instant::now();
    let mut out = RadianceBatch::default();
    let mut stats = ShadeStats::default();
    scene
        .shader(max_depth, 1)
        .shade_batch(&rays, &hits, &mut out, &mut stats);
    let shading = start.elapsed();
    println!(
        "{name}: {} camera rays in {:.2?} ({:.2} Mrays/s); shading {:.2?}, {} more rays ({:.2} Mrays/s incl. shading)",
        rays.len(),
        primary,
        rays.len() as f64 / primary.as_secs_f64() / 1e6,
        shading,
        stats.rays_traced,
        stats.rays_traced as f64 / shading.as_secs_f64() / 1e6
    );
    let mut pixels = vec![Vec3::ZERO; (width * height) as usize];
    for i in 0..rays.len() {
        assert!(out.r[i].is_finite() && out.g[i].is_finite() && out.b[i].is_finite());
        pixels[rays.pixel[i] as usize] += Vec3::new(out.r[i], out.g[i], out.b[i]) / spp as f32;
    }
    // Expose so the mean luminance lands at 18 % grey, then sRGB-encode.
    let mean = pixels
        .iter()
        .map(|p| crate::shade::bsdf::luminance(*p))
        .sum::<f32>()
        / pixels.len() as f32;
    let exposure = if mean > 0.0 { 0.18 / mean } else { 1.0 };
    let encode = |c: f32| {
        let c = (c * exposure).clamp(0.0, 1.0);
        ((if c <= 0.0031308 {
            12.92 * c
        } else {
            1.055 * c.powf(1.0 / 2.4) - 0.055
        }) * 255.0)
            .round() as u8
    };
    let image = image::RgbImage::from_fn(width, height, |x, y| {
        let p = pixels[(y * width + x) as usize];
        image::Rgb([encode(p.x), encode(p.y), encode(p.z)])
    });
    let path = std::env::temp_dir().join(format!("realcam-shade-{name}.png"));
    image.save(&path).expect("png");
    println!("{name}: wrote {}", path.display());
}

fn scene_file(relative: &str) -> Option<std::path::PathBuf> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/scenes")
        .join(relative);
    path.exists().then_some(path)
}

fn build_scene(
    relative: &str,
    punctual: &[PunctualLight],
    environment: Environment,
) -> Option<TestScene> {
    let path = scene_file(relative)?;
    let (instances, materials) = load(&path);
    let accel = SceneAccel::build(&instances, &materials).expect("accel");
    println!(
        "{relative}: {} triangles ({} dropped), {} BVH nodes, built in {:.2?}",
        accel.triangle_count(),
        accel.dropped_triangle_count(),
        accel.node_count(),
        accel.build_time()
    );
    let lights = LightSet::build(punctual, &accel, &materials, &environment);
    Some(TestScene {
        accel,
        materials,
        lights,
        environment,
    })
}

#[test]
#[ignore = "reads ../shared/scenes; run by hand with --ignored --nocapture"]
fn gltf_smoke_cornell_box() {
    let Some(scene) = build_scene(
        "CornellBox/cornellBox-2.80-Eevee-gltf.gltf",
        &[],
        Environment::Uniform(Vec3::ZERO),
    ) else {
        return;
    };
    println!(
        "emissive triangles: {}",
        scene.lights.emissive_triangle_count()
    );
    render(
        "cornell",
        &scene,
        Vec3::new(0.0, 1.5, 5.0),
        Vec3::new(0.0, 1.4, 0.0),
        0.9,
        (160, 120),
        64,
        8,
    );
}

#[test]
#[ignore = "reads ../shared/scenes; run by hand with --ignored --nocapture"]
fn gltf_smoke_damaged_helmet() {
    let sun = PunctualLight::Directional {
        direction: Vec3::new(-0.4, -1.0, -0.6).normalize(),
        illuminance: Vec3::splat(3.0),
    };
    let Some(scene) = build_scene(
        "DamagedHelmet/DamagedHelmet.glb",
        &[sun],
        Environment::Uniform(Vec3::new(0.4, 0.5, 0.6)),
    ) else {
        return;
    };
    render(
        "helmet",
        &scene,
        Vec3::new(0.0, 0.0, 3.2),
        Vec3::ZERO,
        0.7,
        (160, 160),
        32,
        5,
    );
}

#[test]
#[ignore = "reads ../shared/scenes; run by hand with --ignored --nocapture"]
fn gltf_smoke_million_triangles() {
    let Some(scene) = build_scene(
        "MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.gltf",
        &[],
        Environment::Uniform(Vec3::ONE),
    ) else {
        return;
    };
    let bounds = scene.accel.bounds();
    let eye = bounds.center() + Vec3::new(0.0, 0.0, bounds.diagonal() * 0.8);
    render(
        "spheres",
        &scene,
        eye,
        bounds.center(),
        0.8,
        (200, 200),
        16,
        3,
    );
}
