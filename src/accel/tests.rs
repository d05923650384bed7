//! Intersection checked against hand-computed hits and a brute-force reference.

use std::sync::Arc;

use glam::{Mat4, Quat, Vec2, Vec3, Vec4};

use super::*;
use crate::sampling::Rng;
use crate::scene::{AlphaMode, Material, Mesh, Texture, TextureRef, WrapMode};

fn mesh(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>, material: Option<usize>) -> Mesh {
    Mesh {
        positions,
        triangles,
        material,
        ..Default::default()
    }
}

fn instance(mesh: Mesh, world_from_local: Mat4) -> MeshInstance {
    MeshInstance {
        mesh: Arc::new(mesh),
        world_from_local,
        node_name: None,
    }
}

/// The unit right triangle (0,0,z) (1,0,z) (0,1,z), front face towards +z.
fn right_triangle(z: f32, material: Option<usize>) -> Mesh {
    mesh(
        vec![
            Vec3::new(0.0, 0.0, z),
            Vec3::new(1.0, 0.0, z),
            Vec3::new(0.0, 1.0, z),
        ],
        vec![[0, 1, 2]],
        material,
    )
}

fn build(instances: &[MeshInstance]) -> SceneAccel {
    SceneAccel::build(instances, &MaterialLibrary::default()).expect("build")
}

#[test]
fn hit_distance_and_barycentrics_match_hand_computation() {
    let accel = build(&[instance(right_triangle(0.0, None), Mat4::IDENTITY)]);
    assert_eq!(accel.triangle_count(), 1);
    assert!(accel.node_count() >= 1);
    // The point (0.25, 0.5, 0) = 0.25·v0 + 0.25·v1 + 0.5·v2, reached after 2 m.
    let hit = accel
        .intersect(Vec3::new(0.25, 0.5, 2.0), Vec3::NEG_Z, f32::INFINITY)
        .expect("hit");
    assert_eq!(hit.triangle, 0);
    assert!((hit.t - 2.0).abs() < 1e-6, "t = {}", hit.t);
    assert!((hit.u - 0.25).abs() < 1e-6, "u = {}", hit.u);
    assert!((hit.v - 0.5).abs() < 1e-6, "v = {}", hit.v);

    // Oblique ray to the same point: direction (0.6, 0, -0.8) from (0.25 - 0.6·5, 0.5, 4).
    let direction = Vec3::new(0.6, 0.0, -0.8);
    let hit = accel
        .intersect(Vec3::new(0.25 - 3.0, 0.5, 4.0), direction, f32::INFINITY)
        .expect("hit");
    assert!((hit.t - 5.0).abs() < 1e-5);
    assert!((hit.u - 0.25).abs() < 1e-5 && (hit.v - 0.5).abs() < 1e-5);

    let surface = accel.surface(&hit, direction);
    assert!((surface.position - Vec3::new(0.25, 0.5, 0.0)).length() < 1e-6);
    assert_eq!(surface.geometric_normal, Vec3::Z);
    assert!(!surface.back_face);
}

#[test]
fn misses_outside_behind_and_beyond_t_max() {
    let accel = build(&[instance(right_triangle(0.0, None), Mat4::IDENTITY)]);
    // Outside the hypotenuse (u + v = 1.2).
    assert!(
        accel
            .intersect(Vec3::new(0.6, 0.6, 1.0), Vec3::NEG_Z, f32::INFINITY)
            .is_none()
    );
    // Pointing away.
    assert!(
        accel
            .intersect(Vec3::new(0.2, 0.2, 1.0), Vec3::Z, f32::INFINITY)
            .is_none()
    );
    // Too short: the triangle is 1 m away.
    assert!(
        accel
            .intersect(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.99)
            .is_none()
    );
    assert!(!accel.occluded(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.99));
    assert!(accel.occluded(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 1.01));
    // Parallel to the plane, and degenerate input.
    assert!(
        accel
            .intersect(Vec3::new(-1.0, 0.2, 0.0), Vec3::X, f32::INFINITY)
            .is_none()
    );
    assert!(
        accel
            .intersect(Vec3::new(0.2, 0.2, 1.0), Vec3::ZERO, f32::INFINITY)
            .is_none()
    );
    assert!(
        accel
            .intersect(Vec3::new(f32::NAN, 0.2, 1.0), Vec3::NEG_Z, f32::INFINITY)
            .is_none()
    );
    assert!(
        accel
            .intersect(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, f32::NAN)
            .is_none()
    );
}

#[test]
fn closest_of_two_and_back_faces() {
    let accel = build(&[
        instance(right_triangle(-1.0, Some(7)), Mat4::IDENTITY),
        instance(right_triangle(0.0, Some(3)), Mat4::IDENTITY),
    ]);
    let from_above = accel
        .intersect(Vec3::new(0.2, 0.2, 2.0), Vec3::NEG_Z, f32::INFINITY)
        .expect("hit");
    assert!((from_above.t - 2.0).abs() < 1e-6);
    assert_eq!(accel.triangle_material(from_above.triangle), Some(3));
    let from_below = accel
        .intersect(Vec3::new(0.2, 0.2, -3.0), Vec3::Z, f32::INFINITY)
        .expect("hit");
    assert!((from_below.t - 2.0).abs() < 1e-6);
    assert_eq!(accel.triangle_material(from_below.triangle), Some(7));
    let surface = accel.surface(&from_below, Vec3::Z);
    assert!(surface.back_face);
    assert_eq!(surface.geometric_normal, Vec3::NEG_Z, "faces the ray");
    assert_eq!(surface.shading_normal, Vec3::NEG_Z);
    assert_eq!(surface.material, Some(7));
}

