//! No NaN or infinity escapes awkward geometry, and results are reproducible bit for bit.

use std::sync::Arc;

use glam::{Mat4, Vec2, Vec3, Vec4};

use super::*;
use crate::batch::{HitBatch, RayBatch};
use crate::scene::{Mesh, Texture, TextureRef, WrapMode};
use crate::shade::{RadianceBatch, SHADE_STREAM_KEY, ShadeStats};

/// A floor, an emissive square light, a sun, a point light sitting on the floor and a sky.
fn busy_scene() -> TestScene {
    let floor = horizontal_square(Vec3::ZERO, 20.0, true, 0);
    let light = horizontal_square(Vec3::new(0.5, 2.0, 0.0), 0.5, false, 1);
    // A zero-area emitter (collinear) and a sliver of 1e-12 m².
    let degenerate = Mesh {
        positions: vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::X * 2.0,
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(1e-6, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 1e-6),
        ],
        triangles: vec![[0, 1, 2], [3, 4, 5]],
        material: Some(1),
        ..Default::default()
    };
    let degenerate = placed(degenerate, Mat4::IDENTITY);
    let lights = [
        PunctualLight::Point {
            position: Vec3::new(1.0, 0.0, 1.0),
            intensity: Vec3::splat(5.0),
            range: None,
        },
        PunctualLight::Directional {
            direction: Vec3::new(0.3, -1.0, 0.1).normalize(),
            illuminance: Vec3::splat(100.0),
        },
        PunctualLight::Spot {
            position: Vec3::new(-1.0, 1.0, 0.0),
            direction: Vec3::ZERO,
            intensity: Vec3::splat(f32::MAX),
            range: Some(0.0),
            inner_cone_angle: 0.5,
            outer_cone_angle: 0.5,
        },
    ];
    TestScene::new(
        &[floor, light, degenerate],
        vec![rough_floor(0.8), emitter(20.0, false)],
        &lights,
        Environment::Uniform(Vec3::new(0.2, 0.3, 0.5)),
    )
}

/// Rays from all around the scene towards it, some grazing the floor, some degenerate.
fn awkward_rays(n: u32) -> RayBatch {
    let mut rng = Rng::new(99, 1);
    let mut rays = RayBatch::with_capacity(n as usize);
    for i in 0..n {
        let (origin, direction) = match i % 8 {
            // Grazing the floor from just above it.
            0 => (
                Vec3::new(-5.0, 1e-4, rng.next_f32()),
                Vec3::new(1.0, -1e-5, 0.0).normalize(),
            ),
            // Exactly in the floor's plane.
            1 => (Vec3::new(-5.0, 0.0, rng.next_f32()), Vec3::X),
            // Towards the point light sitting on the floor.
            2 => (Vec3::new(1.0, 1.0, 1.0), Vec3::NEG_Y),
            // Degenerate directions.
            3 => (
                Vec3::ONE,
                if rng.next_f32() < 0.5 {
                    Vec3::ZERO
                } else {
                    Vec3::NAN
                },
            ),
            // At the back of the single-sided emitter.
            4 => (Vec3::new(0.5, 3.0, 0.0), Vec3::NEG_Y),
            // At the light's edge, grazing.
            5 => (Vec3::new(-2.0, 2.0 + 1e-6, 0.1), Vec3::X),
            _ => {
                let origin = Vec3::new(
                    rng.next_f32() - 0.5,
                    1.0 + rng.next_f32(),
                    rng.next_f32() - 0.5,
                ) * 3.0;
                (
                    origin,
                    (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5)
                        .normalize_or(Vec3::NEG_Y),
                )
            }
        };
        rays.push(origin.into(), direction.into(), i / 4, i % 4);
    }
    rays
}

fn shade(scene: &TestScene, seed: u64, rays: &RayBatch) -> (RadianceBatch, ShadeStats) {
    let mut hits = HitBatch::default();
    scene.accel.intersect_batch(rays, &mut hits);
    let mut out = RadianceBatch::default();
    let mut stats = ShadeStats::default();
    scene
        .shader(6, seed)
        .shade_batch(rays, &hits, &mut out, &mut stats);
    (out, stats)
}

