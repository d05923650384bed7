//! Which traversal answers ray queries ([`Traversal`]), and obvhs's CWBVH traversal with an
//! 8-wide node test compiled for AVX2 beside obvhs's own (the reference). The renderer's
//! traversal is the wide one (`wide_traversal`); these two stay for comparison and as the
//! fallback for a tree the wide layout cannot hold.
//!
//! obvhs's node test (`CwBvhNode::intersect_ray_simd`) is compiled for the build's baseline
//! (SSE2): it converts the 48 quantised plane bytes of a node to floats one `_mm_set_ps` lane at
//! a time, tests the children four at a time, and assembles the hit mask child by child: about
//! half of a ray's instructions on the helmet (callgrind). Here one AVX2 instruction widens and
//! converts each plane of all eight children, and the hit mask is built with vector shifts.
//!
//! The traversal loop itself is obvhs's (`obvhs::traverse!`), and the slab arithmetic repeats
//! obvhs's operation for operation (separate multiply and add, no FMA, same min/max order, same
//! 1e-4 entry clamp): every node test gives bit-identical masks, so both traversals visit the
//! same triangles in the same order and report identical hits, ties included. That is what
//! lets the tests demand exact agreement.

use glam::{UVec2, Vec3A};
use obvhs::cwbvh::CwBvh;
use obvhs::ray::Ray;

/// Which traversal code answers ray queries.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Traversal {
    /// obvhs's own traversal of its CWBVH, at the build's baseline instruction set: portable,
    /// and the reference the others must reproduce.
    Obvhs,
    /// obvhs's traversal loop with an 8-wide node test for x86-64 AVX2, plus BMI1/2, LZCNT and
    /// POPCNT (CPUs with AVX2 have them in practice; checked anyway): without POPCNT the child
    /// indexing of the traversal loop counts bits in software.
    Avx2,
    /// Our own traversal of the same tree decoded to float boxes, nearest child first
    /// (`wide_traversal`): portable, compiled for AVX2 where the CPU has it. The renderer's.
    Wide,
}

impl Traversal {
    /// The traversal the renderer uses: [`Traversal::Wide`] (where a scene's tree cannot be
    /// decoded for it, `SceneAccel` falls back on [`Traversal::fastest_obvhs`]).
    pub fn detect() -> Traversal {
        Traversal::Wide
    }

    /// The faster of the two traversals of obvhs's own nodes on this CPU.
    pub fn fastest_obvhs() -> Traversal {
        if has_avx2() {
            Traversal::Avx2
        } else {
            Traversal::Obvhs
        }
    }

    /// Every traversal this CPU runs, reference first.
    pub fn available() -> Vec<Traversal> {
        [Traversal::Obvhs, Traversal::Avx2, Traversal::Wide]
            .into_iter()
            .filter(|&t| t != Traversal::Avx2 || has_avx2())
            .collect()
    }

    pub fn name(self) -> &'static str {
        match self {
            Traversal::Obvhs => "obvhs",
            Traversal::Avx2 => "avx2",
            Traversal::Wide => "wide",
        }
    }
}

/// Whether this CPU runs the AVX2 code paths (the node tests, the packets, the wide traversal's
/// AVX2 build).
pub(super) fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2")
        && std::arch::is_x86_feature_detected!("bmi1")
        && std::arch::is_x86_feature_detected!("bmi2")
        && std::arch::is_x86_feature_detected!("lzcnt")
        && std::arch::is_x86_feature_detected!("popcnt")
    {
        return true;
    }
    false
}

/// Closest hit: like `CwBvh::ray_traverse`. `test(ray, index)` returns the hit distance of
/// primitive `index` (∞ for a miss); a distance below the current `ray.tmax` becomes the new
/// `tmax`, so `test` sees the closest hit so far in the ray it is given.
/// Callable where the CPU supports AVX2 ([`Traversal::detect`] found it).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,bmi1,bmi2,lzcnt,popcnt")]
pub(super) fn ray_traverse_avx2(bvh: &CwBvh, ray: Ray, mut test: impl FnMut(&Ray, usize) -> f32) {
    let mut ray = ray;
    let mut state = bvh.new_traversal(ray.direction);
    let planes = NearFar::of(&ray);
    let mut node;
    obvhs::traverse!(
        bvh,
        node,
        state,
        avx2::intersect_node(node, &ray, &planes, state.oct_inv4),
        {
            let t = test(&ray, state.primitive_id as usize);
            if t < ray.tmax {
                ray.tmax = t;
            }
        }
    );
}

