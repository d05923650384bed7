//! Warps from the unit square to directions and points, with their densities.

use std::f32::consts::{FRAC_1_PI, PI, TAU};

use glam::{Vec2, Vec3};

use crate::lanes::Lanes;

/// Shirley–Chiu concentric map of the unit square onto the unit disk (area-preserving, low
/// distortion, so stratification survives).
pub fn concentric_disk(u: [f32; 2]) -> Vec2 {
    let offset = Vec2::new(2.0 * u[0] - 1.0, 2.0 * u[1] - 1.0);
    if offset == Vec2::ZERO {
        return Vec2::ZERO;
    }
    let (radius, theta) = if offset.x.abs() > offset.y.abs() {
        (offset.x, PI / 4.0 * (offset.y / offset.x))
    } else {
        (offset.y, PI / 2.0 - PI / 4.0 * (offset.x / offset.y))
    };
    Vec2::new(theta.cos(), theta.sin()) * radius
}

/// Cosine-weighted direction about +z (Malley's method): density cos θ / π.
pub fn cosine_hemisphere(u: [f32; 2]) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Density of [`cosine_hemisphere`] (solid angle) at a direction of cosine `cos_theta` to the
/// normal, for a group of lanes (see [`crate::lanes`]).
#[inline(always)]
pub fn cosine_hemisphere_pdf<L: Lanes>(cos_theta: L) -> L {
    cos_theta.max(L::splat(0.0)) * L::splat(FRAC_1_PI)
}

/// Uniform direction on the unit sphere: density 1 / 4π.
pub fn uniform_sphere(u: [f32; 2]) -> Vec3 {
    let z = 1.0 - 2.0 * u[0];
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = TAU * u[1];
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

/// Uniform point on a triangle as barycentric weights (u, v) of vertices 1 and 2
/// (square-root parametrisation, Osada et al. 2002): density 1 / area.
pub fn uniform_triangle(u: [f32; 2]) -> (f32, f32) {
    let s = u[0].sqrt();
    (s * (1.0 - u[1]), s * u[1])
}
