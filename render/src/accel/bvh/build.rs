//! Binned SAH construction (16 bins per axis), written straight into the flat depth-first node
//! array. Leaves hold at most [`MAX_LEAF`] primitives; deep branches fall back to median splits
//! so the traversal stack can never overflow.
//!
//! Speed and memory: each primitive is a 32-byte box (`Item`, four lanes per corner so the
//! box arithmetic vectorises) plus its index in a parallel array that ends up as the primitive
//! order. A node makes one pass over its items to bin all three axes at once (alternating
//! between two sets of bins, so consecutive items in the same bin do not wait on each other),
//! and one partition pass that also gathers the children's centroid bounds; the children's
//! boxes are unions of bins, so a child starts binning at once. Small nodes sort their few items
//! by bin instead of clearing and sweeping bins, which chooses exactly the split the bins would.
//! The node array is reserved once at its upper bound (capacity never written costs no memory)
//! and trimmed at the end.

use super::binary::BinaryBvh;
use super::node::BvhNode;
use crate::geometry::Aabb;
use std::convert::Infallible;

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
/// Nodes with at most this many primitives find their split by sorting instead of binning.
const SMALL: usize = 24;
/// Nodes with at least this many primitives bin into two sets of bins.
const TWO_SETS: usize = 256;

/// Four `f32` lanes; the fourth is 0 in item boxes and unused in results.
type V4 = [f32; 4];

/// A box with four-lane corners (an item's bounds, a bin, a node).
#[derive(Clone, Copy)]
#[repr(C, align(16))]
struct Item {
    lo: V4,
    hi: V4,
}

/// Lane-wise minimum; a NaN in `a` gives `b` (one `minps`).
#[inline(always)]
fn vmin(a: V4, b: V4) -> V4 {
    std::array::from_fn(|k| if a[k] < b[k] { a[k] } else { b[k] })
}

/// Lane-wise maximum; a NaN in `a` gives `b` (one `maxps`).
#[inline(always)]
fn vmax(a: V4, b: V4) -> V4 {
    std::array::from_fn(|k| if a[k] > b[k] { a[k] } else { b[k] })
}

impl Item {
    const EMPTY: Item = Item {
        lo: [f32::INFINITY; 4],
        hi: [f32::NEG_INFINITY; 4],
    };

    #[inline(always)]
    fn from_aabb(b: &Aabb) -> Item {
        Item {
            lo: [b.min[0], b.min[1], b.min[2], 0.0],
            hi: [b.max[0], b.max[1], b.max[2], 0.0],
        }
    }

    #[inline(always)]
    fn aabb(&self) -> Aabb {
        Aabb {
            min: [self.lo[0], self.lo[1], self.lo[2]],
            max: [self.hi[0], self.hi[1], self.hi[2]],
        }
    }

    /// The centroid (the same values as [`Aabb::centroid`]).
    #[inline(always)]
    fn centroid(&self) -> V4 {
        std::array::from_fn(|k| 0.5 * (self.lo[k] + self.hi[k]))
    }

    /// Grows to contain box `o`; NaN coordinates of `o` are ignored, as [`Aabb::union`] does.
    #[inline(always)]
    fn grow(&mut self, o: &Item) {
        self.lo = vmin(o.lo, self.lo);
        self.hi = vmax(o.hi, self.hi);
    }

    /// Grows to contain point `p`; NaN coordinates are ignored, as [`Aabb::add_point`] does.
    #[inline(always)]
    fn grow_point(&mut self, p: V4) {
        self.lo = vmin(p, self.lo);
        self.hi = vmax(p, self.hi);
    }

    /// Half the surface area, computed as [`Aabb::half_area`] does.
    #[inline(always)]
    fn half_area(&self) -> f32 {
        let dx = (self.hi[0] - self.lo[0]).max(0.0);
        let dy = (self.hi[1] - self.lo[1]).max(0.0);
        let dz = (self.hi[2] - self.lo[2]).max(0.0);
        dx * dy + dy * dz + dz * dx
    }
}

