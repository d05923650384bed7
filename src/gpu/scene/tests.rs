//! The scene kernels against the CPU's `SceneAccel` and `Texture::sample` on the same inputs.
//!
//! Tolerances. Nearest-texel sampling, triangle vertices and spawn offsets are bit-exact (one
//! correctly rounded multiply, floors, exact power-of-two scaling). Elsewhere the GPU may
//! contract a multiply and an add into an FMA and its 1/x is not correctly rounded, so values
//! agree to a few ulps: bilinear texels within 1e-6 (texels in [0, 1]); hit distances within
//! 1e-5 relative (plus 4 ulp of the coordinates), barycentrics within 1e-3; surface positions within 1e-6 of the triangle's
//! coordinate magnitude; normals, tangents and UVs within 1e-4.
//!
//! Ties. Where the CPU's hit lies within 1e-4 (barycentric) of its triangle's boundary, or the
//! two hits are at the same distance (1e-5 relative), the last-bit rounding of the two
//! triangle tests may decide differently which of two triangles sharing an edge (or whether a
//! silhouette edge) is hit; such rays are counted, must stay under 1 %, and are otherwise
//! excluded from the comparison.

use std::sync::Arc;

use glam::{Mat4, Quat, Vec2, Vec3, Vec4};

use super::*;
use crate::batch::Hit;
use crate::gpu::compute::{
    dispatch, kernel_with, read_buffer, storage_buffer, workgroups_for, zeroed_buffer,
};
use crate::sampling::Rng;
use crate::scene::default_scene::load_default_scene;
use crate::scene::{ColorEncoding, Material, Mesh, MeshInstance, TextureRef};

/// Runs `entry` of the scene's WGSL followed by `source` over `n` invocations (64 a
/// workgroup), the scene bound in group 1 and the test's buffers in group 3.
fn run_kernel(
    context: &GpuContext,
    scene: &GpuScene,
    source: &str,
    entry: &str,
    test: &[(&wgpu::Buffer, Access)],
    n: usize,
) {
    let empty = Bindings::new(context, "empty", &[]);
    let test = Bindings::new(context, "test", test);
    let source = format!("{SCENE_WGSL}\n{source}");
    let layouts = [
        &empty.layout,
        &scene.bindings.layout,
        &empty.layout,
        &test.layout,
    ];
    let pipeline = kernel_with(context, entry, &source, entry, &layouts).unwrap();
    let groups = [
        &empty.group,
        &scene.bindings.group,
        &empty.group,
        &test.group,
    ];
    dispatch(context, &pipeline, &groups, [workgroups_for(n, 64), 1, 1]).unwrap();
}

// ---- Traversal -------------------------------------------------------------------------------

#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct TestRay {
    origin: [f32; 3],
    t_max: f32,
    direction: [f32; 3],
    occlusion_t_max: f32,
}

/// WGSL `Hit`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuHit {
    t: f32,
    u: f32,
    v: f32,
    triangle: u32,
}

const TRACE: &str = r#"
struct TestRay { origin: vec3f, t_max: f32, direction: vec3f, occlusion_t_max: f32 }
@group(3) @binding(0) var<storage, read> test_rays: array<TestRay>;
@group(3) @binding(1) var<storage, read_write> test_hits: array<Hit>;
@group(3) @binding(2) var<storage, read_write> test_occluded: array<u32>;

@compute @workgroup_size(64)
fn trace(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= arrayLength(&test_rays) { return; }
    let ray = test_rays[id.x];
    test_hits[id.x] = scene_intersect(ray.origin, ray.direction, ray.t_max);
    test_occluded[id.x] = select(0u, 1u,
        scene_occluded(ray.origin, ray.direction, ray.occlusion_t_max));
}
"#;

fn gpu_trace(context: &GpuContext, scene: &GpuScene, rays: &[TestRay]) -> (Vec<GpuHit>, Vec<u32>) {
    let input = storage_buffer(context, "rays", rays);
    let hits = zeroed_buffer::<GpuHit>(context, "hits", rays.len());
    let occluded = zeroed_buffer::<u32>(context, "occluded", rays.len());
    run_kernel(
        context,
        scene,
        TRACE,
        "trace",
        &[
            (&input, Access::ReadOnly),
            (&hits, Access::ReadWrite),
            (&occluded, Access::ReadWrite),
        ],
        rays.len(),
    );
    (
        read_buffer(context, &hits, rays.len()).unwrap(),
        read_buffer(context, &occluded, rays.len()).unwrap(),
    )
}

