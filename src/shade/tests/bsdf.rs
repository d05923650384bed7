//! The BRDF and GGX sampling against hand values and quadrature.

use std::f64::consts::PI;

use glam::Vec3;

use super::{
    Tally, integrate_directions, polar_direction as direction, rough_dielectric_normal_view,
};
use crate::sampling::Rng;
use crate::shade::bsdf::{EVAL_BATCH, EvalBatch, MetalRoughBsdf};
use crate::shade::ggx::Ggx;

/// Monte Carlo estimate of the directional albedo ∫ f cos dω by the BSDF's own sampling
/// (paths the sampler ends count as zero), with its standard error.
fn sampled_albedo(bsdf: &MetalRoughBsdf, wo: Vec3, n: u32, seed: u64) -> (f64, f64) {
    let mut rng = Rng::new(seed, 7);
    let mut tally = Tally::default();
    for _ in 0..n {
        tally.add(match bsdf.sample(wo, rng.next_f32(), rng.next_2d()) {
            Some(s) => {
                assert!(
                    (s.pdf - bsdf.pdf(wo, s.wi)).abs() <= 1e-5 * s.pdf,
                    "sample pdf is the density"
                );
                assert_eq!(s.value, bsdf.eval(wo, s.wi));
                (s.value.y * s.wi.z / s.pdf) as f64
            }
            None => 0.0,
        });
    }
    (tally.mean(), tally.std_error())
}

#[test]
fn brdf_matches_the_specification_by_hand() {
    // White, roughness 1, non-metal, viewer along the normal: the closed form of
    // `rough_dielectric_normal_view`. At θ = 0 it is (0.96 + 0.01)/π.
    let bsdf = MetalRoughBsdf::new(Vec3::ONE, 0.0, 1.0);
    let f = bsdf.eval(Vec3::Z, Vec3::Z).y as f64;
    assert!((f - 0.97 / PI).abs() < 1e-6, "f = {f}");
    for theta in [0.3f64, 0.8, 1.2, 1.5] {
        let f = bsdf.eval(Vec3::Z, direction(theta, 0.4)).y as f64;
        let expected = rough_dielectric_normal_view(1.0, theta.cos());
        assert!(
            (f - expected).abs() < 1e-5 * expected,
            "θ = {theta}: {f} vs {expected}"
        );
    }
    // A white metal at normal incidence, roughness r: F = 1, D = 1/(π α²), V = 1/4.
    for roughness in [0.2f32, 0.5] {
        let alpha = (roughness * roughness) as f64;
        let f = MetalRoughBsdf::new(Vec3::ONE, 1.0, roughness)
            .eval(Vec3::Z, Vec3::Z)
            .y as f64;
        let expected = 1.0 / (PI * alpha * alpha) / 4.0;
        assert!((f - expected).abs() < 1e-4 * expected, "{f} vs {expected}");
    }
}

#[test]
fn brdf_is_reciprocal_and_zero_below_the_surface() {
    let bsdf = MetalRoughBsdf::new(Vec3::new(0.8, 0.4, 0.2), 0.3, 0.45);
    let mut rng = Rng::new(5, 5);
    for _ in 0..1000 {
        let a = direction(
            (rng.next_f32() * 1.5) as f64,
            (rng.next_f32() * std::f32::consts::TAU) as f64,
        );
        let b = direction(
            (rng.next_f32() * 1.5) as f64,
            (rng.next_f32() * std::f32::consts::TAU) as f64,
        );
        let (ab, ba) = (bsdf.eval(a, b), bsdf.eval(b, a));
        assert!((ab - ba).abs().max_element() <= 1e-5 * ab.max_element().max(1.0));
        assert_eq!(bsdf.eval(a, b * Vec3::new(1.0, 1.0, -1.0)), Vec3::ZERO);
        assert_eq!(bsdf.pdf(a, b * Vec3::new(1.0, 1.0, -1.0)), 0.0);
    }
}

