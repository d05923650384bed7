//! Closest-hit traversal of 8-ray packets (AVX2), for coherent rays such as the camera rays of
//! one film tile.
//!
//! The single-ray AVX2 traversal spends most of a camera ray's instructions loading and
//! decoding nodes and triangles and in the loop's bookkeeping, not in the box arithmetic. A
//! packet decodes each node once and tests its children against all eight rays in SIMD (one
//! lane per ray), tests each leaf triangle against the packet's rays in SIMD, and walks the
//! tree once for all of them (Wald et al. 2001).
//!
//! Exactness: every ray gets the hit the single-ray traversal gives it, ties included. The
//! packet walks the tree depth first in obvhs's child order, which depends only on the
//! direction octant, so all rays of a packet must share it (the caller checks). Each stack
//! entry keeps every ray's own hit mask of the node's children, computed with that ray's own
//! `tmax` at the time, exactly as the single-ray traversal keeps its one mask; a ray only
//! enters children and tests triangles its mask holds. So each ray sees, in the same order,
//! the same node tests (same arithmetic as `traversal::avx2::intersect_node`) and triangle
//! tests (same arithmetic as `TrianglePrimitive::intersect`) with the same `tmax`, and ends on
//! the same hit. Other rays of the packet only add work, never change a ray's answer.

use std::arch::x86_64::*;

use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::ray::Ray;

use super::traversal::ENTRY_EPSILON;
use super::triangles::TrianglePrimitive;

/// Rays per packet: one per AVX2 `f32` lane.
pub(super) const LANES: usize = 8;

/// The closest hit of each ray of a packet, in BVH space.
#[derive(Clone, Copy, Debug)]
pub(super) struct PacketHits {
    pub t: [f32; LANES],
    /// Triangle index, `u32::MAX` for no hit.
    pub triangle: [u32; LANES],
    pub u: [f32; LANES],
    pub v: [f32; LANES],
}

/// The rays of a packet in BVH space, one lane each, as obvhs's `Ray`s hold them: rays built
/// by `Ray::new`, so that each lane's arithmetic is the single-ray traversal's.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct PacketRays {
    origin: [[f32; LANES]; 3],
    direction: [[f32; LANES]; 3],
    inv_direction: [[f32; LANES]; 3],
    tmax: [f32; LANES],
}

impl PacketRays {
    /// Puts `ray` (`tmin` = 0) in `lane`.
    #[inline]
    pub fn set(&mut self, lane: usize, ray: &Ray) {
        for axis in 0..3 {
            self.origin[axis][lane] = ray.origin[axis];
            self.direction[axis][lane] = ray.direction[axis];
            self.inv_direction[axis][lane] = ray.inv_direction[axis];
        }
        self.tmax[lane] = ray.tmax;
    }

    /// Copies lane `from` into `to`.
    #[inline]
    pub fn copy_lane(&mut self, from: usize, to: usize) {
        for axis in 0..3 {
            self.origin[axis][to] = self.origin[axis][from];
            self.direction[axis][to] = self.direction[axis][from];
            self.inv_direction[axis][to] = self.inv_direction[axis][from];
        }
        self.tmax[to] = self.tmax[from];
    }
}

/// A node whose children some rays of the packet still have to visit.
#[derive(Clone, Copy)]
pub(super) struct StackEntry {
    child_base: u32,
    imask: u32,
    /// Inner-child priority bits (24..32) not yet visited by any ray.
    pending: u32,
    /// Every ray's hit mask of the node, obvhs's layout (see `intersect_node`).
    masks: __m256i,
}

/// The packet's rays, one lane each, in BVH space.
struct Lanes {
    origin: [__m256; 3],
    direction: [__m256; 3],
    inv_direction: [__m256; 3],
    tmax: __m256,
}

