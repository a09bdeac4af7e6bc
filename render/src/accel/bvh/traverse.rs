//! BVH traversal over 8-wide nodes. One SIMD slab test gives the entry distances of all of a
//! node's children: the nearest hit child is visited next, the others are pushed farthest first
//! with their entry distances and skipped when popped if a hit closer than that was found
//! meanwhile. Pruning allows a slack of the scene's margin beyond the best hit: box entry
//! distances and primitive distances are rounded differently, and without it a primitive hit at
//! (or a few ulps below) the best `t` — a shared edge, a ray in a box face — could be skipped.
//! The stack is fixed-size and never zeroed per ray; `occluded` returns at the first hit. A
//! leaf's primitives go to the primitive test together ([`crate::accel::PrimTest`]), which may
//! test them four at a time.
//!
//! There is one walk, generic over the query (`Query`: the closest hit, `Closest`, or any
//! hit, `AnyHit`), monomorphised per query: what a leaf does, whether the walk may stop, how
//! far boxes are taken and in which order children are visited.
//!
//! For `f32` rays on the `avx2` and `avx512` tiers the whole walk is compiled a second time
//! with AVX and AVX2 enabled, so the node's AVX slab test is inlined into it rather than called
//! per node; the walk is the same code, and the primitive tests inlined into it do the same IEEE
//! operations (no FMA is enabled), so every tier gives the same bits. A third copy with
//! AVX-512 enabled, and an AVX-512VL node test with its comparison into a mask register, were
//! measured 2–4 % slower on the `avx512` tier (measured in bench/results/, eight-wide nodes).

use super::build::STACK_SIZE;
use super::wide::{is_leaf, leaf_range, ChildRef, WIDTH};
use super::Bvh;
use crate::accel::prim_test::PrimTest;
use crate::bits::SetBits;
use crate::geometry::slab;
use crate::geometry::slab::NodeRay;
use crate::geometry::{Nearest, PreparedRay, PrimHit};
use crate::isa::{self, Isa};
use crate::real::Real;
use crate::stats::RayStats;
#[cfg(target_arch = "x86_64")]
use std::any::TypeId;
use std::mem::MaybeUninit;

/// Stack entries: a wide node pushes at most `WIDTH − 1` children, and the collapsed tree is no
/// deeper than the binary one, whose depth the builder bounds by `STACK_SIZE`.
const WIDE_STACK: usize = (WIDTH - 1) * STACK_SIZE;

/// A fixed traversal stack of (child, entry distance) that is not initialised up front.
pub(super) struct Stack<R> {
    items: [MaybeUninit<(ChildRef, R)>; WIDE_STACK],
    len: usize,
}

impl<R: Real> Stack<R> {
    #[inline(always)]
    pub(super) fn new() -> Self {
        Stack {
            items: [const { MaybeUninit::uninit() }; WIDE_STACK],
            len: 0,
        }
    }

    #[inline(always)]
    pub(super) fn push(&mut self, child: ChildRef, t: R) {
        // Bounded as WIDE_STACK says; indexing still checks.
        self.items[self.len].write((child, t));
        self.len += 1;
    }

    #[inline(always)]
    pub(super) fn pop(&mut self) -> Option<(ChildRef, R)> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: every slot below `len` was written by `push` before `len` grew past it.
        Some(unsafe { self.items[self.len].assume_init() })
    }
}

/// The hit children of a node in ascending entry distance (insertion sort; ties keep lane
/// order).
#[inline(always)]
fn sorted_hits<R: Real>(
    mask: u32,
    t: &[R; WIDTH],
    child: &[ChildRef; WIDTH],
) -> ([(R, ChildRef); WIDTH], usize) {
    let mut hits = [(R::ZERO, 0); WIDTH];
    let mut k = 0;
    for i in SetBits(mask) {
        let e = (t[i], child[i]);
        let mut j = k;
        while j > 0 && e.0 < hits[j - 1].0 {
            hits[j] = hits[j - 1];
            j -= 1;
        }
        hits[j] = e;
        k += 1;
    }
    (hits, k)
}

