//! What lies beyond the scene: a uniform sky or an equirectangular radiance image.
//!
//! **Mapping of an image** (latitude–longitude): +Y (up) is the top row, −Y the bottom row. The
//! centre of the image is the horizon direction −Z, which is where an un-rotated glTF camera
//! looks; moving right in the image turns right as seen by that camera (towards +X at
//! three-quarters width), and the left and right edges meet at +Z, behind it. In formulas, with
//! image coordinates (u, v) ∈ [0, 1]² from the top-left corner:
//! φ = 2π(u − ½), θ = πv, direction = (sin θ sin φ, cos θ, −sin θ cos φ).
//!
//! Pixel values are radiance in nits (cd/m²), as read from the file.

use std::f32::consts::{PI, TAU};
use std::path::Path;
use std::sync::Arc;

use anyhow::Context;
use glam::{Vec2, Vec3};

use super::bsdf::luminance;
use super::distribution::Distribution2D;
use super::warp::{UNIFORM_SPHERE_PDF, uniform_sphere};
use crate::scene::{Texture, WrapMode};

/// What lies beyond the scene.
#[derive(Clone, Debug)]
pub enum Environment {
    /// A uniform sky of this radiance (nits).
    Uniform(Vec3),
    /// An equirectangular radiance image (see the module docs for the mapping).
    Image(Arc<EnvironmentMap>),
}

/// A direction drawn towards the environment.
#[derive(Clone, Copy, Debug)]
pub struct EnvironmentSample {
    pub direction: Vec3,
    pub radiance: Vec3,
    /// Solid-angle density.
    pub pdf: f32,
}

impl Environment {
    /// Radiance arriving from the environment along `-direction` (i.e. seen looking towards
    /// `direction`).
    pub fn radiance(&self, direction: Vec3) -> Vec3 {
        match self {
            Environment::Uniform(radiance) => *radiance,
            Environment::Image(map) => map.radiance(direction),
        }
    }

    /// Draws a direction: uniform over the sphere for a uniform sky, by luminance × sin θ for
    /// an image. `None` when the environment is black.
    pub fn sample(&self, u: [f32; 2]) -> Option<EnvironmentSample> {
        match self {
            Environment::Uniform(radiance) => {
                (luminance(*radiance) > 0.0).then(|| EnvironmentSample {
                    direction: uniform_sphere(u),
                    radiance: *radiance,
                    pdf: UNIFORM_SPHERE_PDF,
                })
            }
            Environment::Image(map) => map.sample(u),
        }
    }

    /// Solid-angle density of [`Environment::sample`] drawing `direction`.
    pub fn pdf(&self, direction: Vec3) -> f32 {
        match self {
            Environment::Uniform(radiance) => {
                if luminance(*radiance) > 0.0 {
                    UNIFORM_SPHERE_PDF
                } else {
                    0.0
                }
            }
            Environment::Image(map) => map.pdf(direction),
        }
    }

    /// Luminance averaged over all directions (nits): sizes the environment against other lights.
    pub fn mean_luminance(&self) -> f32 {
        match self {
            Environment::Uniform(radiance) => luminance(*radiance).max(0.0),
            Environment::Image(map) => map.mean_luminance,
        }
    }
}

/// An equirectangular radiance image prepared for importance sampling.
#[derive(Clone, Debug)]
pub struct EnvironmentMap {
    /// Wraps around in u, clamps at the poles.
    pub(crate) image: Texture,
    /// Over pixels, see [`sampling_weights`].
    pub(crate) distribution: Distribution2D,
    mean_luminance: f32,
}

impl EnvironmentMap {
    /// From row-major linear RGB radiance, top row first. Negative and non-finite channels are
    /// read as zero.
    pub fn new(width: u32, height: u32, pixels: &[Vec3]) -> anyhow::Result<Self> {
        let (w, h) = (width as usize, height as usize);
        anyhow::ensure!(
            w > 0 && h > 0,
            "environment image is empty ({width}×{height})"
        );
        anyhow::ensure!(
            pixels.len() == w * h,
            "environment image has {} pixels, expected {width}×{height}",
            pixels.len()
        );
        let texels: Vec<[f32; 4]> = pixels
            .iter()
            .map(|p| {
                let p = Vec3::select(p.is_finite_mask(), *p, Vec3::ZERO).max(Vec3::ZERO);
                [p.x, p.y, p.z, 1.0]
            })
            .collect();
        let luminances: Vec<f32> = texels
            .iter()
            .map(|t| luminance(Vec3::new(t[0], t[1], t[2])))
            .collect();
        let weights = sampling_weights(&luminances, w, h);
        let distribution = Distribution2D::new(&weights, w, h);
        // ∫ L dω / 4π, with dω = 2π² sin θ du dv over the unit square of image coordinates.
        let sphere_integral: f64 = luminances
            .iter()
            .enumerate()
            .map(|(i, &l)| l as f64 * pixel_sin_theta(i / w, h) as f64)
            .sum::<f64>()
            * 2.0
            * (PI as f64).powi(2)
            / (w * h) as f64;
        let mean_luminance = (sphere_integral / (4.0 * PI as f64)) as f32;
        let image = Texture {
            width,
            height,
            texels,
            wrap_s: WrapMode::Repeat,
            wrap_t: WrapMode::ClampToEdge,
            nearest: false,
        };
        Ok(EnvironmentMap {
            image,
            distribution,
            mean_luminance,
        })
    }

