//! shade.wgsl and rng.wgsl against the CPU code they mirror, on the same inputs.
//!
//! The scene side is the real one (`GpuScene`, scene.wgsl, itself tested against the CPU's
//! accelerator in `gpu::scene`), so these tests also check the two together.

use std::sync::Arc;

use glam::{Mat4, Vec2, Vec3};

use super::{GpuShading, RNG_WGSL, SHADE_WGSL};
use crate::gpu::compute::{
    Access, Bindings, dispatch, kernel_with, read_buffer, storage_buffer, workgroups_for,
    zeroed_buffer,
};
use crate::gpu::context::GpuContext;
use crate::gpu::scene::{GpuScene, SCENE_WGSL};
use crate::sampling::Rng;
use crate::scene::{
    Material, MaterialLibrary, Mesh, MeshInstance, PunctualLight, Texture, TextureRef, WrapMode,
};
use crate::shade::bsdf::MetalRoughBsdf;
use crate::shade::tests::TestScene;
use crate::shade::{Environment, EnvironmentMap, EnvironmentSampling, SHADE_STREAM_KEY};

#[test]
fn the_rng_draws_the_cpu_streams_bit_for_bit() {
    let Some(context) = GpuContext::for_tests() else {
        return;
    };
    const DRAWS: usize = 12;
    // Keys with every bit pattern that carries in the 64-bit emulation: zeros, all ones,
    // neighbouring pixels and samples, and seeds from a stream.
    let mut keys: Vec<(u64, u32, u32)> = vec![
        (0, 0, 0),
        (u64::MAX, u32::MAX, u32::MAX),
        (1, 0, 1),
        (0x8000_0000_0000_0000, 0x8000_0000, 1),
    ];
    let mut source = Rng::new(17, 29);
    for i in 0..4096u32 {
        let seed = (source.next_u32() as u64) << 32 | source.next_u32() as u64;
        keys.push((seed, i / 64, i % 64 + (i & 0x700) * 1_000_000));
    }
    let inputs: Vec<[u32; 4]> = keys
        .iter()
        .map(|&(seed, pixel, sample)| [seed as u32, (seed >> 32) as u32, pixel, sample])
        .collect();
    let body = "
        @group(0) @binding(0) var<storage, read> keys: array<vec4u>;
        @group(0) @binding(1) var<storage, read_write> draws: array<u32>;
        @compute @workgroup_size(64) fn main(@builtin(global_invocation_id) id: vec3u) {
            let i = id.x;
            if i >= arrayLength(&keys) { return; }
            let key = keys[i];
            var rng = rng_for_sample(key.x, key.y, key.z, key.w);
            for (var k = 0u; k < 8u; k++) { draws[12u * i + k] = rng_next_u32(&rng); }
            draws[12u * i + 8u] = bitcast<u32>(rng_next_f32(&rng));
            draws[12u * i + 9u] = bitcast<u32>(rng_next_f32(&rng));
            let pair = rng_next_2d(&rng);
            draws[12u * i + 10u] = bitcast<u32>(pair.x);
            draws[12u * i + 11u] = bitcast<u32>(pair.y);
        }";
    let keys_buffer = storage_buffer(&context, "keys", &inputs);
    let draws = zeroed_buffer::<u32>(&context, "draws", DRAWS * keys.len());
    let bindings = Bindings::new(
        &context,
        "rng test",
        &[
            (&keys_buffer, Access::ReadOnly),
            (&draws, Access::ReadWrite),
        ],
    );
    let source = format!("{RNG_WGSL}\n{body}");
    let pipeline = kernel_with(&context, "rng test", &source, "main", &[&bindings.layout]).unwrap();
    dispatch(
        &context,
        &pipeline,
        &[&bindings.group],
        [workgroups_for(keys.len(), 64), 1, 1],
    )
    .unwrap();
    let gpu: Vec<u32> = read_buffer(&context, &draws, DRAWS * keys.len()).unwrap();
    for (i, &(seed, pixel, sample)) in keys.iter().enumerate() {
        let mut rng = Rng::for_sample(seed, pixel, sample);
        let mut cpu: Vec<u32> = (0..8).map(|_| rng.next_u32()).collect();
        cpu.push(rng.next_f32().to_bits());
        cpu.push(rng.next_f32().to_bits());
        cpu.extend(rng.next_2d().map(f32::to_bits));
        assert_eq!(
            &gpu[DRAWS * i..DRAWS * (i + 1)],
            &cpu[..],
            "stream of seed {seed:#x}, pixel {pixel}, sample {sample}"
        );
    }
}

