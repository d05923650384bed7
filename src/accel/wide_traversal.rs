//! Single-ray traversal of the [`WideBvh`]: eight float slab tests per node, nearest child
//! first, any-hit shadow rays that stop at the first occluder.
//!
//! The slab test, per child box and axis: the ray `o + t·d` crosses the planes `b` at
//! `t = (b − o) · (1/d)`; it enters the box at the largest entry distance of the three axes
//! and leaves at the smallest exit distance, and hits it when entry ≤ exit. Which plane of an
//! axis is the entry depends only on the sign of `d`, so it is chosen once per ray. The exit
//! distance is widened by `1 + 4ε` (Ize 2013, as pbrt-v4 does with `1 + 2γ₃`): the subtract and
//! the multiply each round, and without the margin a ray through a box's edge or a flat box (a
//! floor's leaves) could be culled although it hits a triangle inside. With it, no box that the
//! ray truly crosses is culled, and so a hit obvhs finds is found here.
//!
//! Entry distances are clamped below at obvhs's [`ENTRY_EPSILON`], as obvhs's node test does, so
//! the two traversals agree on what counts as in front of the origin.
//!
//! Hit children go onto the stack sorted by entry distance, nearest popped first; an entry whose
//! box starts beyond the closest hit found so far is dropped when popped. Any-hit traversal
//! skips the sort: it stops at the first hit, wherever it is.
//!
//! The loops are written for the compiler to vectorise: [`first_hit_avx2`]
//! compiles the same code with AVX2, where each plane of a node is one 8-lane vector.

use std::mem::MaybeUninit;

use obvhs::ray::Ray;

use super::traversal::ENTRY_EPSILON;
use super::triangles::{TriangleHit, TrianglePrimitive};
use super::wide::{ChildRef, STACK_SIZE, WIDTH, WideBvh, WideNode};

/// How much a box's exit distance is widened so that rounding never culls it: 1 + 4ε bounds the
/// relative error of `(b − o)·(1/d)` with room to spare.
pub(super) const EXIT_MARGIN: f32 = 1.0 + 4.0 * f32::EPSILON;

/// What the node test needs of a ray, decided once per ray.
struct SlabRay {
    origin: [f32; 3],
    inverse_direction: [f32; 3],
    /// Per axis, the plane index (into [`WideNode::planes`]) a ray enters a box through: the
    /// minima for a non-negative direction, the maxima for a negative one.
    entry_plane: [usize; 3],
    exit_plane: [usize; 3],
}

impl SlabRay {
    #[inline(always)]
    fn new(ray: &Ray) -> SlabRay {
        let negative = [
            usize::from(ray.direction.x < 0.0),
            usize::from(ray.direction.y < 0.0),
            usize::from(ray.direction.z < 0.0),
        ];
        SlabRay {
            origin: ray.origin.to_array(),
            // obvhs's inverse, finite for axis-parallel rays (`obvhs::ray::safe_inverse`).
            inverse_direction: ray.inv_direction.to_array(),
            entry_plane: [negative[0], 2 + negative[1], 4 + negative[2]],
            exit_plane: [1 - negative[0], 3 - negative[1], 5 - negative[2]],
        }
    }
}

