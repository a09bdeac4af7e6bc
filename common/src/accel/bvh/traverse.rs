//! BVH traversal: a fixed stack, the nearer child first (by the ray's direction sign on the split
//! axis), the search interval shrinking at every hit; `occluded` returns at the first hit.

use super::build::STACK_SIZE;
use super::Bvh;
use crate::geometry::aabb::slab;
use crate::geometry::{PreparedRay, PrimHit};
use crate::real::Real;
use crate::stats::RayStats;

impl Bvh {
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
        if self.nodes.is_empty() {
            return None;
        }
        let mut best: Option<PrimHit<R>> = None;
        let mut best_t = pr.ray.t_max;
        let mut best_prim = u32::MAX;
        let mut stack = [0u32; STACK_SIZE];
        let mut sp = 0usize;
        let mut node = 0u32;
        let mut box_tests = 0u64;
        let mut prim_tests = 0u64;
        loop {
            let n = &self.nodes[node as usize];
            box_tests += 1;
            if slab(&n.min, &n.max, pr, best_t).is_some() {
                if n.is_leaf() {
                    let first = n.offset as usize;
                    for &p in &self.order[first..first + n.count as usize] {
                        prim_tests += 1;
                        if let Some(h) = test(p, best_t) {
                            if h.beats(best_t, best_prim) {
                                best_t = h.t;
                                best_prim = h.prim;
                                best = Some(h);
                            }
                        }
                    }
                } else {
                    // Visit the child on the ray's near side first.
                    let (near, far) = if pr.neg[n.axis as usize] {
                        (n.offset, node + 1)
                    } else {
                        (node + 1, n.offset)
                    };
                    stack[sp] = far;
                    sp += 1;
                    node = near;
                    continue;
                }
            }
            if sp == 0 {
                break;
            }
            sp -= 1;
            node = stack[sp];
        }
        stats.box_tests += box_tests;
        stats.primitive_tests += prim_tests;
        best
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
        if self.nodes.is_empty() {
            return false;
        }
        let t_max = pr.ray.t_max;
        let mut stack = [0u32; STACK_SIZE];
        let mut sp = 0usize;
        let mut node = 0u32;
        let mut box_tests = 0u64;
        let mut prim_tests = 0u64;
        let mut hit = false;
        'outer: loop {
            let n = &self.nodes[node as usize];
            box_tests += 1;
            if slab(&n.min, &n.max, pr, t_max).is_some() {
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
                    let (near, far) = if pr.neg[n.axis as usize] {
                        (n.offset, node + 1)
                    } else {
                        (node + 1, n.offset)
                    };
                    stack[sp] = far;
                    sp += 1;
                    node = near;
                    continue;
                }
            }
            if sp == 0 {
                break;
            }
            sp -= 1;
            node = stack[sp];
        }
        stats.box_tests += box_tests;
        stats.primitive_tests += prim_tests;
        hit
    }
}
