//! The 8-wide BVH the traversal walks: the binary SAH tree collapsed so that each node holds up
//! to eight children's boxes side by side ([`Box8`]) and one ray tests all eight in a single
//! SIMD slab test. A child is an inner node or a leaf (a run of at most [`MAX_LEAF`] primitives in
//! the primitive order), packed into one `u32` ([`ChildRef`]).

use super::build::MAX_LEAF;
use super::least_surface::{Inner, SlotCosts};
use super::node::BvhNode;
use crate::geometry::slab::Box8;

/// Children per node.
pub const WIDTH: usize = crate::geometry::slab::WIDTH;

/// A packed child reference: an inner node's index (top bit clear), or a leaf (top bit set, two
/// bits of `count − 1`, 29 bits of first position in the primitive order), or [`EMPTY`].
pub type ChildRef = u32;

/// An unused child slot.
pub const EMPTY: ChildRef = u32::MAX;
const LEAF_BIT: u32 = 1 << 31;
const COUNT_SHIFT: u32 = 29;
/// Largest first position a leaf reference can hold.
pub const MAX_LEAF_OFFSET: u32 = (1 << COUNT_SHIFT) - 1;

const _: () = assert!(MAX_LEAF <= 4, "a leaf's count must fit in two bits");

/// A leaf reference.
#[inline(always)]
pub fn leaf_ref(first: u32, count: u32) -> ChildRef {
    LEAF_BIT | ((count - 1) << COUNT_SHIFT) | first
}

/// True for a leaf reference (including [`EMPTY`], which is never followed).
#[inline(always)]
pub fn is_leaf(c: ChildRef) -> bool {
    c & LEAF_BIT != 0
}

/// `(first, count)` of a leaf reference.
#[inline(always)]
pub fn leaf_range(c: ChildRef) -> (usize, usize) {
    (
        (c & MAX_LEAF_OFFSET) as usize,
        (((c >> COUNT_SHIFT) & 3) + 1) as usize,
    )
}

/// A node: its children's boxes, their references, and how many are used. 256 bytes, aligned
/// to a cache line.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct WideNode {
    /// The children's boxes (unused lanes empty).
    pub bounds: Box8,
    /// The children (unused slots [`EMPTY`]), used ones first.
    pub child: [ChildRef; WIDTH],
    /// Children in use (1..=8).
    pub used: u32,
}

const _: () = assert!(std::mem::size_of::<WideNode>() == 256);

impl WideNode {
    /// The mask of used lanes.
    #[inline(always)]
    pub fn lanes(&self) -> u32 {
        (1 << self.used) - 1
    }
}

/// Why a binary tree cannot be collapsed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TooManyReferences(pub usize);

/// Collapses a binary tree into wide nodes of the least summed surface (a dynamic programme over
/// slot counts): each wide node takes the descendants of its binary node that cover the subtree
/// in at most eight slots and leave the fewest and smallest inner nodes below. No nodes for an empty tree; a
/// tree that is a single leaf gets one node with one leaf child.
///
/// Takes the binary nodes (`references` is the length of their primitive order) and frees them
/// from the end as the collapse leaves them behind: it walks the subtrees right to left, so the
/// binary nodes and the wide nodes that replace them never both exist in full.
pub fn collapse(
    mut nodes: Vec<BvhNode>,
    references: usize,
) -> Result<Vec<WideNode>, TooManyReferences> {
    if references > MAX_LEAF_OFFSET as usize {
        return Err(TooManyReferences(references));
    }
    let mut out = Vec::with_capacity(nodes.len() / 3 + 1);
    let Some(root) = nodes.first() else {
        return Ok(out);
    };
    if root.is_leaf() {
        let mut n = WideNode {
            bounds: Box8::EMPTY,
            child: [EMPTY; WIDTH],
            used: 1,
        };
        n.bounds.set(0, root.min, root.max);
        n.child[0] = leaf_ref(root.offset, root.count as u32);
        out.push(n);
        return Ok(out);
    }
    // Binary nodes are handed back every 1/32 of them.
    let step = (nodes.len() / 32).max(4096);
    let mut next = nodes.len().saturating_sub(step);
    // Depth-first with an explicit work list: (binary node, wide slot to fill, end of the
    // binary node's subtree). A subtree is the range [node, end) of the depth-first array, the
    // gathered children's ranges follow each other, and the last child pushed is taken first:
    // when a node is taken, every binary node from its end on is done with.
    let mut costs = SlotCosts::of(&nodes);
    out.push(placeholder());
    let mut work = vec![(Inner::ROOT, 0u32, nodes.len() as u32)];
    let mut kids = Vec::with_capacity(WIDTH);
    while let Some((b, slot, end)) = work.pop() {
        if (end as usize) <= next {
            nodes.truncate(end as usize);
            nodes.shrink_to_fit();
            costs.forget_from(b, end);
            crate::heap::give_back_free_pages();
            next = (end as usize).saturating_sub(step);
        }
        costs.wide_slots(&nodes, b, &mut kids);
        let mut node = placeholder();
        node.used = kids.len() as u32;
        for (i, &k) in kids.iter().enumerate() {
            let n = &nodes[k.node as usize];
            node.bounds.set(i, n.min, n.max);
            node.child[i] = if n.is_leaf() {
                leaf_ref(n.offset, n.count as u32)
            } else {
                let index = out.len() as u32;
                out.push(placeholder());
                let kid_end = kids.get(i + 1).map_or(end, |k| k.node);
                work.push((k, index, kid_end));
                index
            };
        }
        out[slot as usize] = node;
    }
    Ok(out)
}