/// True when the hit lies within 1e-4 (barycentric) of its triangle's boundary.
fn on_edge(hit: &Hit) -> bool {
    hit.u.min(hit.v).min(1.0 - hit.u - hit.v) < 1e-4
}

/// Rays over the scene, the cases traversal gets wrong most easily among them: from anywhere
/// in (a margin around) its bounds, from outside aimed at points inside, and leaving random
/// points of triangles from their spawn origins; a quarter along an axis and a quarter with
/// one direction component zero (obvhs's `safe_inverse`); a fifth with a finite t_max.
fn scene_rays(accel: &SceneAccel, count: usize, rng: &mut Rng) -> Vec<(Vec3, Vec3, f32)> {
    let bounds = accel.bounds();
    let size = bounds.max - bounds.min;
    let unit = |rng: &mut Rng| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    let axes = [
        Vec3::X,
        Vec3::Y,
        Vec3::Z,
        Vec3::NEG_X,
        Vec3::NEG_Y,
        Vec3::NEG_Z,
    ];
    (0..count)
        .map(|i| {
            let mut direction = (unit(rng) - 0.5).normalize_or(Vec3::X);
            match i % 4 {
                0 => direction = axes[rng.next_u32() as usize % 6],
                1 => {
                    direction[rng.next_u32() as usize % 3] = 0.0;
                    direction = direction.normalize_or(Vec3::Z);
                }
                _ => {}
            }
            let origin = match (i / 4) % 3 {
                0 => bounds.min + (unit(rng) * 1.2 - 0.1) * size,
                1 => {
                    let target = bounds.min + unit(rng) * size;
                    let from = target - direction * bounds.diagonal();
                    direction = (target - from).normalize();
                    from
                }
                _ => {
                    let triangle = rng.next_u32() % accel.triangle_count() as u32;
                    let (u, v) = (rng.next_f32(), rng.next_f32());
                    let (u, v) = if u + v > 1.0 {
                        (1.0 - u, 1.0 - v)
                    } else {
                        (u, v)
                    };
                    let on = Hit {
                        t: 0.0,
                        triangle,
                        u,
                        v,
                    };
                    accel.surface(&on, -direction).spawn_origin(direction)
                }
            };
            let t_max = if i % 5 == 0 {
                rng.next_f32() * bounds.diagonal()
            } else {
                f32::INFINITY
            };
            (origin, direction, t_max)
        })
        .collect()
}