/// Maps centroids to bins on each axis: `((c - lo) * scale)` truncated and clamped to the bins.
#[derive(Clone, Copy)]
struct Binning {
    lo: V4,
    scale: V4,
    /// Axes along which the centroids spread (the others are not costed).
    spread: [bool; 3],
}

impl Binning {
    fn new(cbounds: &Item) -> Binning {
        let mut b = Binning {
            lo: [0.0; 4],
            scale: [0.0; 4],
            spread: [false; 3],
        };
        for a in 0..3 {
            let extent = cbounds.hi[a] - cbounds.lo[a];
            if extent > 0.0 {
                b.lo[a] = cbounds.lo[a];
                b.scale[a] = BINS as f32 / extent;
                b.spread[a] = true;
            }
        }
        b
    }

    /// The bins of centroid `c` on all axes (lane 3 meaningless). NaN goes to bin 0.
    #[inline(always)]
    fn bins(&self, c: V4) -> [usize; 4] {
        let x: [i32; 4] = std::array::from_fn(|k| {
            let x = (c[k] - self.lo[k]) * self.scale[k];
            let x = if x > 0.0 { x } else { 0.0 };
            let x = if x < (BINS - 1) as f32 {
                x
            } else {
                (BINS - 1) as f32
            };
            // SAFETY: `x` is a number in [0, BINS - 1] (NaN became 0 above).
            unsafe { x.to_int_unchecked::<i32>() }
        });
        // The mask changes nothing (the bins are in range); it spares the bounds checks.
        x.map(|b| b as usize & (BINS - 1))
    }

    /// True when centroid coordinate `c` on `axis` falls in a bin below `boundary` (in
    /// 1..BINS): the same as `bins(c)[axis] < boundary`, since truncating and clamping a number
    /// keep it below an integer in range exactly when it was below, and NaN goes to bin 0.
    #[inline(always)]
    fn below(&self, c: f32, axis: usize, boundary: f32) -> bool {
        !((c - self.lo[axis]) * self.scale[axis] >= boundary)
    }
}

/// A chosen split: the items are partitioned, left first; each side's box and centroid box.
struct Split {
    mid: usize,
    axis: usize,
    left: (Item, Item),
    right: (Item, Item),
}

struct Builder {
    nodes: Vec<BvhNode>,
    max_depth: u32,
    /// Scratch space of the median split.
    scratch: Vec<(Item, u32)>,
}

/// Builds the binary SAH hierarchy over primitive bounds (indexed by primitive).
pub fn build_binary(bounds: &[Aabb]) -> BinaryBvh {
    build_items(items_of(bounds))
}

/// Like [`build_binary`], but frees the bounds while the build's own copy of them is made, and
/// the items of each large subtree once it is built, so the bounds, the build records and the
/// tree's nodes never all exist in full: the same tree, a lower peak.
pub fn build_binary_owned(bounds: Vec<Aabb>) -> BinaryBvh {
    // The records are made from the last box back, the boxes' array shrunk every 1/32, then put
    // in order.
    let n = bounds.len();
    let mut items: Vec<Item> = Vec::with_capacity(n);
    let Ok(()) = crate::heap::drain_back(bounds, |_, b| {
        items.push(Item::from_aabb(&b));
        Ok::<(), Infallible>(())
    });
    items.reverse();
    let (world, cworld) = extent(&items);
    let mut order: Vec<u32> = (0..n as u32).collect();
    let mut b = Builder::new(n);
    if n > 0 {
        let owned = OwnedItems {
            min_len: (n / 8).max(OWNED_MIN),
        };
        b.build_owned(owned, items, &mut order, 0, world, cworld, 0);
    }
    b.finish(order)
}

/// Subtrees with at least this many items (and at least 1/8 of all: three levels, so few items
/// are copied) keep their items in their own allocation, freed as soon as the subtree is built.
const OWNED_MIN: usize = 4096;

/// How [`Builder::build_owned`] splits its work.
#[derive(Clone, Copy)]
struct OwnedItems {
    /// Smaller subtrees are built in place ([`Builder::build`]).
    min_len: usize,
}

