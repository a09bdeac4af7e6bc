//! A Goldsmith–Salmon hierarchy (Goldsmith & Salmon 1987, "Automatic creation of object
//! hierarchies for ray tracing"): the comparator the binned-SAH build ([`super::build`]) is
//! measured against (`--accel bvh-gs`, `bench/bvh_quality.sh`). It is not meant to be fast or
//! good, only a faithful, deterministic instance of the classic incremental method.
//!
//! As in the paper the tree is n-ary, with the objects (primitives) as its leaves, and grows one
//! object at a time in a fixed-seed pseudo-random order (the paper recommends randomising the
//! input order). The hierarchy's cost is Σ area(node)/area(root) × (children of the node): the
//! tests made when a ray hits the node. An insertion walks down from the root into the child
//! whose box grows least (ties: the child whose centre is nearest, as the paper suggests), and
//! prices each place it passes by the increase of that cost, including the growth of the boxes
//! above it: a new node pairing the node passed with the object (2 × its area), the object as
//! one more child of the node passed (k × growth + area), and, where the walk ends at an object,
//! a new node pairing the two. The cheapest place on the path wins, the shallowest on a tie.
//!
//! [`BinaryBvh`] is binary with leaves of one to [`MAX_LEAF`] primitives, so each n-ary node is
//! flattened into a balanced binary tree over its children (median of their centres along the
//! widest axis), its objects gathered in leaves. The traversal's stack is fixed
//! ([`STACK_SIZE`]), so leaves may be at most [`MAX_DEPTH`] deep; insertion order can make a
//! deeper tree. Such a tree is not rejected: each subtree that would reach past the limit is
//! rebuilt by median splits from the deepest node where that still fits, with a warning, and
//! [`GsReport`] says how much was rebuilt. The build never panics.

use super::binary::BinaryBvh;
use super::build::{MAX_LEAF, STACK_SIZE};
use super::node::BvhNode;
use crate::geometry::Aabb;

/// Deepest leaf allowed: the traversal pushes at most one node per level, and a few slots of its
/// [`STACK_SIZE`] stay spare.
pub const MAX_DEPTH: u32 = STACK_SIZE as u32 - 8;

/// Seed of the insertion-order shuffle (any fixed value: the build must be reproducible).
const SHUFFLE_SEED: u64 = 0x6f6c_6473_6d69_7468;

/// "No node" in parent links.
const NONE: u32 = u32::MAX;

/// The shape of a Goldsmith–Salmon build, and what the depth limit changed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GsReport {
    /// Levels of the n-ary tree insertion produced (0: a single object).
    pub nary_depth: u32,
    /// Most children of one n-ary node.
    pub max_children: u32,
    /// Deepest leaf of the binary form before the depth limit.
    pub binary_height: u32,
    /// Subtrees rebuilt by median splits to respect [`MAX_DEPTH`].
    pub rebuilt_subtrees: u32,
    /// Primitives in those subtrees.
    pub rebuilt_prims: u64,
}

/// Builds the Goldsmith–Salmon hierarchy over primitive bounds (indexed by primitive). Logs a
/// warning when the depth limit made it rebuild part of the tree.
pub fn build_goldsmith_salmon(bounds: &[Aabb]) -> BinaryBvh {
    let (bvh, report) = build_goldsmith_salmon_with_report(bounds);
    if report.rebuilt_subtrees > 0 {
        tracing::warn!(
            height = report.binary_height,
            limit = MAX_DEPTH,
            subtrees = report.rebuilt_subtrees,
            primitives = report.rebuilt_prims,
            "Goldsmith-Salmon hierarchy too deep for the traversal stack: rebuilt its deepest \
             parts by median splits"
        );
    } else {
        tracing::debug!(?report, "Goldsmith-Salmon hierarchy built");
    }
    bvh
}

/// [`build_goldsmith_salmon`], also describing the tree and what the depth limit changed.
pub fn build_goldsmith_salmon_with_report(bounds: &[Aabb]) -> (BinaryBvh, GsReport) {
    let mut gs = Nary {
        nodes: Vec::with_capacity(bounds.len()),
        root: None,
        bounds,
    };
    for p in shuffled(bounds.len()) {
        gs.insert(p);
    }
    let mut report = GsReport::default();
    let Some(root) = gs.root else {
        return (BinaryBvh::default(), report);
    };
    (report.nary_depth, report.max_children) = gs.shape();
    let tree = gs.binarize(root);
    report.binary_height = tree.nodes[0].height;
    let mut flat = Flat {
        bvh: BinaryBvh {
            nodes: Vec::with_capacity(tree.nodes.len()),
            order: Vec::with_capacity(bounds.len()),
            max_depth: 0,
        },
        report: &mut report,
        bounds,
    };
    flat.emit(&tree, 0, 0);
    (flat.bvh, report)
}