/// A 2×2 quad in the z = 0 plane with UVs (0,0)…(1,1), two triangles.
fn textured_quad(material: Option<usize>) -> Mesh {
    Mesh {
        positions: vec![
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ],
        uvs: vec![
            Vec2::new(0.0, 1.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(1.0, 0.0),
            Vec2::new(0.0, 0.0),
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        material,
        ..Default::default()
    }
}

#[test]
fn alpha_mask_cuts_a_hole() {
    // Left half of the texture opaque, right half transparent; cutoff 0.5 × factor 1.
    let texels = (0..8)
        .map(|i| [1.0, 1.0, 1.0, if i < 4 { 1.0 } else { 0.0 }])
        .collect();
    let texture = Texture {
        width: 8,
        height: 1,
        texels,
        wrap_s: WrapMode::ClampToEdge,
        wrap_t: WrapMode::ClampToEdge,
        nearest: false,
    };
    let masked = Material {
        base_color_texture: Some(TextureRef {
            texture: 0,
            tex_coord: 0,
        }),
        alpha_mode: AlphaMode::Mask(0.5),
        ..Material::matte(Vec3::ONE)
    };
    let library = MaterialLibrary {
        materials: vec![masked, Material::matte(Vec3::ONE)],
        textures: vec![Arc::new(texture)],
        ..Default::default()
    };
    let instances = [
        instance(textured_quad(Some(0)), Mat4::IDENTITY),
        instance(
            textured_quad(Some(1)),
            Mat4::from_translation(Vec3::new(0.0, 0.0, -1.0)),
        ),
    ];
    let accel = SceneAccel::build(&instances, &library).expect("build");

    // x = -0.5 is u = 0.25 (opaque): the masked quad is hit at t = 1.
    let opaque = accel
        .intersect(Vec3::new(-0.5, 0.3, 1.0), Vec3::NEG_Z, f32::INFINITY)
        .expect("hit");
    assert!((opaque.t - 1.0).abs() < 1e-6);
    assert_eq!(accel.triangle_material(opaque.triangle), Some(0));
    // x = 0.5 is u = 0.75 (transparent): the ray goes through to the quad behind, t = 2.
    let through = accel
        .intersect(Vec3::new(0.5, 0.3, 1.0), Vec3::NEG_Z, f32::INFINITY)
        .expect("hit");
    assert!((through.t - 2.0).abs() < 1e-6);
    assert_eq!(accel.triangle_material(through.triangle), Some(1));
    // Shadow rays agree.
    assert!(accel.occluded(Vec3::new(-0.5, 0.3, 1.0), Vec3::NEG_Z, 1.5));
    assert!(!accel.occluded(Vec3::new(0.5, 0.3, 1.0), Vec3::NEG_Z, 1.5));
    assert!(!accel.is_alpha_hole(through.triangle, 0.5, 0.0));
}

#[test]
fn transformed_and_mirrored_instances() {
    let mut tilted = right_triangle(0.0, None);
    tilted.normals = vec![Vec3::new(1.0, 0.0, 1.0).normalize(); 3];
    let rotation = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2); // local +z → world +y
    let transform = Mat4::from_scale_rotation_translation(
        Vec3::new(2.0, 3.0, 1.0),
        rotation,
        Vec3::new(10.0, 1.0, 0.0),
    );
    let accel = build(&[instance(tilted, transform)]);
    // World triangle: (10,1,0) (12,1,0) (10,1,-3), front towards +y.
    let hit = accel
        .intersect(Vec3::new(10.5, 5.0, -1.5), Vec3::NEG_Y, f32::INFINITY)
        .expect("hit");
    assert!((hit.t - 4.0).abs() < 1e-5);
    assert!((hit.u - 0.25).abs() < 1e-5 && (hit.v - 0.5).abs() < 1e-5);
    let surface = accel.surface(&hit, Vec3::NEG_Y);
    assert!(!surface.back_face);
    assert!((surface.geometric_normal - Vec3::Y).length() < 1e-6);
    // Inverse transpose: local normal (1,0,1) scaled by (1/2, 1/3, 1) → (1/2, 0, 1) → rotated.
    let expected = rotation * Vec3::new(0.5, 0.0, 1.0).normalize();
    assert!(
        (surface.shading_normal - expected).length() < 1e-5,
        "{:?} vs {expected:?}",
        surface.shading_normal
    );

    // A mirror (x → −x) reverses the winding, so the front face still points to +z.
    let accel = build(&[instance(
        right_triangle(0.0, None),
        Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)),
    )]);
    let hit = accel
        .intersect(Vec3::new(-0.25, 0.5, 1.0), Vec3::NEG_Z, f32::INFINITY)
        .expect("hit");
    let surface = accel.surface(&hit, Vec3::NEG_Z);
    assert!(!surface.back_face);
    assert_eq!(surface.geometric_normal, Vec3::Z);
}

#[test]
fn surface_uv_and_tangent_from_uv_layout() {
    let accel = build(&[instance(textured_quad(None), Mat4::IDENTITY)]);
    let hit = accel
        .intersect(Vec3::new(0.5, -0.5, 1.0), Vec3::NEG_Z, f32::INFINITY)
        .expect("hit");
    let surface = accel.surface(&hit, Vec3::NEG_Z);
    // u grows with x, v grows with −y.
    assert!(
        (surface.uv - Vec2::new(0.75, 0.75)).length() < 1e-6,
        "{:?}",
        surface.uv
    );
    // Tangent = dp/du = +x; bitangent = cross(n, t)·w must point to −v = +y, so w = +1.
    assert!(
        (surface.tangent - Vec4::new(1.0, 0.0, 0.0, 1.0)).length() < 1e-6,
        "{:?}",
        surface.tangent
    );
    // Seen from behind the whole frame is mirrored.
    let hit = accel
        .intersect(Vec3::new(0.5, -0.5, -1.0), Vec3::Z, f32::INFINITY)
        .expect("hit");
    let surface = accel.surface(&hit, Vec3::Z);
    assert!(surface.back_face);
    assert!((surface.tangent - Vec4::new(-1.0, 0.0, 0.0, -1.0)).length() < 1e-6);
}