/// The box of the items and the box of their centroids, in item order.
fn extent(items: &[Item]) -> (Item, Item) {
    let mut world = Item::EMPTY;
    let mut cworld = Item::EMPTY;
    for it in items {
        world.grow(it);
        cworld.grow_point(it.centroid());
    }
    (world, cworld)
}

/// The build records of the primitives, with the box of all of them and of their centroids.
fn items_of(bounds: &[Aabb]) -> (Vec<Item>, Item, Item) {
    let items: Vec<Item> = bounds.iter().map(Item::from_aabb).collect();
    let (world, cworld) = extent(&items);
    (items, world, cworld)
}

fn build_items((mut items, world, cworld): (Vec<Item>, Item, Item)) -> BinaryBvh {
    let n = items.len();
    let mut order: Vec<u32> = (0..n as u32).collect();
    let mut b = Builder::new(n);
    if n > 0 {
        b.build(&mut items, &mut order, 0, world, cworld, 0);
    }
    drop(items);
    b.finish(order)
}

impl Builder {
    fn new(n: usize) -> Builder {
        Builder {
            // A tree over n primitives has at most 2n - 1 nodes; pages never written cost
            // nothing.
            nodes: Vec::with_capacity((2 * n).saturating_sub(1)),
            max_depth: 0,
            scratch: Vec::new(),
        }
    }

    fn finish(mut self, order: Vec<u32>) -> BinaryBvh {
        self.nodes.shrink_to_fit();
        BinaryBvh {
            nodes: self.nodes,
            order,
            max_depth: self.max_depth,
        }
    }

    /// Builds the subtree over `items` and their primitive indices `index` (which start at
    /// `first` in the final order), with box `bounds` and centroid box `cbounds`; returns its
    /// node index.
    fn build(
        &mut self,
        items: &mut [Item],
        index: &mut [u32],
        first: usize,
        bounds: Item,
        cbounds: Item,
        depth: u32,
    ) -> u32 {
        let (me, split) = self.open(items, index, first, &bounds, &cbounds, depth);
        let Some(s) = split else {
            return me;
        };
        let (li, ri) = items.split_at_mut(s.mid);
        let (lx, rx) = index.split_at_mut(s.mid);
        self.build(li, lx, first, s.left.0, s.left.1, depth + 1);
        let second = self.build(ri, rx, first + s.mid, s.right.0, s.right.1, depth + 1);
        self.close(me, second, s.axis);
        me
    }

    /// [`Builder::build`] over items it owns: a large subtree moves its right part's items to
    /// their own allocation and shrinks its own to the left part, so each part's items are
    /// freed as soon as it is built. The same tree as [`Builder::build`].
    #[allow(clippy::too_many_arguments)]
    fn build_owned(
        &mut self,
        how: OwnedItems,
        mut items: Vec<Item>,
        index: &mut [u32],
        first: usize,
        bounds: Item,
        cbounds: Item,
        depth: u32,
    ) -> u32 {
        if items.len() < how.min_len {
            return self.build(&mut items, index, first, bounds, cbounds, depth);
        }
        let (me, split) = self.open(&mut items, index, first, &bounds, &cbounds, depth);
        let Some(s) = split else {
            return me;
        };
        let right = items.split_off(s.mid);
        items.shrink_to_fit();
        crate::heap::give_back_free_pages();
        let (lx, rx) = index.split_at_mut(s.mid);
        self.build_owned(how, items, lx, first, s.left.0, s.left.1, depth + 1);
        crate::heap::give_back_free_pages();
        let second = self.build_owned(
            how,
            right,
            rx,
            first + s.mid,
            s.right.0,
            s.right.1,
            depth + 1,
        );
        self.close(me, second, s.axis);
        me
    }