/// `0..n` in a fixed pseudo-random order (Fisher–Yates driven by splitmix64).
fn shuffled(n: usize) -> Vec<u32> {
    let mut v: Vec<u32> = (0..n as u32).collect();
    let mut state = SHUFFLE_SEED;
    let mut next = || {
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    };
    for i in (1..v.len()).rev() {
        // Multiply-shift maps the 64-bit draw onto 0..=i without a modulo.
        let j = ((next() as u128 * (i as u128 + 1)) >> 64) as usize;
        v.swap(i, j);
    }
    v
}

#[inline]
fn area(b: &Aabb) -> f64 {
    b.half_area() as f64
}

fn dist2(a: [f32; 3], b: [f32; 3]) -> f64 {
    (0..3).map(|i| ((a[i] - b[i]) as f64).powi(2)).sum()
}

/// A child in the n-ary tree: an object (primitive) or a bounding-volume node.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Child {
    Prim(u32),
    Node(u32),
}

/// A bounding-volume node of the n-ary tree.
#[derive(Clone, Debug)]
struct NaryNode {
    bounds: Aabb,
    parent: u32,
    children: Vec<Child>,
}

/// Where an insertion puts the new object.
#[derive(Clone, Copy, Debug)]
enum Place {
    /// A new node pairs `at` (child `slot` of `parent`, or the root) with the object.
    Pair { at: Child, parent: u32, slot: usize },
    /// The object becomes one more child of this node.
    Add(u32),
}

/// The Goldsmith–Salmon tree as the paper grows it.
struct Nary<'a> {
    nodes: Vec<NaryNode>,
    root: Option<Child>,
    bounds: &'a [Aabb],
}