#[test]
fn ggx_reflection_density_integrates_to_one() {
    for roughness in [0.3f32, 0.6, 1.0] {
        let ggx = Ggx::from_roughness(roughness);
        for theta_o in [0.0f64, 0.8, 1.4] {
            let wo = direction(theta_o, 0.0);
            // Over the whole sphere: reflection can send some of it below the horizon.
            let total = integrate_directions(false, 700, |wi| ggx.reflection_pdf(wo, wi) as f64);
            assert!(
                (total - 1.0).abs() < 3e-3,
                "roughness {roughness}, θo {theta_o}: ∫ pdf = {total}"
            );
            // Visible normals: ∫ D_wo(h) dh = 1 as well.
            let normals = integrate_directions(true, 700, |h| ggx.visible_normal_pdf(wo, h) as f64);
            assert!((normals - 1.0).abs() < 3e-3, "∫ D_wo = {normals}");
        }
    }
}

#[test]
fn sampling_follows_the_density_it_reports() {
    // If the sampler drew directions with another density than `pdf` says, the sampled
    // albedo would differ from the quadrature of f cos θ.
    let materials = [
        MetalRoughBsdf::new(Vec3::ONE, 0.0, 1.0),
        MetalRoughBsdf::new(Vec3::splat(0.5), 0.0, 0.4),
        MetalRoughBsdf::new(Vec3::ONE, 1.0, 0.5),
        MetalRoughBsdf::new(Vec3::new(0.9, 0.6, 0.3), 0.5, 0.7),
    ];
    for (k, bsdf) in materials.iter().enumerate() {
        for theta_o in [0.2f64, 1.0] {
            let wo = direction(theta_o, 1.0);
            let quadrature =
                integrate_directions(true, 500, |wi| (bsdf.eval(wo, wi).y * wi.z) as f64);
            let (mean, error) = sampled_albedo(bsdf, wo, 200_000, k as u64);
            assert!(error < 0.005 * quadrature);
            assert!(
                (mean - quadrature).abs() < 4.0 * error + 1e-3 * quadrature,
                "material {k}, θo {theta_o}: sampled {mean} ± {error}, quadrature {quadrature}"
            );
        }
    }
}

#[test]
fn white_metal_furnace_keeps_at_most_all_energy() {
    for roughness in [0.05f32, 0.2, 0.3, 0.6, 1.0] {
        let bsdf = MetalRoughBsdf::new(Vec3::ONE, 1.0, roughness);
        for theta_o in [0.0f64, 0.6, 1.0] {
            let wo = direction(theta_o, 0.0);
            let (albedo, error) = sampled_albedo(&bsdf, wo, 100_000, 3);
            assert!(
                albedo <= 1.0 + 3.0 * error,
                "roughness {roughness}, θo {theta_o}: albedo {albedo}"
            );
            if roughness <= 0.3 {
                // Single scattering loses little when the surface is smooth.
                assert!(
                    albedo >= 0.9,
                    "roughness {roughness}, θo {theta_o}: albedo {albedo}"
                );
            }
        }
    }
    // At α = 1 and normal view, D = 1/π and V = 1/(2(1 + cos θ)), so the albedo is
    // ∫₀¹ μ/(1 + μ) dμ = 1 − ln 2: single scattering loses most of the energy there.
    let (albedo, error) = sampled_albedo(
        &MetalRoughBsdf::new(Vec3::ONE, 1.0, 1.0),
        Vec3::Z,
        100_000,
        4,
    );
    let expected = 1.0 - 2f64.ln();
    assert!(
        (albedo - expected).abs() < 4.0 * error,
        "{albedo} ± {error} vs 1 − ln 2 = {expected}"
    );
}

