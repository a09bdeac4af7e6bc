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
use crate::geometry::slab::SlabRay;
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

impl Bvh {
    /// The pruning slack in units of the ray's `t`.
    #[inline(always)]
    fn slack<R: Real>(&self, pr: &PreparedRay<R>) -> R {
        R::from_f64(self.margin) / pr.ray.d.length()
    }

    #[inline(always)]
    fn slab_ray<R: Real>(pr: &PreparedRay<R>) -> SlabRay<R> {
        let (o, inv) = (pr.ray.o, pr.inv_d);
        SlabRay {
            o: [o.x, o.y, o.z],
            inv: [inv.x, inv.y, inv.z],
            neg: pr.neg,
            t_min: pr.ray.t_min,
        }
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
        let tier = isa::current();
        #[cfg(target_arch = "x86_64")]
        if TypeId::of::<R>() == TypeId::of::<f32>() && tier.avx() {
            // SAFETY: the avx2 and avx512 tiers are only chosen on a CPU with AVX and AVX2.
            return unsafe { self.intersect_avx(pr, stats, test, tier) };
        }
        self.intersect_walk(pr, stats, test, tier)
    }

    /// [`Bvh::intersect`]'s walk compiled for the `avx2` and `avx512` tiers.
    ///
    /// # Safety
    /// The CPU must support AVX and AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    unsafe fn intersect_avx<R: Real, T: PrimTest<R>>(
        &self,
        pr: &PreparedRay<R>,
        stats: &mut RayStats,
        test: T,
        tier: Isa,
    ) -> Option<PrimHit<R>> {
        self.intersect_walk(pr, stats, test, tier)
    }

    /// The closest-hit walk of a non-empty tree, with the slab kernel of `tier`.
    #[inline(always)]
    fn intersect_walk<R: Real, T: PrimTest<R>>(
        &self,
        pr: &PreparedRay<R>,
        stats: &mut RayStats,
        mut test: T,
        tier: Isa,
    ) -> Option<PrimHit<R>> {
        let sr = Self::slab_ray(pr);
        let mut box_tests = 0u64;
        let mut prim_tests = 0u64;
        let mut best = Nearest::new(pr.ray.t_max);
        let slack = self.slack(pr);
        let mut stack = Stack::<R>::new();
        let mut cur: ChildRef = 0;
        'walk: loop {
            if is_leaf(cur) {
                let (first, count) = leaf_range(cur);
                prim_tests += count as u64;
                test.closest(&self.order[first..first + count], &mut best);
            } else {
                let n = &self.nodes[cur as usize];
                box_tests += u64::from(n.used);
                let (mask, t) = slab::slab8_on(tier, &n.bounds, &sr, best.t + slack);
                // Empty lanes are never entered; the mask makes that independent of the ray.
                let mask = mask & n.lanes();
                if mask != 0 {
                    if mask & (mask - 1) == 0 {
                        cur = n.child[mask.trailing_zeros() as usize];
                        continue 'walk;
                    }
                    let (hits, k) = sorted_hits(mask, &t, &n.child);
                    for &(t, c) in hits[1..k].iter().rev() {
                        stack.push(c, t);
                    }
                    cur = hits[0].1;
                    continue 'walk;
                }
            }
            loop {
                match stack.pop() {
                    // Skip a subtree that starts beyond the nearest hit so far (ties still go in).
                    Some((c, t)) if t <= best.t + slack => {
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
        best.hit
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
        let tier = isa::current();
        #[cfg(target_arch = "x86_64")]
        if TypeId::of::<R>() == TypeId::of::<f32>() && tier.avx() {
            // SAFETY: the avx2 and avx512 tiers are only chosen on a CPU with AVX and AVX2.
            return unsafe { self.occluded_avx(pr, stats, test, tier) };
        }
        self.occluded_walk(pr, stats, test, tier)
    }

    /// [`Bvh::occluded`]'s walk compiled for the `avx2` and `avx512` tiers.
    ///
    /// # Safety
    /// The CPU must support AVX and AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    unsafe fn occluded_avx<R: Real, T: PrimTest<R>>(
        &self,
        pr: &PreparedRay<R>,
        stats: &mut RayStats,
        test: T,
        tier: Isa,
    ) -> bool {
        self.occluded_walk(pr, stats, test, tier)
    }

    /// The any-hit walk of a non-empty tree, with the slab kernel of `tier`.
    #[inline(always)]
    fn occluded_walk<R: Real, T: PrimTest<R>>(
        &self,
        pr: &PreparedRay<R>,
        stats: &mut RayStats,
        mut test: T,
        tier: Isa,
    ) -> bool {
        let sr = Self::slab_ray(pr);
        let t_max = pr.ray.t_max;
        let reach = t_max + self.slack(pr);
        let mut box_tests = 0u64;
        let mut prim_tests = 0u64;
        let mut hit = false;
        let mut stack = Stack::<R>::new();
        let mut cur: ChildRef = 0;
        'walk: loop {
            if is_leaf(cur) {
                let (first, count) = leaf_range(cur);
                // Counted as the one-at-a-time loop counts: up to the first hit.
                if let Some(i) = test.any(&self.order[first..first + count], t_max) {
                    prim_tests += i as u64 + 1;
                    hit = true;
                    break 'walk;
                }
                prim_tests += count as u64;
            } else {
                let n = &self.nodes[cur as usize];
                box_tests += u64::from(n.used);
                let (mask, t) = slab::slab8_on(tier, &n.bounds, &sr, reach);
                let mut mask = mask & n.lanes();
                if mask != 0 {
                    let first = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    while mask != 0 {
                        let i = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        stack.push(n.child[i], t[i]);
                    }
                    cur = n.child[first];
                    continue 'walk;
                }
            }
            match stack.pop() {
                Some((c, _)) => cur = c,
                None => break 'walk,
            }
        }
        stats.box_tests += box_tests;
        stats.primitive_tests += prim_tests;
        hit
    }
}
