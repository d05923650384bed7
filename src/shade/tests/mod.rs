//! Shading checked against independent numbers: closed forms, form factors, quadrature of the
//! glTF BRDF as the specification writes it, and agreement between sampling strategies.

mod bsdf;
mod environment;
mod lighting;
mod robustness;
mod wavefront;

use std::sync::Arc;

use glam::{Mat4, Vec3};

use super::integrator::Strategy;
use super::{Environment, EnvironmentSampling, LightSet, ShadeStats, Shader};
use crate::accel::{BatchParallelism, SceneAccel};
use crate::sampling::Rng;
use crate::scene::{Material, MaterialLibrary, Mesh, MeshInstance, PunctualLight};

/// A scene with everything a [`Shader`] borrows (the GPU's shading tests upload it too).
pub(crate) struct TestScene {
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
        Self::with_environment_sampling(
            instances,
            materials,
            punctual,
            environment,
            EnvironmentSampling::default(),
        )
    }

    /// A scene whose light set samples the environment as `environment_sampling` says.
    pub fn with_environment_sampling(
        instances: &[MeshInstance],
        materials: Vec<Material>,
        punctual: &[PunctualLight],
        environment: Environment,
        environment_sampling: EnvironmentSampling,
    ) -> Self {
        let materials = MaterialLibrary {
            materials,
            ..Default::default()
        };
        Self::with_library(
            instances,
            materials,
            punctual,
            environment,
            environment_sampling,
        )
    }

    /// A scene of a whole material library (textures included).
    pub fn with_library(
        instances: &[MeshInstance],
        materials: MaterialLibrary,
        punctual: &[PunctualLight],
        environment: Environment,
        environment_sampling: EnvironmentSampling,
    ) -> Self {
        let accel = SceneAccel::build(instances, &materials).expect("accel");
        let lights = LightSet::build_with(
            punctual,
            &accel,
            &materials,
            &environment,
            environment_sampling,
        );
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
            parallelism: BatchParallelism::Spread,
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
    placed(mesh, Mat4::from_translation(centre))
}

/// One placed copy of a mesh.
pub(super) fn placed(mesh: Mesh, world_from_local: Mat4) -> MeshInstance {
    MeshInstance {
        mesh: Arc::new(mesh),
        world_from_local,
        node_name: None,
    }
}

/// A 100 m rough floor of albedo ρ at y = 0 under one punctual light and a black sky.
pub(super) fn floor_under(albedo: f32, light: PunctualLight) -> TestScene {
    TestScene::new(
        &[horizontal_square(Vec3::ZERO, 100.0, true, 0)],
        vec![rough_floor(albedo)],
        &[light],
        Environment::Uniform(Vec3::ZERO),
    )
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

/// Running mean and standard error of independent Monte Carlo samples.
#[derive(Default)]
pub(super) struct Tally {
    n: u64,
    sum: f64,
    sum2: f64,
}

impl Tally {
    pub fn add(&mut self, x: f64) {
        self.n += 1;
        self.sum += x;
        self.sum2 += x * x;
    }

    pub fn mean(&self) -> f64 {
        self.sum / self.n.max(1) as f64
    }

    pub fn std_error(&self) -> f64 {
        let n = self.n.max(1) as f64;
        ((self.sum2 / n - self.mean().powi(2)).max(0.0) / n).sqrt()
    }

    /// Asserts agreement with `expected` within `sigmas` standard errors, and that the
    /// estimate is precise enough (relative standard error below `max_relative_error`) for
    /// the comparison to mean something.
    pub fn assert_matches(&self, expected: f64, sigmas: f64, max_relative_error: f64, what: &str) {
        let (mean, error) = (self.mean(), self.std_error());
        assert!(
            error <= max_relative_error * expected.abs(),
            "{what}: too noisy to judge, {mean} ± {error} (expected {expected})"
        );
        assert!(
            (mean - expected).abs() <= sigmas * error + 1e-6 * expected.abs(),
            "{what}: {mean} ± {error} but expected {expected} ({:+.3}%)",
            100.0 * (mean / expected - 1.0)
        );
    }
}

/// The luminance-channel (green) radiance of `n` independent paths along one camera ray.
pub(super) fn estimate(
    shader: &Shader,
    origin: Vec3,
    direction: Vec3,
    strategy: Strategy,
    n: u32,
) -> Tally {
    let first_hit = shader.accel.intersect(origin, direction, f32::INFINITY);
    let mut tally = Tally::default();
    for sample in 0..n {
        let mut rng = Rng::for_sample(shader.seed, 0, sample);
        let radiance = shader.path_radiance(
            origin,
            direction,
            first_hit,
            &mut rng,
            &mut ShadeStats::default(),
            strategy,
        );
        assert!(
            radiance.is_finite() && radiance.min_element() >= 0.0,
            "radiance {radiance}"
        );
        tally.add(radiance.y as f64);
    }
    tally
}

/// The unit direction at polar angle θ from +z and azimuth φ.
pub(super) fn polar_direction(theta: f64, phi: f64) -> Vec3 {
    Vec3::new(
        (theta.sin() * phi.cos()) as f32,
        (theta.sin() * phi.sin()) as f32,
        theta.cos() as f32,
    )
}

/// ∫ g(ω) dω over the sphere (or the hemisphere around +z) by the midpoint rule in (θ, φ).
pub(super) fn integrate_directions(
    upper_hemisphere_only: bool,
    n_theta: usize,
    g: impl Fn(Vec3) -> f64,
) -> f64 {
    use std::f64::consts::PI;
    let theta_max = if upper_hemisphere_only { PI / 2.0 } else { PI };
    let n_phi = 2 * n_theta;
    let (d_theta, d_phi) = (theta_max / n_theta as f64, 2.0 * PI / n_phi as f64);
    let mut sum = 0.0;
    for i in 0..n_theta {
        let theta = (i as f64 + 0.5) * d_theta;
        let ring: f64 = (0..n_phi)
            .map(|j| g(polar_direction(theta, (j as f64 + 0.5) * d_phi)))
            .sum();
        sum += ring * theta.sin() * d_theta * d_phi;
    }
    sum
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
