//! Which binary nodes become the wide tree's nodes: the choice of least summed surface. Every
//! wide node is a visit (one eight-lane slab test) for each ray that enters its box, so the
//! expected cost of a tree's inner visits is proportional to the summed surface (half area) of
//! its nodes' boxes. Leaves do not enter the choice: every leaf sits in exactly one slot
//! whatever the collapse, so its primitives cost the same in all of them.
//!
//! For each inner binary node and each slot count `s` = 1..=8, [`SlotCosts`] holds the least
//! summed surface of the wide nodes that its subtree needs below at most `s` slots of a wide
//! parent. In one slot an inner node is a wide node of its own: its surface plus its children's
//! best share of eight slots; with more slots it may instead give `k` of them to its first child
//! and the rest to its second. This is the dynamic programme of Ylitie, Karras and Laine
//! ("Efficient incoherent ray traversal on GPUs through compressed wide BVHs", 2017), with their
//! leaf-forming choice left out (parrt's leaves are the binary build's).
//!
//! Only inner nodes have a row, at their rank among the inner nodes in the depth-first array
//! ([`Inner`]): the table is a quarter of the binary nodes' bytes, not half.

use super::node::BvhNode;
use super::wide::WIDTH;
use crate::geometry::Aabb;

/// A binary node and, if it is inner, its row in the table.
#[derive(Clone, Copy, Debug)]
pub struct Inner {
    /// Index in the depth-first array.
    pub node: u32,
    /// Inner nodes before it in that array (its row, when it is inner).
    pub rank: u32,
}

impl Inner {
    /// The root.
    pub const ROOT: Inner = Inner { node: 0, rank: 0 };

    /// The two children of this inner node. The first follows it in the array; the second
    /// follows the first's whole subtree, whose (`second − node − 1`) nodes are a full binary
    /// tree with `(second − node) / 2` leaves and one inner node fewer.
    fn children(self, nodes: &[BvhNode]) -> (Inner, Inner) {
        let second = nodes[self.node as usize].offset;
        (
            Inner {
                node: self.node + 1,
                rank: self.rank + 1,
            },
            Inner {
                node: second,
                rank: self.rank + (second - self.node) / 2,
            },
        )
    }
}

/// The least cost of each inner node's subtree under 1..=8 slots (index `s − 1`).
pub struct SlotCosts {
    rows: Vec<[f32; WIDTH]>,
}

const LEAF_ROW: [f32; WIDTH] = [0.0; WIDTH];

impl SlotCosts {
    /// Computes every row, from the last node back: a node's children come after it.
    pub fn of(nodes: &[BvhNode]) -> SlotCosts {
        let inner = nodes.len() / 2;
        let mut t = SlotCosts {
            rows: vec![LEAF_ROW; inner],
        };
        let mut rank = inner as u32;
        for b in (0..nodes.len()).rev() {
            let n = &nodes[b];
            if n.is_leaf() {
                continue;
            }
            rank -= 1;
            let (l, r) = Inner {
                node: b as u32,
                rank,
            }
            .children(nodes);
            let area = Aabb {
                min: n.min,
                max: n.max,
            }
            .half_area();
            let alone = area + t.best_split(nodes, l, r, WIDTH).1;
            let mut row = [alone; WIDTH];
            for s in 2..=WIDTH {
                row[s - 1] = alone.min(t.best_split(nodes, l, r, s).1);
            }
            t.rows[rank as usize] = row;
        }
        t
    }

    /// Drops the rows of every inner node from index `end` on in the array, given the inner
    /// node `b` whose subtree ends there (its rows are no longer needed).
    pub fn forget_from(&mut self, b: Inner, end: u32) {
        // The subtree [b, end) is full binary: an odd count of nodes, one more leaf than inner.
        let keep = b.rank + (end - b.node).div_ceil(2) - 1;
        self.rows.truncate(keep as usize);
        self.rows.shrink_to_fit();
    }

    fn row(&self, nodes: &[BvhNode], c: Inner) -> &[f32; WIDTH] {
        if nodes[c.node as usize].is_leaf() {
            &LEAF_ROW
        } else {
            &self.rows[c.rank as usize]
        }
    }

    /// The cheapest share of `s` ≥ 2 slots between children `l` and `r`: (slots for `l`,
    /// cost). The first of equal costs wins, so the choice is the same on every machine.
    fn best_split(&self, nodes: &[BvhNode], l: Inner, r: Inner, s: usize) -> (usize, f32) {
        let (cl, cr) = (self.row(nodes, l), self.row(nodes, r));
        let mut best = (1, cl[0] + cr[s - 2]);
        for k in 2..s {
            let c = cl[k - 1] + cr[s - k - 1];
            if c < best.1 {
                best = (k, c);
            }
        }
        best
    }

    /// The slots of inner node `b` as a wide node, left to right, into `out`.
    pub fn wide_slots(&self, nodes: &[BvhNode], b: Inner, out: &mut Vec<Inner>) {
        out.clear();
        let (l, r) = b.children(nodes);
        let (k, _) = self.best_split(nodes, l, r, WIDTH);
        self.slots(nodes, l, k, out);
        self.slots(nodes, r, WIDTH - k, out);
    }

    /// Appends, left to right, the slots that cover `c`'s subtree in at most `s` slots at the
    /// least cost: `c` itself when it is a leaf, when one slot is left, or when a wide node of
    /// its own costs no more than sharing the slots among its children.
    fn slots(&self, nodes: &[BvhNode], c: Inner, s: usize, out: &mut Vec<Inner>) {
        if nodes[c.node as usize].is_leaf() || s == 1 {
            out.push(c);
            return;
        }
        let (l, r) = c.children(nodes);
        let (k, split) = self.best_split(nodes, l, r, s);
        if self.row(nodes, c)[0] <= split {
            out.push(c);
        } else {
            self.slots(nodes, l, k, out);
            self.slots(nodes, r, s - k, out);
        }
    }
}
