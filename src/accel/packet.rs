//! Closest-hit traversal of 8-ray packets over the [`WideBvh`] (AVX2), for coherent rays such
//! as the camera rays of one film tile.
//!
//! A packet walks the tree once for its eight rays (Wald et al. 2001): at each node it tests
//! every child box against all eight rays in SIMD (one lane per ray, the box's planes
//! broadcast), and each leaf triangle against the rays that reached the leaf. Children are
//! visited nearest first by the nearest of the packet's entry distances. All rays of a packet
//! share the direction octant (the caller checks), so each axis's entry plane is the same for
//! all of them.
//!
//! Exactness: each lane's box test is the single-ray traversal's arithmetic
//! (`wide_traversal::hit_children`: the same operations in the same order), with that ray's
//! own closest hit so far as `t_max`, and each lane's triangle test is
//! `TrianglePrimitive::intersect`'s. A ray enters only the boxes its own test accepts and
//! tests only the triangles of the leaves it enters. The order differs from the single-ray
//! traversal's (the packet's nearest first, not the ray's), so a ray may enter boxes the
//! single ray would have culled, never fewer of those that hold its closest hit: each ray gets
//! the single-ray traversal's closest hit, up to which of two triangles at exactly the same
//! distance is reported. Other rays of the packet only add work.

use std::arch::x86_64::*;

use obvhs::ray::Ray;

use super::traversal::ENTRY_EPSILON;
use super::triangles::TrianglePrimitive;
use super::wide::{ChildRef, WIDTH, WideBvh};
use super::wide_traversal::{EXIT_MARGIN, insert_farthest_first, set_bits};

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
    /// Interior nodes the packet visited, and the rays it held at those visits, summed: how
    /// full it ran (see `packet_use`); counted only when asked.
    pub visits: u32,
    pub rays_at_visits: u32,
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