#[test]
fn degenerate_and_non_finite_triangles_are_dropped() {
    let bad = mesh(
        vec![
            Vec3::ZERO,
            Vec3::X,
            Vec3::X * 2.0,
            Vec3::new(f32::NAN, 0.0, 0.0),
            Vec3::Y,
        ],
        vec![[0, 1, 2], [0, 3, 4], [0, 1, 9], [0, 1, 4]],
        None,
    );
    let accel = build(&[instance(bad, Mat4::IDENTITY)]);
    assert_eq!(accel.triangle_count(), 1);
    assert_eq!(accel.dropped_triangle_count(), 3);

    let empty = build(&[]);
    assert_eq!(empty.triangle_count(), 0);
    assert_eq!(empty.node_count(), 0);
    assert!(
        empty
            .intersect(Vec3::ZERO, Vec3::X, f32::INFINITY)
            .is_none()
    );
    assert!(!empty.occluded(Vec3::ZERO, Vec3::X, f32::INFINITY));
}

/// A random triangle soup of `count` triangles in the unit cube, split over a few instances.
fn random_soup(count: usize, rng: &mut Rng) -> Vec<MeshInstance> {
    let point = |rng: &mut Rng| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    (0..4)
        .map(|k| {
            let mut positions = Vec::new();
            let mut triangles = Vec::new();
            for i in 0..count / 4 {
                let centre = point(rng) * 4.0 - 2.0;
                for _ in 0..3 {
                    positions.push(centre + (point(rng) - 0.5) * 0.3);
                }
                let base = 3 * i as u32;
                triangles.push([base, base + 1, base + 2]);
            }
            let transform = Mat4::from_rotation_translation(
                Quat::from_rotation_y(k as f32),
                Vec3::new(0.0, k as f32 * 0.1, 0.0),
            );
            instance(mesh(positions, triangles, Some(k)), transform)
        })
        .collect()
}

/// The closest hit by testing every triangle: the reference the BVH must reproduce.
fn brute_force(accel: &SceneAccel, origin: Vec3, direction: Vec3) -> Option<(f32, u32)> {
    let scale = accel.bvh_scale;
    let mut best: Option<(f32, u32)> = None;
    for (i, primitive) in accel.primitives.iter().enumerate() {
        let hit = primitive.intersect(
            (origin * scale).into(),
            direction.into(),
            0.0,
            f32::INFINITY,
        );
        if let Some(hit) = hit
            && best.is_none_or(|(t, _)| hit.t / scale < t)
        {
            best = Some((hit.t / scale, i as u32));
        }
    }
    best
}

#[test]
fn bvh_matches_brute_force_on_random_rays() {
    let mut rng = Rng::new(11, 5);
    let accel = build(&random_soup(4000, &mut rng));
    assert_eq!(accel.triangle_count(), 4000);
    let mut hits = 0;
    for _ in 0..2000 {
        let origin = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 6.0 - 3.0;
        let direction =
            (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5).normalize_or(Vec3::X);
        let expected = brute_force(&accel, origin, direction);
        let found = accel.intersect(origin, direction, f32::INFINITY);
        match (expected, found) {
            (None, None) => {}
            (Some((t, triangle)), Some(hit)) => {
                hits += 1;
                // Same distance; the same triangle unless two share it to within rounding.
                assert!((hit.t - t).abs() <= 1e-5 * t.max(1.0), "t {} vs {t}", hit.t);
                assert!(hit.triangle == triangle || (hit.t - t).abs() < 1e-6);
                assert!(accel.occluded(origin, direction, t * 1.001));
                assert!(!accel.occluded(origin, direction, t * 0.999));
            }
            other => panic!("BVH and brute force disagree: {other:?}"),
        }
    }
    assert!(hits > 500, "the test should exercise hits, got {hits}");
}

#[test]
fn batch_equals_scalar() {
    let mut rng = Rng::new(3, 9);
    let accel = build(&random_soup(1000, &mut rng));
    let mut rays = RayBatch::with_capacity(500);
    for i in 0..500u32 {
        let origin = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 6.0 - 3.0;
        let direction =
            (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5).normalize_or(Vec3::X);
        rays.push(origin.into(), direction.into(), i, 0);
    }
    for i in (0..500).step_by(7) {
        rays.alive[i] = false;
    }
    let mut hits = HitBatch::default();
    accel.intersect_batch(&rays, &mut hits);
    assert_eq!(hits.len(), 500);
    for i in 0..500 {
        let scalar = rays.alive[i]
            .then(|| {
                accel.intersect(
                    Vec3::from(rays.origin(i)),
                    Vec3::from(rays.direction(i)),
                    f32::INFINITY,
                )
            })
            .flatten();
        match scalar {
            Some(hit) => {
                assert_eq!(
                    (hits.t[i], hits.triangle[i], hits.u[i], hits.v[i]),
                    (hit.t, hit.triangle, hit.u, hit.v)
                );
            }
            None => {
                assert_eq!(hits.triangle[i], HitBatch::MISS);
                assert_eq!(hits.t[i], f32::INFINITY);
            }
        }
    }
}

#[test]
fn millimetre_scene_sees_geometry_a_few_microns_away() {
    // A 7 mm scene: a floor and a chip 20 µm above it. A ray leaving the floor upwards must
    // hit the chip's underside at t = 20 µm (obvhs alone would skip boxes within 0.1 mm).
    let floor = mesh(
        vec![
            Vec3::new(-0.0035, 0.0, -0.0035),
            Vec3::new(0.0035, 0.0, -0.0035),
            Vec3::new(0.0, 0.0, 0.0035),
        ],
        vec![[0, 2, 1]],
        None,
    );
    let chip = mesh(
        vec![
            Vec3::new(0.0, 2e-5, 0.0),
            Vec3::new(1e-5, 2e-5, 0.0),
            Vec3::new(0.0, 2e-5, 1e-5),
        ],
        vec![[0, 1, 2]],
        Some(1),
    );
    let accel = build(&[
        instance(floor, Mat4::IDENTITY),
        instance(chip, Mat4::IDENTITY),
    ]);
    // Reach the floor point under the chip obliquely, passing beside the chip.
    let floor_point = Vec3::new(2e-6, 0.0, 2e-6);
    let from = Vec3::new(2e-6, 0.001, 0.003);
    let incoming = (floor_point - from).normalize();
    let floor_hit = accel
        .intersect(from, incoming, f32::INFINITY)
        .expect("floor");
    assert_eq!(accel.triangle_material(floor_hit.triangle), None);
    let surface = accel.surface(&floor_hit, incoming);
    let origin = surface.spawn_origin(Vec3::Y);
    let hit = accel
        .intersect(origin, Vec3::Y, f32::INFINITY)
        .expect("chip");
    assert_eq!(accel.triangle_material(hit.triangle), Some(1));
    assert!((hit.t - 2e-5).abs() < 1e-7, "t = {}", hit.t);
}