impl Nary<'_> {
    fn child_bounds(&self, c: Child) -> Aabb {
        match c {
            Child::Prim(p) => self.bounds[p as usize],
            Child::Node(n) => self.nodes[n as usize].bounds,
        }
    }

    /// Inserts object `p` where it raises the cost least.
    fn insert(&mut self, p: u32) {
        let b = self.bounds[p as usize];
        let place = match self.root {
            None => {
                self.root = Some(Child::Prim(p));
                return;
            }
            Some(at @ Child::Prim(_)) => Place::Pair {
                at,
                parent: NONE,
                slot: 0,
            },
            Some(Child::Node(r)) => self.choose(r, &b),
        };
        match place {
            Place::Add(n) => {
                let node = &mut self.nodes[n as usize];
                node.children.push(Child::Prim(p));
                node.bounds = node.bounds.union(&b);
                let above = node.parent;
                self.refit(above, &b);
            }
            Place::Pair { at, parent, slot } => {
                let pair = self.nodes.len() as u32;
                self.nodes.push(NaryNode {
                    bounds: self.child_bounds(at).union(&b),
                    parent,
                    children: vec![at, Child::Prim(p)],
                });
                if let Child::Node(n) = at {
                    self.nodes[n as usize].parent = pair;
                }
                if parent == NONE {
                    self.root = Some(Child::Node(pair));
                } else {
                    self.nodes[parent as usize].children[slot] = Child::Node(pair);
                }
                self.refit(parent, &b);
            }
        }
    }

    /// The cheapest place on the path from root `r` that follows the least box growth.
    fn choose(&self, r: u32, b: &Aabb) -> Place {
        let (new_area, centre) = (area(b), b.centroid());
        let (mut n, mut parent, mut slot) = (r, NONE, 0);
        // Cost the growth of the boxes above `n` adds, whatever is chosen at or below it.
        let mut inherited = 0.0f64;
        let mut best: Option<(f64, Place)> = None;
        let offer = |cost: f64, place: Place, best: &mut Option<(f64, Place)>| {
            if best.is_none_or(|(c, _)| cost < c) {
                *best = Some((cost, place));
            }
        };
        loop {
            let node = &self.nodes[n as usize];
            let old = area(&node.bounds);
            let grown = area(&node.bounds.union(b));
            let k = node.children.len() as f64;
            let at = Child::Node(n);
            // A new node over `n` and the object: two tests when it is hit.
            offer(
                inherited + 2.0 * grown,
                Place::Pair { at, parent, slot },
                &mut best,
            );
            // One more child of `n`: its k tests happen more often, plus the new one.
            inherited += k * (grown - old);
            offer(inherited + grown, Place::Add(n), &mut best);
            // Every place below costs at least the growth so far plus one test of the object's
            // box; stop when that cannot beat the best (also when it is NaN).
            let bound = inherited + new_area;
            if best.is_some_and(|(c, _)| bound >= c || bound.is_nan()) {
                break;
            }
            let mut pick: Option<(f64, f64, usize)> = None;
            for (i, &c) in node.children.iter().enumerate() {
                let cb = self.child_bounds(c);
                let key = (area(&cb.union(b)) - area(&cb), dist2(cb.centroid(), centre));
                if pick.is_none_or(|(g, d, _)| key.0 < g || (key.0 == g && key.1 < d)) {
                    pick = Some((key.0, key.1, i));
                }
            }
            let Some((_, _, i)) = pick else { break };
            match node.children[i] {
                at @ Child::Prim(o) => {
                    let paired = area(&self.bounds[o as usize].union(b));
                    offer(
                        inherited + 2.0 * paired,
                        Place::Pair {
                            at,
                            parent: n,
                            slot: i,
                        },
                        &mut best,
                    );
                    break;
                }
                Child::Node(m) => (n, parent, slot) = (m, n, i),
            }
        }
        best.map_or(
            Place::Pair {
                at: Child::Node(r),
                parent: NONE,
                slot: 0,
            },
            |(_, place)| place,
        )
    }

    /// Grows the boxes from `n` up to the root by `b` after an insertion below them.
    fn refit(&mut self, mut n: u32, b: &Aabb) {
        while n != NONE {
            let node = &mut self.nodes[n as usize];
            node.bounds = node.bounds.union(b);
            n = node.parent;
        }
    }

    /// (levels of nodes, most children of one node).
    fn shape(&self) -> (u32, u32) {
        let (mut depth, mut widest) = (0, 0);
        let mut todo: Vec<(Child, u32)> = self.root.into_iter().map(|c| (c, 0)).collect();
        while let Some((c, d)) = todo.pop() {
            if let Child::Node(n) = c {
                let children = &self.nodes[n as usize].children;
                depth = depth.max(d + 1);
                widest = widest.max(children.len() as u32);
                todo.extend(children.iter().map(|&c| (c, d + 1)));
            }
        }
        (depth, widest)
    }

    /// The binary form: each node a balanced binary tree over its children (median of their
    /// centres along the widest axis), objects gathered in leaves of up to [`MAX_LEAF`]. Node 0
    /// is the root and children follow their parents in the arena.
    fn binarize(&self, root: Child) -> Tree {
        let mut tree = Tree { nodes: Vec::new() };
        // (children to cover, parent in `tree`, which child of it)
        let mut todo = vec![(vec![root], NONE, 0usize)];
        while let Some((mut items, parent, side)) = todo.pop() {
            // A lone node is its children.
            while let [Child::Node(n)] = items[..] {
                items = self.nodes[n as usize].children.clone();
            }
            let bounds = items
                .iter()
                .fold(Aabb::EMPTY, |acc, &c| acc.union(&self.child_bounds(c)));
            let me = tree.nodes.len() as u32;
            let all_prims = items.iter().all(|c| matches!(c, Child::Prim(_)));
            if all_prims && items.len() <= MAX_LEAF {
                let mut prims = [0; MAX_LEAF];
                for (slot, c) in prims.iter_mut().zip(&items) {
                    if let Child::Prim(p) = c {
                        *slot = *p;
                    }
                }
                tree.nodes.push(Node {
                    bounds,
                    height: 0,
                    prims: items.len() as u64,
                    kind: Kind::Leaf {
                        prims,
                        len: items.len() as u8,
                    },
                });
            } else {
                tree.nodes.push(Node {
                    bounds,
                    height: 0,
                    prims: 0,
                    kind: Kind::Interior { children: [0; 2] },
                });
                let right = self.split(&mut items);
                todo.push((right, me, 1));
                todo.push((items, me, 0));
            }
            if parent != NONE {
                if let Kind::Interior { children } = &mut tree.nodes[parent as usize].kind {
                    children[side] = me;
                }
            }
        }
        // Children come after their parents: heights and counts bottom-up.
        for i in (0..tree.nodes.len()).rev() {
            if let Kind::Interior { children } = tree.nodes[i].kind {
                let (a, b) = (
                    &tree.nodes[children[0] as usize],
                    &tree.nodes[children[1] as usize],
                );
                let (height, prims) = (1 + a.height.max(b.height), a.prims + b.prims);
                tree.nodes[i].height = height;
                tree.nodes[i].prims = prims;
            }
        }
        tree
    }

    /// Splits `items` (at least two) at the median centre along the widest axis of the centres;
    /// `items` keeps the first half, the second is returned.
    fn split(&self, items: &mut Vec<Child>) -> Vec<Child> {
        let mut cbounds = Aabb::EMPTY;
        for &c in items.iter() {
            cbounds.add_point(self.child_bounds(c).centroid());
        }
        let axis = widest_axis(&cbounds);
        let key = |c: &Child| {
            let id = match *c {
                Child::Prim(p) => (0, p),
                Child::Node(n) => (1, n),
            };
            (self.child_bounds(*c).centroid()[axis], id)
        };
        let mid = items.len().div_ceil(2);
        items.select_nth_unstable_by(mid - 1, |a, b| {
            let (ka, kb) = (key(a), key(b));
            ka.0.total_cmp(&kb.0).then(ka.1.cmp(&kb.1))
        });
        items.split_off(mid)
    }
}