/// Traces `rays` on both devices and checks closest hits and occlusion agree (see the module
/// documentation for tolerances and ties). Returns the number of hits compared.
fn assert_traces_agree(
    context: &GpuContext,
    accel: &SceneAccel,
    scene: &GpuScene,
    rays: &[(Vec3, Vec3, f32)],
) -> usize {
    let test_rays: Vec<TestRay> = rays
        .iter()
        .enumerate()
        .map(|(i, &(origin, direction, t_max))| {
            // Shadow rays to half or one and a half times the first hit: both well away from
            // it, so occlusion is decided by the closest hit alone.
            let first = accel.intersect(origin, direction, f32::INFINITY);
            let occlusion_t_max = first.map_or(f32::INFINITY, |hit| {
                hit.t * if i % 2 == 0 { 0.5 } else { 1.5 }
            });
            TestRay {
                origin: origin.to_array(),
                t_max,
                direction: direction.to_array(),
                occlusion_t_max,
            }
        })
        .collect();
    let (gpu_hits, gpu_occluded) = gpu_trace(context, scene, &test_rays);
    let (mut compared, mut ties) = (0, 0);
    for (i, ray) in test_rays.iter().enumerate() {
        let (origin, direction) = (Vec3::from(ray.origin), Vec3::from(ray.direction));
        let cpu = accel.intersect(origin, direction, ray.t_max);
        let gpu = gpu_hits[i];
        let gpu = (gpu.triangle != NONE).then_some(Hit {
            t: gpu.t,
            triangle: gpu.triangle,
            u: gpu.u,
            v: gpu.v,
        });
        // t's rounding error scales with the coordinates it is computed from (the origin's and
        // the hit's), not with t alone: a hit 3 mm from a ray starting a metre away is known to
        // about 1e-7 m (an H200 differed from the CPU by 1.4e-10 m at t = 3.3 mm).
        // A grazing ray's t is ill-conditioned as 1/cos of its angle to the triangle (t is a
        // quotient by the ray's component along the normal): an H200 put a hit at cos 0.006
        // 0.4 mm away at 6.5 m.
        let scale = origin.abs().max_element();
        let agree = match (cpu, gpu) {
            (None, None) => true,
            (Some(c), Some(g)) if c.triangle == g.triangle => {
                let [a, b, c3] = accel.triangle_vertices(c.triangle);
                let cos = (b - a)
                    .cross(c3 - a)
                    .normalize_or_zero()
                    .dot(direction.normalize())
                    .abs();
                let close = |x: f32, y: f32| {
                    (x - y).abs() <= (1e-5 * y.abs() + 4.0 * f32::EPSILON * scale) / cos.max(1e-3)
                };
                assert!(close(g.t, c.t), "ray {i}: t {} vs {}", g.t, c.t);
                // Barycentrics are ill-conditioned as t is (fused multiply-adds moved them by
                // 1.7e-4, and by 1e-3 at cos 0.006, on an H200). A wrong point on the triangle is
                // off by O(1).
                let barycentric = 5e-4 / cos.max(1e-3);
                assert!(
                    (g.u - c.u).abs() <= barycentric && (g.v - c.v).abs() <= barycentric,
                    "ray {i}: uv ({}, {}) vs ({}, {})",
                    g.u,
                    g.v,
                    c.u,
                    c.v
                );
                compared += 1;
                true
            }
            (c, g) => {
                let tie = c.is_some_and(|c| on_edge(&c))
                    || g.is_some_and(|g| on_edge(&g))
                    || matches!((c, g), (Some(c), Some(g))
                        if (g.t - c.t).abs() <= 1e-5 * c.t.abs() + 4.0 * f32::EPSILON * scale);
                assert!(
                    tie,
                    "ray {i} from {origin} along {direction}: CPU {c:?}, GPU {g:?}"
                );
                ties += 1;
                false
            }
        };
        let cpu_occluded = accel.occluded(origin, direction, ray.occlusion_t_max);
        if agree {
            assert_eq!(
                gpu_occluded[i] != 0,
                cpu_occluded,
                "ray {i} from {origin} along {direction} to {}",
                ray.occlusion_t_max
            );
        }
    }
    assert!(
        ties * 100 <= rays.len(),
        "{ties} ties in {} rays",
        rays.len()
    );
    eprintln!("{} rays: {compared} equal hits, {ties} ties", rays.len());
    compared
}

// ---- Surfaces ---------------------------------------------------------------------------------

#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct SurfaceQuery {
    hit: GpuHit,
    direction: [f32; 3],
    _pad0: f32,
    leave: [f32; 3],
    _pad1: f32,
}

/// Vec4s written per query by the `surfaces` kernel.
const SURFACE_OUTPUTS: usize = 9;

const SURFACES: &str = r#"
struct SurfaceQuery { hit: Hit, direction: vec3f, leave: vec3f }
@group(3) @binding(0) var<storage, read> test_queries: array<SurfaceQuery>;
@group(3) @binding(1) var<storage, read_write> test_out: array<vec4f>;

@compute @workgroup_size(64)
fn surfaces(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= arrayLength(&test_queries) { return; }
    let query = test_queries[id.x];
    let s = scene_surface(query.hit, query.direction);
    let vertices = scene_triangle_vertices(query.hit.triangle);
    let at = 9u * id.x;
    test_out[at] = vec4f(s.position, s.spawn_offset);
    test_out[at + 1u] = vec4f(s.geometric_normal, select(0.0, 1.0, s.back_face));
    test_out[at + 2u] = vec4f(s.shading_normal, bitcast<f32>(s.material));
    test_out[at + 3u] = s.tangent;
    test_out[at + 4u] = vec4f(s.uv, bitcast<f32>(scene_triangle_material(query.hit.triangle)), 0.0);
    test_out[at + 5u] = vec4f(scene_spawn_origin(s, query.leave), 0.0);
    test_out[at + 6u] = vec4f(vertices[0], 0.0);
    test_out[at + 7u] = vec4f(vertices[1], 0.0);
    test_out[at + 8u] = vec4f(vertices[2], 0.0);
}
"#;

