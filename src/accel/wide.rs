//! The CPU's own node layout: obvhs's compressed wide BVH decoded once into 8-wide nodes with
//! float child boxes (issue 27).
//!
//! obvhs stays the builder. Its CWBVH stores each child box as bytes on a per-node grid
//! (`p + e·q`, `e` a power of two) and its children in a per-node order, and a traversal pays a
//! dependent load and a decode of 48 bytes at every node. Here every child box is decoded once,
//! at build time, into `f32` planes laid out slot-major (all eight children's `x` minima side
//! by side, ...), so that one vector load gives a plane of all eight children and a slab test
//! is a subtract and a multiply per plane. Each child slot names its target directly: another
//! node, or a leaf's run of (at most three) triangles in BVH order, the order the triangle
//! data is stored in. The tree is obvhs's, child for child: the same leaves, the same boxes
//! (rounded outwards to `f32`, never inwards), so a traversal of it visits a superset of the
//! triangles obvhs's would for the same ray, and its closest hit is obvhs's.

use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::node::CwBvhNode;
use rayon::prelude::*;

/// Children per node.
pub const WIDTH: usize = 8;

/// The deepest tree the traversals' fixed stacks hold (each level pushes at most
/// `WIDTH - 1` entries). PLOC trees of real scenes are 10–25 nodes deep; a deeper one is
/// traversed by obvhs's code instead ([`WideBvh::from_cwbvh`] returns `None`).
pub const MAX_DEPTH: usize = 64;

/// Entries a traversal stack needs for a tree of [`MAX_DEPTH`].
pub const STACK_SIZE: usize = MAX_DEPTH * (WIDTH - 1) + 1;

/// A child slot: another node, a leaf (a run of triangles), or nothing.
///
/// Bit 31 set: a leaf; bits 29–30 hold its triangle count (1–3) and bits 0–28 the index of its
/// first triangle (BVH order). Bit 31 clear: the index of an inner node. An empty slot is
/// [`ChildRef::EMPTY`], and its box is empty, so no ray ever reaches it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(transparent)]
pub struct ChildRef(pub u32);

impl ChildRef {
    pub const EMPTY: ChildRef = ChildRef(u32::MAX);
    /// Node 0, where every traversal starts.
    pub const ROOT: ChildRef = ChildRef(0);
    const LEAF: u32 = 1 << 31;
    const COUNT_SHIFT: u32 = 29;
    /// Triangles a leaf's first index may reach: 2^29.
    pub const MAX_TRIANGLES: usize = 1 << Self::COUNT_SHIFT;

    fn node(index: u32) -> ChildRef {
        debug_assert!(index < Self::LEAF);
        ChildRef(index)
    }

    fn leaf(first: u32, count: u32) -> ChildRef {
        debug_assert!((1..=3).contains(&count) && (first as usize) < Self::MAX_TRIANGLES);
        ChildRef(Self::LEAF | count << Self::COUNT_SHIFT | first)
    }

    #[inline(always)]
    pub fn is_leaf(self) -> bool {
        self.0 & Self::LEAF != 0
    }

    /// An inner child's node index.
    #[inline(always)]
    pub fn node_index(self) -> usize {
        self.0 as usize
    }

    /// A leaf's triangles, BVH order.
    #[inline(always)]
    pub fn triangles(self) -> std::ops::Range<usize> {
        let first = (self.0 & (Self::MAX_TRIANGLES as u32 - 1)) as usize;
        let count = ((self.0 >> Self::COUNT_SHIFT) & 3) as usize;
        first..first + count
    }
}

/// Eight children's boxes as planes of eight floats each, and what each child is.
///
/// Plane `2·axis` holds the children's minima on that axis, plane `2·axis + 1` their maxima,
/// in BVH space. An empty slot has +∞ minima and −∞ maxima.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct WideNode {
    pub planes: [[f32; WIDTH]; 6],
    pub children: [ChildRef; WIDTH],
}

/// obvhs's tree with float boxes (see the module documentation). Node 0 is the root.
#[derive(Clone, Debug, Default)]
pub struct WideBvh {
    pub nodes: Vec<WideNode>,
}

impl WideBvh {
    /// Decodes every node of `cwbvh`; `None` where the tree is deeper than [`MAX_DEPTH`], holds
    /// more triangles than a [`ChildRef`] can index, or breaks the CWBVH layout obvhs documents
    /// (then obvhs's own traversal serves).
    pub fn from_cwbvh(cwbvh: &CwBvh) -> Option<WideBvh> {
        if cwbvh.nodes.is_empty()
            || cwbvh.primitive_indices.len() > ChildRef::MAX_TRIANGLES
            || cwbvh.nodes.len() >= ChildRef::LEAF as usize
        {
            return None;
        }
        let nodes: Vec<WideNode> = cwbvh
            .nodes
            .par_iter()
            .map(decode_node)
            .collect::<Option<_>>()?;
        tree_depth(&nodes)?;
        Some(WideBvh { nodes })
    }
}

/// One CWBVH node decoded: child `i`'s box is `p + e·q` on each axis, computed in `f64` (exact:
/// `e` is a power of two and `q` a byte) and rounded outwards to `f32`.
fn decode_node(node: &CwBvhNode) -> Option<WideNode> {
    let mut wide = WideNode {
        planes: [0, 1, 2, 3, 4, 5].map(|plane| {
            [if plane % 2 == 0 {
                f32::INFINITY
            } else {
                f32::NEG_INFINITY
            }; WIDTH]
        }),
        children: [ChildRef::EMPTY; WIDTH],
    };
    let origin = [node.p.x, node.p.y, node.p.z];
    let quantised = [
        [node.child_min_x, node.child_max_x],
        [node.child_min_y, node.child_max_y],
        [node.child_min_z, node.child_max_z],
    ];
    for slot in 0..WIDTH {
        if node.is_child_empty(slot) {
            continue;
        }
        wide.children[slot] = if node.is_leaf(slot) {
            let (first, count) = node.child_primitives(slot);
            if !(1..=3).contains(&count) || first as usize >= ChildRef::MAX_TRIANGLES {
                return None;
            }
            ChildRef::leaf(first, count)
        } else {
            ChildRef::node(node.child_node_index(slot))
        };
        for (axis, [min, max]) in quantised.iter().enumerate() {
            let scale = f64::from(f32::from_bits(u32::from(node.e[axis]) << 23));
            let plane = |q: u8| f64::from(origin[axis]) + scale * f64::from(q);
            wide.planes[2 * axis][slot] = round_down(plane(min[slot]));
            wide.planes[2 * axis + 1][slot] = round_up(plane(max[slot]));
        }
    }
    Some(wide)
}

/// The largest `f32` at most `x`.
fn round_down(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) > x { f.next_down() } else { f }
}

/// The smallest `f32` at least `x`.
fn round_up(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) < x { f.next_up() } else { f }
}

/// Levels of the deepest path from the root, `None` beyond [`MAX_DEPTH`] or for a child index
/// out of range (a malformed tree).
fn tree_depth(nodes: &[WideNode]) -> Option<usize> {
    let mut deepest = 0;
    let mut pending = vec![(0usize, 1usize)];
    while let Some((index, depth)) = pending.pop() {
        if depth > MAX_DEPTH {
            return None;
        }
        deepest = deepest.max(depth);
        for child in nodes.get(index)?.children {
            if child != ChildRef::EMPTY && !child.is_leaf() {
                pending.push((child.node_index(), depth + 1));
            }
        }
    }
    Some(deepest)
}