/// The axis along which `b` is widest (0 when it is empty or not a number).
fn widest_axis(b: &Aabb) -> usize {
    let mut axis = 0;
    let mut widest = f32::NEG_INFINITY;
    for a in 0..3 {
        let e = b.max[a] - b.min[a];
        if e > widest {
            widest = e;
            axis = a;
        }
    }
    axis
}

#[derive(Clone, Copy, Debug)]
enum Kind {
    Leaf { prims: [u32; MAX_LEAF], len: u8 },
    Interior { children: [u32; 2] },
}

/// A node of the binary form.
#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: Aabb,
    /// Longest path down to a leaf (0 for a leaf).
    height: u32,
    /// Primitives below.
    prims: u64,
    kind: Kind,
}

/// The binary form of the n-ary tree, before the depth limit.
struct Tree {
    nodes: Vec<Node>,
}

/// Levels a median-split tree over `m` primitives needs below its root.
fn median_height(m: u64) -> u32 {
    let mut m = m;
    let mut h = 0;
    while m > MAX_LEAF as u64 {
        m = m.div_ceil(2);
        h += 1;
    }
    h
}

#[derive(Clone, Copy)]
struct Item {
    bounds: Aabb,
    centroid: [f32; 3],
    index: u32,
}

/// The flat hierarchy being written.
struct Flat<'a> {
    bvh: BinaryBvh,
    report: &'a mut GsReport,
    bounds: &'a [Aabb],
}