#[test]
fn offset_origins_avoid_self_intersection_at_all_scales() {
    for (scale, offset) in [
        (0.007f32, Vec3::ZERO),
        (1.0, Vec3::new(3.0, -2.0, 1.0)),
        (100.0, Vec3::new(90.0, 40.0, -70.0)),
        (20_000.0, Vec3::new(0.0, 1.0, 0.0)),
    ] {
        // A tilted, finely tessellated fan so that hits land near shared edges too.
        let mut positions = vec![Vec3::ZERO];
        let mut triangles = Vec::new();
        for i in 0..64u32 {
            let angle = i as f32 / 64.0 * std::f32::consts::TAU;
            positions.push(Vec3::new(angle.cos(), 0.0, -angle.sin()));
            triangles.push([0, i + 1, (i + 1) % 64 + 1]);
        }
        let transform = Mat4::from_scale_rotation_translation(
            Vec3::splat(scale),
            Quat::from_euler(glam::EulerRot::XYZ, 0.3, 0.2, 0.1),
            offset,
        );
        let accel = build(&[instance(mesh(positions, triangles, None), transform)]);
        let mut rng = Rng::new(scale.to_bits() as u64, 1);
        let normal = (transform.transform_vector3(Vec3::Y)).normalize();
        for _ in 0..2000 {
            let target = transform
                .transform_point3(Vec3::new(rng.next_f32() - 0.5, 0.0, rng.next_f32() - 0.5) * 1.2);
            let from = target
                + normal * scale
                + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * scale;
            let incoming = (target - from).normalize();
            let Some(hit) = accel.intersect(from, incoming, f32::INFINITY) else {
                continue;
            };
            let surface = accel.surface(&hit, incoming);
            // Leave at a grazing or steep angle on the viewer's side.
            let u = rng.next_f32();
            let tangent = normal.any_orthonormal_vector();
            let outgoing =
                (surface.geometric_normal * (0.002 + u) + tangent * (1.0 - u)).normalize();
            let origin = surface.spawn_origin(outgoing);
            assert!(
                accel.intersect(origin, outgoing, f32::INFINITY).is_none(),
                "self-hit at scale {scale}"
            );
        }
    }
}

#[test]
fn rays_leaving_a_wall_next_to_a_corner_hit_the_adjacent_wall() {
    // Floor y = 0 and wall x = 0 meeting in a corner. A ray leaving the floor 20 µm from the
    // wall, towards it, must hit it after ~28 µm (obvhs's 1e-4 box epsilon would skip the
    // wall's flat leaf box without the BVH-space scaling).
    let floor = mesh(
        vec![
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(2.0, 0.0, 0.0),
        ],
        vec![[0, 1, 2]],
        None,
    );
    let wall = mesh(
        vec![
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
        ],
        vec![[0, 1, 2]],
        Some(1),
    );
    let accel = build(&[
        instance(floor, Mat4::IDENTITY),
        instance(wall, Mat4::IDENTITY),
    ]);
    let direction = Vec3::new(-1.0, 1.0, 0.0).normalize();
    let hit = accel
        .intersect(Vec3::new(2e-5, 1e-9, 0.0), direction, f32::INFINITY)
        .expect("wall");
    assert_eq!(accel.triangle_material(hit.triangle), Some(1));
    assert!((hit.t - 2e-5 * 2f32.sqrt()).abs() < 1e-7, "t = {}", hit.t);
}

/// A sample scene of `tests/data` (or `$REALCAM_SAMPLE_SCENES`), loaded.
fn sample_scene(relative: &str) -> crate::scene::LoadedScene {
    let root = std::env::var_os("REALCAM_SAMPLE_SCENES")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data"));
    let path = root.join(relative);
    crate::scene::load_gltf(&path).unwrap_or_else(|e| panic!("{}: {e:#}", path.display()))
}

/// `materials` with every material (and the default) alpha-masked by a 16×16 checkerboard of
/// opaque and transparent texels, so that real meshes get holes wherever they have UVs (UV
/// (0, 0), which meshes without UVs read, is opaque).
fn checker_masked(materials: &MaterialLibrary) -> MaterialLibrary {
    let texels = (0..256)
        .map(|i| [1.0, 1.0, 1.0, ((i / 16 + i % 16 + 1) % 2) as f32])
        .collect();
    let checker = Texture {
        width: 16,
        height: 16,
        texels,
        wrap_s: WrapMode::Repeat,
        wrap_t: WrapMode::Repeat,
        nearest: true,
    };
    let mut masked = materials.clone();
    masked.textures.push(Arc::new(checker));
    let texture = masked.textures.len() - 1;
    for material in masked
        .materials
        .iter_mut()
        .chain(std::iter::once(&mut masked.default_material))
    {
        material.alpha_mode = AlphaMode::Mask(0.5);
        material.base_color.w = 1.0;
        material.base_color_texture = Some(TextureRef {
            texture,
            tex_coord: 0,
        });
    }
    masked
}

/// Hits closer than this (BVH space) may or may not be found: traversal skips child boxes the
/// ray leaves within obvhs's 1e-4 of its origin (see `triangles::bvh_space_scale`).
const BLIND_ZONE: f32 = 1e-3;

/// The closest hit in [BLIND_ZONE, t_max) over every triangle, alpha holes skipped: what every
/// traversal must reproduce (or find a hit inside the blind zone).
fn brute_force_closest(
    accel: &SceneAccel,
    origin: Vec3,
    direction: Vec3,
    t_max: f32,
) -> Option<(f32, u32)> {
    let scale = accel.bvh_scale;
    let mut best: Option<(f32, u32)> = None;
    for (i, primitive) in accel.primitives.iter().enumerate() {
        let Some(hit) = primitive.intersect(
            (origin * scale).into(),
            direction.into(),
            BLIND_ZONE,
            t_max * scale,
        ) else {
            continue;
        };
        if hit.t < t_max * scale
            && !accel.is_alpha_hole(i as u32, hit.u, hit.v)
            && best.is_none_or(|(t, _)| hit.t / scale < t)
        {
            best = Some((hit.t / scale, i as u32));
        }
    }
    best
}