/// The GPU's surface points at the CPU's hits of `rays` equal the CPU's. Returns how many.
fn assert_surfaces_agree(
    context: &GpuContext,
    accel: &SceneAccel,
    scene: &GpuScene,
    rays: &[(Vec3, Vec3, f32)],
    rng: &mut Rng,
) -> usize {
    let mut cases = Vec::new();
    for &(origin, direction, _) in rays {
        if let Some(hit) = accel.intersect(origin, direction, f32::INFINITY) {
            let leave = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5;
            cases.push((hit, direction, leave.normalize_or(Vec3::Z)));
        }
    }
    let queries: Vec<SurfaceQuery> = cases
        .iter()
        .map(|(hit, direction, leave)| SurfaceQuery {
            hit: GpuHit {
                t: hit.t,
                u: hit.u,
                v: hit.v,
                triangle: hit.triangle,
            },
            direction: direction.to_array(),
            _pad0: 0.0,
            leave: leave.to_array(),
            _pad1: 0.0,
        })
        .collect();
    let input = storage_buffer(context, "queries", &queries);
    let output = zeroed_buffer::<[f32; 4]>(context, "surfaces", SURFACE_OUTPUTS * queries.len());
    run_kernel(
        context,
        scene,
        SURFACES,
        "surfaces",
        &[(&input, Access::ReadOnly), (&output, Access::ReadWrite)],
        queries.len(),
    );
    let out: Vec<[f32; 4]> =
        read_buffer(context, &output, SURFACE_OUTPUTS * queries.len()).unwrap();
    let xyz = |v: [f32; 4]| Vec3::new(v[0], v[1], v[2]);
    for (i, (hit, direction, leave)) in cases.iter().enumerate() {
        let o = &out[SURFACE_OUTPUTS * i..SURFACE_OUTPUTS * (i + 1)];
        let cpu = accel.surface(hit, *direction);
        let vertices = accel.triangle_vertices(hit.triangle);
        let context = format!("hit {hit:?} along {direction}: CPU {cpu:?}, GPU {o:?}");
        let magnitude = cpu.spawn_offset * 65536.0;
        let near = |a: Vec3, b: Vec3, tolerance: f32| (a - b).abs().max_element() <= tolerance;

        assert!(
            near(xyz(o[0]), cpu.position, 1e-6 * magnitude),
            "position: {context}"
        );
        assert_eq!(o[0][3], cpu.spawn_offset, "spawn offset: {context}");
        let grazing = Vec3::from(accel.primitives[hit.triangle as usize].winding_normal())
            .normalize()
            .dot(*direction)
            .abs()
            < 1e-6;
        if !grazing {
            assert_eq!(o[1][3] != 0.0, cpu.back_face, "back face: {context}");
            assert!(
                near(xyz(o[1]), cpu.geometric_normal, 1e-5),
                "geometric normal: {context}"
            );
            assert!(
                near(xyz(o[2]), cpu.shading_normal, 1e-4),
                "shading normal: {context}"
            );
            assert!(
                (Vec4::from(o[3]) - cpu.tangent).abs().max_element() <= 1e-4,
                "tangent: {context}"
            );
            assert!(
                near(
                    xyz(o[5]),
                    cpu.spawn_origin(*leave),
                    1e-6 * magnitude + 1e-6 * cpu.spawn_offset
                ),
                "spawn origin: {context}"
            );
        }
        let material = cpu.material.map_or(NONE, |m| m as u32);
        assert_eq!(o[2][3].to_bits(), material, "material: {context}");
        assert_eq!(o[4][2].to_bits(), material, "triangle material: {context}");
        let uv = Vec2::new(o[4][0], o[4][1]);
        assert!(
            (uv - cpu.uv).abs().max_element() <= 1e-4 * cpu.uv.abs().max_element().max(1.0),
            "uv: {context}"
        );
        for k in 0..3 {
            assert_eq!(xyz(o[6 + k]), vertices[k], "vertex {k}: {context}");
        }
    }
    cases.len()
}

// ---- Scenes -----------------------------------------------------------------------------------

fn instance(mesh: Mesh, world_from_local: Mat4) -> MeshInstance {
    MeshInstance {
        mesh: Arc::new(mesh),
        world_from_local,
        node_name: None,
    }
}

