//! World-space triangles: flattening mesh instances into one triangle soup, and the
//! ray–triangle test the BVH traversal calls.
//!
//! Positions live in *BVH space*: world space scaled by an exact power of two (see
//! [`bvh_space_scale`]). Every other attribute stays per vertex in world space and is reached
//! through the triangle's three vertex indices, so shared vertices are stored once.

use glam::{Mat3, Vec2, Vec3, Vec3A, Vec4};

use crate::scene::{Bounds, MeshInstance};

/// Marks a triangle without a material (glTF's default material).
pub const NO_MATERIAL: u32 = u32::MAX;

/// Which optional vertex attributes a triangle's vertices carry.
pub mod attributes {
    pub const NORMALS: u8 = 1;
    pub const UVS: u8 = 2;
    pub const TANGENTS: u8 = 4;
}

/// A triangle in BVH space, laid out for the Möller–Trumbore test.
#[derive(Clone, Copy, Debug, Default)]
pub struct TrianglePrimitive {
    pub v0: Vec3A,
    /// v1 − v0
    pub edge1: Vec3A,
    /// v2 − v0
    pub edge2: Vec3A,
}

/// A ray hit on one triangle: distance and the barycentric weights of vertices 1 and 2.
#[derive(Clone, Copy, Debug)]
pub struct TriangleHit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

impl TrianglePrimitive {
    pub fn new(v0: Vec3A, v1: Vec3A, v2: Vec3A) -> Self {
        TrianglePrimitive {
            v0,
            edge1: v1 - v0,
            edge2: v2 - v0,
        }
    }

    pub fn vertices(&self) -> [Vec3A; 3] {
        [self.v0, self.v0 + self.edge1, self.v0 + self.edge2]
    }

    /// Möller–Trumbore (1997). Edges and the hit distance are inclusive (u = 0, u + v = 1 and
    /// t = t_max count), so a ray through a shared edge hits at least one of its triangles.
    #[inline(always)]
    pub fn intersect(
        &self,
        origin: Vec3A,
        direction: Vec3A,
        t_min: f32,
        t_max: f32,
    ) -> Option<TriangleHit> {
        let p = direction.cross(self.edge2);
        let det = self.edge1.dot(p);
        // A ray in the triangle's plane (det = 0) or a degenerate triangle never hits.
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let inv_det = 1.0 / det;
        let s = origin - self.v0;
        let u = s.dot(p) * inv_det;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = s.cross(self.edge1);
        let v = direction.dot(q) * inv_det;
        if !(v >= 0.0 && u + v <= 1.0) {
            return None;
        }
        let t = self.edge2.dot(q) * inv_det;
        (t >= t_min && t <= t_max).then_some(TriangleHit { t, u, v })
    }

    /// The point with barycentric weights (u, v) of vertices 1 and 2.
    pub fn point(&self, u: f32, v: f32) -> Vec3A {
        self.v0 + self.edge1 * u + self.edge2 * v
    }

    /// Unnormalised normal of the front face (counter-clockwise winding, glTF's convention).
    pub fn winding_normal(&self) -> Vec3A {
        self.edge1.cross(self.edge2)
    }
}

/// Which vertices, material and attributes a triangle uses.
#[derive(Clone, Copy, Debug)]
pub struct TriangleRecord {
    /// Indices into [`WorldVertices`].
    pub vertices: [u32; 3],
    /// Index into the material library, or [`NO_MATERIAL`].
    pub material: u32,
    /// [`attributes`] flags: which vertex attributes are meaningful for this triangle.
    pub attributes: u8,
}

/// Per-vertex shading attributes of every instance, in world space. Attributes a mesh lacks
/// are zero-filled so that one index addresses all arrays.
#[derive(Clone, Debug, Default)]
pub struct WorldVertices {
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    /// Tangent direction in xyz, bitangent sign in w.
    pub tangents: Vec<Vec4>,
}

/// Everything [`flatten_instances`] produces, in input order (before BVH reordering).
#[derive(Debug, Default)]
pub struct TriangleSoup {
    /// World-space vertices of each kept triangle.
    pub positions: Vec<[Vec3; 3]>,
    pub records: Vec<TriangleRecord>,
    pub vertices: WorldVertices,
    pub bounds: Bounds,
    /// Triangles dropped as degenerate (zero area) or non-finite.
    pub dropped: usize,
}

