//! Mesh instances in world space: triangles the renderer cannot use there are dropped, with a
//! warning, before anything downstream (framing, BVH, light sampling) sees them.
//!
//! A mesh can be fine in its own frame and not in the world: a huge scale makes its
//! coordinates overflow f32 or reach sizes where f32 area and distance arithmetic overflows; a
//! zero scale flattens it to nothing.

use std::sync::Arc;

use glam::{Mat4, Vec3};

use crate::scene::{Bounds, Mesh, MeshInstance};

/// World coordinates beyond ±this many metres are refused. Triangle areas are computed in f32
/// as squared cross products of edges: with every coordinate within 1e9 m (2.6× the Moon's
/// distance), |edge| components ≤ 2e9, cross components ≤ 8e18 and the squared length
/// ≤ 1.9e38 < f32::MAX. Beyond this, areas overflow and the BVH's scaling of the scene would
/// shrink everything else to nothing.
pub const MAX_WORLD_COORDINATE_M: f32 = 1e9;

/// `instance` with only the triangles usable in world space, or `None` when none are left.
/// The shared mesh is kept when every triangle is usable, so instancing stays cheap.
pub(super) fn usable_in_world(
    instance: MeshInstance,
    meshes: &mut Vec<Arc<Mesh>>,
    warnings: &mut Vec<String>,
) -> Option<MeshInstance> {
    let transform = instance.world_from_local;
    let world: Vec<Vec3> = instance
        .mesh
        .positions
        .iter()
        .map(|&p| transform.transform_point3(p))
        .collect();
    let (mut too_far, mut collapsed) = (0usize, 0usize);
    let kept: Vec<[u32; 3]> = instance
        .mesh
        .triangles
        .iter()
        .copied()
        .filter(
            |triangle| match world_problem(triangle.map(|i| world[i as usize])) {
                Some(Problem::TooFar) => {
                    too_far += 1;
                    false
                }
                Some(Problem::Collapsed) => {
                    collapsed += 1;
                    false
                }
                None => true,
            },
        )
        .collect();
    if too_far + collapsed == 0 {
        return Some(instance);
    }
    let label = instance
        .node_name
        .as_deref()
        .map_or("an unnamed node".to_string(), |name| {
            format!("node '{name}'")
        });
    if too_far > 0 {
        warnings.push(format!(
            "{label}: {too_far} triangles lie beyond ±{MAX_WORLD_COORDINATE_M:e} m in world space (or overflow); dropped. Check the scene's units and scales"
        ));
    }
    if collapsed > 0 {
        warnings.push(format!(
            "{label}: {collapsed} triangles collapse to zero area in world space (a zero scale?); dropped"
        ));
    }
    if kept.is_empty() {
        return None;
    }
    let mesh = Arc::new(Mesh {
        triangles: kept,
        ..(*instance.mesh).clone()
    });
    meshes.push(mesh.clone());
    Some(MeshInstance { mesh, ..instance })
}

enum Problem {
    TooFar,
    Collapsed,
}

fn world_problem(corners: [Vec3; 3]) -> Option<Problem> {
    let within = |p: Vec3| p.is_finite() && p.abs().max_element() <= MAX_WORLD_COORDINATE_M;
    if !corners.into_iter().all(within) {
        return Some(Problem::TooFar);
    }
    let [a, b, c] = corners;
    let area2 = (b - a).cross(c - a).length_squared();
    (area2 == 0.0).then_some(Problem::Collapsed)
}

/// World bounds of every vertex of every instanced triangle.
pub(super) fn world_bounds(instances: &[MeshInstance]) -> Bounds {
    let mut bounds = Bounds::EMPTY;
    for instance in instances {
        let transform: Mat4 = instance.world_from_local;
        for triangle in &instance.mesh.triangles {
            for &index in triangle {
                if let Some(&position) = instance.mesh.positions.get(index as usize) {
                    bounds.include(transform.transform_point3(position));
                }
            }
        }
    }
    bounds
}

#[cfg(test)]
mod tests {
    use super::*;

    fn instance(scale: f32) -> MeshInstance {
        MeshInstance {
            mesh: Arc::new(Mesh {
                positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1e3, 0.0, 0.0)],
                triangles: vec![[0, 1, 2], [0, 3, 2]],
                ..Mesh::default()
            }),
            world_from_local: Mat4::from_scale(Vec3::splat(scale)),
            node_name: Some("n".into()),
        }
    }

    #[test]
    fn usable_instances_keep_their_shared_mesh() {
        let (mut meshes, mut warnings) = (Vec::new(), Vec::new());
        let original = instance(2.0);
        let kept = usable_in_world(original.clone(), &mut meshes, &mut warnings).unwrap();
        assert!(Arc::ptr_eq(&kept.mesh, &original.mesh));
        assert!(meshes.is_empty() && warnings.is_empty());
    }

    #[test]
    fn far_and_flattened_triangles_are_dropped_with_a_warning() {
        let (mut meshes, mut warnings) = (Vec::new(), Vec::new());
        // 1e3 × 1e7 = 1e10 m: the second triangle is too far, the first is not.
        let kept = usable_in_world(instance(1e7), &mut meshes, &mut warnings).unwrap();
        assert_eq!(kept.mesh.triangles, [[0, 1, 2]]);
        assert_eq!(meshes.len(), 1);
        assert!(
            warnings[0].contains("node 'n': 1 triangles lie beyond"),
            "{warnings:?}"
        );

        let mut warnings = Vec::new();
        assert!(usable_in_world(instance(0.0), &mut meshes, &mut warnings).is_none());
        assert!(warnings[0].contains("2 triangles collapse"), "{warnings:?}");
        let mut warnings = Vec::new();
        assert!(usable_in_world(instance(f32::MAX), &mut meshes, &mut warnings).is_none());
        assert!(
            warnings[0].contains("2 triangles lie beyond"),
            "{warnings:?}"
        );
    }
}