/// The shading tests' scene (`shade::tests::TestScene`), uploaded to the GPU as well.
impl TestScene {
    /// Runs `body` (a kernel `main` reading `inputs` at group 3 binding 0 and writing
    /// `output_len` `O`s at binding 1) over `inputs`, with this scene uploaded as the renderer
    /// uploads it: its geometry and textures at group 1, its shading data at group 2.
    fn run<I: bytemuck::Pod, O: bytemuck::Pod>(
        &self,
        context: &GpuContext,
        max_depth: u32,
        seed: u64,
        body: &str,
        inputs: &[I],
        output_len: usize,
    ) -> Vec<O> {
        let shading = GpuShading::upload(
            context,
            &self.materials,
            &self.lights,
            &self.environment,
            max_depth,
            seed,
        )
        .unwrap();
        let scene = GpuScene::upload(context, &self.accel, &self.materials).unwrap();
        let inputs_buffer = storage_buffer(context, "inputs", inputs);
        let outputs = zeroed_buffer::<O>(context, "outputs", output_len);
        let test_group = Bindings::new(
            context,
            "test",
            &[
                (&inputs_buffer, Access::ReadOnly),
                (&outputs, Access::ReadWrite),
            ],
        );
        let empty = Bindings::new(context, "unused", &[]);
        let source = format!("{RNG_WGSL}\n{SCENE_WGSL}\n{SHADE_WGSL}\n{body}");
        let pipeline = kernel_with(
            context,
            "shading test",
            &source,
            "main",
            &[
                &empty.layout,
                &scene.bindings.layout,
                &shading.bindings.layout,
                &test_group.layout,
            ],
        )
        .unwrap();
        dispatch(
            context,
            &pipeline,
            &[
                &empty.group,
                &scene.bindings.group,
                &shading.bindings.group,
                &test_group.group,
            ],
            [workgroups_for(inputs.len(), 64), 1, 1],
        )
        .unwrap();
        read_buffer(context, &outputs, output_len).unwrap()
    }
}

/// A quad of side `size` in the plane spanned by `right` and `up` (unit, orthogonal) around
/// `centre`, front face towards right × up, UVs over [0, 1]² (v down `up`).
fn quad(centre: Vec3, right: Vec3, up: Vec3, size: f32, material: usize) -> MeshInstance {
    let h = 0.5 * size;
    let positions = vec![
        centre - right * h - up * h,
        centre + right * h - up * h,
        centre + right * h + up * h,
        centre - right * h + up * h,
    ];
    let uvs = vec![
        Vec2::new(0.0, 1.0),
        Vec2::new(1.0, 1.0),
        Vec2::new(1.0, 0.0),
        Vec2::new(0.0, 0.0),
    ];
    let mesh = Mesh {
        positions,
        uvs,
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        material: Some(material),
        ..Default::default()
    };
    MeshInstance {
        mesh: Arc::new(mesh),
        world_from_local: Mat4::IDENTITY,
        node_name: None,
    }
}

/// A `size`×`size` texture whose texel (x, y) is `texel(x, y)`.
fn texture(size: u32, wrap: WrapMode, texel: impl Fn(u32, u32) -> [f32; 4]) -> Arc<Texture> {
    let texels = (0..size * size)
        .map(|i| texel(i % size, i / size))
        .collect();
    Arc::new(Texture {
        width: size,
        height: size,
        texels,
        wrap_s: wrap,
        wrap_t: wrap,
        nearest: false,
    })
}

fn slot(texture: usize) -> Option<TextureRef> {
    Some(TextureRef {
        texture,
        tex_coord: 0,
    })
}