/// `a.max(b)` for numbers that are never NaN here (so that it compiles to one instruction).
#[inline(always)]
fn larger(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

#[inline(always)]
fn smaller(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

/// Which children the ray hits before `t_max` (bit `i` for child `i`), and each child's entry
/// distance.
///
/// Never NaN: the planes are finite or ±∞, the origin finite, the inverse direction finite
/// and non-zero.
#[inline(always)]
fn hit_children(node: &WideNode, ray: &SlabRay, t_max: f32) -> (u32, [f32; WIDTH]) {
    let [ox, oy, oz] = ray.origin;
    let [ix, iy, iz] = ray.inverse_direction;
    let planes = &node.planes;
    let (entry_x, entry_y, entry_z) = (
        &planes[ray.entry_plane[0]],
        &planes[ray.entry_plane[1]],
        &planes[ray.entry_plane[2]],
    );
    let (exit_x, exit_y, exit_z) = (
        &planes[ray.exit_plane[0]],
        &planes[ray.exit_plane[1]],
        &planes[ray.exit_plane[2]],
    );
    let mut entry = [0.0; WIDTH];
    let mut exit = [0.0; WIDTH];
    for slot in 0..WIDTH {
        let ex = (entry_x[slot] - ox) * ix;
        let ey = (entry_y[slot] - oy) * iy;
        let ez = (entry_z[slot] - oz) * iz;
        let lx = (exit_x[slot] - ox) * ix;
        let ly = (exit_y[slot] - oy) * iy;
        let lz = (exit_z[slot] - oz) * iz;
        entry[slot] = larger(larger(ex, ey), larger(ez, ENTRY_EPSILON));
        exit[slot] = smaller(smaller(smaller(lx, ly), lz) * EXIT_MARGIN, t_max);
    }
    let mut mask = 0;
    for slot in 0..WIDTH {
        mask |= u32::from(entry[slot] <= exit[slot]) << slot;
    }
    (mask, entry)
}

/// A stack entry: the child's entry distance (a positive float's bits order like the float) in
/// the high half, the child in the low half.
#[inline(always)]
fn stack_entry(distance: f32, child: ChildRef) -> u64 {
    u64::from(distance.to_bits()) << 32 | u64::from(child.0)
}

#[inline(always)]
fn entry_distance(entry: u64) -> f32 {
    f32::from_bits((entry >> 32) as u32)
}

/// A triangle's hit, BVH order index.
pub(super) type ClosestHit = Option<(usize, TriangleHit)>;

/// With `ANY_HIT` false, the closest hit in (`ENTRY_EPSILON`, `ray.tmax`]: the triangle test
/// of every triangle of every box the ray reaches, `is_hole(triangle, u, v)` skipping
/// alpha-masked holes. With `ANY_HIT` true, the first hit found before `ray.tmax` (whether
/// there is one: shadow rays stop there).
#[inline(always)]
pub(super) fn first_hit<const ANY_HIT: bool>(
    bvh: &WideBvh,
    primitives: &[TrianglePrimitive],
    ray: Ray,
    is_hole: impl Fn(usize, f32, f32) -> bool,
) -> ClosestHit {
    traverse::<ANY_HIT>(bvh, primitives, ray, ChildRef::ROOT, is_hole, hit_children)
}

/// [`first_hit`] with the AVX2 node test. Callable where the CPU has AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,bmi1,bmi2,lzcnt,popcnt")]
pub(super) fn first_hit_avx2<const ANY_HIT: bool>(
    bvh: &WideBvh,
    primitives: &[TrianglePrimitive],
    ray: Ray,
    is_hole: impl Fn(usize, f32, f32) -> bool,
) -> ClosestHit {
    traverse::<ANY_HIT>(
        bvh,
        primitives,
        ray,
        ChildRef::ROOT,
        is_hole,
        |node, slab, t_max| avx2::hit_children(node, slab, t_max),
    )
}

/// The traversal loop; `ANY_HIT` picks the any-hit flavour (which returns its first hit).
#[inline(always)]
fn traverse<const ANY_HIT: bool>(
    bvh: &WideBvh,
    primitives: &[TrianglePrimitive],
    ray: Ray,
    start: ChildRef,
    is_hole: impl Fn(usize, f32, f32) -> bool,
    hit_children: impl Fn(&WideNode, &SlabRay, f32) -> (u32, [f32; WIDTH]),
) -> ClosestHit {
    let slab = SlabRay::new(&ray);
    let mut t_max = ray.tmax;
    // At most WIDTH − 1 entries wait per level of the current path (see `wide::STACK_SIZE`).
    // Uninitialised: a ray reads only the entries it wrote (3.6 KB would cost a memset a ray).
    let mut stack = [MaybeUninit::<u64>::uninit(); STACK_SIZE];
    let mut pending = 0;
    let mut closest = None;
    let mut current = start;
    loop {
        if current.is_leaf() {
            for triangle in current.triangles() {
                let Some(hit) =
                    primitives[triangle].intersect(ray.origin, ray.direction, ray.tmin, t_max)
                else {
                    continue;
                };
                if nearer(
                    hit.t,
                    triangle,
                    t_max,
                    closest.map(|(index, _)| index),
                    ANY_HIT,
                ) && !is_hole(triangle, hit.u, hit.v)
                {
                    closest = Some((triangle, hit));
                    if ANY_HIT {
                        return closest;
                    }
                    t_max = hit.t;
                }
            }
        } else {
            let node = &bvh.nodes[current.node_index()];
            let (mask, entry) = hit_children(node, &slab, t_max);
            if mask != 0 {
                current = if mask.is_power_of_two() {
                    node.children[mask.trailing_zeros() as usize]
                } else {
                    // Any-hit rays stop at the first hit wherever it is: no sort for them.
                    push_children(node, mask, &entry, !ANY_HIT, &mut stack, &mut pending)
                };
                continue;
            }
        }
        // Next: the nearest waiting child that still starts before the closest hit.
        loop {
            if pending == 0 {
                return closest;
            }
            pending -= 1;
            // SAFETY: entries below `pending` were written by the pushes.
            let waiting = unsafe { stack[pending].assume_init() };
            if entry_distance(waiting) <= t_max {
                current = ChildRef(waiting as u32);
                break;
            }
        }
    }
}

/// Whether a hit on `triangle` at `t` replaces the closest so far (at `t_max`, on `closest`).
///
/// Strictly nearer wins. Of hits at exactly the same distance (a ray through an edge two
/// triangles share), the lower triangle index wins, whichever was found first: the closest hit
/// then does not depend on the order leaves are visited in, so single rays and packets agree
/// bit for bit. (The triangle test accepts `t = t_max` for this.) Any-hit queries, and a first
/// hit at exactly the query's `t_max`, want strictly nearer.
#[inline(always)]
pub(super) fn nearer(
    t: f32,
    triangle: usize,
    t_max: f32,
    closest: Option<usize>,
    any_hit: bool,
) -> bool {
    t < t_max || (!any_hit && t == t_max && closest.is_some_and(|index| triangle < index))
}

/// The indices of the set bits of `mask`, lowest first.
#[inline(always)]
pub(super) fn set_bits(mask: u32) -> impl Iterator<Item = usize> {
    let mut remaining = mask;
    std::iter::from_fn(move || {
        let bit = (remaining != 0).then(|| remaining.trailing_zeros() as usize)?;
        remaining &= remaining - 1;
        Some(bit)
    })
}

/// Inserts `item` into `sorted[..count]`, which stays in descending `key` order (farthest
/// first, so the nearest comes last, to be visited next): an insertion sort of eight at most.
#[inline(always)]
pub(super) fn insert_farthest_first<T: Copy, K: PartialOrd>(
    sorted: &mut [T; WIDTH],
    count: usize,
    item: T,
    key: impl Fn(&T) -> K,
) {
    let mut at = count;
    while at > 0 && key(&sorted[at - 1]) < key(&item) {
        sorted[at] = sorted[at - 1];
        at -= 1;
    }
    sorted[at] = item;
}

/// Pushes the hit children (two or more) but one, and returns that one, the child to visit
/// next: with `nearest_first`, pushed farthest first and the nearest returned; otherwise in
/// slot order.
#[inline(always)]
fn push_children(
    node: &WideNode,
    mask: u32,
    entry: &[f32; WIDTH],
    nearest_first: bool,
    stack: &mut [MaybeUninit<u64>; STACK_SIZE],
    pending: &mut usize,
) -> ChildRef {
    let mut order = [0u64; WIDTH];
    let mut count = 0;
    for slot in set_bits(mask) {
        let key = stack_entry(entry[slot], node.children[slot]);
        if nearest_first {
            insert_farthest_first(&mut order, count, key, |&key| key);
        } else {
            order[count] = key;
        }
        count += 1;
    }
    for &key in &order[..count - 1] {
        stack[*pending].write(key);
        *pending += 1;
    }
    ChildRef(order[count - 1] as u32)
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use super::{ENTRY_EPSILON, EXIT_MARGIN, SlabRay, WIDTH, WideNode};

    /// [`super::hit_children`], one plane of all eight children per instruction: the same
    /// operations in the same order, so the same bits.
    #[target_feature(enable = "avx2")]
    #[inline]
    pub(super) fn hit_children(node: &WideNode, ray: &SlabRay, t_max: f32) -> (u32, [f32; WIDTH]) {
        let distance = |plane: usize, axis: usize| {
            // SAFETY: `WideNode` is 32-byte aligned and each plane is 32 bytes.
            let plane = unsafe { _mm256_load_ps(node.planes[plane].as_ptr()) };
            _mm256_mul_ps(
                _mm256_sub_ps(plane, _mm256_set1_ps(ray.origin[axis])),
                _mm256_set1_ps(ray.inverse_direction[axis]),
            )
        };
        let entry = _mm256_max_ps(
            _mm256_max_ps(
                distance(ray.entry_plane[0], 0),
                distance(ray.entry_plane[1], 1),
            ),
            _mm256_max_ps(
                distance(ray.entry_plane[2], 2),
                _mm256_set1_ps(ENTRY_EPSILON),
            ),
        );
        let exit = _mm256_min_ps(
            _mm256_mul_ps(
                _mm256_min_ps(
                    _mm256_min_ps(
                        distance(ray.exit_plane[0], 0),
                        distance(ray.exit_plane[1], 1),
                    ),
                    distance(ray.exit_plane[2], 2),
                ),
                _mm256_set1_ps(EXIT_MARGIN),
            ),
            _mm256_set1_ps(t_max),
        );
        let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(entry, exit)) as u32;
        let mut distances = [0.0; WIDTH];
        // SAFETY: `distances` holds eight floats.
        unsafe { _mm256_storeu_ps(distances.as_mut_ptr(), entry) };
        (mask, distances)
    }
}