/// What a walk asks of the tree: the leaf test, when to stop and how far boxes are taken. Its
/// methods are `#[inline(always)]` so each query's walk is compiled as if written for it.
trait Query<R: Real> {
    /// The answer of the walk.
    type Answer;
    /// Children visited nearest first (the closest hit); else in lane order.
    const NEAREST_FIRST: bool;
    /// Tests a leaf's primitives, counting the tests into `tests` as the one-at-a-time loop
    /// counts them; true when the walk may stop.
    fn leaf(&mut self, prims: &[u32], tests: &mut u64) -> bool;
    /// The distance a box must be entered within (the ray's best hit so far plus the slack).
    fn reach(&self) -> R;
    /// Whether a subtree entered at `t` can be skipped.
    fn prune(&self, t: R) -> bool;
    /// The answer once the walk is over.
    fn answer(self) -> Self::Answer;
}

/// The closest hit: a leaf offers its hits to the best so far, boxes are taken up to that hit
/// plus the slack, and the walk never stops early.
struct Closest<R: Real, T> {
    test: T,
    best: Nearest<R>,
    slack: R,
}

impl<R: Real, T: PrimTest<R>> Query<R> for Closest<R, T> {
    type Answer = Option<PrimHit<R>>;
    const NEAREST_FIRST: bool = true;

    #[inline(always)]
    fn leaf(&mut self, prims: &[u32], tests: &mut u64) -> bool {
        *tests += prims.len() as u64;
        self.test.closest(prims, &mut self.best);
        false
    }
    #[inline(always)]
    fn reach(&self) -> R {
        self.best.t + self.slack
    }
    #[inline(always)]
    fn prune(&self, t: R) -> bool {
        // Ties still go in.
        !(t <= self.reach())
    }
    #[inline(always)]
    fn answer(self) -> Option<PrimHit<R>> {
        self.best.hit
    }
}

/// Any hit within the ray's range: the walk stops at the first leaf that has one.
struct AnyHit<R, T> {
    test: T,
    t_max: R,
    reach: R,
    hit: bool,
}

impl<R: Real, T: PrimTest<R>> Query<R> for AnyHit<R, T> {
    type Answer = bool;
    const NEAREST_FIRST: bool = false;

    #[inline(always)]
    fn leaf(&mut self, prims: &[u32], tests: &mut u64) -> bool {
        // Counted as the one-at-a-time loop counts: up to the first hit.
        if let Some(i) = self.test.any(prims, self.t_max) {
            *tests += i as u64 + 1;
            self.hit = true;
            return true;
        }
        *tests += prims.len() as u64;
        false
    }
    #[inline(always)]
    fn reach(&self) -> R {
        self.reach
    }
    #[inline(always)]
    fn prune(&self, _t: R) -> bool {
        false
    }
    #[inline(always)]
    fn answer(self) -> bool {
        self.hit
    }
}

impl Bvh {
    /// The pruning slack in units of the ray's `t`.
    #[inline(always)]
    fn slack<R: Real>(&self, pr: &PreparedRay<R>) -> R {
        R::from_f64(self.margin) / pr.ray.d.length()
    }

    /// Closest hit; `test` is the primitive test (inclusive of `t_max`), called leaf by leaf.
    #[inline]
    pub fn intersect<R: Real, T: PrimTest<R>>(
        &self,
        pr: &PreparedRay<R>,
        stats: &mut RayStats,
        test: T,
    ) -> Option<PrimHit<R>> {
        if self.nodes.is_empty() {
            return None;
        }
        let q = Closest {
            test,
            best: Nearest::new(pr.ray.t_max),
            slack: self.slack(pr),
        };
        self.walk(pr, stats, q)
    }