/// A room-like scene: a textured floor, a normal-mapped glossy metal panel, a one-sided
/// emissive panel above, a point light and a uniform sky that light sampling also draws.
fn lit_room() -> TestScene {
    let checker = texture(4, WrapMode::Repeat, |x, y| {
        let c = if (x + y) % 2 == 0 { 0.8 } else { 0.2 };
        [c, 0.5 * c + 0.1, 0.3, 1.0]
    });
    let bumps = texture(8, WrapMode::MirroredRepeat, |x, y| {
        let n = Vec3::new(0.4 * (x as f32).sin(), 0.4 * (y as f32 * 1.3).cos(), 1.0).normalize();
        [0.5 * n.x + 0.5, 0.5 * n.y + 0.5, 0.5 * n.z + 0.5, 1.0]
    });
    let roughness_map = texture(4, WrapMode::ClampToEdge, |x, y| {
        [0.0, 0.3 + 0.15 * x as f32, 0.5 + 0.1 * y as f32, 1.0]
    });
    let materials = MaterialLibrary {
        materials: vec![
            Material {
                base_color_texture: slot(0),
                roughness: 0.8,
                ..Material::matte(Vec3::ONE)
            },
            Material {
                base_color: Vec3::new(0.9, 0.6, 0.3).extend(1.0),
                metallic: 1.0,
                roughness: 0.6,
                metallic_roughness_texture: slot(2),
                normal_texture: slot(1),
                normal_scale: 0.8,
                ..Default::default()
            },
            Material {
                emissive: Vec3::new(12.0, 10.0, 8.0),
                ..Material::matte(Vec3::ZERO)
            },
        ],
        textures: vec![checker, bumps, roughness_map],
        ..Default::default()
    };
    let instances = [
        quad(Vec3::ZERO, Vec3::X, Vec3::NEG_Z, 4.0, 0),
        quad(
            Vec3::new(0.8, 0.6, -0.8),
            Vec3::new(1.0, 0.0, 1.0).normalize(),
            Vec3::new(-0.3, 1.0, 0.3).normalize(),
            1.0,
            1,
        ),
        // Facing down: right × up = −Y.
        quad(Vec3::new(-0.5, 2.0, -0.5), Vec3::X, Vec3::Z, 1.5, 2),
        // An untextured, materialless triangle: the library's default material.
        MeshInstance {
            mesh: Arc::new(Mesh {
                positions: vec![
                    Vec3::new(-1.5, 0.0, -1.0),
                    Vec3::new(-0.8, 0.0, -1.2),
                    Vec3::new(-1.2, 1.0, -1.1),
                ],
                triangles: vec![[0, 1, 2]],
                material: None,
                ..Default::default()
            }),
            world_from_local: Mat4::IDENTITY,
            node_name: None,
        },
    ];
    TestScene::with_library(
        &instances,
        materials,
        &[PunctualLight::Point {
            position: Vec3::new(1.0, 1.5, 0.5),
            intensity: Vec3::new(3.0, 2.5, 2.0),
            range: Some(6.0),
        }],
        Environment::Uniform(Vec3::new(0.3, 0.35, 0.4)),
        EnvironmentSampling::Always,
    )
}

