//! BVH traversal. Both children's boxes are tested at their parent: the nearer hit child is
//! visited first, the farther is pushed with its entry distance and skipped when popped if a
//! hit closer than that was found meanwhile. Pruning allows a slack of the scene's margin beyond
//! the best hit: box entry distances and primitive distances are rounded differently, and
//! without it a primitive hit at (or a few ulps below) the best `t` — a shared edge, a ray in a
//! box face — could be skipped. The stack is fixed-size and never zeroed per ray; `occluded`
//! returns at the first hit.

use super::build::STACK_SIZE;
use super::Bvh;
use crate::geometry::aabb::slab;
use crate::geometry::{Nearest, PreparedRay, PrimHit};
use crate::real::Real;
use crate::stats::RayStats;
use std::mem::MaybeUninit;

/// A fixed traversal stack of (node, entry distance) that is not initialised up front.
struct Stack<R> {
    items: [MaybeUninit<(u32, R)>; STACK_SIZE],
    len: usize,
}

impl<R: Real> Stack<R> {
    #[inline(always)]
    fn new() -> Self {
        Stack {
            items: [const { MaybeUninit::uninit() }; STACK_SIZE],
            len: 0,
        }
    }

    #[inline(always)]
    fn push(&mut self, node: u32, t: R) {
        // The builder bounds the depth (median splits past its SAH depth limit), and a push
        // happens at most once per level, so this cannot overflow; indexing still checks.
        self.items[self.len].write((node, t));
        self.len += 1;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, R)> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: every slot below `len` was written by `push` before `len` grew past it.
        Some(unsafe { self.items[self.len].assume_init() })
    }
}

impl Bvh {
    /// The pruning slack in units of the ray's `t`.
    #[inline(always)]
    fn slack<R: Real>(&self, pr: &PreparedRay<R>) -> R {
        R::from_f64(self.margin) / pr.ray.d.length()
    }

    /// Closest hit; `test(prim, t_max)` is the primitive test (inclusive of `t_max`).
    #[inline]
    pub fn intersect<R: Real, F>(
        &self,
        pr: &PreparedRay<R>,
        stats: &mut RayStats,
        mut test: F,
    ) -> Option<PrimHit<R>>
    where
        F: FnMut(u32, R) -> Option<PrimHit<R>>,
    {
        let root = self.nodes.first()?;
        let mut box_tests = 1u64;
        let mut prim_tests = 0u64;
        let mut best = Nearest::new(pr.ray.t_max);
        let slack = self.slack(pr);
        let mut stack = Stack::<R>::new();
        let mut next = slab(&root.min, &root.max, pr, best.t + slack).map(|_| 0u32);
        while let Some(node) = next {
            let n = &self.nodes[node as usize];
            next = None;
            if n.is_leaf() {
                let first = n.offset as usize;
                for &p in &self.order[first..first + n.count as usize] {
                    prim_tests += 1;
                    best.offer(test(p, best.t));
                }
            } else {
                let (a, b) = (node + 1, n.offset);
                let (na, nb) = (&self.nodes[a as usize], &self.nodes[b as usize]);
                box_tests += 2;
                let ta = slab(&na.min, &na.max, pr, best.t + slack);
                let tb = slab(&nb.min, &nb.max, pr, best.t + slack);
                next = match (ta, tb) {
                    (Some(ta), Some(tb)) => {
                        if tb < ta {
                            stack.push(a, ta);
                            Some(b)
                        } else {
                            stack.push(b, tb);
                            Some(a)
                        }
                    }
                    (Some(_), None) => Some(a),
                    (None, Some(_)) => Some(b),
                    (None, None) => None,
                };
            }
            while next.is_none() {
                match stack.pop() {
                    // Skip a subtree that starts beyond the nearest hit so far (ties still go in).
                    Some((node, t)) if t <= best.t + slack => next = Some(node),
                    Some(_) => {}
                    None => break,
                }
            }
        }
        stats.box_tests += box_tests;
        stats.primitive_tests += prim_tests;
        best.hit
    }

    /// True when anything is hit within the ray's range.
    #[inline]
    pub fn occluded<R: Real, F>(
        &self,
        pr: &PreparedRay<R>,
        stats: &mut RayStats,
        mut test: F,
    ) -> bool
    where
        F: FnMut(u32, R) -> Option<PrimHit<R>>,
    {
        let Some(root) = self.nodes.first() else {
            return false;
        };
        let t_max = pr.ray.t_max;
        let reach = t_max + self.slack(pr);
        let mut box_tests = 1u64;
        let mut prim_tests = 0u64;
        let mut hit = false;
        let mut stack = Stack::<R>::new();
        let mut next = slab(&root.min, &root.max, pr, reach).map(|_| 0u32);
        'outer: while let Some(node) = next {
            let n = &self.nodes[node as usize];
            next = None;
            if n.is_leaf() {
                let first = n.offset as usize;
                for &p in &self.order[first..first + n.count as usize] {
                    prim_tests += 1;
                    if test(p, t_max).is_some() {
                        hit = true;
                        break 'outer;
                    }
                }
            } else {
                let (a, b) = (node + 1, n.offset);
                let (na, nb) = (&self.nodes[a as usize], &self.nodes[b as usize]);
                box_tests += 2;
                let ta = slab(&na.min, &na.max, pr, reach);
                let tb = slab(&nb.min, &nb.max, pr, reach);
                next = match (ta, tb) {
                    (Some(_), Some(tb)) => {
                        stack.push(b, tb);
                        Some(a)
                    }
                    (Some(_), None) => Some(a),
                    (None, Some(_)) => Some(b),
                    (None, None) => None,
                };
            }
            if next.is_none() {
                next = stack.pop().map(|(n, _)| n);
            }
        }
        stats.box_tests += box_tests;
        stats.primitive_tests += prim_tests;
        hit
    }
}