/// Closest hits of `rays` (BVH space, `tmin` = 0) for the lanes set in `active` (bit i = ray
/// i); other lanes report no hit. All active rays must share the direction octant (by
/// `d < 0` per axis, obvhs's test). `is_hole(triangle, u, v)` is the alpha check, asked only
/// when `check_holes` and only for geometric hits closer than the ray's closest so far.
/// `stack` is scratch space (kept by the caller to spare an allocation per packet).
/// Callable where the CPU supports AVX2 ([`super::Traversal::detect`] found it).
#[target_feature(enable = "avx2,bmi1,bmi2,lzcnt,popcnt")]
pub(super) fn intersect_packet_avx2(
    bvh: &CwBvh,
    primitives: &[TrianglePrimitive],
    rays: &PacketRays,
    active: u32,
    check_holes: bool,
    is_hole: impl Fn(usize, f32, f32) -> bool,
    stack: &mut Vec<StackEntry>,
) -> PacketHits {
    let mut hits = PacketHits {
        t: [f32::INFINITY; LANES],
        triangle: [u32::MAX; LANES],
        u: [0.0; LANES],
        v: [0.0; LANES],
    };
    let active = active & 0xff;
    if active == 0 || bvh.nodes.is_empty() {
        return hits;
    }
    let lead = active.trailing_zeros() as usize;
    let load = |lane: &[f32; LANES]| {
        // SAFETY: `[f32; 8]` and `__m256` have the same size; unaligned load.
        unsafe { _mm256_loadu_ps(lane.as_ptr()) }
    };
    let mut lanes = Lanes {
        origin: rays.origin.each_ref().map(load),
        direction: rays.direction.each_ref().map(load),
        inv_direction: rays.inv_direction.each_ref().map(load),
        tmax: load(&rays.tmax),
    };
    let negative = rays.direction.map(|d| d[lead] < 0.0);
    // The octant code of `obvhs::cwbvh::ray_get_octant_inv4` (crate-private).
    let oct_inv4 = (if negative[0] { 0 } else { 0x0404_0404 })
        | (if negative[1] { 0 } else { 0x0202_0202 })
        | (if negative[2] { 0 } else { 0x0101_0101 });

    let mut triangle = _mm256_set1_epi32(-1);
    let mut hit_u = _mm256_setzero_ps();
    let mut hit_v = _mm256_setzero_ps();

    let lane_bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    let active_lanes = _mm256_cmpeq_epi32(
        _mm256_and_si256(_mm256_set1_epi32(active as i32), lane_bits),
        lane_bits,
    );

    stack.clear();
    // The root, as obvhs enters it: node 0 for every ray.
    let mut next = Some((0u32, active_lanes));
    loop {
        let (node_index, node_lanes) = match next.take() {
            Some(visit) => visit,
            None => {
                let Some(top) = stack.last_mut() else { break };
                let bit = 31 - top.pending.leading_zeros();
                top.pending &= !(1 << bit);
                let slot = (bit - 24) ^ (oct_inv4 & 0xff);
                let index = top.child_base + (top.imask & !(u32::MAX << slot)).count_ones();
                let bit_mask = _mm256_set1_epi32(1 << bit);
                let lanes_in = _mm256_cmpeq_epi32(_mm256_and_si256(top.masks, bit_mask), bit_mask);
                if top.pending == 0 {
                    stack.pop();
                }
                (index, lanes_in)
            }
        };
        let node = &bvh.nodes[node_index as usize];
        let masks = intersect_node(node, &lanes, negative, oct_inv4, node_lanes);

        let any = or_lanes(masks);
        let mut primitive_bits = any & 0x00ff_ffff;
        while primitive_bits != 0 {
            let bit = 31 - primitive_bits.leading_zeros();
            primitive_bits &= !(1 << bit);
            let bit_mask = _mm256_set1_epi32(1 << bit);
            let tri_lanes = _mm256_cmpeq_epi32(_mm256_and_si256(masks, bit_mask), bit_mask);
            let index = (node.primitive_base_idx + bit) as usize;
            let (mut hit, t, u, v) = primitives[index].intersect8(&lanes, tri_lanes);
            let mut bits = _mm256_movemask_ps(_mm256_castsi256_ps(hit)) as u32;
            if bits == 0 {
                continue;
            }
            if check_holes {
                let (u_lane, v_lane) = (to_array(u), to_array(v));
                let mut kept = bits;
                while bits != 0 {
                    let lane = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    if is_hole(index, u_lane[lane], v_lane[lane]) {
                        kept &= !(1 << lane);
                    }
                }
                hit = _mm256_cmpeq_epi32(
                    _mm256_and_si256(_mm256_set1_epi32(kept as i32), lane_bits),
                    lane_bits,
                );
            }
            let hit_ps = _mm256_castsi256_ps(hit);
            lanes.tmax = _mm256_blendv_ps(lanes.tmax, t, hit_ps);
            hit_u = _mm256_blendv_ps(hit_u, u, hit_ps);
            hit_v = _mm256_blendv_ps(hit_v, v, hit_ps);
            triangle = _mm256_blendv_epi8(triangle, _mm256_set1_epi32(index as i32), hit);
        }

        let pending = any & 0xff00_0000;
        if pending != 0 {
            stack.push(StackEntry {
                child_base: node.child_base_idx,
                imask: node.imask as u32,
                pending,
                masks,
            });
        }
    }

    let triangle = to_array(_mm256_castsi256_ps(triangle)).map(f32::to_bits);
    let (t, u, v) = (to_array(lanes.tmax), to_array(hit_u), to_array(hit_v));
    for lane in 0..LANES {
        if triangle[lane] != u32::MAX {
            hits.triangle[lane] = triangle[lane];
            hits.t[lane] = t[lane];
            hits.u[lane] = u[lane];
            hits.v[lane] = v[lane];
        }
    }
    hits
}