/// An outdoor scene: an importance-sampled sky image with a sun, a floor, a glossy
/// dielectric panel, a double-sided emitter with an emissive texture, a spot and a
/// directional light.
fn sunlit_yard() -> TestScene {
    let (width, height) = (32u32, 16u32);
    let pixels: Vec<Vec3> = (0..width * height)
        .map(|i| {
            let (x, y) = (i % width, i / width);
            let sky = if y < height / 2 {
                Vec3::new(0.4, 0.6, 1.0) * (1.0 - y as f32 / height as f32)
            } else {
                Vec3::splat(0.1)
            };
            let sun = if (x, y) == (20, 4) || (x, y) == (21, 4) {
                Vec3::new(200.0, 180.0, 150.0)
            } else {
                Vec3::ZERO
            };
            sky + sun
        })
        .collect();
    let sky = EnvironmentMap::new(width, height, &pixels).expect("sky");
    let glow = texture(4, WrapMode::Repeat, |x, y| {
        [0.2 + 0.2 * x as f32, 1.0, 0.1 + 0.3 * y as f32, 1.0]
    });
    let materials = MaterialLibrary {
        materials: vec![
            Material {
                roughness: 0.9,
                ..Material::matte(Vec3::new(0.5, 0.45, 0.4))
            },
            Material {
                roughness: 0.25,
                ..Material::matte(Vec3::new(0.1, 0.3, 0.6))
            },
            Material {
                emissive: Vec3::new(2.0, 3.0, 2.0),
                emissive_texture: slot(0),
                double_sided: true,
                ..Material::matte(Vec3::ZERO)
            },
        ],
        textures: vec![glow],
        ..Default::default()
    };
    let instances = [
        quad(Vec3::ZERO, Vec3::X, Vec3::NEG_Z, 6.0, 0),
        quad(Vec3::new(0.5, 0.7, -1.5), Vec3::X, Vec3::Y, 1.4, 1),
        quad(
            Vec3::new(-1.2, 0.6, -0.8),
            Vec3::new(1.0, 0.0, -1.0).normalize(),
            Vec3::Y,
            0.8,
            2,
        ),
    ];
    TestScene::with_library(
        &instances,
        materials,
        &[
            PunctualLight::Spot {
                position: Vec3::new(-1.0, 2.5, 1.0),
                direction: Vec3::new(0.3, -1.0, -0.4).normalize(),
                intensity: Vec3::splat(20.0),
                range: None,
                inner_cone_angle: 0.3,
                outer_cone_angle: 0.6,
            },
            PunctualLight::Directional {
                direction: Vec3::new(-0.4, -1.0, -0.2).normalize(),
                illuminance: Vec3::new(2.0, 1.8, 1.5),
            },
        ],
        Environment::Image(Arc::new(sky)),
        EnvironmentSampling::ImagesOnly,
    )
}

/// One camera ray of the path test: origin, direction and its shading stream's key.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct PathInput {
    origin: [f32; 4],
    direction: [f32; 4],
    /// (pixel, sample, 0, 0).
    key: [u32; 4],
}

const PATH_KERNEL: &str = "
    struct PathInput { origin: vec4f, direction: vec4f, key: vec4u }
    @group(3) @binding(0) var<storage, read> rays: array<PathInput>;
    @group(3) @binding(1) var<storage, read_write> radiances: array<vec4f>;
    @compute @workgroup_size(64) fn main(@builtin(global_invocation_id) id: vec3u) {
        let i = id.x;
        if i >= arrayLength(&rays) { return; }
        let ray = rays[i];
        let hit = scene_intersect(ray.origin.xyz, ray.direction.xyz, SHADE_FAR);
        var rng = shade_rng(ray.key.x, ray.key.y);
        radiances[i] = vec4f(path_radiance(ray.origin.xyz, ray.direction.xyz, hit, &rng), 0.0);
    }";