    /// Makes the node over `items` and chooses its split (partitioning the items and their
    /// indices); `None` for a leaf.
    #[inline(always)]
    fn open(
        &mut self,
        items: &mut [Item],
        index: &mut [u32],
        first: usize,
        bounds: &Item,
        cbounds: &Item,
        depth: u32,
    ) -> (u32, Option<Split>) {
        self.max_depth = self.max_depth.max(depth);
        let me = self.nodes.len() as u32;
        let n = items.len();
        let b = bounds.aabb();
        self.nodes.push(BvhNode {
            min: b.min,
            offset: first as u32,
            max: b.max,
            count: n as u16,
            axis: 0,
        });
        if n == 1 {
            return (me, None);
        }
        let split = if depth >= SAH_DEPTH_LIMIT {
            Err(NoSplit)
        } else if n <= SMALL {
            sah_split_small(items, index, bounds, cbounds)
        } else {
            sah_split_binned(items, index, bounds, cbounds)
        };
        let s = match split {
            Ok(s) => s,
            Err(NoSplit) if n <= MAX_LEAF && depth < SAH_DEPTH_LIMIT => return (me, None),
            Err(NoSplit) => self.median_split(items, index, cbounds),
        };
        (me, Some(s))
    }

    /// Turns node `me` into an inner node whose second child is `second`.
    fn close(&mut self, me: u32, second: u32, axis: usize) {
        let node = &mut self.nodes[me as usize];
        node.offset = second;
        node.count = 0;
        node.axis = axis as u16;
    }

    /// Splits at the median centroid along the widest centroid axis (by index when all are
    /// equal).
    fn median_split(&mut self, items: &mut [Item], index: &mut [u32], cbounds: &Item) -> Split {
        let mut axis = 0;
        let mut widest = -1.0f32;
        for a in 0..3 {
            let e = cbounds.hi[a] - cbounds.lo[a];
            if e > widest {
                widest = e;
                axis = a;
            }
        }
        let mid = items.len() / 2;
        let tmp = &mut self.scratch;
        tmp.clear();
        tmp.extend(items.iter().copied().zip(index.iter().copied()));
        tmp.select_nth_unstable_by(mid, |(a, ia), (b, ib)| {
            a.centroid()[axis]
                .total_cmp(&b.centroid()[axis])
                .then(ia.cmp(ib))
        });
        for (k, (it, i)) in tmp.iter().enumerate() {
            items[k] = *it;
            index[k] = *i;
        }
        let side = |part: &[Item]| {
            let (mut b, mut c) = (Item::EMPTY, Item::EMPTY);
            for it in part {
                b.grow(it);
                c.grow_point(it.centroid());
            }
            (b, c)
        };
        Split {
            mid,
            axis,
            left: side(&items[..mid]),
            right: side(&items[mid..]),
        }
    }
}

/// No SAH split: a leaf is cheaper (only considered for small sets), no split separates
/// anything, or the depth limit is reached.
struct NoSplit;

/// The cheapest split candidate so far: (cost, axis, bin boundary).
type Best = Option<(f32, usize, usize)>;

/// Accepts a candidate only when strictly cheaper, so the first of equal candidates wins
/// (axes in order, boundaries ascending).
#[inline(always)]
fn consider(best: &mut Best, cost: f32, axis: usize, boundary: usize) {
    if best.is_none_or(|(c, _, _)| cost < c) {
        *best = Some((cost, axis, boundary));
    }
}

/// Turns the best candidate into a decision: a leaf is preferred for small sets when splitting
/// costs at least as much as testing every primitive.
fn decide(best: Best, n: usize, bounds: &Item) -> Result<(usize, usize), NoSplit> {
    let (cost, axis, boundary) = best.ok_or(NoSplit)?;
    let area = bounds.half_area();
    let split_cost = TRAVERSAL_COST + if area > 0.0 { cost / area } else { n as f32 };
    if n <= MAX_LEAF && split_cost >= n as f32 {
        return Err(NoSplit);
    }
    Ok((axis, boundary))
}

/// One set of bins for all three axes.
#[derive(Clone, Copy)]
struct Bins {
    boxes: [[Item; BINS]; 3],
    counts: [[u32; BINS]; 3],
}

impl Bins {
    const EMPTY: Bins = Bins {
        boxes: [[Item::EMPTY; BINS]; 3],
        counts: [[0; BINS]; 3],
    };