#[target_feature(enable = "avx2")]
#[inline]
fn to_array(x: __m256) -> [f32; LANES] {
    let mut out = [0.0; LANES];
    // SAFETY: `out` holds 8 floats; unaligned store.
    unsafe { _mm256_storeu_ps(out.as_mut_ptr(), x) };
    out
}

/// The OR of the eight 32-bit lanes.
#[target_feature(enable = "avx2")]
#[inline]
fn or_lanes(x: __m256i) -> u32 {
    let x = _mm_or_si128(_mm256_castsi256_si128(x), _mm256_extracti128_si256::<1>(x));
    let x = _mm_or_si128(x, _mm_unpackhi_epi64(x, x));
    let x = _mm_or_si128(x, _mm_shuffle_epi32::<0b01>(x));
    _mm_cvtsi128_si32(x) as u32
}

/// Every ray's hit mask of `node`'s children, in obvhs's layout (see
/// `traversal::avx2::intersect_node`, whose per-ray arithmetic this repeats with rays and
/// children swapped between lanes and loop); zero for lanes not set in `lanes_in`.
#[target_feature(enable = "avx2,bmi1,bmi2,lzcnt,popcnt")]
#[inline]
fn intersect_node(
    node: &CwBvhNode,
    rays: &Lanes,
    negative: [bool; 3],
    oct_inv4: u32,
    lanes_in: __m256i,
) -> __m256i {
    let extent = node.compute_extent();
    let p = node.p;
    let mut scale = [_mm256_setzero_ps(); 3];
    let mut offset = [_mm256_setzero_ps(); 3];
    for axis in 0..3 {
        scale[axis] = _mm256_mul_ps(_mm256_set1_ps(extent[axis]), rays.inv_direction[axis]);
        offset[axis] = _mm256_mul_ps(
            _mm256_sub_ps(_mm256_set1_ps(p[axis]), rays.origin[axis]),
            rays.inv_direction[axis],
        );
    }
    let planes = [
        (node.child_min_x, node.child_max_x),
        (node.child_min_y, node.child_max_y),
        (node.child_min_z, node.child_max_z),
    ];
    // Entry and exit plane of every child per axis, as floats, and every child's mask bits:
    // decoded once for the packet.
    let widen = |bytes: u64| _mm256_cvtepu8_epi32(_mm_cvtsi64_si128(bytes as i64));
    let floats = |bytes: [u8; 8]| {
        let mut out = [0f32; 8];
        // SAFETY: `out` holds 8 floats; unaligned store.
        unsafe {
            _mm256_storeu_ps(
                out.as_mut_ptr(),
                _mm256_cvtepi32_ps(widen(u64::from_le_bytes(bytes))),
            )
        };
        out
    };
    let mut near = [[0f32; 8]; 3];
    let mut far = [[0f32; 8]; 3];
    for axis in 0..3 {
        let (min, max) = planes[axis];
        let (n, f) = if negative[axis] {
            (max, min)
        } else {
            (min, max)
        };
        near[axis] = floats(n);
        far[axis] = floats(f);
    }
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    let mut contributions = [0u32; 8];
    // SAFETY: `contributions` holds 8 u32s; unaligned store.
    unsafe {
        _mm256_storeu_si256(
            contributions.as_mut_ptr().cast(),
            _mm256_sllv_epi32(widen(child_bits8), widen(bit_index8)),
        )
    };

    let epsilon = _mm256_set1_ps(ENTRY_EPSILON);
    let mut masks = _mm256_setzero_si256();
    let mut children = child_bits8;
    while children != 0 {
        // Empty slots have no child bits and would contribute nothing.
        let c = (children.trailing_zeros() / 8) as usize;
        children &= !(0xffu64 << (c * 8));
        let contribution = contributions[c];
        let slab = |q: f32, axis: usize| {
            _mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(q), scale[axis]), offset[axis])
        };
        let t_near = _mm256_max_ps(
            slab(near[0][c], 0),
            _mm256_max_ps(slab(near[1][c], 1), slab(near[2][c], 2)),
        );
        let t_far = _mm256_min_ps(
            slab(far[0][c], 0),
            _mm256_min_ps(slab(far[1][c], 1), slab(far[2][c], 2)),
        );
        let t_near = _mm256_max_ps(t_near, epsilon);
        let t_far = _mm256_min_ps(t_far, rays.tmax);
        let hit = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LE_OQ>(t_near, t_far));
        masks = _mm256_or_si256(
            masks,
            _mm256_and_si256(hit, _mm256_set1_epi32(contribution as i32)),
        );
    }
    _mm256_and_si256(masks, lanes_in)
}