/// Paths of `scene` along a fan of camera rays from `eye`, on both devices with the same
/// streams: asserts that all but `max_diverged` of them (paths whose f32 rounding took a
/// different branch somewhere: a lobe choice, a roulette draw, a silhouette) agree within
/// `tolerance` relative (+ 1e-5 nits absolute), and that the scene shows light.
fn assert_paths_agree(scene: &TestScene, eye: Vec3, look: Vec3, tolerance: f32, max_diverged: f64) {
    let Some(context) = GpuContext::for_tests() else {
        return;
    };
    let (max_depth, seed) = (6, 0x5eed_0000_1234_abcd);
    let shader = scene.shader(max_depth, seed);
    let forward = look.normalize();
    let right = forward.cross(Vec3::Y).normalize();
    let up = right.cross(forward);
    let side = 32;
    let mut rays = Vec::new();
    for sample in 0..2u32 {
        for i in 0..side * side {
            let (x, y) = ((i % side) as f32, (i / side) as f32);
            let (sx, sy) = (x / (side - 1) as f32 - 0.5, 0.5 - y / (side - 1) as f32);
            let direction = (forward + right * (1.4 * sx) + up * (1.2 * sy)).normalize();
            rays.push(PathInput {
                origin: eye.extend(1.0).to_array(),
                direction: direction.extend(0.0).to_array(),
                key: [i, sample, 0, 0],
            });
        }
    }
    let gpu: Vec<[f32; 4]> = scene.run(&context, max_depth, seed, PATH_KERNEL, &rays, rays.len());
    let mut diverged = Vec::new();
    let mut lit = 0;
    for (ray, gpu) in rays.iter().zip(&gpu) {
        let origin = Vec3::from_slice(&ray.origin[..3]);
        let direction = Vec3::from_slice(&ray.direction[..3]);
        let first_hit = scene.accel.intersect(origin, direction, f32::INFINITY);
        let mut rng = Rng::for_sample(seed ^ SHADE_STREAM_KEY, ray.key[0], ray.key[1]);
        let cpu = shader.radiance(origin, direction, first_hit, &mut rng);
        let gpu = Vec3::from_slice(&gpu[..3]);
        let close = (gpu - cpu)
            .abs()
            .cmple(cpu.abs().max(gpu.abs()) * tolerance + Vec3::splat(1e-5))
            .all();
        if !close {
            diverged.push((ray.key, cpu, gpu));
        }
        lit += (cpu.max_element() > 0.0) as usize;
    }
    let fraction = diverged.len() as f64 / rays.len() as f64;
    assert!(
        fraction <= max_diverged,
        "{} of {} paths differ beyond {tolerance} (allowed {max_diverged}); first: {:?}",
        diverged.len(),
        rays.len(),
        &diverged[..diverged.len().min(8)]
    );
    assert!(
        lit > rays.len() / 2,
        "only {lit} of {} paths lit",
        rays.len()
    );
    eprintln!(
        "{} of {} paths diverged ({:.2} %)",
        diverged.len(),
        rays.len(),
        100.0 * fraction
    );
}

#[test]
fn path_radiance_matches_the_cpu_in_a_lit_room() {
    // 2048 paths, up to 6 bounces. A path agrees to 1e-3 unless rounding flips a branch
    // (lobe choice at u ≈ p_specular, roulette at u ≈ survival, a ray grazing an edge):
    // then the rest of the path differs. Allowed: 0.5 % of the paths (lavapipe: none).
    assert_paths_agree(
        &lit_room(),
        Vec3::new(0.2, 1.2, 2.5),
        Vec3::new(0.0, -0.5, -1.0),
        1e-3,
        0.005,
    );
}

#[test]
fn path_radiance_matches_the_cpu_under_an_image_sky() {
    assert_paths_agree(
        &sunlit_yard(),
        Vec3::new(0.0, 1.0, 3.0),
        Vec3::new(0.0, -0.2, -1.0),
        1e-3,
        0.005,
    );
}

/// One BSDF query: material, view direction, random numbers and a light direction.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct BsdfCase {
    /// Base colour, metallic.
    material: [f32; 4],
    /// wo (local frame), roughness.
    wo: [f32; 4],
    /// u_lobe, u.
    u: [f32; 4],
    /// wi for eval_and_pdf.
    wi: [f32; 4],
}

const BSDF_KERNEL: &str = "
    struct BsdfCase { material: vec4f, wo: vec4f, u: vec4f, wi: vec4f }
    @group(3) @binding(0) var<storage, read> cases: array<BsdfCase>;
    @group(3) @binding(1) var<storage, read_write> results: array<vec4f>;
    @compute @workgroup_size(64) fn main(@builtin(global_invocation_id) id: vec3u) {
        let i = id.x;
        if i >= arrayLength(&cases) { return; }
        let c = cases[i];
        let bsdf = shade_bsdf_new(c.material.xyz, c.material.w, c.wo.w);
        let drawn = shade_bsdf_sample(bsdf, c.wo.xyz, c.u.x, c.u.yz);
        let evaluated = shade_bsdf_eval_and_pdf(bsdf, c.wo.xyz, c.wi.xyz);
        results[3u * i] = vec4f(drawn.wi, drawn.pdf);
        results[3u * i + 1u] = vec4f(drawn.value, 0.0);
        results[3u * i + 2u] = evaluated;
    }";