/// Transforms every instance's triangles to world space. Normals go through the inverse
/// transpose; a mirroring transform (negative determinant) reverses the winding so that front
/// faces stay front faces (glTF 2.0 §3.7.4) and flips the tangent handedness.
pub fn flatten_instances<'a>(
    instances: impl IntoIterator<Item = &'a MeshInstance>,
) -> TriangleSoup {
    let mut soup = TriangleSoup {
        bounds: Bounds::EMPTY,
        ..Default::default()
    };
    for instance in instances {
        let mesh = &instance.mesh;
        let transform = instance.world_from_local;
        let linear = Mat3::from_mat4(transform);
        let determinant = linear.determinant();
        let normal_matrix = if determinant != 0.0 && determinant.is_finite() {
            linear.inverse().transpose()
        } else {
            Mat3::ZERO
        };
        let mirrored = determinant < 0.0;
        let vertex_base = soup.vertices.normals.len() as u32;
        let vertex_count = mesh.positions.len();
        let has_normals = mesh.normals.len() == vertex_count;
        let has_uvs = mesh.uvs.len() == vertex_count;
        let has_tangents = mesh.tangents.len() == vertex_count && has_normals;

        // Room for the whole mesh at once: growing by doubling would copy and fault in a large
        // mesh's arrays several times over.
        soup.vertices.normals.reserve(vertex_count);
        soup.vertices.uvs.reserve(vertex_count);
        soup.vertices.tangents.reserve(vertex_count);
        soup.positions.reserve(mesh.triangles.len());
        soup.records.reserve(mesh.triangles.len());
        let world_positions: Vec<Vec3> = mesh
            .positions
            .iter()
            .map(|&p| transform.transform_point3(p))
            .collect();
        for i in 0..vertex_count {
            let normal = if has_normals {
                (normal_matrix * mesh.normals[i]).normalize_or_zero()
            } else {
                Vec3::ZERO
            };
            soup.vertices.normals.push(finite_or_zero(normal));
            soup.vertices
                .uvs
                .push(if has_uvs && mesh.uvs[i].is_finite() {
                    mesh.uvs[i]
                } else {
                    Vec2::ZERO
                });
            let tangent = if has_tangents {
                let t = mesh.tangents[i];
                let handedness = if (t.w < 0.0) != mirrored { -1.0 } else { 1.0 };
                finite_or_zero((linear * t.truncate()).normalize_or_zero()).extend(handedness)
            } else {
                Vec4::ZERO
            };
            soup.vertices.tangents.push(tangent);
        }

        let material = mesh.material.map_or(NO_MATERIAL, |m| m as u32);
        for &[a, b, c] in &mesh.triangles {
            let [a, b, c] = if mirrored { [a, c, b] } else { [a, b, c] };
            let corner = |i: u32| world_positions.get(i as usize).copied();
            let (Some(p0), Some(p1), Some(p2)) = (corner(a), corner(b), corner(c)) else {
                soup.dropped += 1;
                continue;
            };
            let area2 = (p1 - p0).cross(p2 - p0).length_squared();
            if !(p0.is_finite()
                && p1.is_finite()
                && p2.is_finite()
                && area2 > 0.0
                && area2.is_finite())
            {
                soup.dropped += 1;
                continue;
            }
            let usable = |i: u32| soup.vertices.normals[(vertex_base + i) as usize] != Vec3::ZERO;
            let mut flags = 0;
            if has_normals && usable(a) && usable(b) && usable(c) {
                flags |= attributes::NORMALS;
                if has_tangents {
                    flags |= attributes::TANGENTS;
                }
            }
            if has_uvs {
                flags |= attributes::UVS;
            }
            for p in [p0, p1, p2] {
                soup.bounds.include(p);
            }
            soup.positions.push([p0, p1, p2]);
            soup.records.push(TriangleRecord {
                vertices: [vertex_base + a, vertex_base + b, vertex_base + c],
                material,
                attributes: flags,
            });
        }
    }
    soup
}

fn finite_or_zero(v: Vec3) -> Vec3 {
    if v.is_finite() { v } else { Vec3::ZERO }
}

/// log2 of the size BVH space gives the scene's diagonal.
const BVH_SPACE_DIAGONAL_EXPONENT: i32 = 20;

/// The exact power of two that scales world space into BVH space, where the scene's
/// diagonal is about 2^20.
///
/// obvhs's wide-node test clamps each child box's entry distance to an absolute 1e-4, so a box
/// lying entirely within 1e-4 of a ray origin is skipped: in metres, a ray leaving a wall 50 µm
/// from the adjacent wall escapes through the corner, and in a 7 mm scene whole features
/// vanish. At a diagonal of 2^20 that blind zone is 1e-10 of the scene, far below the f32
/// resolution of positions. A power of two keeps the scaling, and the mapping of hit
/// distances back, exact; coordinates stay far from f32's range (a 7 mm object 1 km from the
/// origin lands near 1e11).
pub fn bvh_space_scale(bounds: &Bounds) -> f32 {
    let diagonal = bounds.diagonal();
    if bounds.is_empty() || !(diagonal > 0.0 && diagonal.is_finite()) {
        return 1.0;
    }
    let exponent = BVH_SPACE_DIAGONAL_EXPONENT - diagonal.log2().ceil() as i32;
    2f32.powi(exponent.clamp(-60, 60))
}
