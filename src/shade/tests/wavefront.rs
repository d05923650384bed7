//! The batched (wavefront) shading against the one-ray reference path tracer.

use glam::Vec3;

use super::*;
use crate::accel::BatchParallelism;
use crate::batch::{HitBatch, RayBatch};
use crate::scene::PunctualLight;
use crate::shade::{RadianceBatch, SHADE_STREAM_KEY, ShadeStats};

#[test]
fn wavefront_shading_is_the_reference_path_tracer_bit_for_bit() {
    // A floor under a roof with a gap, lit by the sky through the gap, a point light under the
    // roof and an emissive square: paths bounce many times, take light samples of every kind
    // and end in every way (escape, depth, roulette, absorption).
    let mut instances = vec![horizontal_square(Vec3::ZERO, 40.0, true, 0)];
    instances.extend(
        [(-10.5, 0.0), (10.5, 0.0), (0.0, -10.5), (0.0, 10.5)]
            .map(|(x, z)| horizontal_square(Vec3::new(x, 2.0, z), 20.0, false, 0)),
    );
    instances.push(horizontal_square(Vec3::new(3.0, 1.5, 3.0), 0.5, false, 1));
    let light = PunctualLight::Point {
        position: Vec3::new(-3.0, 1.8, 1.0),
        intensity: Vec3::splat(20.0),
        range: None,
    };
    let scene = TestScene::new(
        &instances,
        vec![rough_floor(0.8), emitter(5.0, true)],
        &[light],
        Environment::Uniform(Vec3::new(0.4, 0.6, 1.0)),
    );
    // Each tile's rays spread over the threads or kept on one: the same bits.
    let modes = [BatchParallelism::Spread, BatchParallelism::OneThread];
    for (max_depth, parallelism) in [1, 5, u32::MAX]
        .into_iter()
        .flat_map(|d| modes.map(|m| (d, m)))
    {
        let shader = Shader {
            parallelism,
            ..scene.shader(max_depth, 11)
        };
        let mut rng = Rng::new(3, 4);
        let mut rays = RayBatch::default();
        for pixel in 0..700 {
            let origin = Vec3::new(rng.next_f32() * 8.0 - 4.0, 1.0, rng.next_f32() * 8.0 - 4.0);
            let direction = Vec3::new(
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
            )
            .normalize();
            rays.push(origin.to_array(), direction.to_array(), pixel, pixel % 3);
        }
        // Dead rays get nothing.
        rays.alive[5] = false;
        rays.alive[6] = false;
        let mut hits = HitBatch::default();
        scene
            .accel
            .intersect_batch_with(&rays, &mut hits, parallelism);
        let (mut out, mut stats) = (RadianceBatch::default(), ShadeStats::default());
        shader.shade_batch(&rays, &hits, &mut out, &mut stats);

        let mut reference = ShadeStats::default();
        for i in 0..rays.len() {
            let expected = if rays.alive[i] {
                let mut rng = Rng::for_sample(
                    shader.seed ^ SHADE_STREAM_KEY,
                    rays.pixel[i],
                    rays.sample[i],
                );
                let origin = Vec3::from(rays.origin(i));
                let direction = Vec3::from(rays.direction(i));
                shader.path_radiance(
                    origin,
                    direction,
                    shader.accel.intersect(origin, direction, f32::INFINITY),
                    &mut rng,
                    &mut reference,
                    Strategy::Mis,
                )
            } else {
                Vec3::ZERO
            };
            let got = Vec3::new(out.r[i], out.g[i], out.b[i]);
            assert_eq!(
                got.to_array().map(f32::to_bits),
                expected.to_array().map(f32::to_bits),
                "ray {i}, depth {max_depth}, {parallelism:?}: {got} vs {expected}"
            );
        }
        // The same work and the same outcomes, counted path by path.
        assert_eq!(stats, reference, "depth {max_depth}, {parallelism:?}");
        assert!(stats.camera_rays_escaped > 0 && stats.bounce_rays_escaped > 0);
        assert!(stats.light_samples > 0 && stats.light_samples_reached > 0);
        assert!(out.g.iter().any(|&g| g > 0.0));
    }
}