fn close(a: f32, b: f32, tolerance: f32) -> bool {
    (a - b).abs() <= tolerance * a.abs().max(b.abs()) + 1e-6
}

#[test]
fn bsdf_sample_eval_and_pdf_match_the_cpu() {
    let Some(context) = GpuContext::for_tests() else {
        return;
    };
    // (base colour, metallic, roughness): rough dielectric, glossy gold, half-metal, a
    // shiny dielectric, and out-of-range inputs the CPU clamps.
    let materials = [
        (Vec3::new(0.5, 0.5, 0.5), 0.0, 1.0),
        (Vec3::new(1.0, 0.78, 0.34), 1.0, 0.3),
        (Vec3::new(0.2, 0.6, 0.3), 0.5, 0.6),
        (Vec3::new(0.8, 0.1, 0.1), 0.0, 0.15),
        (Vec3::new(1.5, -0.2, 0.4), 1.3, 1.4),
    ];
    let mut rng = Rng::new(3, 5);
    let mut cases = Vec::new();
    for &(base, metallic, roughness) in &materials {
        for k in 0..800 {
            let mut direction = || {
                let z = 1.0 - 2.0 * rng.next_f32();
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = std::f32::consts::TAU * rng.next_f32();
                // Mostly above the surface, some below (no sample, zero value).
                let z = if k % 10 == 0 { z } else { z.abs() };
                [r * phi.cos(), r * phi.sin(), z]
            };
            let (wo, wi) = (direction(), direction());
            cases.push(BsdfCase {
                material: base.extend(metallic).to_array(),
                wo: [wo[0], wo[1], wo[2], roughness],
                u: [rng.next_f32(), rng.next_f32(), rng.next_f32(), 0.0],
                wi: [wi[0], wi[1], wi[2], 0.0],
            });
        }
    }
    // Any scene will do: the kernel reads none of it.
    let scene = lit_room();
    let gpu: Vec<[f32; 4]> = scene.run(&context, 1, 0, BSDF_KERNEL, &cases, 3 * cases.len());
    let mut mismatches = Vec::new();
    for (i, case) in cases.iter().enumerate() {
        let bsdf = MetalRoughBsdf::new(
            Vec3::from_slice(&case.material[..3]),
            case.material[3],
            case.wo[3],
        );
        let wo = Vec3::from_slice(&case.wo[..3]);
        let wi = Vec3::from_slice(&case.wi[..3]);
        let [drawn, drawn_value, evaluated] = [gpu[3 * i], gpu[3 * i + 1], gpu[3 * i + 2]];
        let (value, pdf) = bsdf.eval_and_pdf(wo, wi);
        let eval_ok =
            (0..3).all(|c| close(evaluated[c], value[c], 1e-4)) && close(evaluated[3], pdf, 1e-4);
        let sample_ok = match bsdf.sample(wo, case.u[0], [case.u[1], case.u[2]]) {
            None => drawn[3] == 0.0,
            Some(s) => {
                (0..3).all(|c| (drawn[c] - s.wi[c]).abs() <= 1e-4)
                    && close(drawn[3], s.pdf, 1e-3)
                    && (0..3).all(|c| close(drawn_value[c], s.value[c], 1e-3))
            }
        };
        if !(eval_ok && sample_ok) {
            mismatches.push((i, case, drawn, drawn_value, evaluated));
        }
    }
    // f32 rounding may flip a sample's lobe where u_lobe lies within an ulp of the lobe
    // probability, or tip a grazing direction below the horizon: allow 0.2 % of 4000.
    assert!(
        mismatches.len() <= cases.len() / 500,
        "{} of {} BSDF queries differ: {:?}",
        mismatches.len(),
        cases.len(),
        &mismatches[..mismatches.len().min(5)]
    );
}

/// One light-sampling query: a shading position, a direction and a stream key.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct LightQuery {
    /// xyz: where the light is sampled from; w: the stream's sample index.
    position: [f32; 4],
    /// A direction whose environment density is asked for.
    direction: [f32; 4],
}