/// A random RGBA texture from an 8-bit image, decoded with `encoding`.
fn random_8_bit_texture(
    width: u32,
    height: u32,
    encoding: ColorEncoding,
    rng: &mut Rng,
) -> Texture {
    let image = image::RgbaImage::from_fn(width, height, |_, _| {
        image::Rgba(rng.next_u32().to_le_bytes())
    });
    Texture::from_image(&image::DynamicImage::ImageRgba8(image), encoding)
}

/// A random RGBA texture of arbitrary f32 texels in [0, 1).
fn random_f32_texture(width: u32, height: u32, rng: &mut Rng) -> Texture {
    Texture {
        width,
        height,
        texels: (0..width * height)
            .map(|_| std::array::from_fn(|_| rng.next_f32()))
            .collect(),
        wrap_s: WrapMode::Repeat,
        wrap_t: WrapMode::Repeat,
        nearest: false,
    }
}

/// Four instances of `count / 4` random triangles in a 4 m cube, exercising every surface
/// path: vertex normals (some against their face) and tangents; UVs without tangents; flat
/// triangles without attributes (and without material); a mirrored instance. Material 1 is
/// alpha-masked by a bilinear 8-bit texture, the default material by a nearest f32 one.
fn attributed_soup(count: usize, rng: &mut Rng) -> (Vec<MeshInstance>, MaterialLibrary) {
    let point = |rng: &mut Rng| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    let instances = (0..4)
        .map(|k| {
            let mut mesh = Mesh::default();
            for i in 0..count / 4 {
                let centre = point(rng) * 4.0 - 2.0;
                for _ in 0..3 {
                    mesh.positions.push(centre + (point(rng) - 0.5) * 0.4);
                    let normal = (point(rng) - 0.5).normalize_or(Vec3::Z);
                    mesh.normals.push(normal);
                    mesh.uvs
                        .push(Vec2::new(rng.next_f32(), rng.next_f32()) * 3.0 - 1.0);
                    let tangent = (point(rng) - 0.5).normalize_or(Vec3::X);
                    let sign = if rng.next_f32() < 0.5 { -1.0 } else { 1.0 };
                    mesh.tangents.push(tangent.extend(sign));
                }
                let base = 3 * i as u32;
                mesh.triangles.push([base, base + 1, base + 2]);
            }
            match k {
                1 => mesh.tangents.clear(),
                2 => {
                    mesh.normals.clear();
                    mesh.tangents.clear();
                    mesh.uvs.clear();
                }
                _ => {}
            }
            mesh.material = (k != 2).then_some(k % 2);
            let transform = Mat4::from_rotation_translation(
                Quat::from_rotation_y(k as f32),
                Vec3::new(0.0, k as f32 * 0.1, 0.0),
            );
            let transform = if k == 3 {
                Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)) * transform
            } else {
                transform
            };
            instance(mesh, transform)
        })
        .collect();
    let mask = random_8_bit_texture(8, 8, ColorEncoding::Srgb, rng);
    let default_mask = random_f32_texture(5, 3, rng).with_sampler(
        WrapMode::MirroredRepeat,
        WrapMode::ClampToEdge,
        true,
    );
    let masked = |texture| Material {
        base_color_texture: Some(TextureRef {
            texture,
            tex_coord: 0,
        }),
        alpha_mode: AlphaMode::Mask(0.5),
        ..Material::matte(Vec3::ONE)
    };
    let materials = MaterialLibrary {
        materials: vec![Material::matte(Vec3::ONE), masked(0)],
        textures: vec![Arc::new(mask), Arc::new(default_mask)],
        default_material: masked(1),
    };
    (instances, materials)
}

fn check_scene(
    context: &GpuContext,
    instances: &[MeshInstance],
    materials: &MaterialLibrary,
    rays: usize,
    seed: u64,
) -> (usize, usize) {
    let accel = SceneAccel::build(instances, materials).unwrap();
    let scene = GpuScene::upload(context, &accel, materials).unwrap();
    let mut rng = Rng::new(seed, 3);
    let rays = scene_rays(&accel, rays, &mut rng);
    let hits = assert_traces_agree(context, &accel, &scene, &rays);
    let surfaces = assert_surfaces_agree(context, &accel, &scene, &rays, &mut rng);
    (hits, surfaces)
}