/// Any hit: like `CwBvh::ray_traverse_miss`, true when no primitive's `test` distance is below
/// `ray.tmax`. Stops at the first such primitive.
/// Callable where the CPU supports AVX2 ([`Traversal::detect`] found it).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,bmi1,bmi2,lzcnt,popcnt")]
pub(super) fn ray_traverse_miss_avx2(
    bvh: &CwBvh,
    ray: Ray,
    mut test: impl FnMut(&Ray, usize) -> f32,
) -> bool {
    let mut state = bvh.new_traversal(ray.direction);
    let planes = NearFar::of(&ray);
    let mut node;
    'traversal: {
        obvhs::traverse!(
            bvh,
            node,
            state,
            avx2::intersect_node(node, &ray, &planes, state.oct_inv4),
            {
                if test(&ray, state.primitive_id as usize) < ray.tmax {
                    break 'traversal;
                }
            }
        );
        return true;
    }
    false
}

/// Per axis, whether the ray enters a child box through its max plane (negative direction) and
/// leaves through its min plane. Decided once per ray rather than per node, as obvhs decides it.
#[derive(Clone, Copy)]
struct NearFar {
    negative: [bool; 3],
}

impl NearFar {
    fn of(ray: &Ray) -> NearFar {
        let d: Vec3A = ray.direction;
        NearFar {
            negative: [d.x < 0.0, d.y < 0.0, d.z < 0.0],
        }
    }

    /// The (entry, exit) planes of one axis, given its (min, max) planes.
    #[inline(always)]
    fn pick(self, axis: usize, min: [u8; 8], max: [u8; 8]) -> (u64, u64) {
        let (near, far) = if self.negative[axis] {
            (max, min)
        } else {
            (min, max)
        };
        (u64::from_le_bytes(near), u64::from_le_bytes(far))
    }
}

/// obvhs's child-box entry clamp (`cwbvh::node::EPSILON`, crate-private): boxes the ray
/// leaves before this distance are skipped. `triangles::bvh_space_scale` sizes BVH space so
/// that it is negligible.
pub(super) const ENTRY_EPSILON: f32 = 0.0001;

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use glam::Vec3A;
    use obvhs::cwbvh::node::CwBvhNode;
    use obvhs::ray::Ray;

    use super::{ENTRY_EPSILON, NearFar};

    /// The hit mask of `node`'s children in obvhs's layout (`CwBvhNode::intersect_ray`): for a hit
    /// inner child, its traversal-priority bit in bits 24..32; for a hit leaf, its primitives'
    /// bits in 0..24.
    #[target_feature(enable = "avx2,bmi1,bmi2,lzcnt,popcnt")]
    #[inline]
    pub(super) fn intersect_node(
        node: &CwBvhNode,
        ray: &Ray,
        planes: &NearFar,
        oct_inv4: u32,
    ) -> u32 {
        // The ray in the node's quantised grid, as obvhs computes it (bit-identical slabs).
        let scale = node.compute_extent() * ray.inv_direction;
        let offset = (Vec3A::from(node.p) - ray.origin) * ray.inv_direction;

        let (near_x, far_x) = planes.pick(0, node.child_min_x, node.child_max_x);
        let (near_y, far_y) = planes.pick(1, node.child_min_y, node.child_max_y);
        let (near_z, far_z) = planes.pick(2, node.child_min_z, node.child_max_z);
        let slab = |q: u64, scale: f32, offset: f32| {
            let q = _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_cvtsi64_si128(q as i64)));
            _mm256_add_ps(
                _mm256_mul_ps(q, _mm256_set1_ps(scale)),
                _mm256_set1_ps(offset),
            )
        };
        let t_near = _mm256_max_ps(
            slab(near_x, scale.x, offset.x),
            _mm256_max_ps(
                slab(near_y, scale.y, offset.y),
                slab(near_z, scale.z, offset.z),
            ),
        );
        let t_far = _mm256_min_ps(
            slab(far_x, scale.x, offset.x),
            _mm256_min_ps(
                slab(far_y, scale.y, offset.y),
                slab(far_z, scale.z, offset.z),
            ),
        );
        let t_near = _mm256_max_ps(t_near, _mm256_set1_ps(ENTRY_EPSILON));
        let t_far = _mm256_min_ps(t_far, _mm256_set1_ps(ray.tmax));
        let hit = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LE_OQ>(t_near, t_far));

        // Each child's contribution is `child_bits << bit_index` (both bytes of obvhs's
        // per-node words); empty slots contribute nothing. Contributions occupy disjoint
        // bits, so OR-ing the hit lanes together assembles the mask.
        let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
        let widen = |bytes: u64| _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(bytes as i64));
        let lanes = _mm256_and_si256(
            _mm256_sllv_epi32(widen(child_bits8), widen(bit_index8)),
            hit,
        );
        let x = _mm_or_si128(
            _mm256_castsi256_si128(lanes),
            _mm256_extracti128_si256::<1>(lanes),
        );
        let x = _mm_or_si128(x, _mm_unpackhi_epi64(x, x));
        let x = _mm_or_si128(x, _mm_shuffle_epi32::<0b01>(x));
        _mm_cvtsi128_si32(x) as u32
    }
}