impl Flat<'_> {
    fn push(&mut self, bounds: &Aabb, depth: u32) -> u32 {
        self.bvh.max_depth = self.bvh.max_depth.max(depth);
        self.bvh.nodes.push(BvhNode {
            min: bounds.min,
            offset: 0,
            max: bounds.max,
            count: 0,
            axis: 0,
        });
        (self.bvh.nodes.len() - 1) as u32
    }

    fn leaf(&mut self, bounds: &Aabb, prims: impl Iterator<Item = u32>, depth: u32) -> u32 {
        let me = self.push(bounds, depth);
        let first = self.bvh.order.len();
        self.bvh.order.extend(prims);
        let node = &mut self.bvh.nodes[me as usize];
        node.offset = first as u32;
        node.count = (self.bvh.order.len() - first) as u16;
        me
    }

    /// Writes tree node `n` at `depth` depth-first and returns its index. On entry the subtree
    /// fits as it is or rebuilt (`depth + min(height, median_height(prims)) <= MAX_DEPTH`); an
    /// interior node that does not fit as it is keeps its place while both children fit, and is
    /// rebuilt otherwise, so only the deepest parts that must change do.
    fn emit(&mut self, tree: &Tree, n: u32, depth: u32) -> u32 {
        let node = &tree.nodes[n as usize];
        match node.kind {
            Kind::Leaf { prims, len } => {
                self.leaf(&node.bounds, prims[..len as usize].iter().copied(), depth)
            }
            Kind::Interior { children } => {
                let fits = |c: u32| {
                    let c = &tree.nodes[c as usize];
                    depth + 1 + c.height.min(median_height(c.prims)) <= MAX_DEPTH
                };
                if depth + node.height <= MAX_DEPTH || (fits(children[0]) && fits(children[1])) {
                    let me = self.push(&node.bounds, depth);
                    self.emit(tree, children[0], depth + 1);
                    let second = self.emit(tree, children[1], depth + 1);
                    self.bvh.nodes[me as usize].offset = second;
                    me
                } else {
                    self.rebuild(tree, n, depth)
                }
            }
        }
    }

    /// Replaces the subtree at `n` by a median-split one.
    fn rebuild(&mut self, tree: &Tree, n: u32, depth: u32) -> u32 {
        let mut items = Vec::new();
        let mut todo = vec![n];
        while let Some(m) = todo.pop() {
            match tree.nodes[m as usize].kind {
                Kind::Leaf { prims, len } => {
                    items.extend(prims[..len as usize].iter().map(|&p| {
                        let b = self.bounds[p as usize];
                        Item {
                            bounds: b,
                            centroid: b.centroid(),
                            index: p,
                        }
                    }));
                }
                Kind::Interior { children } => todo.extend(children),
            }
        }
        self.report.rebuilt_subtrees += 1;
        self.report.rebuilt_prims += items.len() as u64;
        self.median(&mut items, depth)
    }

    /// A median-split subtree over `items` (leaves of up to [`MAX_LEAF`]).
    fn median(&mut self, items: &mut [Item], depth: u32) -> u32 {
        let mut bounds = Aabb::EMPTY;
        let mut cbounds = Aabb::EMPTY;
        for it in items.iter() {
            bounds = bounds.union(&it.bounds);
            cbounds.add_point(it.centroid);
        }
        if items.len() <= MAX_LEAF {
            return self.leaf(&bounds, items.iter().map(|it| it.index), depth);
        }
        let axis = widest_axis(&cbounds);
        // The first half gets the larger share, matching `median_height`.
        let mid = items.len().div_ceil(2);
        items.select_nth_unstable_by(mid - 1, |a, b| {
            a.centroid[axis]
                .total_cmp(&b.centroid[axis])
                .then(a.index.cmp(&b.index))
        });
        let me = self.push(&bounds, depth);
        let (left, right) = items.split_at_mut(mid);
        self.median(left, depth + 1);
        let second = self.median(right, depth + 1);
        self.bvh.nodes[me as usize].offset = second;
        me
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator for test boxes.
    struct Rng(u64);

    impl Rng {
        fn unit(&mut self) -> f32 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    fn random_boxes(n: usize, seed: u64) -> Vec<Aabb> {
        let mut rng = Rng(seed);
        (0..n)
            .map(|i| {
                let c = [rng.unit() * 100.0, rng.unit() * 100.0, rng.unit() * 100.0];
                // Mostly small boxes, a few large and a few flat ones.
                let s = if i % 50 == 0 { 40.0 } else { 2.0 };
                let mut e = [rng.unit() * s, rng.unit() * s, rng.unit() * s];
                if i % 7 == 0 {
                    e[i % 3] = 0.0;
                }
                Aabb {
                    min: [c[0] - e[0], c[1] - e[1], c[2] - e[2]],
                    max: [c[0] + e[0], c[1] + e[1], c[2] + e[2]],
                }
            })
            .collect()
    }

    fn contains(outer: &BvhNode, inner: &Aabb) -> bool {
        (0..3).all(|a| outer.min[a] <= inner.min[a] && inner.max[a] <= outer.max[a])
    }

    fn node_box(n: &BvhNode) -> Aabb {
        Aabb {
            min: n.min,
            max: n.max,
        }
    }

    /// Checks the subtree at `i` (at `depth`) and returns (one past its last node, deepest leaf,
    /// one past its last order slot); `next_prim` is where its first leaf must start in `order`.
    fn walk(
        bvh: &BinaryBvh,
        bounds: &[Aabb],
        i: usize,
        depth: u32,
        next_prim: usize,
    ) -> (usize, u32, usize) {
        let n = &bvh.nodes[i];
        if n.is_leaf() {
            assert!(
                (1..=MAX_LEAF as u16).contains(&n.count),
                "leaf size {}",
                n.count
            );
            assert_eq!(n.offset as usize, next_prim, "leaves cover order in order");
            let end = next_prim + n.count as usize;
            for &p in &bvh.order[next_prim..end] {
                assert!(contains(n, &bounds[p as usize]), "leaf {i} holds prim {p}");
            }
            return (i + 1, depth, end);
        }
        assert_eq!(n.count, 0);
        for c in [i + 1, n.offset as usize] {
            assert!(c < bvh.nodes.len());
            assert!(
                contains(n, &node_box(&bvh.nodes[c])),
                "node {i} holds child {c}"
            );
        }
        let (end_l, dl, p) = walk(bvh, bounds, i + 1, depth + 1, next_prim);
        assert_eq!(
            end_l, n.offset as usize,
            "second child follows the first subtree"
        );
        let (end_r, dr, p) = walk(bvh, bounds, end_l, depth + 1, p);
        (end_r, dl.max(dr), p)
    }

    fn check(bounds: &[Aabb]) -> (BinaryBvh, GsReport) {
        let (bvh, report) = build_goldsmith_salmon_with_report(bounds);
        let mut seen = vec![0u32; bounds.len()];
        for &p in &bvh.order {
            seen[p as usize] += 1;
        }
        assert!(seen.iter().all(|&k| k == 1), "every primitive exactly once");
        assert_eq!(bvh.order.len(), bounds.len());
        if bounds.is_empty() {
            assert!(bvh.nodes.is_empty());
            return (bvh, report);
        }
        let (end, deepest, prims) = walk(&bvh, bounds, 0, 0, 0);
        assert_eq!(end, bvh.nodes.len(), "every node reachable once");
        assert_eq!(prims, bounds.len());
        assert_eq!(deepest, bvh.max_depth);
        assert!(bvh.max_depth <= MAX_DEPTH, "depth {}", bvh.max_depth);
        assert!(bvh.sah_cost().is_finite());
        (bvh, report)
    }

    #[test]
    fn empty_and_single() {
        let (bvh, _) = check(&[]);
        assert_eq!(bvh.max_depth, 0);
        let b = Aabb {
            min: [1.0, 2.0, 3.0],
            max: [2.0, 3.0, 4.0],
        };
        let (bvh, _) = check(&[b]);
        assert_eq!(bvh.nodes.len(), 1);
        assert_eq!(bvh.order, vec![0]);
        assert_eq!(node_box(&bvh.nodes[0]), b);
    }

    #[test]
    fn random_boxes_make_valid_trees() {
        for (n, seed) in [(2, 1), (5, 2), (17, 3), (300, 4), (5000, 5)] {
            let bounds = random_boxes(n, seed);
            let (bvh, _) = check(&bounds);
            // The root is the whole scene.
            let world = bounds.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
            assert_eq!(bvh.world(), world);
        }
    }

    #[test]
    fn deterministic() {
        let bounds = random_boxes(1000, 9);
        let a = build_goldsmith_salmon(&bounds);
        let b = build_goldsmith_salmon(&bounds);
        assert_eq!(a.nodes, b.nodes);
        assert_eq!(a.order, b.order);
    }

    #[test]
    fn clusters_are_grouped() {
        // Two far clusters: the root's children are the two clusters.
        let mut bounds = random_boxes(200, 11);
        for b in random_boxes(200, 12) {
            bounds.push(Aabb {
                min: [b.min[0] + 1000.0, b.min[1], b.min[2]],
                max: [b.max[0] + 1000.0, b.max[1], b.max[2]],
            });
        }
        let (bvh, _) = check(&bounds);
        let (l, r) = (&bvh.nodes[1], &bvh.nodes[bvh.nodes[0].offset as usize]);
        let (near, far) = if l.min[0] < r.min[0] { (l, r) } else { (r, l) };
        assert!(
            near.max[0] < 500.0 && far.min[0] > 500.0,
            "{near:?} {far:?}"
        );
    }

    #[test]
    fn identical_boxes_share_one_node() {
        // Adding one more child (cost: its area) beats pairing (twice its area) everywhere.
        let b = Aabb {
            min: [0.0; 3],
            max: [1.0; 3],
        };
        let bounds = vec![b; 3000];
        let (bvh, report) = check(&bounds);
        assert_eq!(
            (report.nary_depth, report.max_children),
            (1, 3000),
            "{report:?}"
        );
        assert_eq!(report.rebuilt_subtrees, 0);
        assert_eq!(bvh.max_depth, median_height(3000));
    }

    #[test]
    fn too_deep_trees_are_rebuilt_below_the_limit() {
        // A chain of 3000 one-primitive leaves, as an insertion order could make.
        let n = 3000usize;
        let bounds = random_boxes(n, 21);
        let mut nodes = Vec::new();
        for i in 0..n - 1 {
            let mut prims = [0; MAX_LEAF];
            prims[0] = i as u32;
            nodes.push(Node {
                bounds: bounds[i..].iter().fold(Aabb::EMPTY, |a, b| a.union(b)),
                height: (n - 1 - i) as u32,
                prims: (n - i) as u64,
                kind: Kind::Interior {
                    children: [2 * i as u32 + 1, 2 * i as u32 + 2],
                },
            });
            nodes.push(Node {
                bounds: bounds[i],
                height: 0,
                prims: 1,
                kind: Kind::Leaf { prims, len: 1 },
            });
        }
        let mut prims = [0; MAX_LEAF];
        prims[0] = n as u32 - 1;
        nodes.push(Node {
            bounds: bounds[n - 1],
            height: 0,
            prims: 1,
            kind: Kind::Leaf { prims, len: 1 },
        });
        let tree = Tree { nodes };
        let mut report = GsReport::default();
        let mut flat = Flat {
            bvh: BinaryBvh::default(),
            report: &mut report,
            bounds: &bounds,
        };
        flat.emit(&tree, 0, 0);
        let bvh = flat.bvh;
        assert_eq!(report.rebuilt_subtrees, 1);
        // Rebuilt as deep as possible: the last spine node whose median rebuild still fits.
        let rebuilt = report.rebuilt_prims;
        assert!(bvh.max_depth <= MAX_DEPTH);
        assert_eq!(
            n as u64 - rebuilt,
            (MAX_DEPTH - median_height(rebuilt)) as u64,
            "{report:?}"
        );
        let (end, deepest, prims) = walk(&bvh, &bounds, 0, 0, 0);
        assert_eq!((end, deepest, prims), (bvh.nodes.len(), bvh.max_depth, n));
    }

    #[test]
    fn degenerate_boxes_do_not_panic() {
        let mut bounds = random_boxes(50, 13);
        bounds.push(Aabb::EMPTY);
        bounds.push(Aabb {
            min: [5.0; 3],
            max: [5.0; 3],
        });
        bounds.push(Aabb {
            min: [f32::NEG_INFINITY, 0.0, 0.0],
            max: [f32::INFINITY, 1.0, 1.0],
        });
        let (bvh, _) = build_goldsmith_salmon_with_report(&bounds);
        let mut order = bvh.order.clone();
        order.sort_unstable();
        assert_eq!(order, (0..bounds.len() as u32).collect::<Vec<_>>());
        assert!(bvh.max_depth <= MAX_DEPTH);
    }

    #[test]
    fn median_height_matches_median_build() {
        for m in [1u64, 4, 5, 8, 9, 16, 17, 1000] {
            let bounds = vec![
                Aabb {
                    min: [0.0; 3],
                    max: [1.0; 3],
                };
                m as usize
            ];
            let mut report = GsReport::default();
            let mut flat = Flat {
                bvh: BinaryBvh::default(),
                report: &mut report,
                bounds: &bounds,
            };
            let mut items: Vec<Item> = bounds
                .iter()
                .enumerate()
                .map(|(i, b)| Item {
                    bounds: *b,
                    centroid: b.centroid(),
                    index: i as u32,
                })
                .collect();
            flat.median(&mut items, 0);
            assert_eq!(flat.bvh.max_depth, median_height(m), "m = {m}");
        }
    }

    #[test]
    fn shuffle_is_a_permutation() {
        let mut v = shuffled(1000);
        assert_ne!(v, (0..1000).collect::<Vec<_>>());
        v.sort_unstable();
        assert_eq!(v, (0..1000).collect::<Vec<_>>());
        assert!(shuffled(0).is_empty());
    }
}