/// True when the ray runs inside a plane that bounds `triangle` on one axis (a zero direction
/// component, the origin's coordinate at the triangle's extreme). The slab test puts the exit
/// from a leaf box bounded by that plane at t = 0, so the BVH may not see what brute force
/// counts as a hit on the triangle's edge. obvhs behaves so; the fast traversal reproduces it.
fn grazes(accel: &SceneAccel, triangle: u32, origin: Vec3, direction: Vec3) -> bool {
    let [a, b, c] = accel.triangle_vertices(triangle);
    (0..3).any(|k| {
        let extremes = [a[k].min(b[k]).min(c[k]), a[k].max(b[k]).max(c[k])];
        direction[k] == 0.0 && extremes.contains(&origin[k])
    })
}

/// Rays that probe the cases traversal gets wrong most easily, around a scene's bounds: from
/// inside and from outside, along the axes and in coordinate planes (zero direction
/// components, infinite reciprocals), and leaving triangles from points on them.
fn probe_rays(accel: &SceneAccel, count: usize, rng: &mut Rng) -> Vec<(Vec3, Vec3)> {
    let bounds = accel.bounds();
    let (centre, size) = (bounds.center(), bounds.max - bounds.min);
    let unit = |rng: &mut Rng| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    let axes = [
        Vec3::X,
        Vec3::Y,
        Vec3::Z,
        Vec3::NEG_X,
        Vec3::NEG_Y,
        Vec3::NEG_Z,
    ];
    (0..count)
        .map(|i| {
            let mut direction = (unit(rng) - 0.5).normalize_or(Vec3::X);
            match i % 4 {
                // Along an axis, or with one component zeroed.
                0 => direction = axes[rng.next_u32() as usize % 6],
                1 => {
                    direction[rng.next_u32() as usize % 3] = 0.0;
                    direction = direction.normalize_or(Vec3::Z);
                }
                _ => {}
            }
            let origin = match (i / 4) % 3 {
                // Anywhere in (a margin around) the bounds.
                0 => bounds.min + (unit(rng) * 1.2 - 0.1) * size,
                // Outside, aimed at the scene with some spread.
                1 => {
                    let from = centre - direction * bounds.diagonal();
                    return (from, (centre + (unit(rng) - 0.5) * size - from).normalize());
                }
                // On a triangle.
                _ => {
                    let triangle = rng.next_u32() % accel.triangle_count() as u32;
                    let [a, b, c] = accel.triangle_vertices(triangle);
                    let (u, v) = (rng.next_f32(), rng.next_f32());
                    let (u, v) = if u + v > 1.0 {
                        (1.0 - u, 1.0 - v)
                    } else {
                        (u, v)
                    };
                    a + (b - a) * u + (c - a) * v
                }
            };
            (origin, direction)
        })
        .collect()
}

/// `found` is the closest hit brute force finds, to rounding (or one in the blind zone, or
/// none for a grazing ray, see [`grazes`]). True when `found` is a hit.
fn assert_matches_brute_force(
    accel: &SceneAccel,
    origin: Vec3,
    direction: Vec3,
    found: Option<Hit>,
) -> bool {
    let expected = brute_force_closest(accel, origin, direction, f32::INFINITY);
    match (expected, found) {
        (None, None) => false,
        (_, Some(hit)) if hit.t * accel.bvh_scale < BLIND_ZONE => true,
        (Some((_, triangle)), found) if grazes(accel, triangle, origin, direction) => {
            found.is_some()
        }
        (Some((t, triangle)), Some(hit)) => {
            assert!((hit.t - t).abs() <= 1e-5 * t.max(1.0), "t {} vs {t}", hit.t);
            assert!(hit.triangle == triangle || (hit.t - t).abs() < 1e-6);
            true
        }
        other => {
            panic!("BVH and brute force disagree from {origin:?} along {direction:?}: {other:?}")
        }
    }
}

/// The tolerance every traversal is held to against obvhs's: the identical hit (triangle, t,
/// u, v), or, where two triangles are hit at exactly the same distance (a ray through their
/// shared edge or vertex), either of them. Traversals that visit leaves in another order
/// (the wide tree's nearest first, the packets' nearest of eight) may report the other one.
fn assert_same_hit(found: Option<Hit>, reference: Option<Hit>, what: impl Fn() -> String) {
    let tie = matches!((found, reference), (Some(a), Some(b)) if a.t == b.t);
    assert!(
        found == reference || tie,
        "{}: {found:?} vs {reference:?}",
        what()
    );
}

/// Every traversal agrees with obvhs's (closest triangle, t, u, v, to exact ties; occlusion
/// at several distances exactly) and, to rounding, with brute force.
fn assert_traversals_agree(accel: &SceneAccel, rays: &[(Vec3, Vec3)]) -> usize {
    let mut hits = 0;
    for &(origin, direction) in rays {
        let reference = accel.intersect_with(Traversal::Obvhs, origin, direction, f32::INFINITY);
        for traversal in Traversal::available() {
            let found = accel.intersect_with(traversal, origin, direction, f32::INFINITY);
            assert_same_hit(found, reference, || {
                format!("{traversal:?} vs obvhs from {origin:?} along {direction:?}")
            });
        }
        hits += usize::from(assert_matches_brute_force(
            accel, origin, direction, reference,
        ));
        let diagonal = accel.bounds().diagonal();
        let distances = match reference {
            Some(hit) => vec![hit.t, hit.t * 0.999, hit.t * 1.001, hit.t * 0.5],
            None => vec![diagonal * 3.0],
        };
        for t_max in distances.into_iter().chain([f32::INFINITY, diagonal * 0.1]) {
            let occluded = accel.occluded_with(Traversal::Obvhs, origin, direction, t_max);
            for traversal in Traversal::available() {
                assert_eq!(
                    accel.occluded_with(traversal, origin, direction, t_max),
                    occluded,
                    "{traversal:?} vs obvhs from {origin:?} along {direction:?} to {t_max}"
                );
            }
            // Occlusion is exactly "the closest hit is nearer than t_max".
            let closest = accel.intersect_with(Traversal::Obvhs, origin, direction, t_max);
            assert_eq!(occluded, closest.is_some(), "to {t_max}");
        }
    }
    hits
}