fn placeholder() -> WideNode {
    WideNode {
        bounds: Box8::EMPTY,
        child: [EMPTY; WIDTH],
        used: 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::bvh::build::build_binary;
    use crate::geometry::Aabb;

    fn boxes(n: usize) -> Vec<Aabb> {
        (0..n)
            .map(|i| {
                let x = (i * 7919 % 1000) as f32 * 0.01;
                let y = (i * 104_729 % 997) as f32 * 0.01;
                let z = (i % 13) as f32 * 0.3;
                Aabb {
                    min: [x, y, z],
                    max: [x + 0.05, y + 0.02, z + 0.1],
                }
            })
            .collect()
    }

    /// Every primitive reachable exactly once, every child box inside its parent's, nodes
    /// mostly full.
    #[test]
    fn collapse_keeps_every_primitive_and_nests_boxes() {
        // 20,000: many 4096-node steps of the freeing collapse.
        for n in [0usize, 1, 3, 4, 5, 17, 1000, 20_000] {
            let b = boxes(n);
            let bin = build_binary(&b);
            let wide = collapse(bin.nodes.clone(), bin.order.len()).expect("collapses");
            let mut seen = vec![0u32; n];
            let mut stack = vec![(0u32, None::<([f32; 3], [f32; 3])>)];
            while let Some((i, parent)) = stack.pop().filter(|_| n > 0) {
                let node = &wide[i as usize];
                assert!((1..=WIDTH as u32).contains(&node.used));
                for lane in 0..WIDTH {
                    let c = node.child[lane];
                    if lane >= node.used as usize {
                        assert_eq!(c, EMPTY);
                        continue;
                    }
                    let lo = [0, 1, 2].map(|a| node.bounds.lo[a][lane]);
                    let hi = [0, 1, 2].map(|a| node.bounds.hi[a][lane]);
                    if let Some((plo, phi)) = parent {
                        for a in 0..3 {
                            assert!(plo[a] <= lo[a] && hi[a] <= phi[a]);
                        }
                    }
                    if is_leaf(c) {
                        let (first, count) = leaf_range(c);
                        for &p in &bin.order[first..first + count] {
                            seen[p as usize] += 1;
                            let pb = &b[p as usize];
                            for a in 0..3 {
                                assert!(lo[a] <= pb.min[a] && pb.max[a] <= hi[a]);
                            }
                        }
                    } else {
                        stack.push((c, Some((lo, hi))));
                    }
                }
            }
            assert!(seen.iter().all(|&s| s == 1), "n = {n}");
            // A node stops gathering only when it is full or none of its children is inner.
            for node in &wide {
                if (node.used as usize) < WIDTH {
                    assert!(node.child[..node.used as usize].iter().all(|&c| is_leaf(c)));
                }
            }
            if n == 1000 {
                // Full eight-child nodes exist, and fewer nodes than binary inner nodes / 2.
                assert!(wide.iter().any(|node| node.used == 8));
                let wide_nodes = wide.len();
                assert!(
                    wide_nodes * 2 < bin.nodes.len() / 2,
                    "{wide_nodes} wide nodes for {} binary ones",
                    bin.nodes.len()
                );
            }
        }
    }

    fn half_area(n: &BvhNode) -> f32 {
        Aabb {
            min: n.min,
            max: n.max,
        }
        .half_area()
    }

    /// The least cost of the wide nodes below every way to cover binary node `b`'s subtree
    /// with exactly `s` slots, at index `s` (infinite where there is none): `b` alone in one
    /// slot, or a way for each child side by side. Cost is additive over the slots, so the
    /// least for each count stands for all the ways of that count.
    fn covers(nodes: &[BvhNode], b: usize) -> [f32; WIDTH + 1] {
        let n = &nodes[b];
        if n.is_leaf() {
            let mut one = [f32::INFINITY; WIDTH + 1];
            one[1] = 0.0;
            return one;
        }
        let mut all = side_by_side(nodes, b);
        all[1] = best_root(nodes, b);
        all
    }

    /// The ways to cover inner node `b`'s subtree with a way for each child, by slot count.
    fn side_by_side(nodes: &[BvhNode], b: usize) -> [f32; WIDTH + 1] {
        let (l, r) = (
            covers(nodes, b + 1),
            covers(nodes, nodes[b].offset as usize),
        );
        let mut all = [f32::INFINITY; WIDTH + 1];
        for (sl, cl) in l.iter().enumerate().skip(1) {
            for (sr, cr) in r.iter().enumerate().skip(1).take(WIDTH - sl) {
                all[sl + sr] = all[sl + sr].min(cl + cr);
            }
        }
        all
    }

    /// The least summed surface of the wide nodes of a tree rooted at inner node `b`.
    fn best_root(nodes: &[BvhNode], b: usize) -> f32 {
        let least = side_by_side(nodes, b)
            .into_iter()
            .fold(f32::INFINITY, f32::min);
        half_area(&nodes[b]) + least
    }

    /// Boxes at the corners of a tetrahedron, each again cut into four, `depth` times: a tree
    /// four-ary by construction, like the SPD tetra's.
    fn tetra_boxes(depth: u32) -> Vec<Aabb> {
        let corners = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.5, 0.87, 0.0],
            [0.5, 0.29, 0.82],
        ];
        let mut at = vec![([0f32; 3], 1f32)];
        for _ in 0..depth {
            at = at
                .iter()
                .flat_map(|&(o, size)| {
                    corners.map(|c| ([0, 1, 2].map(|a| o[a] + c[a] * size / 2.0), size / 2.0))
                })
                .collect();
        }
        at.iter()
            .map(|&(o, size)| Aabb {
                min: o,
                max: o.map(|v| v + size),
            })
            .collect()
    }

    /// The collapse is the cheapest there is: its wide nodes' summed surface (each node's box
    /// is its slot's in the parent) equals the least over every collapse ([`best_root`]). The
    /// greedy rule it replaced (open the largest inner child while a slot is free) is over the
    /// least by 7.4 % and 5.9 % on the four-ary trees of 256 and 1 024 boxes, by 3.0 % and 2.2 %
    /// on 300 and 2 000 scattered ones (and on the SPD tetra-6 it made 585 nodes, this 187).
    #[test]
    fn collapse_has_the_least_summed_surface() {
        let sets = [5usize, 17, 40, 300, 2000].map(boxes);
        for b in sets.iter().chain([&tetra_boxes(4), &tetra_boxes(5)]) {
            let bin = build_binary(b);
            let wide = collapse(bin.nodes.clone(), bin.order.len()).expect("collapses");
            let mut got = half_area(&bin.nodes[0]);
            for node in &wide {
                for lane in 0..node.used as usize {
                    if !is_leaf(node.child[lane]) {
                        let lo = [0, 1, 2].map(|a| node.bounds.lo[a][lane]);
                        let hi = [0, 1, 2].map(|a| node.bounds.hi[a][lane]);
                        got += Aabb { min: lo, max: hi }.half_area();
                    }
                }
            }
            let want = best_root(&bin.nodes, 0);
            assert!(
                (got - want).abs() <= 1e-5 * want,
                "{} boxes: the collapse's surface {got}, the least {want}",
                b.len()
            );
        }
    }

    #[test]
    fn leaf_refs_round_trip() {
        for (first, count) in [(0u32, 1u32), (5, 4), (MAX_LEAF_OFFSET, 3)] {
            let c = leaf_ref(first, count);
            assert!(is_leaf(c));
            assert_eq!(leaf_range(c), (first as usize, count as usize));
        }
        assert!(!is_leaf(12345));
    }
}