    #[inline(always)]
    fn add(&mut self, it: &Item, bins: [usize; 4]) {
        for (a, &b) in bins[..3].iter().enumerate() {
            self.counts[a][b] += 1;
            self.boxes[a][b].grow(it);
        }
    }
}

/// Binned SAH over all three axes in one pass; partitions the items by the best split.
#[inline(never)]
fn sah_split_binned(
    items: &mut [Item],
    index: &mut [u32],
    bounds: &Item,
    cbounds: &Item,
) -> Result<Split, NoSplit> {
    let binning = Binning::new(cbounds);
    let mut bins = Bins::EMPTY;
    if items.len() < TWO_SETS {
        for it in items.iter() {
            bins.add(it, binning.bins(it.centroid()));
        }
    } else {
        // Odd items go to a second set: consecutive items often share bins, and one set would
        // make each update wait for the previous one.
        let mut odd = Bins::EMPTY;
        let mut pairs = items.chunks_exact(2);
        for p in &mut pairs {
            bins.add(&p[0], binning.bins(p[0].centroid()));
            odd.add(&p[1], binning.bins(p[1].centroid()));
        }
        if let [it] = pairs.remainder() {
            bins.add(it, binning.bins(it.centroid()));
        }
        for a in 0..3 {
            for b in 0..BINS {
                bins.counts[a][b] += odd.counts[a][b];
                bins.boxes[a][b].grow(&odd.boxes[a][b]);
            }
        }
    }
    let n = items.len();
    let mut best: Best = None;
    for a in (0..3).filter(|&a| binning.spread[a]) {
        let (boxes, counts) = (&bins.boxes[a], &bins.counts[a]);
        // Sweep from the right to get suffix areas, then from the left.
        let mut right_area = [0.0f32; BINS];
        let mut right_count = [0u32; BINS];
        let mut acc = Item::EMPTY;
        let mut cnt = 0;
        for i in (1..BINS).rev() {
            acc.grow(&boxes[i]);
            cnt += counts[i];
            right_area[i] = acc.half_area();
            right_count[i] = cnt;
        }
        let mut acc = Item::EMPTY;
        let mut cnt = 0;
        for i in 0..BINS - 1 {
            acc.grow(&boxes[i]);
            cnt += counts[i];
            let (nl, nr) = (cnt, right_count[i + 1]);
            if nl == 0 || nr == 0 {
                continue;
            }
            let cost = acc.half_area() * nl as f32 + right_area[i + 1] * nr as f32;
            consider(&mut best, cost, a, i + 1);
        }
    }
    let (axis, boundary) = decide(best, n, bounds)?;
    let sides = bins.boxes[axis].iter().enumerate();
    let (lb, rb) = side_boxes(sides.map(|(i, b)| (i < boundary, b)));
    Ok(partition(items, index, &binning, axis, boundary, lb, rb))
}

/// The boxes of a split's two sides: each `(left, box)` grows the left side's box or the
/// right's.
fn side_boxes<'a>(members: impl Iterator<Item = (bool, &'a Item)>) -> (Item, Item) {
    let (mut lb, mut rb) = (Item::EMPTY, Item::EMPTY);
    for (left, b) in members {
        if left {
            lb.grow(b);
        } else {
            rb.grow(b);
        }
    }
    (lb, rb)
}

