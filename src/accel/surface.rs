//! The shading frame at a hit: position, normals, tangent and texture coordinates.

use glam::{Vec2, Vec3, Vec4};

use super::spawn::triangle_spawn_offset;
use super::triangles::{NO_MATERIAL, attributes};
use super::{SceneAccel, SurfacePoint};
use crate::batch::Hit;
use crate::prefetch::{prefetch, prefetch_at};

impl SceneAccel {
    /// Asks the memory system for the triangle's primitive and record, which
    /// [`SceneAccel::surface`] will read: a hint that never changes a result.
    #[inline(always)]
    pub fn prefetch_triangle(&self, triangle: u32) {
        let index = triangle as usize;
        if let (Some(primitive), Some(record)) =
            (self.primitives.get(index), self.records.get(index))
        {
            prefetch(primitive);
            prefetch(record);
        }
    }

    /// Asks the memory system for the triangle's vertex attributes, which
    /// [`SceneAccel::surface`] will read. Where they lie is in the triangle's record: call it
    /// a while after [`SceneAccel::prefetch_triangle`], once the record is likely in cache.
    #[inline(always)]
    pub fn prefetch_vertices(&self, triangle: u32) {
        let Some(record) = self.records.get(triangle as usize) else {
            return;
        };
        let has = |flag: u8| record.attributes & flag != 0;
        for i in record.vertices.map(|i| i as usize) {
            if has(attributes::NORMALS) {
                prefetch_at(&self.vertices.normals, i);
            }
            if has(attributes::UVS) {
                prefetch_at(&self.vertices.uvs, i);
            }
            if has(attributes::TANGENTS) {
                prefetch_at(&self.vertices.tangents, i);
            }
        }
    }

    /// The surface at `hit`, seen along `ray_direction`.
    ///
    /// The position is interpolated from the vertices (more accurate than origin + t·direction).
    /// Triangles without usable vertex normals shade flat. Without vertex tangents the tangent is
    /// derived from the UV layout (dp/du), as glTF asks of implementations.
    pub fn surface(&self, hit: &Hit, ray_direction: Vec3) -> SurfacePoint {
        let index = hit.triangle as usize;
        let (Some(primitive), Some(record)) = (self.primitives.get(index), self.records.get(index))
        else {
            // Not a triangle of this scene: a caller bug. Answer with a harmless frame.
            debug_assert!(
                false,
                "surface() of triangle {} out of {}",
                hit.triangle,
                self.primitives.len()
            );
            let normal = -ray_direction.normalize_or(Vec3::Z);
            return SurfacePoint {
                position: Vec3::ZERO,
                geometric_normal: normal,
                shading_normal: normal,
                tangent: Vec4::ZERO,
                uv: Vec2::ZERO,
                material: None,
                back_face: false,
                spawn_offset: 0.0,
            };
        };
        let (u, v) = (hit.u, hit.v);
        let w = 1.0 - u - v;
        let position = Vec3::from(primitive.point(u, v)) * self.world_per_bvh_unit;
        // Zero-area triangles were dropped at build, so the winding normal is non-zero.
        let front_normal = Vec3::from(primitive.winding_normal()).normalize_or(Vec3::Z);
        let back_face = front_normal.dot(ray_direction) > 0.0;
        let side = if back_face { -1.0 } else { 1.0 };
        let geometric_normal = front_normal * side;

        let [i0, i1, i2] = record.vertices.map(|i| i as usize);
        let has = |flag: u8| record.attributes & flag != 0;
        let interpolated_normal = if has(attributes::NORMALS) {
            let n = &self.vertices.normals;
            (n[i0] * w + n[i1] * u + n[i2] * v).normalize_or(front_normal)
        } else {
            front_normal
        };
        let uvs = has(attributes::UVS).then(|| [i0, i1, i2].map(|i| self.vertices.uvs[i]));
        let uv = uvs.map_or(Vec2::ZERO, |[a, b, c]| a * w + b * u + c * v);

        let tangent = if has(attributes::TANGENTS) {
            let t = &self.vertices.tangents;
            let direction = (t[i0] * w + t[i1] * u + t[i2] * v).truncate();
            orthogonal_tangent(direction, interpolated_normal, t[i0].w)
        } else if let Some(uvs) = uvs {
            uv_tangent(
                Vec3::from(primitive.edge1),
                Vec3::from(primitive.edge2),
                uvs,
                interpolated_normal,
            )
        } else {
            Vec4::ZERO
        };

        // Mirror the whole frame onto the side the ray came from. Vertex normals that point
        // against their own face (inverted data) are turned to the viewer's side as well.
        let mut shading_normal = interpolated_normal * side;
        if shading_normal.dot(geometric_normal) < 0.0 {
            shading_normal = -shading_normal;
        }
        SurfacePoint {
            position,
            geometric_normal,
            shading_normal,
            tangent: tangent * side,
            uv,
            material: (record.material != NO_MATERIAL).then_some(record.material as usize),
            back_face,
            spawn_offset: triangle_spawn_offset(primitive.vertices(), self.world_per_bvh_unit),
        }
    }
}

/// `direction` made orthogonal to `normal` (Gram–Schmidt) and unit, with bitangent sign `sign`;
/// zero when nothing of it is left.
fn orthogonal_tangent(direction: Vec3, normal: Vec3, sign: f32) -> Vec4 {
    let tangent = (direction - normal * normal.dot(direction)).normalize_or_zero();
    if tangent == Vec3::ZERO {
        return Vec4::ZERO;
    }
    tangent.extend(if sign < 0.0 { -1.0 } else { 1.0 })
}

/// The tangent frame a UV layout implies: tangent = dp/du, and the bitangent sign chosen so that
/// cross(normal, tangent) × sign points to −v, "up" in a glTF image (whose v runs downwards),
/// which is where a normal map's +Y points.
fn uv_tangent(edge1: Vec3, edge2: Vec3, [uv0, uv1, uv2]: [Vec2; 3], normal: Vec3) -> Vec4 {
    let (duv1, duv2) = (uv1 - uv0, uv2 - uv0);
    let det = duv1.x * duv2.y - duv1.y * duv2.x;
    if det == 0.0 || !det.is_finite() {
        return Vec4::ZERO;
    }
    // Solve edge_i = duv_i.x · dp/du + duv_i.y · dp/dv for dp/du and dp/dv.
    let dp_du = (edge1 * duv2.y - edge2 * duv1.y) / det;
    let dp_dv = (edge2 * duv1.x - edge1 * duv2.x) / det;
    let sign = if normal.cross(dp_du).dot(-dp_dv) < 0.0 {
        -1.0
    } else {
        1.0
    };
    orthogonal_tangent(dp_du, normal, sign)
}
