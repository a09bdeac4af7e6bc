//! Binned SAH construction (16 bins per axis), written straight into the flat depth-first node
//! array. Leaves hold at most [`MAX_LEAF`] primitives; deep branches fall back to median splits
//! so the traversal stack can never overflow.

use super::binary::BinaryBvh;
use super::node::BvhNode;
use crate::geometry::Aabb;

/// Bins per axis.
const BINS: usize = 16;
/// Largest leaf the SAH may choose.
pub const MAX_LEAF: usize = 4;
/// Cost of one node visit relative to one primitive test.
pub const TRAVERSAL_COST: f32 = 1.0;
/// Below this depth the SAH decides; deeper, splits are at the median so depth stays bounded.
const SAH_DEPTH_LIMIT: u32 = 56;
/// Traversal stack size: SAH depth limit plus a balanced tree over 2^32 primitives.
pub const STACK_SIZE: usize = 96;

#[derive(Clone, Copy)]
struct Item {
    bounds: Aabb,
    centroid: [f32; 3],
    index: u32,
}

struct Builder {
    nodes: Vec<BvhNode>,
    max_depth: u32,
}

/// Builds the binary SAH hierarchy over primitive bounds (indexed by primitive).
pub fn build_binary(bounds: &[Aabb]) -> BinaryBvh {
    let mut items: Vec<Item> = bounds
        .iter()
        .enumerate()
        .map(|(i, b)| Item {
            bounds: *b,
            centroid: b.centroid(),
            index: i as u32,
        })
        .collect();
    let mut b = Builder {
        nodes: Vec::with_capacity(2 * items.len().max(1) / MAX_LEAF + 1),
        max_depth: 0,
    };
    if !items.is_empty() {
        b.build(&mut items, 0, 0);
    }
    BinaryBvh {
        nodes: b.nodes,
        order: items.iter().map(|it| it.index).collect(),
        max_depth: b.max_depth,
    }
}

impl Builder {
    /// Builds the subtree over `items` (which start at `first` in the final order) and returns
    /// its node index.
    fn build(&mut self, items: &mut [Item], first: usize, depth: u32) -> u32 {
        self.max_depth = self.max_depth.max(depth);
        let me = self.nodes.len() as u32;
        let mut bounds = Aabb::EMPTY;
        let mut cbounds = Aabb::EMPTY;
        for it in items.iter() {
            bounds = bounds.union(&it.bounds);
            cbounds.add_point(it.centroid);
        }
        self.nodes.push(BvhNode {
            min: bounds.min,
            offset: first as u32,
            max: bounds.max,
            count: items.len() as u16,
            axis: 0,
        });
        let n = items.len();
        if n == 1 {
            return me;
        }
        let split = if depth < SAH_DEPTH_LIMIT {
            self.sah_split(items, &bounds, &cbounds)
        } else {
            Some(median_split(items, &cbounds))
        };
        let (mid, axis) = match split {
            Some(s) => s,
            None if n <= MAX_LEAF => return me,
            None => median_split(items, &cbounds),
        };
        let (left, right) = items.split_at_mut(mid);
        self.build(left, first, depth + 1);
        let second = self.build(right, first + mid, depth + 1);
        let node = &mut self.nodes[me as usize];
        node.offset = second;
        node.count = 0;
        node.axis = axis as u16;
        me
    }

    /// Chooses the cheapest binned split, partitions `items` and returns `(mid, axis)`; `None`
    /// when a leaf is cheaper (only considered for small sets) or no split separates anything.
    fn sah_split(
        &mut self,
        items: &mut [Item],
        bounds: &Aabb,
        cbounds: &Aabb,
    ) -> Option<(usize, usize)> {
        let n = items.len();
        let mut best: Option<(f32, usize, usize)> = None; // (cost, axis, bin boundary)
        for axis in 0..3 {
            let lo = cbounds.min[axis];
            let extent = cbounds.max[axis] - lo;
            if !(extent > 0.0) {
                continue;
            }
            let scale = BINS as f32 / extent;
            let mut counts = [0u32; BINS];
            let mut boxes = [Aabb::EMPTY; BINS];
            for it in items.iter() {
                let b = bin_of(it.centroid[axis], lo, scale);
                counts[b] += 1;
                boxes[b] = boxes[b].union(&it.bounds);
            }
            // Sweep from the right to get suffix areas, then from the left.
            let mut right_area = [0.0f32; BINS];
            let mut right_count = [0u32; BINS];
            let mut acc = Aabb::EMPTY;
            let mut cnt = 0;
            for i in (1..BINS).rev() {
                acc = acc.union(&boxes[i]);
                cnt += counts[i];
                right_area[i] = acc.half_area();
                right_count[i] = cnt;
            }
            let mut acc = Aabb::EMPTY;
            let mut cnt = 0;
            for i in 0..BINS - 1 {
                acc = acc.union(&boxes[i]);
                cnt += counts[i];
                let (nl, nr) = (cnt, right_count[i + 1]);
                if nl == 0 || nr == 0 {
                    continue;
                }
                let cost = acc.half_area() * nl as f32 + right_area[i + 1] * nr as f32;
                if best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, axis, i + 1));
                }
            }
        }
        let (cost, axis, boundary) = best?;
        let area = bounds.half_area();
        let split_cost = TRAVERSAL_COST + if area > 0.0 { cost / area } else { n as f32 };
        if n <= MAX_LEAF && split_cost >= n as f32 {
            return None;
        }
        let lo = cbounds.min[axis];
        let scale = BINS as f32 / (cbounds.max[axis] - lo);
        let mid = partition(items, |it| bin_of(it.centroid[axis], lo, scale) < boundary);
        if mid == 0 || mid == n {
            return None;
        }
        Some((mid, axis))
    }
}

#[inline]
fn bin_of(c: f32, lo: f32, scale: f32) -> usize {
    let b = ((c - lo) * scale) as isize;
    b.clamp(0, BINS as isize - 1) as usize
}

/// Splits at the median centroid along the widest centroid axis (by index when all are equal).
fn median_split(items: &mut [Item], cbounds: &Aabb) -> (usize, usize) {
    let mut axis = 0;
    let mut widest = -1.0f32;
    for a in 0..3 {
        let e = cbounds.max[a] - cbounds.min[a];
        if e > widest {
            widest = e;
            axis = a;
        }
    }
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |a, b| {
        a.centroid[axis]
            .total_cmp(&b.centroid[axis])
            .then(a.index.cmp(&b.index))
    });
    (mid, axis)
}

/// Stable-enough in-place partition: items satisfying `pred` first; returns their count.
fn partition(items: &mut [Item], pred: impl Fn(&Item) -> bool) -> usize {
    let mut i = 0;
    for j in 0..items.len() {
        if pred(&items[j]) {
            items.swap(i, j);
            i += 1;
        }
    }
    i
}