#[test]
fn nothing_non_finite_escapes_awkward_scenes() {
    let scene = busy_scene();
    assert_eq!(
        scene.lights.emissive_triangle_count(),
        3,
        "the zero-area emitter is dropped, the sliver kept"
    );
    let rays = awkward_rays(4000);
    let (out, stats) = shade(&scene, 3, &rays);
    assert_eq!(out.r.len(), rays.len());
    for i in 0..rays.len() {
        let radiance = Vec3::new(out.r[i], out.g[i], out.b[i]);
        assert!(
            radiance.is_finite() && radiance.min_element() >= 0.0,
            "ray {i}: {radiance}"
        );
    }
    assert!(stats.rays_traced > 0);
    // Single-sided emitter (20 nits) seen from behind: only its 4 % coating reflecting the
    // sky (0.5 nits in blue) and the lit floor remains.
    assert!(out.b[4] < 0.5, "back of the emitter: {}", out.b[4]);
}

#[test]
fn normal_maps_bending_away_from_the_viewer_stay_finite() {
    // A normal map whose normals lie almost in the surface plane, at full scale and beyond.
    let texels = vec![
        [1.0, 0.5, 0.501, 1.0],
        [0.0, 0.0, 0.5, 1.0],
        [0.5, 1.0, 0.5, 1.0],
        [0.5, 0.5, 1.0, 1.0],
    ];
    let texture = Texture {
        width: 2,
        height: 2,
        texels,
        wrap_s: WrapMode::Repeat,
        wrap_t: WrapMode::Repeat,
        nearest: true,
    };
    let mesh = Mesh {
        positions: vec![
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::new(-1.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
        ],
        normals: vec![Vec3::Y; 3],
        tangents: vec![Vec4::new(1.0, 0.0, 0.0, 1.0); 3],
        uvs: vec![Vec2::ZERO, Vec2::new(0.0, 1.0), Vec2::ONE],
        triangles: vec![[0, 1, 2]],
        material: Some(0),
    };
    let instance = placed(mesh, Mat4::IDENTITY);
    for normal_scale in [1.0, 5.0, -3.0] {
        let material = Material {
            normal_texture: Some(TextureRef {
                texture: 0,
                tex_coord: 0,
            }),
            normal_scale,
            ..rough_floor(0.9)
        };
        let mut scene = TestScene::new(
            std::slice::from_ref(&instance),
            vec![material],
            &[],
            Environment::Uniform(Vec3::ONE),
        );
        scene.materials.textures.push(Arc::new(texture.clone()));
        let mut rng = Rng::new(1, 1);
        for _ in 0..2000 {
            let target = Vec3::new(-0.2 + 0.4 * rng.next_f32(), 0.0, 0.3 + 0.4 * rng.next_f32());
            let from = target
                + (Vec3::new(
                    rng.next_f32() - 0.5,
                    rng.next_f32() * 0.01,
                    rng.next_f32() - 0.5,
                ))
                .normalize_or(Vec3::Y);
            let direction = (target - from).normalize();
            let hit = scene.accel.intersect(from, direction, f32::INFINITY);
            let radiance = scene.shader(4, 1).radiance(from, direction, hit, &mut rng);
            assert!(radiance.is_finite() && radiance.min_element() >= 0.0);
        }
    }
}

#[test]
fn same_seed_gives_identical_results_whatever_the_batching() {
    let scene = busy_scene();
    let rays = awkward_rays(1000);
    let (whole, stats) = shade(&scene, 17, &rays);
    let (again, stats_again) = shade(&scene, 17, &rays);
    let bits = |b: &RadianceBatch| -> Vec<[u32; 3]> {
        (0..b.r.len())
            .map(|i| [b.r[i].to_bits(), b.g[i].to_bits(), b.b[i].to_bits()])
            .collect()
    };
    assert_eq!(bits(&whole), bits(&again));
    assert_eq!(stats.rays_traced, stats_again.rays_traced);

    // Split into uneven batches, in another order.
    let mut pieces = Vec::new();
    for range in [600..1000, 0..1, 1..600] {
        let mut part = RayBatch::with_capacity(range.len());
        for i in range.clone() {
            part.push(
                rays.origin(i),
                rays.direction(i),
                rays.pixel[i],
                rays.sample[i],
            );
        }
        pieces.push((range, shade(&scene, 17, &part).0));
    }
    for (range, out) in pieces {
        for (k, i) in range.enumerate() {
            assert_eq!(
                [out.r[k].to_bits(), out.g[k].to_bits(), out.b[k].to_bits()],
                bits(&whole)[i],
                "ray {i} differs when batched differently"
            );
        }
    }

    // The scalar entry point with the documented stream reproduces the batch.
    let shader = scene.shader(6, 17);
    for i in (0..rays.len()).step_by(37) {
        let (origin, direction) = (Vec3::from(rays.origin(i)), Vec3::from(rays.direction(i)));
        let hit = scene.accel.intersect(origin, direction, f32::INFINITY);
        let mut rng = Rng::for_sample(17 ^ SHADE_STREAM_KEY, rays.pixel[i], rays.sample[i]);
        let radiance = shader.radiance(origin, direction, hit, &mut rng);
        assert_eq!(
            [
                radiance.x.to_bits(),
                radiance.y.to_bits(),
                radiance.z.to_bits()
            ],
            bits(&whole)[i]
        );
    }

    // Another seed gives another image.
    let (other, _) = shade(&scene, 18, &rays);
    assert_ne!(bits(&whole), bits(&other));
}

#[test]
fn dead_rays_are_dark_and_rays_are_counted() {
    let light = PunctualLight::Point {
        position: Vec3::new(0.0, 2.0, 0.0),
        intensity: Vec3::splat(10.0),
        range: None,
    };
    let scene = floor_under(0.5, light);
    let mut rays = RayBatch::with_capacity(10);
    for i in 0..10 {
        rays.push([i as f32 * 0.1, 1.0, 0.0], [0.0, -1.0, 0.0], i, 0);
    }
    rays.alive[3] = false;
    let mut hits = HitBatch::default();
    scene.accel.intersect_batch(&rays, &mut hits);
    let mut out = RadianceBatch::default();
    let mut stats = ShadeStats::default();
    scene
        .shader(1, 1)
        .shade_batch(&rays, &hits, &mut out, &mut stats);
    assert_eq!(out.r[3], 0.0);
    assert!(out.r[2] > 0.0);
    // Direct lighting: one shadow ray and one bounce ray per alive ray.
    assert_eq!(stats.rays_traced, 2 * 9);
}

#[test]
fn paths_end_in_a_closed_mirror_box_without_a_depth_limit() {
    // A closed box of white, nearly smooth metal keeps a path's throughput near 1 at every
    // bounce; only the capped Russian roulette can end it.
    let corners: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32) * 2.0 - 1.0
        })
        .collect();
    let faces = [
        [0, 1, 3, 2],
        [4, 6, 7, 5],
        [0, 4, 5, 1],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 5, 7, 3],
    ];
    let triangles = faces
        .iter()
        .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
        .collect();
    let mesh = Mesh {
        positions: corners,
        triangles,
        material: Some(0),
        ..Default::default()
    };
    let instance = placed(mesh, Mat4::IDENTITY);
    let mirror = Material {
        base_color: Vec4::ONE,
        metallic: 1.0,
        roughness: 0.05,
        ..Default::default()
    };
    let scene = TestScene::new(
        &[instance],
        vec![mirror],
        &[],
        Environment::Uniform(Vec3::ONE),
    );
    // No light reaches the inside of the box: neither along shadow rays nor by paths slipping
    // out through the corners a mirror box sends them into.
    for strategy in [Strategy::Mis, Strategy::LightOnly, Strategy::BsdfOnly] {
        let origin = Vec3::new(0.1, 0.2, 0.3);
        let direction = Vec3::new(0.3, -0.5, 0.8).normalize();
        let e = estimate(
            &scene.shader(u32::MAX, 1),
            origin,
            direction,
            strategy,
            2000,
        );
        assert_eq!(e.mean(), 0.0, "{strategy:?}");
    }
}