#[test]
fn traversals_agree_on_sample_meshes() {
    for (relative, rays) in [
        ("Box/Box.gltf", 3000),
        ("Duck/Duck.gltf", 1500),
        ("CornellBox/cornellBox-2.80-Eevee-gltf.gltf", 1500),
    ] {
        let scene = sample_scene(relative);
        let mut rng = Rng::new(relative.len() as u64, 7);
        for materials in [scene.materials.clone(), checker_masked(&scene.materials)] {
            let accel = SceneAccel::build(&scene.instances, &materials).expect("build");
            let hits = assert_traversals_agree(&accel, &probe_rays(&accel, rays, &mut rng));
            assert!(
                hits > rays / 5,
                "{relative}: only {hits} hits of {rays} rays"
            );
        }
    }
}

#[test]
fn traversals_agree_on_random_soup() {
    let mut rng = Rng::new(5, 3);
    let accel = build(&random_soup(4000, &mut rng));
    let hits = assert_traversals_agree(&accel, &probe_rays(&accel, 2000, &mut rng));
    assert!(hits > 400, "only {hits} hits");
}

/// The batch call gives every ray exactly the renderer's single-ray hit (ties too: both break
/// them by triangle index), obvhs's to exact ties, and brute force's to rounding, whether its
/// packets all walk as packets, none do, or the renderer's measure picks; the same hits all
/// three ways. Returns the number of hits.
fn assert_batch_agrees(accel: &SceneAccel, rays: &RayBatch) -> usize {
    let trace = |parallelism, packets| {
        let mut hits = HitBatch::default();
        accel.intersect_batch_using(rays, &mut hits, parallelism, packets);
        hits
    };
    let hits = trace(BatchParallelism::Spread, PacketUse::Always);
    for packets in [PacketUse::Always, PacketUse::Never, PacketUse::WherePaying] {
        // On one thread: the whole batch one task, the way the renderer's measure runs.
        let other = trace(BatchParallelism::OneThread, packets);
        assert_eq!(
            (&other.t, &other.triangle, &other.u, &other.v),
            (&hits.t, &hits.triangle, &hits.u, &hits.v),
            "{packets:?} against every packet walking"
        );
    }
    // A gauge carried from batch to batch, as the renderer's bounce rays keep one: the second
    // batch walks by the first's measure.
    let mut gauge = PacketGauge::default();
    for round in 0..2 {
        let mut other = HitBatch::default();
        accel.intersect_batch_gauged(rays, &mut other, &mut gauge);
        assert_eq!(
            (&other.t, &other.triangle, &other.u, &other.v),
            (&hits.t, &hits.triangle, &hits.u, &hits.v),
            "a gauged batch, round {round}"
        );
    }
    assert_eq!(hits.len(), rays.len());
    let mut found = 0;
    for i in 0..rays.len() {
        let (origin, direction) = (Vec3::from(rays.origin(i)), Vec3::from(rays.direction(i)));
        let batch = hits.hit(i);
        if !rays.alive[i] {
            assert_eq!(batch, None, "dead ray {i}");
            assert_eq!(hits.t[i], f32::INFINITY);
            continue;
        }
        let reference = accel.intersect_with(Traversal::Obvhs, origin, direction, f32::INFINITY);
        assert_same_hit(batch, reference, || {
            format!("ray {i} from {origin:?} along {direction:?}")
        });
        assert_eq!(
            batch,
            accel.intersect(origin, direction, f32::INFINITY),
            "ray {i}: packet and single ray"
        );
        if batch.is_none() {
            assert_eq!(hits.t[i], f32::INFINITY);
        }
        found += usize::from(assert_matches_brute_force(accel, origin, direction, batch));
    }
    found
}

/// Camera rays as the renderer batches them: a `side`² grid of pixels row-major, each ray
/// from a point of a lens aperture `aperture` wide (0: a pinhole) through its pixel's point on
/// a focus plane at the scene's centre. Looking from `from` (a direction from the centre).
fn camera_rays(
    accel: &SceneAccel,
    from: Vec3,
    side: u32,
    aperture: f32,
    rng: &mut Rng,
) -> RayBatch {
    let bounds = accel.bounds();
    let centre = bounds.center();
    let eye = centre + from.normalize() * bounds.diagonal();
    let forward = (centre - eye).normalize();
    let right = forward.any_orthonormal_vector();
    let up = right.cross(forward);
    let half = bounds.diagonal() * 0.4;
    let mut rays = RayBatch::with_capacity((side * side) as usize);
    for y in 0..side {
        for x in 0..side {
            let (jx, jy) = (rng.next_f32(), rng.next_f32());
            let sx = ((x as f32 + jx) / side as f32 * 2.0 - 1.0) * half;
            let sy = (1.0 - (y as f32 + jy) / side as f32 * 2.0) * half;
            let focus = centre + right * sx + up * sy;
            let lens = (Vec2::new(rng.next_f32(), rng.next_f32()) - 0.5) * aperture;
            let origin = eye + right * lens.x + up * lens.y;
            let direction = (focus - origin).normalize();
            rays.push(origin.into(), direction.into(), y * side + x, 0);
        }
    }
    rays
}