#[test]
fn default_scene_hits_and_surfaces_equal_the_cpu() {
    let Some(context) = GpuContext::for_tests() else {
        return;
    };
    let scene = load_default_scene().unwrap();
    let (hits, surfaces) = check_scene(&context, &scene.instances, &scene.materials, 3000, 1);
    assert!(
        hits > 500 && surfaces > 500,
        "{hits} hits, {surfaces} surfaces"
    );
}

#[test]
fn textured_gltf_hits_and_surfaces_equal_the_cpu_and_its_texels_pack_to_bytes() {
    let Some(context) = GpuContext::for_tests() else {
        return;
    };
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/Duck/Duck.gltf");
    let duck = crate::scene::load_gltf(&path).unwrap();
    assert!(!duck.materials.textures.is_empty());
    for texture in &duck.materials.textures {
        assert_ne!(pack_texels(&texture.texels).0, TexelFormat::F32);
    }
    let (hits, surfaces) = check_scene(&context, &duck.instances, &duck.materials, 2000, 3);
    assert!(
        hits > 300 && surfaces > 300,
        "{hits} hits, {surfaces} surfaces"
    );
}

#[test]
fn masked_random_soup_hits_and_surfaces_equal_the_cpu() {
    let Some(context) = GpuContext::for_tests() else {
        return;
    };
    let (instances, materials) = attributed_soup(2000, &mut Rng::new(7, 1));
    let (hits, surfaces) = check_scene(&context, &instances, &materials, 3000, 2);
    assert!(
        hits > 500 && surfaces > 500,
        "{hits} hits, {surfaces} surfaces"
    );
}

#[test]
fn alpha_masks_cut_holes_on_the_gpu_as_on_the_cpu() {
    let Some(context) = GpuContext::for_tests() else {
        return;
    };
    let (instances, materials) = attributed_soup(2000, &mut Rng::new(7, 1));
    let accel = SceneAccel::build(&instances, &materials).unwrap();
    let scene = GpuScene::upload(&context, &accel, &materials).unwrap();
    // Rays straight at random points of the masked triangles: both sides of the cutoff.
    let mut rng = Rng::new(5, 5);
    let masked: Vec<u32> = (0..accel.triangle_count() as u32)
        .filter(|&t| accel.triangle_material(t) != Some(0))
        .collect();
    let rays: Vec<(Vec3, Vec3, f32)> = (0..2000)
        .map(|_| {
            let triangle = masked[rng.next_u32() as usize % masked.len()];
            let [a, b, c] = accel.triangle_vertices(triangle);
            let (u, v) = (rng.next_f32(), rng.next_f32());
            let (u, v) = if u + v > 1.0 {
                (1.0 - u, 1.0 - v)
            } else {
                (u, v)
            };
            let target = a + (b - a) * u + (c - a) * v;
            let from = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 10.0 - 5.0;
            (from, (target - from).normalize(), f32::INFINITY)
        })
        .collect();
    let holes = rays
        .iter()
        .filter(|&&(origin, direction, _)| {
            accel
                .intersect(origin, direction, f32::INFINITY)
                .is_none_or(|hit| masked.binary_search(&hit.triangle).is_err())
        })
        .count();
    assert!(holes > 100, "only {holes} rays went through holes");
    assert_traces_agree(&context, &accel, &scene, &rays);
}

#[test]
fn an_empty_scene_is_missed_by_every_ray() {
    let Some(context) = GpuContext::for_tests() else {
        return;
    };
    let materials = MaterialLibrary::default();
    let accel = SceneAccel::build(&[], &materials).unwrap();
    let scene = GpuScene::upload(&context, &accel, &materials).unwrap();
    let ray = TestRay {
        origin: [0.0; 3],
        t_max: f32::INFINITY,
        direction: [0.0, 0.0, 1.0],
        occlusion_t_max: f32::INFINITY,
    };
    let (hits, occluded) = gpu_trace(&context, &scene, &[ray]);
    assert_eq!((hits[0].triangle, occluded[0]), (NONE, 0));
}

// ---- Textures ---------------------------------------------------------------------------------

#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Lookup {
    uv: [f32; 2],
    texture: u32,
    _pad: u32,
}

const SAMPLES: &str = r#"
struct Lookup { uv: vec2f, texture: u32 }
@group(3) @binding(0) var<storage, read> test_lookups: array<Lookup>;
@group(3) @binding(1) var<storage, read_write> test_texels: array<vec4f>;

