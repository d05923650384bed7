//! Spawning rays from surfaces without hitting the surface they start on.
//!
//! A hit point computed in f32 lies off the true surface by a few ulps of its triangle's
//! vertex coordinates, and the test of a new ray against that triangle errs by as much, so a
//! ray leaving the point can hit its own triangle again. Starting it a little off the surface,
//! along the geometric normal, by an amount relative to the triangle's coordinates avoids
//! that at every scale (7 mm objects, 100 m rooms, a 20 km ground plane) without a fixed
//! epsilon that would be too small for one and swallow the detail of another.

use glam::{Vec3, Vec3A};

use super::{SceneAccel, SurfacePoint};

/// Offset relative to the largest vertex coordinate: 2^-16 ≈ 128 ulps of f32.
const COORDINATE_RELATIVE: f32 = 1.0 / 65536.0;

/// How far off a triangle a ray leaving it must start, from its vertices in BVH space and the
/// world length of a BVH unit. That length is a power of two, so the largest coordinate is
/// found in BVH space and scaled once: the same bits as scaling each of the nine first.
pub(super) fn triangle_spawn_offset(bvh_vertices: [Vec3A; 3], world_per_bvh_unit: f32) -> f32 {
    let magnitude = bvh_vertices
        .iter()
        .map(|&v| Vec3::from(v).abs().max_element())
        .fold(0.0f32, f32::max)
        * world_per_bvh_unit;
    COORDINATE_RELATIVE
        * if magnitude.is_finite() {
            magnitude
        } else {
            0.0
        }
}

/// `position` moved `offset` along `normal`, to the side `direction` points to.
pub fn offset_along_normal(position: Vec3, normal: Vec3, offset: f32, direction: Vec3) -> Vec3 {
    let toward = if normal.dot(direction) < 0.0 {
        -normal
    } else {
        normal
    };
    position + toward * offset
}

impl SurfacePoint {
    /// The origin for a ray leaving this point in `direction` that will not hit its own
    /// surface: the position moved off the surface to the side `direction` points to.
    pub fn spawn_origin(&self, direction: Vec3) -> Vec3 {
        offset_along_normal(
            self.position,
            self.geometric_normal,
            self.spawn_offset,
            direction,
        )
    }
}

impl SceneAccel {
    /// How far off `triangle` a ray leaving it must start (see [`SurfacePoint::spawn_origin`]).
    pub fn triangle_spawn_offset(&self, triangle: u32) -> f32 {
        self.primitives.get(triangle as usize).map_or(0.0, |p| {
            triangle_spawn_offset(p.vertices(), self.world_per_bvh_unit)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Rng;

    /// Values of every magnitude f32 has, subnormals and the extremes among them.
    fn coordinates(rng: &mut Rng) -> Vec<f32> {
        let mut values = vec![
            0.0,
            -0.0,
            f32::MIN_POSITIVE,
            1e-40,
            f32::MAX,
            -f32::MAX,
            1.0,
        ];
        values.extend((0..4000).map(|_| {
            let bits = ((rng.next_f32() * u32::MAX as f32) as u32) & !(0xff << 23)
                | (((rng.next_f32() * 254.0) as u32) << 23);
            let x = f32::from_bits(bits);
            if rng.next_f32() < 0.5 { -x } else { x }
        }));
        values
    }

    /// BVH space is world space times a power of two (`bvh_space_scale`, 2⁻⁶⁰ … 2⁶⁰), so a
    /// product with the exact inverse is the quotient, bit for bit, and the largest coordinate
    /// scaled once is the largest of the coordinates scaled each: what lets `surface` and the
    /// spawn offset multiply where they divided.
    #[test]
    fn scaling_out_of_bvh_space_by_the_inverse_is_dividing() {
        let mut rng = Rng::new(5, 8);
        let values = coordinates(&mut rng);
        for exponent in -60..=60 {
            let scale = 2f32.powi(exponent);
            let inverse = 1.0 / scale;
            for &x in &values {
                assert_eq!(
                    (x * inverse).to_bits(),
                    (x / scale).to_bits(),
                    "{x} at 2^{exponent}"
                );
            }
            for triangle in values.chunks_exact(9) {
                let vertices: [Vec3A; 3] =
                    std::array::from_fn(|k| Vec3A::from_slice(&triangle[3 * k..3 * k + 3]));
                let each_scaled_first = vertices
                    .map(|v| Vec3::from(v) / scale)
                    .iter()
                    .map(|v| v.abs().max_element())
                    .fold(0.0f32, f32::max);
                let expected = COORDINATE_RELATIVE
                    * if each_scaled_first.is_finite() {
                        each_scaled_first
                    } else {
                        0.0
                    };
                let got = triangle_spawn_offset(vertices, inverse);
                assert_eq!(
                    got.to_bits(),
                    expected.to_bits(),
                    "{triangle:?} at 2^{exponent}"
                );
            }
        }
    }
}