#[test]
fn packets_agree_on_sample_meshes() {
    for relative in [
        "Box/Box.gltf",
        "Duck/Duck.gltf",
        "CornellBox/cornellBox-2.80-Eevee-gltf.gltf",
    ] {
        let scene = sample_scene(relative);
        let mut rng = Rng::new(relative.len() as u64, 11);
        for materials in [scene.materials.clone(), checker_masked(&scene.materials)] {
            let accel = SceneAccel::build(&scene.instances, &materials).expect("build");
            let diagonal = accel.bounds().diagonal();
            // Coherent packets from pinholes and lenses, one view along an axis so that the
            // middle packets mix direction octants (and some components are exactly zero).
            let mut hits = 0;
            for (from, aperture) in [
                (Vec3::new(0.3, 0.5, 1.0), 0.0),
                (Vec3::new(-1.0, 0.2, -0.4), 0.02 * diagonal),
                (Vec3::Z, 0.0),
            ] {
                hits +=
                    assert_batch_agrees(&accel, &camera_rays(&accel, from, 40, aperture, &mut rng));
            }
            assert!(hits > 1000, "{relative}: only {hits} camera-ray hits");
            // Incoherent packets: the probe rays, mixed octants, from inside and outside.
            let mut probes = RayBatch::default();
            for (i, (origin, direction)) in
                probe_rays(&accel, 803, &mut rng).into_iter().enumerate()
            {
                probes.push(origin.into(), direction.into(), i as u32, 0);
            }
            assert!(assert_batch_agrees(&accel, &probes) > 100, "{relative}");
        }
    }
}

#[test]
fn packets_with_dead_rays_and_partial_packets() {
    let mut rng = Rng::new(8, 2);
    let accel = build(&random_soup(3000, &mut rng));
    // 37² is not a multiple of 8, so the batch ends in a partial packet.
    let mut rays = camera_rays(&accel, Vec3::new(0.2, -0.3, 1.0), 37, 0.05, &mut rng);
    for i in 0..rays.len() {
        // Scattered dead rays, a whole dead packet, and packets left with one alive ray.
        if i % 5 == 0 || (64..72).contains(&i) || ((128..136).contains(&i) && i != 131) {
            rays.alive[i] = false;
        }
    }
    let hits = assert_batch_agrees(&accel, &rays);
    assert!(hits > 200, "only {hits} hits");
    // A batch shorter than one packet.
    rays.ox.truncate(5);
    for v in [
        &mut rays.oy,
        &mut rays.oz,
        &mut rays.dx,
        &mut rays.dy,
        &mut rays.dz,
    ] {
        v.truncate(5);
    }
    rays.alive.truncate(5);
    assert_batch_agrees(&accel, &rays);
}

#[test]
fn packets_agree_on_random_soup_with_random_rays() {
    let mut rng = Rng::new(6, 4);
    let accel = build(&random_soup(4000, &mut rng));
    let mut rays = RayBatch::default();
    for (i, (origin, direction)) in probe_rays(&accel, 2000, &mut rng).into_iter().enumerate() {
        rays.push(origin.into(), direction.into(), i as u32, 0);
    }
    assert!(assert_batch_agrees(&accel, &rays) > 400);
    let rays = camera_rays(&accel, Vec3::new(1.0, 1.0, 0.5), 48, 0.1, &mut rng);
    assert!(assert_batch_agrees(&accel, &rays) > 500);
}

/// How full a packet ran, as the packet traversal counts it for [`PacketUse::WherePaying`]:
/// eight copies of one ray hold all eight at every node they visit, a lone ray one, and both
/// visit the nodes that ray visits.
#[cfg(target_arch = "x86_64")]
#[test]
fn packets_count_the_rays_at_each_visit() {
    if !std::arch::is_x86_feature_detected!("avx2") {
        return;
    }
    let mut rng = Rng::new(5, 9);
    let accel = build(&random_soup(3000, &mut rng));
    let wide = accel.wide.as_ref().expect("wide tree");
    let mut stack = Vec::new();
    let mut visited = 0;
    for (origin, direction) in probe_rays(&accel, 200, &mut rng) {
        let Some(ray) = accel.bvh_ray(origin, direction, f32::INFINITY) else {
            continue;
        };
        let mut packet = super::packet::PacketRays::default();
        for lane in 0..super::packet::LANES {
            packet.set(lane, &ray);
        }
        // SAFETY: AVX2 was detected above.
        let mut walk = |active| unsafe {
            super::packet::intersect_packet_avx2(
                wide,
                &accel.primitives,
                &packet,
                active,
                None::<fn(usize, f32, f32) -> bool>,
                &mut stack,
                true,
            )
        };
        let (full, alone) = (walk(0xff), walk(0b100));
        assert_eq!(full.visits, alone.visits);
        assert_eq!(full.rays_at_visits, 8 * full.visits);
        assert_eq!(alone.rays_at_visits, alone.visits);
        assert_eq!(full.triangle, [alone.triangle[2]; 8]);
        visited += full.visits;
    }
    assert!(visited > 200, "only {visited} node visits");
}

#[test]
fn batch_hits_do_not_depend_on_thread_count() {
    let mut rng = Rng::new(2, 2);
    let accel = build(&random_soup(2000, &mut rng));
    let rays = camera_rays(&accel, Vec3::new(0.4, 0.1, 1.0), 50, 0.05, &mut rng);
    let trace = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        let mut hits = HitBatch::default();
        pool.install(|| accel.intersect_batch(&rays, &mut hits));
        (hits.t, hits.triangle, hits.u, hits.v)
    };
    assert_eq!(trace(1), trace(3));
}

/// The wide tree is obvhs's, decoded: as many nodes, every triangle in exactly one leaf, and
/// every triangle's vertices inside the (float) box of the leaf that holds it.
fn assert_wide_tree_holds_every_triangle(accel: &SceneAccel) {
    let cwbvh = accel.bvh.as_ref().expect("a tree");
    let wide = accel.wide.as_ref().expect("a wide tree");
    assert_eq!(wide.nodes.len(), cwbvh.nodes.len());
    let mut seen = vec![0u32; accel.triangle_count()];
    let mut pending = vec![wide::ChildRef::ROOT];
    while let Some(child) = pending.pop() {
        let node = &wide.nodes[child.node_index()];
        for (slot, &child) in node.children.iter().enumerate() {
            if child == wide::ChildRef::EMPTY {
                assert!(
                    node.planes[0][slot] > node.planes[1][slot],
                    "an empty slot's box"
                );
                continue;
            }
            if !child.is_leaf() {
                pending.push(child);
                continue;
            }
            for triangle in child.triangles() {
                seen[triangle] += 1;
                // `vertices()` adds the stored edges back to v0, which may round by an ulp.
                for vertex in accel.primitives[triangle].vertices() {
                    for axis in 0..3 {
                        let slack = 1e-6 * vertex[axis].abs().max(1.0);
                        let (min, max) =
                            (node.planes[2 * axis][slot], node.planes[2 * axis + 1][slot]);
                        assert!(
                            min - slack <= vertex[axis] && vertex[axis] <= max + slack,
                            "triangle {triangle} outside its leaf box on axis {axis}"
                        );
                    }
                }
            }
        }
    }
    assert!(
        seen.iter().all(|&n| n == 1),
        "a triangle in no leaf or several"
    );
}

