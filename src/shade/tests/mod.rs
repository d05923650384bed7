//! Shading checked against independent numbers: closed forms, form factors, quadrature of the
//! glTF BRDF as the specification writes it, and agreement between sampling strategies.

mod bsdf;
mod environment;
mod lighting;
mod robustness;

use std::sync::Arc;

use glam::{Mat4, Vec3};

use super::integrator::Strategy;
use super::{Environment, LightSet, Shader};
use crate::accel::SceneAccel;
use crate::sampling::Rng;
use crate::scene::{Material, MaterialLibrary, Mesh, MeshInstance, PunctualLight};

/// A scene with everything a [`Shader`] borrows.
pub(super) struct TestScene {
    pub accel: SceneAccel,
    pub materials: MaterialLibrary,
    pub lights: LightSet,
    pub environment: Environment,
}

impl TestScene {
    pub fn new(
        instances: &[MeshInstance],
        materials: Vec<Material>,
        punctual: &[PunctualLight],
        environment: Environment,
    ) -> Self {
        let materials = MaterialLibrary {
            materials,
            ..Default::default()
        };
        let accel = SceneAccel::build(instances, &materials).expect("accel");
        let lights = LightSet::build(punctual, &accel, &materials, &environment);
        TestScene {
            accel,
            materials,
            lights,
            environment,
        }
    }

    pub fn shader(&self, max_depth: u32, seed: u64) -> Shader<'_> {
        Shader {
            accel: &self.accel,
            materials: &self.materials,
            lights: &self.lights,
            environment: &self.environment,
            max_depth,
            seed,
        }
    }
}

/// A horizontal square of side `size` centred at `centre`, front face up (+Y) or down.
pub(super) fn horizontal_square(
    centre: Vec3,
    size: f32,
    facing_up: bool,
    material: usize,
) -> MeshInstance {
    let h = 0.5 * size;
    let positions = vec![
        Vec3::new(-h, 0.0, -h),
        Vec3::new(h, 0.0, -h),
        Vec3::new(h, 0.0, h),
        Vec3::new(-h, 0.0, h),
    ];
    // Counter-clockwise seen from +Y: (−,−) → (−,+) → (+,+).
    let triangles = if facing_up {
        vec![[0, 3, 2], [0, 2, 1]]
    } else {
        vec![[0, 2, 3], [0, 1, 2]]
    };
    let mesh = Mesh {
        positions,
        triangles,
        material: Some(material),
        ..Default::default()
    };
    MeshInstance {
        mesh: Arc::new(mesh),
        world_from_local: Mat4::from_translation(centre),
        node_name: None,
    }
}

/// A rough (roughness 1) dielectric of the given albedo: the floor of most tests.
pub(super) fn rough_floor(albedo: f32) -> Material {
    Material {
        roughness: 1.0,
        ..Material::matte(Vec3::splat(albedo))
    }
}

/// An emissive material of radiance `radiance` (nits) and black base.
pub(super) fn emitter(radiance: f32, double_sided: bool) -> Material {
    Material {
        emissive: Vec3::splat(radiance),
        double_sided,
        ..Material::matte(Vec3::ZERO)
    }
}

/// Mean and standard error of one channel over `n` independent paths along one camera ray.
pub(super) struct Estimate {
    pub mean: f64,
    pub std_error: f64,
}

impl Estimate {
    /// Asserts agreement with `expected` within `sigmas` standard errors, and that the
    /// estimate is precise enough (relative standard error below `max_relative_error`) for
    /// the comparison to mean something.
    pub fn assert_matches(&self, expected: f64, sigmas: f64, max_relative_error: f64, what: &str) {
        assert!(
            self.std_error <= max_relative_error * expected.abs(),
            "{what}: too noisy to judge, {} ± {} (expected {expected})",
            self.mean,
            self.std_error
        );
        assert!(
            (self.mean - expected).abs() <= sigmas * self.std_error + 1e-6 * expected.abs(),
            "{what}: {} ± {} but expected {expected} ({:+.3}%)",
            self.mean,
            self.std_error,
            100.0 * (self.mean / expected - 1.0)
        );
    }
}

pub(super) fn estimate(
    shader: &Shader,
    origin: Vec3,
    direction: Vec3,
    strategy: Strategy,
    n: u32,
) -> Estimate {
    let first_hit = shader.accel.intersect(origin, direction, f32::INFINITY);
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    for sample in 0..n {
        let mut rng = Rng::for_sample(shader.seed, 0, sample);
        let radiance =
            shader.path_radiance(origin, direction, first_hit, &mut rng, &mut 0, strategy);
        assert!(
            radiance.is_finite() && radiance.min_element() >= 0.0,
            "radiance {radiance}"
        );
        let x = radiance.y as f64;
        sum += x;
        sum2 += x * x;
    }
    let mean = sum / n as f64;
    let variance = (sum2 / n as f64 - mean * mean).max(0.0);
    Estimate {
        mean,
        std_error: (variance / n as f64).sqrt(),
    }
}

/// The glTF BRDF of a roughness-1, non-metallic material of albedo ρ for a viewer along the
/// normal and light at angle θ (cos θ = `cos_light`), written out from glTF 2.0 Appendix B:
/// with α = 1, D = 1/π and V = 0.5 / (n·l + n·v), so
/// f = (1 − F) ρ/π + F / (2π (1 + cos θ)), F = 0.04 + 0.96 (1 − v·h)⁵, v·h = cos(θ/2).
pub(super) fn rough_dielectric_normal_view(albedo: f64, cos_light: f64) -> f64 {
    use std::f64::consts::PI;
    let v_dot_h = ((1.0 + cos_light) / 2.0).sqrt();
    let fresnel = 0.04 + 0.96 * (1.0 - v_dot_h).powi(5);
    (1.0 - fresnel) * albedo / PI + fresnel / (2.0 * PI * (1.0 + cos_light))
}