/// The binned SAH's choice for a few items, found without bin arrays: per axis the items are
/// sorted by bin and only boundaries between occupied bins are costed (the others repeat a
/// partition with the same cost, and the first boundary of each wins there too), so the split is
/// exactly the one [`sah_split_binned`] would choose.
fn sah_split_small(
    items: &mut [Item],
    index: &mut [u32],
    bounds: &Item,
    cbounds: &Item,
) -> Result<Split, NoSplit> {
    let n = items.len();
    debug_assert!(n <= SMALL);
    let binning = Binning::new(cbounds);
    let mut bins = [[0u8; 4]; SMALL];
    for (b, it) in bins.iter_mut().zip(items.iter()) {
        *b = binning.bins(it.centroid()).map(|x| x as u8);
    }
    let mut best: Best = None;
    let mut perm = [0u8; SMALL]; // items ordered by bin
    let mut right_area = [0.0f32; SMALL];
    if n == 2 {
        // Every axis that separates the two costs the same, so the first one wins.
        if let Some(a) = (0..3).find(|&a| binning.spread[a] && bins[0][a] != bins[1][a]) {
            let cost = items[0].half_area() + items[1].half_area();
            best = Some((cost, a, bins[0][a].min(bins[1][a]) as usize + 1));
        }
    }
    for a in (0..3).filter(|&a| n > 2 && binning.spread[a]) {
        if n <= 4 {
            // A sorting network over (bin, item) keys: no branches.
            let mut k: [u16; 4] = std::array::from_fn(|i| {
                if i < n {
                    (bins[i][a] as u16) << 8 | i as u16
                } else {
                    u16::MAX
                }
            });
            for (x, y) in [(0, 1), (2, 3), (0, 2), (1, 3), (1, 2)] {
                let (lo, hi) = (k[x].min(k[y]), k[x].max(k[y]));
                k[x] = lo;
                k[y] = hi;
            }
            for (p, k) in perm.iter_mut().zip(k) {
                *p = k as u8;
            }
        } else {
            // Counting sort by bin.
            let mut start = [0u8; BINS + 1];
            for b in &bins[..n] {
                start[b[a] as usize + 1] += 1;
            }
            for k in 1..=BINS {
                start[k] += start[k - 1];
            }
            for (i, b) in bins[..n].iter().enumerate() {
                let s = &mut start[b[a] as usize];
                perm[*s as usize] = i as u8;
                *s += 1;
            }
        }
        let perm = &perm[..n];
        // right_area[j]: the box of perm[j..].
        let mut acc = Item::EMPTY;
        for j in (1..n).rev() {
            acc.grow(&items[perm[j] as usize]);
            right_area[j] = acc.half_area();
        }
        let mut acc = Item::EMPTY;
        for j in 0..n - 1 {
            acc.grow(&items[perm[j] as usize]);
            let (bj, next) = (bins[perm[j] as usize][a], bins[perm[j + 1] as usize][a]);
            if bj == next {
                continue;
            }
            let (nl, nr) = ((j + 1) as f32, (n - j - 1) as f32);
            let cost = acc.half_area() * nl + right_area[j + 1] * nr;
            consider(&mut best, cost, a, bj as usize + 1);
        }
    }
    let (axis, boundary) = decide(best, n, bounds)?;
    let sides = items.iter().zip(bins.iter());
    let (lb, rb) = side_boxes(sides.map(|(it, b)| ((b[axis] as usize) < boundary, it)));
    Ok(partition(items, index, &binning, axis, boundary, lb, rb))
}