    /// Bilinearly filtered radiance seen looking towards `direction`.
    pub fn radiance(&self, direction: Vec3) -> Vec3 {
        Vec3::from_slice(&self.image.sample(direction_to_image(direction))[..3])
    }

    fn sample(&self, u: [f32; 2]) -> Option<EnvironmentSample> {
        let ((x, y), density_uv) = self.distribution.sample(u)?;
        let uv = Vec2::new(x, y);
        let sin_theta = (PI * y).sin();
        if !(sin_theta > 0.0) {
            return None;
        }
        let direction = image_to_direction(uv);
        // dω = 2π² sin θ du dv.
        let pdf = density_uv / (2.0 * PI * PI * sin_theta);
        (pdf > 0.0 && pdf.is_finite()).then(|| EnvironmentSample {
            direction,
            radiance: self.radiance(direction),
            pdf,
        })
    }

    fn pdf(&self, direction: Vec3) -> f32 {
        let uv = direction_to_image(direction);
        let d = direction.normalize_or_zero();
        let sin_theta = (d.x * d.x + d.z * d.z).sqrt();
        if !(sin_theta > 0.0) {
            return 0.0;
        }
        let pdf = self.distribution.density(uv.x, uv.y) / (2.0 * PI * PI * sin_theta);
        if pdf.is_finite() { pdf } else { 0.0 }
    }
}

/// sin θ at the centre of pixel row `y` of `height`: the solid angle a pixel covers shrinks
/// towards the poles.
fn pixel_sin_theta(y: usize, height: usize) -> f32 {
    (PI * (y as f32 + 0.5) / height as f32).sin()
}

/// Pixel weights for importance sampling: the largest luminance among the pixel and its eight
/// neighbours, × sin θ. Radiance is looked up bilinearly, so the value inside a pixel's cell
/// can reach towards a neighbour's; weighting by the neighbourhood maximum keeps radiance /
/// density bounded (no fireflies beside a bright sun) and the density non-zero wherever the
/// radiance is. u wraps around, v clamps at the poles, as the lookup does.
fn sampling_weights(luminances: &[f32], width: usize, height: usize) -> Vec<f32> {
    let mut weights = vec![0.0; width * height];
    for y in 0..height {
        for x in 0..width {
            let mut brightest = 0.0f32;
            for ny in y.saturating_sub(1)..=(y + 1).min(height - 1) {
                for dx in [width - 1, 0, 1] {
                    brightest = brightest.max(luminances[ny * width + (x + dx) % width]);
                }
            }
            weights[y * width + x] = brightest * pixel_sin_theta(y, height);
        }
    }
    weights
}

/// Image coordinates (u, v) ∈ [0, 1]² of a direction (see the module docs).
pub fn direction_to_image(direction: Vec3) -> Vec2 {
    let d = direction.normalize_or(Vec3::NEG_Z);
    let u = d.x.atan2(-d.z) / TAU + 0.5;
    // θ by atan2 rather than acos(y): acos loses precision near the poles.
    let v = (d.x * d.x + d.z * d.z).sqrt().atan2(d.y) / PI;
    Vec2::new(u, v)
}

/// The direction of image coordinates (u, v) (see the module docs).
pub fn image_to_direction(uv: Vec2) -> Vec3 {
    let phi = TAU * (uv.x - 0.5);
    let theta = PI * uv.y;
    let (sin_theta, cos_theta) = theta.sin_cos();
    Vec3::new(sin_theta * phi.sin(), cos_theta, -sin_theta * phi.cos())
}

/// Loads an equirectangular `.exr` or `.hdr` radiance image (see the module docs for the
/// mapping and units).
pub fn load_environment(path: impl AsRef<Path>) -> anyhow::Result<Environment> {
    let path = path.as_ref();
    let image = image::open(path)
        .with_context(|| format!("cannot read environment image {}", path.display()))?
        .into_rgb32f();
    let (width, height) = image.dimensions();
    let pixels: Vec<Vec3> = image.pixels().map(|p| Vec3::from_array(p.0)).collect();
    let map = EnvironmentMap::new(width, height, &pixels)
        .with_context(|| format!("environment image {} is unusable", path.display()))?;
    Ok(Environment::Image(Arc::new(map)))
}