/// A child some rays of the packet (bit i: ray i) still have to visit.
#[derive(Clone, Copy)]
pub(super) struct StackEntry {
    child: ChildRef,
    lanes: u8,
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
/// `d < 0` per axis). `holes(triangle, u, v)` is the alpha check, where the scene has alpha
/// masks, asked only for geometric hits closer than the ray's closest so far.
/// `stack` is scratch space (kept by the caller to spare an allocation per packet).
/// Callable where the CPU supports AVX2.
#[target_feature(enable = "avx2,bmi1,bmi2,lzcnt,popcnt")]
pub(super) fn intersect_packet_avx2(
    bvh: &WideBvh,
    primitives: &[TrianglePrimitive],
    rays: &PacketRays,
    active: u32,
    holes: Option<impl Fn(usize, f32, f32) -> bool>,
    stack: &mut Vec<StackEntry>,
    count: bool,
) -> PacketHits {
    let mut hits = PacketHits {
        t: [f32::INFINITY; LANES],
        triangle: [u32::MAX; LANES],
        u: [0.0; LANES],
        v: [0.0; LANES],
        visits: 0,
        rays_at_visits: 0,
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
    let negative = rays.direction.map(|d| usize::from(d[lead] < 0.0));
    let entry_plane = [negative[0], 2 + negative[1], 4 + negative[2]];
    let exit_plane = [1 - negative[0], 3 - negative[1], 5 - negative[2]];

    let mut triangle = _mm256_set1_epi32(-1);
    let mut hit_u = _mm256_setzero_ps();
    let mut hit_v = _mm256_setzero_ps();
    let lane_bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    let lanes_of = |bits: u32| {
        _mm256_cmpeq_epi32(
            _mm256_and_si256(_mm256_set1_epi32(bits as i32), lane_bits),
            lane_bits,
        )
    };
    let epsilon = _mm256_set1_ps(ENTRY_EPSILON);
    let margin = _mm256_set1_ps(EXIT_MARGIN);

    let (mut visits, mut rays_at_visits) = (0, 0);
    stack.clear();
    let mut next = Some(StackEntry {
        child: ChildRef(0),
        lanes: active as u8,
    });
    while let Some(StackEntry { child, lanes: bits }) = next.take().or_else(|| stack.pop()) {
        if child.is_leaf() {
            for index in child.triangles() {
                let (mut hit, t, u, v) =
                    primitives[index].intersect8(&lanes, lanes_of(bits.into()), index, triangle);
                let found = _mm256_movemask_ps(_mm256_castsi256_ps(hit)) as u32;
                if found == 0 {
                    continue;
                }
                if let Some(is_hole) = &holes {
                    let (u_lane, v_lane) = (to_array(u), to_array(v));
                    let mut kept = found;
                    for lane in set_bits(found) {
                        if is_hole(index, u_lane[lane], v_lane[lane]) {
                            kept &= !(1 << lane);
                        }
                    }
                    hit = lanes_of(kept);
                }
                let hit_ps = _mm256_castsi256_ps(hit);
                lanes.tmax = _mm256_blendv_ps(lanes.tmax, t, hit_ps);
                hit_u = _mm256_blendv_ps(hit_u, u, hit_ps);
                hit_v = _mm256_blendv_ps(hit_v, v, hit_ps);
                triangle = _mm256_blendv_epi8(triangle, _mm256_set1_epi32(index as i32), hit);
            }
            continue;
        }
        if count {
            visits += 1;
            rays_at_visits += bits.count_ones();
        }
        let node = &bvh.nodes[child.node_index()];
        // Every child against every ray still in this node: each lane's arithmetic is the
        // single-ray `hit_children`'s, with the child's planes broadcast.
        let mut sorted = [(0u32, StackEntry { child, lanes: 0 }); WIDTH];
        let mut count = 0;
        for slot in 0..WIDTH {
            if node.children[slot] == ChildRef::EMPTY {
                continue;
            }
            let distance = |plane: usize, axis: usize| {
                _mm256_mul_ps(
                    _mm256_sub_ps(_mm256_set1_ps(node.planes[plane][slot]), lanes.origin[axis]),
                    lanes.inv_direction[axis],
                )
            };
            let entry = _mm256_max_ps(
                _mm256_max_ps(distance(entry_plane[0], 0), distance(entry_plane[1], 1)),
                _mm256_max_ps(distance(entry_plane[2], 2), epsilon),
            );
            let exit = _mm256_min_ps(
                _mm256_mul_ps(
                    _mm256_min_ps(
                        _mm256_min_ps(distance(exit_plane[0], 0), distance(exit_plane[1], 1)),
                        distance(exit_plane[2], 2),
                    ),
                    margin,
                ),
                lanes.tmax,
            );
            let hit = _mm256_cmp_ps::<_CMP_LE_OQ>(entry, exit);
            let hit_bits = _mm256_movemask_ps(hit) as u32 & u32::from(bits);
            if hit_bits == 0 {
                continue;
            }
            // Order key: the nearest entry among the rays that hit (positive floats order
            // like their bits).
            let nearest = min_lane(_mm256_blendv_ps(
                _mm256_set1_ps(f32::INFINITY),
                entry,
                _mm256_castsi256_ps(lanes_of(hit_bits)),
            ));
            let visit = StackEntry {
                child: node.children[slot],
                lanes: hit_bits as u8,
            };
            insert_farthest_first(
                &mut sorted,
                count,
                (nearest.to_bits(), visit),
                |&(key, _)| key,
            );
            count += 1;
        }
        if count > 0 {
            stack.extend(sorted[..count - 1].iter().map(|&(_, visit)| visit));
            next = Some(sorted[count - 1].1);
        }
    }

    (hits.visits, hits.rays_at_visits) = (visits, rays_at_visits);
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

/// The smallest of the eight lanes.
#[target_feature(enable = "avx2")]
#[inline]
fn min_lane(x: __m256) -> f32 {
    let x = _mm_min_ps(_mm256_castps256_ps128(x), _mm256_extractf128_ps::<1>(x));
    let x = _mm_min_ps(x, _mm_movehl_ps(x, x));
    let x = _mm_min_ss(x, _mm_shuffle_ps::<0b01>(x, x));
    _mm_cvtss_f32(x)
}

#[target_feature(enable = "avx2")]
#[inline]
fn to_array(x: __m256) -> [f32; LANES] {
    let mut out = [0.0; LANES];
    // SAFETY: `out` holds 8 floats; unaligned store.
    unsafe { _mm256_storeu_ps(out.as_mut_ptr(), x) };
    out
}

impl TrianglePrimitive {
    /// [`TrianglePrimitive::intersect`] for eight rays at once, `t_min` = 0, keeping the hits
    /// that replace each ray's closest so far (`t_max`, on triangle `closest`, −1 for none) by
    /// `wide_traversal::nearer`'s rule, this triangle being number `index`: the same
    /// operations in the same order (no FMA), so each lane's answer is bit-identical to the
    /// scalar test's. Returns the lanes of `lanes_in` that hit (all ones), and t, u, v per lane.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn intersect8(
        &self,
        rays: &Lanes,
        lanes_in: __m256i,
        index: usize,
        closest: __m256i,
    ) -> (__m256i, __m256, __m256, __m256) {
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
        // Nearer, or as near on a lower-numbered triangle than a hit found before.
        let lower = _mm256_andnot_si256(
            _mm256_cmpeq_epi32(closest, _mm256_set1_epi32(-1)),
            _mm256_cmpgt_epi32(closest, _mm256_set1_epi32(index as i32)),
        );
        let tie = _mm256_and_ps(
            _mm256_cmp_ps::<_CMP_EQ_OQ>(t, rays.tmax),
            _mm256_castsi256_ps(lower),
        );
        ok = _mm256_and_ps(
            ok,
            _mm256_or_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(t, rays.tmax), tie),
        );
        let hit = _mm256_and_si256(_mm256_castps_si256(ok), lanes_in);
        (hit, t, u, v)
    }
}