@compute @workgroup_size(64)
fn samples(@builtin(global_invocation_id) id: vec3u) {
    if id.x >= arrayLength(&test_lookups) { return; }
    let lookup = test_lookups[id.x];
    test_texels[id.x] = texture_sample(lookup.texture, lookup.uv);
}
"#;

#[test]
fn eight_bit_textures_pack_to_bytes_and_others_to_f32() {
    let mut rng = Rng::new(3, 3);
    let srgb = random_8_bit_texture(4, 4, ColorEncoding::Srgb, &mut rng);
    let linear = random_8_bit_texture(4, 4, ColorEncoding::Linear, &mut rng);
    let float = random_f32_texture(4, 4, &mut rng);
    assert_eq!(pack_texels(&srgb.texels).0, TexelFormat::Srgb8);
    assert_eq!(pack_texels(&linear.texels).0, TexelFormat::Linear8);
    let (format, words) = pack_texels(&float.texels);
    assert_eq!((format, words.len()), (TexelFormat::F32, 64));
}

#[test]
fn texture_samples_equal_the_cpu() {
    let Some(context) = GpuContext::for_tests() else {
        return;
    };
    let mut rng = Rng::new(9, 4);
    let bases = [
        random_8_bit_texture(5, 3, ColorEncoding::Srgb, &mut rng),
        random_8_bit_texture(4, 7, ColorEncoding::Linear, &mut rng),
        random_f32_texture(6, 5, &mut rng),
    ];
    let wraps = [
        WrapMode::Repeat,
        WrapMode::MirroredRepeat,
        WrapMode::ClampToEdge,
    ];
    let mut textures: Vec<Arc<Texture>> = Vec::new();
    for base in &bases {
        for (s, wrap_s) in wraps.iter().enumerate() {
            for nearest in [false, true] {
                let wrap_t = wraps[(s + 1) % 3];
                textures.push(Arc::new(
                    base.clone().with_sampler(*wrap_s, wrap_t, nearest),
                ));
            }
        }
    }
    textures.push(Arc::new(Texture {
        width: 0,
        height: 0,
        texels: Vec::new(),
        ..bases[0].clone()
    }));
    let materials = MaterialLibrary {
        textures,
        ..Default::default()
    };
    let accel = SceneAccel::build(&[], &materials).unwrap();
    let scene = GpuScene::upload(&context, &accel, &materials).unwrap();

    let special = [
        Vec2::new(f32::NAN, 0.3),
        Vec2::new(f32::INFINITY, 0.5),
        Vec2::new(0.0, 0.0),
        Vec2::new(1.0, 1.0),
        Vec2::new(-1.0, 2.0),
        Vec2::new(0.5, -0.25),
        Vec2::new(1000.25, -777.5),
    ];
    let mut lookups = Vec::new();
    for texture in 0..materials.textures.len() as u32 {
        for i in 0..200 {
            let uv = special
                .get(i)
                .copied()
                .unwrap_or_else(|| Vec2::new(rng.next_f32(), rng.next_f32()) * 6.0 - 3.0);
            lookups.push(Lookup {
                uv: uv.to_array(),
                texture,
                _pad: 0,
            });
        }
    }
    let input = storage_buffer(&context, "lookups", &lookups);
    let output = zeroed_buffer::<[f32; 4]>(&context, "texels", lookups.len());
    run_kernel(
        &context,
        &scene,
        SAMPLES,
        "samples",
        &[(&input, Access::ReadOnly), (&output, Access::ReadWrite)],
        lookups.len(),
    );
    let gpu: Vec<[f32; 4]> = read_buffer(&context, &output, lookups.len()).unwrap();
    for (lookup, gpu) in lookups.iter().zip(&gpu) {
        let texture = &materials.textures[lookup.texture as usize];
        let cpu = texture.sample(Vec2::from(lookup.uv));
        let what = format!(
            "texture {} at {:?}: CPU {cpu:?}, GPU {gpu:?}",
            lookup.texture, lookup.uv
        );
        if texture.nearest {
            assert_eq!(gpu.map(f32::to_bits), cpu.map(f32::to_bits), "{what}");
        } else {
            assert!((0..4).all(|c| (gpu[c] - cpu[c]).abs() <= 1e-6), "{what}");
        }
    }
}