/// Partitions the items (those whose bin on `axis` is below `boundary` first) with both ends
/// moving inwards, gathering each side's centroid bounds on the way; `lb`/`rb` are the sides'
/// boxes, already known.
fn partition(
    items: &mut [Item],
    index: &mut [u32],
    binning: &Binning,
    axis: usize,
    boundary: usize,
    lb: Item,
    rb: Item,
) -> Split {
    let boundary = boundary as f32;
    let (mut lc, mut rc) = (Item::EMPTY, Item::EMPTY);
    let (mut i, mut j) = (0, items.len());
    loop {
        while i < j {
            let c = items[i].centroid();
            if !binning.below(c[axis], axis, boundary) {
                break;
            }
            lc.grow_point(c);
            i += 1;
        }
        while i < j {
            let c = items[j - 1].centroid();
            if binning.below(c[axis], axis, boundary) {
                break;
            }
            rc.grow_point(c);
            j -= 1;
        }
        if i >= j {
            break;
        }
        // items[i] belongs right and items[j - 1] left.
        items.swap(i, j - 1);
        index.swap(i, j - 1);
        lc.grow_point(items[i].centroid());
        rc.grow_point(items[j - 1].centroid());
        i += 1;
        j -= 1;
    }
    Split {
        mid: i,
        axis,
        left: (lb, lc),
        right: (rb, rc),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic generator (xorshift).
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            self.0
        }

        /// A coordinate on a coarse grid, so bins and boxes often coincide.
        fn coord(&mut self, steps: u64) -> f32 {
            (self.next() % steps) as f32 * 0.25
        }
    }

    fn random_boxes(rng: &mut Rng, n: usize, steps: u64) -> Vec<Aabb> {
        (0..n)
            .map(|_| {
                let min = [rng.coord(steps), rng.coord(steps), rng.coord(steps)];
                let ext = [rng.coord(4), rng.coord(4), rng.coord(4)];
                Aabb {
                    min,
                    max: [min[0] + ext[0], min[1] + ext[1], min[2] + ext[2]],
                }
            })
            .collect()
    }

    fn contains(outer: &BvhNode, min: [f32; 3], max: [f32; 3]) -> bool {
        (0..3).all(|k| outer.min[k] <= min[k] && max[k] <= outer.max[k])
    }

    /// Checks the `BinaryBvh` contract; returns the primitive count below `node`.
    fn check(
        bvh: &BinaryBvh,
        bounds: &[Aabb],
        node: usize,
        depth: u32,
        seen: &mut [bool],
    ) -> usize {
        let nd = &bvh.nodes[node];
        assert!(depth <= bvh.max_depth);
        if nd.is_leaf() {
            assert!((1..=MAX_LEAF as u16).contains(&nd.count));
            for &p in &bvh.order[nd.offset as usize..][..nd.count as usize] {
                assert!(!seen[p as usize], "primitive {p} twice");
                seen[p as usize] = true;
                assert!(contains(nd, bounds[p as usize].min, bounds[p as usize].max));
            }
            return nd.count as usize;
        }
        assert!(nd.axis < 3);
        let (l, r) = (node + 1, nd.offset as usize);
        assert!(r > l && r < bvh.nodes.len());
        for c in [l, r] {
            assert!(contains(nd, bvh.nodes[c].min, bvh.nodes[c].max));
        }
        let nl = check(bvh, bounds, l, depth + 1, seen);
        // Depth first: the second child follows the first child's subtree.
        assert_eq!(r, l + 2 * nl - 1 - count_leaf_slack(bvh, l));
        nl + check(bvh, bounds, r, depth + 1, seen)
    }

    /// Nodes in the subtree at `node` are 2·leaves − 1; with leaves of several primitives the
    /// subtree is smaller than 2·primitives − 1 by this much.
    fn count_leaf_slack(bvh: &BinaryBvh, node: usize) -> usize {
        let nd = &bvh.nodes[node];
        if nd.is_leaf() {
            return 2 * (nd.count as usize - 1);
        }
        count_leaf_slack(bvh, node + 1) + count_leaf_slack(bvh, nd.offset as usize)
    }

    fn check_tree(bounds: &[Aabb]) -> BinaryBvh {
        let bvh = build_binary(bounds);
        if bounds.is_empty() {
            assert!(bvh.nodes.is_empty() && bvh.order.is_empty());
            return bvh;
        }
        let mut seen = vec![false; bounds.len()];
        assert_eq!(check(&bvh, bounds, 0, 0, &mut seen), bounds.len());
        assert_eq!(bvh.order.len(), bounds.len());
        let deepest = deepest_leaf(&bvh, 0);
        assert_eq!(bvh.max_depth, deepest);
        assert!((bvh.max_depth as usize) < STACK_SIZE);
        bvh
    }

    fn deepest_leaf(bvh: &BinaryBvh, node: usize) -> u32 {
        let nd = &bvh.nodes[node];
        if nd.is_leaf() {
            return 0;
        }
        1 + deepest_leaf(bvh, node + 1).max(deepest_leaf(bvh, nd.offset as usize))
    }

    #[test]
    fn trees_keep_the_contract() {
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        for n in [0, 1, 2, 3, 4, 5, 7, 13, 24, 25, 100, 300, 1000, 5000] {
            for steps in [2, 16, 1000] {
                check_tree(&random_boxes(&mut rng, n, steps));
            }
        }
    }

    #[test]
    fn identical_boxes_split_at_the_median_with_bounded_depth() {
        let b = Aabb {
            min: [1.0, 2.0, 3.0],
            max: [2.0, 3.0, 4.0],
        };
        let bvh = check_tree(&vec![b; 1000]);
        assert!(bvh.max_depth <= 10, "depth {}", bvh.max_depth);
    }

    #[test]
    fn a_long_thin_chain_stays_within_the_stack() {
        // Nested boxes growing geometrically: the SAH peels one off per level.
        let bounds: Vec<Aabb> = (0..400)
            .map(|i| {
                let s = 1.05f32.powi(i);
                Aabb {
                    min: [s, 0.0, 0.0],
                    max: [s * 1.01, 1.0, 1.0],
                }
            })
            .collect();
        let bvh = check_tree(&bounds);
        assert!((bvh.max_depth as usize) < STACK_SIZE);
    }

    #[test]
    fn nan_and_infinite_boxes_still_make_a_tree() {
        let mut rng = Rng(99);
        let mut bounds = random_boxes(&mut rng, 200, 16);
        for (i, b) in bounds.iter_mut().enumerate().step_by(7) {
            b.min[i % 3] = if i % 2 == 0 {
                f32::NAN
            } else {
                f32::NEG_INFINITY
            };
            b.max[(i + 1) % 3] = f32::INFINITY;
        }
        let bvh = build_binary(&bounds);
        let mut order = bvh.order.clone();
        order.sort_unstable();
        assert_eq!(order, (0..200).collect::<Vec<u32>>());
        assert!(bvh.nodes.iter().all(|n| n.is_leaf() == (n.count > 0)));
        assert!(bvh.nodes[0].min.iter().all(|v| !v.is_nan()));
    }

    #[test]
    fn the_build_is_deterministic() {
        let mut rng = Rng(7);
        let bounds = random_boxes(&mut rng, 3000, 64);
        let (a, b) = (build_binary(&bounds), build_binary(&bounds));
        assert_eq!(a.nodes, b.nodes);
        assert_eq!(a.order, b.order);
        assert_eq!(a.max_depth, b.max_depth);
    }

    fn node_boxes(bounds: &[Aabb]) -> (Vec<Item>, Item, Item) {
        let items: Vec<Item> = bounds.iter().map(Item::from_aabb).collect();
        let (mut b, mut c) = (Item::EMPTY, Item::EMPTY);
        for it in &items {
            b.grow(it);
            c.grow_point(it.centroid());
        }
        (items, b, c)
    }

    fn same_box(a: &Item, b: &Item) -> bool {
        a.aabb() == b.aabb()
    }

    /// The sorting path for small nodes must choose exactly what the bins choose.
    #[test]
    fn small_nodes_split_as_the_bins_would() {
        let mut rng = Rng(12345);
        for round in 0..4000 {
            let n = 2 + round % (SMALL - 1);
            let steps = [2, 3, 8, 64][round % 4];
            let bounds = random_boxes(&mut rng, n, steps);
            let (items, b, c) = node_boxes(&bounds);
            let index: Vec<u32> = (0..n as u32).collect();
            let (mut i1, mut x1) = (items.clone(), index.clone());
            let (mut i2, mut x2) = (items, index);
            let small = sah_split_small(&mut i1, &mut x1, &b, &c);
            let binned = sah_split_binned(&mut i2, &mut x2, &b, &c);
            match (small, binned) {
                (Err(NoSplit), Err(NoSplit)) => {}
                (Ok(s), Ok(t)) => {
                    assert_eq!((s.mid, s.axis), (t.mid, t.axis), "round {round}");
                    let (mut l1, mut l2) = (x1[..s.mid].to_vec(), x2[..t.mid].to_vec());
                    l1.sort_unstable();
                    l2.sort_unstable();
                    assert_eq!(l1, l2, "round {round}");
                    for (p, q) in [(&s.left, &t.left), (&s.right, &t.right)] {
                        assert!(
                            same_box(&p.0, &q.0) && same_box(&p.1, &q.1),
                            "round {round}"
                        );
                    }
                }
                _ => panic!("round {round}: one path splits, the other does not"),
            }
        }
    }
}