#[test]
fn wide_tree_holds_every_triangle_once_inside_its_box() {
    let mut rng = Rng::new(3, 9);
    assert_wide_tree_holds_every_triangle(&build(&random_soup(5000, &mut rng)));
    for relative in [
        "Duck/Duck.gltf",
        "CornellBox/cornellBox-2.80-Eevee-gltf.gltf",
    ] {
        let scene = sample_scene(relative);
        let accel = SceneAccel::build(&scene.instances, &scene.materials).expect("build");
        assert_wide_tree_holds_every_triangle(&accel);
    }
}

/// The portable wide traversal (what a CPU without AVX2 runs) and the AVX2 one give the same
/// hits and the same occlusion on every ray: the same arithmetic, lane for lane.
#[cfg(target_arch = "x86_64")]
#[test]
fn wide_traversal_portable_equals_avx2() {
    if !traversal::has_avx2() {
        return;
    }
    let mut rng = Rng::new(4, 4);
    let accel = build(&random_soup(4000, &mut rng));
    let wide = accel.wide.as_ref().expect("a wide tree");
    let is_hole = |_: usize, _: f32, _: f32| false;
    let mut hits = 0;
    for (origin, direction) in probe_rays(&accel, 3000, &mut rng) {
        let ray = accel
            .bvh_ray(origin, direction, f32::INFINITY)
            .expect("a ray");
        let portable = wide_traversal::first_hit::<false>(wide, &accel.primitives, ray, is_hole);
        // SAFETY: checked above that the CPU has AVX2.
        let avx2 = unsafe {
            wide_traversal::first_hit_avx2::<false>(wide, &accel.primitives, ray, is_hole)
        };
        assert_eq!(
            portable.map(|(i, h)| (i, h.t, h.u, h.v)),
            avx2.map(|(i, h)| (i, h.t, h.u, h.v)),
            "from {origin:?} along {direction:?}"
        );
        hits += usize::from(portable.is_some());
        for t_max in [0.5, 2.0, f32::INFINITY] {
            let ray = accel.bvh_ray(origin, direction, t_max).expect("a ray");
            // SAFETY: as above.
            let avx2 = unsafe {
                wide_traversal::first_hit_avx2::<true>(wide, &accel.primitives, ray, is_hole)
            };
            assert_eq!(
                wide_traversal::first_hit::<true>(wide, &accel.primitives, ray, is_hole).is_some(),
                avx2.is_some()
            );
        }
    }
    assert!(hits > 600, "only {hits} hits");
}

/// A floor tiled with axis-aligned triangles: its leaf boxes are flat (zero height), the case
/// where a slab test without a rounding margin can cull a box the ray crosses. Rays aimed at
/// the tiles' shared edges and corners, from steep to grazing, must find the floor wherever
/// brute force does: through the wide tree, single rays and packets. (obvhs's own node test has
/// no margin and misses some of them: counted, not asserted.)
#[test]
fn flat_floor_is_hit_at_every_tile_edge_and_corner() {
    let tiles = 40;
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for i in 0..=tiles {
        for j in 0..=tiles {
            positions.push(Vec3::new(i as f32 * 0.25 - 5.0, 0.0, j as f32 * 0.25 - 5.0));
        }
    }
    let at = |i: u32, j: u32| i * (tiles + 1) + j;
    for i in 0..tiles {
        for j in 0..tiles {
            triangles.push([at(i, j), at(i, j + 1), at(i + 1, j)]);
            triangles.push([at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)]);
        }
    }
    let accel = build(&[instance(mesh(positions, triangles, None), Mat4::IDENTITY)]);
    let mut rng = Rng::new(11, 1);
    let mut rays = RayBatch::default();
    let (mut checked, mut obvhs_misses) = (0, 0);
    for k in 0..4000 {
        // A grid point, or the midpoint of a grid edge.
        let (i, j) = (rng.next_u32() % tiles, rng.next_u32() % tiles);
        let half = if k % 2 == 0 { 0.0 } else { 0.125 };
        let target = Vec3::new(i as f32 * 0.25 - 5.0 + half, 0.0, j as f32 * 0.25 - 5.0);
        let elevation = [1.2f32, 0.5, 0.1, 0.01][k % 4];
        let azimuth = rng.next_f32() * std::f32::consts::TAU;
        let towards = Vec3::new(
            elevation.cos() * azimuth.cos(),
            -elevation.sin(),
            elevation.cos() * azimuth.sin(),
        );
        let origin = target - towards * 3.0;
        if brute_force_closest(&accel, origin, towards, f32::INFINITY).is_some() {
            checked += 1;
            assert!(
                accel
                    .intersect_with(Traversal::Wide, origin, towards, f32::INFINITY)
                    .is_some(),
                "the wide traversal misses the floor from {origin:?} along {towards:?}"
            );
            assert!(accel.occluded_with(Traversal::Wide, origin, towards, 10.0));
            obvhs_misses += usize::from(
                accel
                    .intersect_with(Traversal::Obvhs, origin, towards, f32::INFINITY)
                    .is_none(),
            );
            rays.push(origin.into(), towards.into(), k as u32, 0);
        }
    }
    assert!(checked > 3500, "only {checked} rays reach the floor");
    eprintln!("obvhs's traversal missed the floor on {obvhs_misses} of {checked} rays");
    let mut hits = HitBatch::default();
    accel.intersect_batch(&rays, &mut hits);
    assert!(
        (0..rays.len()).all(|i| hits.hit(i).is_some()),
        "a packet missed the floor"
    );
}