#[test]
fn grazing_and_degenerate_input_stay_finite() {
    let bsdf = MetalRoughBsdf::new(Vec3::new(f32::NAN, 0.5, 2.0), f32::INFINITY, f32::NAN);
    let grazing = Vec3::new(1.0, 0.0, 1e-8).normalize();
    let mut rng = Rng::new(1, 2);
    for wo in [grazing, Vec3::Z, Vec3::new(0.0, 1.0, 1e-30)] {
        for wi in [grazing, Vec3::Z, Vec3::new(-1.0, 0.0, 1e-7).normalize(), wo] {
            assert!(bsdf.eval(wo, wi).is_finite());
            assert!(bsdf.pdf(wo, wi).is_finite());
        }
        for _ in 0..1000 {
            if let Some(s) = bsdf.sample(wo, rng.next_f32(), rng.next_2d()) {
                assert!(
                    s.pdf > 0.0 && s.pdf.is_finite() && s.value.is_finite() && s.wi.is_finite()
                );
                assert!((s.value * s.wi.z / s.pdf).is_finite());
            }
        }
    }
    // Mirror-like: roughness 0 clamps α to its minimum and stays finite at the peak.
    let mirror = MetalRoughBsdf::new(Vec3::ONE, 1.0, 0.0);
    assert!(mirror.eval(Vec3::Z, Vec3::Z).is_finite());
    assert!(mirror.pdf(Vec3::Z, Vec3::Z).is_finite());
}

/// The wavefront's batched evaluation (eight lanes at a time) gives every lane what the scalar
/// BSDF gives, bit for bit: random materials and directions, and the awkward ones (grazing
/// and tiny cosines, wi the mirror of wo, wi opposite to wo in the plane, the smallest α,
/// black and white base colours), in batches of every length up to full.
#[test]
fn batched_evaluation_is_the_scalar_one_bit_for_bit() {
    let mut rng = Rng::new(11, 3);
    let unit = |rng: &mut Rng| {
        let [u, v] = rng.next_2d();
        let z = u;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = std::f32::consts::TAU * v;
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    };
    let mut cases = Vec::new();
    for _ in 0..3000 {
        let [r, g] = rng.next_2d();
        let [b, metallic] = rng.next_2d();
        let bsdf = MetalRoughBsdf::new(Vec3::new(r, g, b), metallic, rng.next_f32());
        cases.push((bsdf, unit(&mut rng), unit(&mut rng)));
    }
    let awkward_wo = [
        Vec3::Z,
        Vec3::new(1.0, 0.0, 1e-7).normalize(),
        Vec3::new(0.6, 0.0, 0.8),
        Vec3::new(1.0, 0.0, 1e-30),
    ];
    for &wo in &awkward_wo {
        for bsdf in [
            MetalRoughBsdf::new(Vec3::ZERO, 0.0, 0.0),
            MetalRoughBsdf::new(Vec3::ONE, 1.0, 0.0),
            MetalRoughBsdf::new(Vec3::splat(0.5), 0.5, 1.0),
        ] {
            let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
            let opposite = Vec3::new(-wo.x, -wo.y, wo.z.max(1e-30));
            for wi in [
                wo,
                mirror,
                opposite,
                Vec3::Z,
                Vec3::new(0.0, 1.0, 1e-6).normalize(),
            ] {
                cases.push((bsdf, wo, wi));
            }
        }
    }
    let mut batch = EvalBatch::new();
    let mut done = 0;
    let mut length = 1;
    while done < cases.len() {
        let group = &cases[done..(done + length).min(cases.len())];
        batch.clear();
        for (bsdf, wo, wi) in group {
            let p_specular = bsdf.specular_probability(*wo);
            batch.push(bsdf, *wo, *wi, p_specular);
        }
        batch.run();
        for (i, (bsdf, wo, wi)) in group.iter().enumerate() {
            let expected = bsdf.eval_and_pdf(*wo, *wi);
            let got = batch.result(i);
            assert_eq!(
                (got.0.to_array().map(f32::to_bits), got.1.to_bits()),
                (
                    expected.0.to_array().map(f32::to_bits),
                    expected.1.to_bits()
                ),
                "{bsdf:?} at wo {wo:?}, wi {wi:?}: {got:?} against {expected:?}"
            );
        }
        done += group.len();
        length = length % EVAL_BATCH + 1;
    }
}