impl TrianglePrimitive {
    /// [`TrianglePrimitive::intersect`] for eight rays at once, `t_min` = 0 and an exclusive
    /// `t_max` (the closest hit so far): the same operations in the same order (no FMA), so
    /// each lane's answer is bit-identical to the scalar test's. Returns the lanes of
    /// `lanes_in` that hit (all ones), and t, u, v per lane.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn intersect8(&self, rays: &Lanes, lanes_in: __m256i) -> (__m256i, __m256, __m256, __m256) {
        let splat = |v: glam::Vec3A| {
            [
                _mm256_set1_ps(v.x),
                _mm256_set1_ps(v.y),
                _mm256_set1_ps(v.z),
            ]
        };
        // glam's Vec3A arithmetic: cross as a.y·b.z − a.z·b.y …, dot as (x + y) + z.
        let cross = |a: [__m256; 3], b: [__m256; 3]| {
            [
                _mm256_sub_ps(_mm256_mul_ps(a[1], b[2]), _mm256_mul_ps(a[2], b[1])),
                _mm256_sub_ps(_mm256_mul_ps(a[2], b[0]), _mm256_mul_ps(a[0], b[2])),
                _mm256_sub_ps(_mm256_mul_ps(a[0], b[1]), _mm256_mul_ps(a[1], b[0])),
            ]
        };
        let dot = |a: [__m256; 3], b: [__m256; 3]| {
            _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(a[0], b[0]), _mm256_mul_ps(a[1], b[1])),
                _mm256_mul_ps(a[2], b[2]),
            )
        };
        let (v0, edge1, edge2) = (splat(self.v0), splat(self.edge1), splat(self.edge2));
        let zero = _mm256_setzero_ps();
        let one = _mm256_set1_ps(1.0);

        let p = cross(rays.direction, edge2);
        let det = dot(edge1, p);
        let abs_det = _mm256_andnot_ps(_mm256_set1_ps(-0.0), det);
        let mut ok = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_NEQ_OQ>(det, zero),
            _mm256_cmp_ps::<_CMP_LT_OQ>(abs_det, _mm256_set1_ps(f32::INFINITY)),
        );
        let inv_det = _mm256_div_ps(one, det);
        let s = [
            _mm256_sub_ps(rays.origin[0], v0[0]),
            _mm256_sub_ps(rays.origin[1], v0[1]),
            _mm256_sub_ps(rays.origin[2], v0[2]),
        ];
        let u = _mm256_mul_ps(dot(s, p), inv_det);
        ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_GE_OQ>(u, zero));
        ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_LE_OQ>(u, one));
        let q = cross(s, edge1);
        let v = _mm256_mul_ps(dot(rays.direction, q), inv_det);
        ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_GE_OQ>(v, zero));
        ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_LE_OQ>(_mm256_add_ps(u, v), one));
        let t = _mm256_mul_ps(dot(edge2, q), inv_det);
        ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_GE_OQ>(t, zero));
        ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_LT_OQ>(t, rays.tmax));
        let hit = _mm256_and_si256(_mm256_castps_si256(ok), lanes_in);
        (hit, t, u, v)
    }
}