    /// True when anything is hit within the ray's range.
    #[inline]
    pub fn occluded<R: Real, T: PrimTest<R>>(
        &self,
        pr: &PreparedRay<R>,
        stats: &mut RayStats,
        test: T,
    ) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let q = AnyHit {
            test,
            t_max: pr.ray.t_max,
            reach: pr.ray.t_max + self.slack(pr),
            hit: false,
        };
        self.walk(pr, stats, q)
    }

    /// The walk of a non-empty tree for query `q`, in the copy compiled for the process's tier.
    #[inline(always)]
    fn walk<R: Real, Q: Query<R>>(
        &self,
        pr: &PreparedRay<R>,
        stats: &mut RayStats,
        q: Q,
    ) -> Q::Answer {
        let tier = isa::current();
        #[cfg(target_arch = "x86_64")]
        if TypeId::of::<R>() == TypeId::of::<f32>() && tier.avx() {
            // SAFETY: the avx2 and avx512 tiers are only chosen on a CPU with AVX and AVX2.
            return unsafe { self.walk_avx(pr, stats, q, tier) };
        }
        self.walk_on(pr, stats, q, tier)
    }

    /// [`Bvh::walk`] compiled for the `avx2` and `avx512` tiers.
    ///
    /// # Safety
    /// The CPU must support AVX and AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    unsafe fn walk_avx<R: Real, Q: Query<R>>(
        &self,
        pr: &PreparedRay<R>,
        stats: &mut RayStats,
        q: Q,
        tier: Isa,
    ) -> Q::Answer {
        self.walk_on(pr, stats, q, tier)
    }

    /// The walk of a non-empty tree for query `q`, with the slab kernel of `tier`.
    #[inline(always)]
    fn walk_on<R: Real, Q: Query<R>>(
        &self,
        pr: &PreparedRay<R>,
        stats: &mut RayStats,
        mut q: Q,
        tier: Isa,
    ) -> Q::Answer {
        let (o, inv) = (pr.ray.o, pr.inv_d);
        let sr = NodeRay {
            o: [o.x, o.y, o.z],
            inv: [inv.x, inv.y, inv.z],
            neg: pr.neg,
            t_min: pr.ray.t_min,
        };
        let mut box_tests = 0u64;
        let mut prim_tests = 0u64;
        let mut stack = Stack::<R>::new();
        let mut cur: ChildRef = 0;
        'walk: loop {
            if is_leaf(cur) {
                let (first, count) = leaf_range(cur);
                if q.leaf(&self.order[first..first + count], &mut prim_tests) {
                    break 'walk;
                }
            } else {
                let n = &self.nodes[cur as usize];
                box_tests += u64::from(n.used);
                let (mask, t) = slab::slab8_on(tier, &n.bounds, &sr, q.reach());
                // Empty lanes are never entered; the mask makes that independent of the ray.
                let mask = mask & n.lanes();
                if mask != 0 {
                    cur = if Q::NEAREST_FIRST {
                        nearest_first(mask, &t, &n.child, &mut stack)
                    } else {
                        lane_order(mask, &t, &n.child, &mut stack)
                    };
                    continue 'walk;
                }
            }
            loop {
                match stack.pop() {
                    Some((c, t)) if !q.prune(t) => {
                        cur = c;
                        continue 'walk;
                    }
                    Some(_) => {}
                    None => break 'walk,
                }
            }
        }
        stats.box_tests += box_tests;
        stats.primitive_tests += prim_tests;
        q.answer()
    }
}

/// The nearest hit child of a node (`mask` not empty), the others pushed farthest first.
#[inline(always)]
fn nearest_first<R: Real>(
    mask: u32,
    t: &[R; WIDTH],
    child: &[ChildRef; WIDTH],
    stack: &mut Stack<R>,
) -> ChildRef {
    if mask & (mask - 1) == 0 {
        return child[mask.trailing_zeros() as usize];
    }
    let (hits, k) = sorted_hits(mask, t, child);
    for &(t, c) in hits[1..k].iter().rev() {
        stack.push(c, t);
    }
    hits[0].1
}

/// The first hit child of a node in lane order (`mask` not empty), the others pushed in lane
/// order.
#[inline(always)]
fn lane_order<R: Real>(
    mask: u32,
    t: &[R; WIDTH],
    child: &[ChildRef; WIDTH],
    stack: &mut Stack<R>,
) -> ChildRef {
    let first = mask.trailing_zeros() as usize;
    for i in SetBits(mask & (mask - 1)) {
        stack.push(child[i], t[i]);
    }
    child[first]
}