const LIGHT_KERNEL: &str = "
    struct LightQuery { position: vec4f, direction: vec4f }
    @group(3) @binding(0) var<storage, read> queries: array<LightQuery>;
    @group(3) @binding(1) var<storage, read_write> results: array<vec4f>;
    @compute @workgroup_size(64) fn main(@builtin(global_invocation_id) id: vec3u) {
        let i = id.x;
        if i >= arrayLength(&queries) { return; }
        let q = queries[i];
        var rng = shade_rng(i, u32(q.position.w));
        let light = shade_sample_light(q.position.xyz, &rng);
        results[3u * i] = vec4f(light.direction, light.pdf);
        results[3u * i + 1u] = vec4f(light.radiance, select(0.0, 1.0, light.is_delta));
        results[3u * i + 2u] = vec4f(shade_light_environment_pdf(q.direction.xyz),
            shade_environment_radiance(q.direction.xyz));
    }";

/// `LightSet::sample`, `LightSet::environment_pdf` and `Environment::radiance` on both devices
/// for points above the floor of `scene`: the pieces of next-event estimation, alone.
fn assert_light_samples_agree(scene: &TestScene) {
    let Some(context) = GpuContext::for_tests() else {
        return;
    };
    let seed = 0xfeed_beef;
    let mut rng = Rng::new(11, 13);
    let queries: Vec<LightQuery> = (0..2000)
        .map(|k| {
            let position = Vec3::new(
                3.0 * rng.next_f32() - 1.5,
                1.5 * rng.next_f32(),
                3.0 * rng.next_f32() - 1.5,
            );
            let z = 1.0 - 2.0 * rng.next_f32();
            let phi = std::f32::consts::TAU * rng.next_f32();
            let r = (1.0 - z * z).sqrt();
            LightQuery {
                position: position.extend((k % 7) as f32).to_array(),
                direction: [r * phi.cos(), z, r * phi.sin(), 0.0],
            }
        })
        .collect();
    let gpu: Vec<[f32; 4]> =
        scene.run(&context, 1, seed, LIGHT_KERNEL, &queries, 3 * queries.len());
    let mut mismatches = Vec::new();
    let mut sampled = 0;
    for (i, query) in queries.iter().enumerate() {
        let position = Vec3::from_slice(&query.position[..3]);
        let direction = Vec3::from_slice(&query.direction[..3]);
        let mut stream =
            Rng::for_sample(seed ^ SHADE_STREAM_KEY, i as u32, query.position[3] as u32);
        let cpu = scene.lights.sample(
            position,
            &scene.accel,
            &scene.materials,
            &scene.environment,
            &mut stream,
        );
        let [drawn, radiance, environment] = [gpu[3 * i], gpu[3 * i + 1], gpu[3 * i + 2]];
        let sample_ok = match cpu {
            None => drawn[3] == 0.0,
            Some(light) => {
                sampled += 1;
                (0..3).all(|c| (drawn[c] - light.direction[c]).abs() <= 1e-4)
                    && close(drawn[3], light.pdf, 1e-3)
                    && (0..3).all(|c| close(radiance[c], light.radiance[c], 1e-3))
                    && (radiance[3] == 1.0) == light.is_delta
            }
        };
        let environment_ok = close(
            environment[0],
            scene.lights.environment_pdf(&scene.environment, direction),
            1e-3,
        ) && (0..3).all(|c| {
            close(
                environment[c + 1],
                scene.environment.radiance(direction)[c],
                1e-3,
            )
        });
        if !(sample_ok && environment_ok) {
            mismatches.push((i, cpu, drawn, radiance, environment));
        }
    }
    assert!(sampled > queries.len() / 2, "only {sampled} light samples");
    // A point drawn on an emitter's edge, or a direction on a pixel boundary of the image, may
    // land on the other side by rounding: allow 0.2 %.
    assert!(
        mismatches.len() <= queries.len() / 500,
        "{} of {} light queries differ: {:?}",
        mismatches.len(),
        queries.len(),
        &mismatches[..mismatches.len().min(4)]
    );
}

#[test]
fn light_samples_match_the_cpu_in_a_lit_room() {
    assert_light_samples_agree(&lit_room());
}

#[test]
fn light_samples_match_the_cpu_under_an_image_sky() {
    assert_light_samples_agree(&sunlit_yard());
}
