//! The 8-wide BVH the traversal walks: the binary SAH tree collapsed so that each node holds up
//! to eight children's boxes side by side ([`Box8`]) and one ray tests all eight in a single
//! SIMD slab test. A child is an inner node or a leaf (a run of at most [`MAX_LEAF`] primitives in
//! the primitive order), packed into one `u32` ([`ChildRef`]).

use super::build::MAX_LEAF;
use super::node::BvhNode;
use crate::geometry::slab::Box8;
use crate::geometry::Aabb;

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

/// Collapses a binary tree: each wide node takes its binary node's two children and, while it
/// has fewer than eight, replaces the inner child with the largest surface by that child's own
/// two children. No nodes for an empty tree; a tree that is a single leaf gets one node with
/// one leaf child.
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
    out.push(placeholder());
    let mut work = vec![(0u32, 0u32, nodes.len() as u32)];
    while let Some((b, slot, end)) = work.pop() {
        if (end as usize) <= next {
            nodes.truncate(end as usize);
            nodes.shrink_to_fit();
            crate::heap::give_back_free_pages();
            next = (end as usize).saturating_sub(step);
        }
        let kids = gather(&nodes, b);
        let mut node = placeholder();
        node.used = kids.len() as u32;
        for (i, &k) in kids.iter().enumerate() {
            let n = &nodes[k as usize];
            node.bounds.set(i, n.min, n.max);
            node.child[i] = if n.is_leaf() {
                leaf_ref(n.offset, n.count as u32)
            } else {
                let index = out.len() as u32;
                out.push(placeholder());
                let kid_end = kids.get(i + 1).copied().unwrap_or(end);
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

/// Up to eight binary descendants of inner node `b` that together hold its whole subtree.
fn gather(nodes: &[BvhNode], b: u32) -> Vec<u32> {
    let n = &nodes[b as usize];
    let mut kids = vec![b + 1, n.offset];
    while kids.len() < WIDTH {
        let area = |k: u32| {
            let n = &nodes[k as usize];
            Aabb {
                min: n.min,
                max: n.max,
            }
            .half_area()
        };
        let Some((pos, _)) = kids
            .iter()
            .enumerate()
            .filter(|(_, &k)| !nodes[k as usize].is_leaf())
            .max_by(|(_, &a), (_, &b)| area(a).total_cmp(&area(b)))
        else {
            break;
        };
        let k = kids[pos];
        let inner = &nodes[k as usize];
        kids[pos] = k + 1;
        kids.insert(pos + 1, inner.offset);
    }
    kids
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::bvh::build::build_binary;

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
