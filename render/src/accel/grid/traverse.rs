//! Grid traversal: the entry slab test against the grid box, then the Amanatides–Woo 3D-DDA in
//! the ray's precision, one cell at a time in order along the ray. The closest-hit walk stops
//! once the next cell begins beyond the best hit so far; `occluded` returns at the first hit.
//! Allocates nothing: the walk state and the mailbox live on the stack.

use super::mailbox::Mailbox;
use super::Grid;
use crate::geometry::slab::slab;
use crate::geometry::{Nearest, PreparedRay, PrimHit};
use crate::real::Real;
use crate::stats::RayStats;

/// The state of one 3D-DDA walk.
#[derive(Clone, Copy, Debug)]
struct Dda<R> {
    /// Current cell per axis.
    idx: [u32; 3],
    /// Linear index of the current cell, kept in step with `idx`.
    cell: usize,
    /// Ray parameter at which the walk leaves the current cell through each axis' next plane
    /// (infinity for an axis the ray does not move along).
    t_next: [R; 3],
    /// Whether the ray moves towards larger indices on each axis.
    up: [bool; 3],
}

impl Grid {
    /// The coordinate of the `k`-th cell plane on axis `a`, computed fresh each time so no error
    /// accumulates along the walk.
    #[inline(always)]
    fn plane<R: Real>(&self, a: usize, k: u32) -> R {
        R::from_f64(self.min[a] + k as f64 * self.cell[a])
    }

    /// The ray parameter at which the ray crosses plane `k` of axis `a`.
    #[inline(always)]
    fn crossing<R: Real>(&self, pr: &PreparedRay<R>, a: usize, k: u32) -> R {
        (self.plane::<R>(a, k) - pr.ray.o.get(a)) * pr.inv_d.get(a)
    }

    /// Enters the grid: `None` when the ray misses its box within `[t_min, t_max]`.
    #[inline(always)]
    fn enter<R: Real>(&self, pr: &PreparedRay<R>, stats: &mut RayStats) -> Option<Dda<R>> {
        if self.is_empty() {
            return None;
        }
        stats.box_tests += 1;
        let t0 = slab(&self.bounds.min, &self.bounds.max, pr, pr.ray.t_max)?;
        let mut w = Dda {
            idx: [0; 3],
            cell: 0,
            t_next: [R::INFINITY; 3],
            up: [false; 3],
        };
        for a in 0..3 {
            let last = self.res[a] - 1;
            let p = (pr.ray.o.get(a) + pr.ray.d.get(a) * t0).to_f64();
            let f = ((p - self.min[a]) * self.inv_cell[a]).floor();
            // Clamped into the grid; NaN goes to cell 0 (the walk still covers the box).
            let i = if f >= last as f64 {
                last
            } else if f >= 0.0 {
                f as u32
            } else {
                0
            };
            w.idx[a] = i;
            let d = pr.ray.d.get(a);
            // A zero (or so tiny that 1/d overflows) component never crosses a plane.
            if d != R::ZERO && pr.inv_d.get(a).is_finite() {
                w.up[a] = d > R::ZERO;
                w.t_next[a] = self.crossing(pr, a, if w.up[a] { i + 1 } else { i });
            }
        }
        w.cell = self.cell_index(w.idx[0], w.idx[1], w.idx[2]);
        Some(w)
    }

    /// How far the linear cell index moves for one step along axis `a`.
    #[inline(always)]
    fn stride(&self, a: usize) -> usize {
        match a {
            0 => 1,
            1 => self.res[0] as usize,
            _ => self.res[0] as usize * self.res[1] as usize,
        }
    }

    /// Steps to the next cell along the ray. False when the walk is over: the next cell begins
    /// beyond `limit` (an equal parameter still steps, for the tie rule), or lies outside.
    #[inline(always)]
    fn advance<R: Real>(&self, pr: &PreparedRay<R>, w: &mut Dda<R>, limit: R) -> bool {
        // The axis is picked by branches so that every array access below has a constant
        // index and the walk state stays in registers.
        let t = &w.t_next;
        if t[0] < t[1] {
            if t[0] < t[2] {
                self.step::<0, R>(pr, w, limit)
            } else {
                self.step::<2, R>(pr, w, limit)
            }
        } else if t[1] < t[2] {
            self.step::<1, R>(pr, w, limit)
        } else {
            self.step::<2, R>(pr, w, limit)
        }
    }

    /// One step of [`Grid::advance`] across the next plane of axis `A`.
    #[inline(always)]
    fn step<const A: usize, R: Real>(&self, pr: &PreparedRay<R>, w: &mut Dda<R>, limit: R) -> bool {
        let t = w.t_next[A];
        // Also false for NaN and for an infinite crossing (no axis moves).
        if !(t <= limit && t < R::INFINITY) {
            return false;
        }
        if w.up[A] {
            if w.idx[A] + 1 >= self.res[A] {
                return false;
            }
            w.idx[A] += 1;
            w.cell += self.stride(A);
            w.t_next[A] = self.crossing(pr, A, w.idx[A] + 1);
        } else {
            if w.idx[A] == 0 {
                return false;
            }
            w.idx[A] -= 1;
            w.cell -= self.stride(A);
            w.t_next[A] = self.crossing(pr, A, w.idx[A]);
        }
        true
    }

    /// Closest hit; `test(prim, t_max)` is the primitive test (inclusive of `t_max`). Returns the
    /// same hit as the brute-force scan: nearest `t`, ties to the smaller primitive index.
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
        let mut w = self.enter(pr, stats)?;
        let mut mailbox = Mailbox::new();
        let mut best = Nearest::new(pr.ray.t_max);
        let mut steps = 0u64;
        let mut prim_tests = 0u64;
        loop {
            steps += 1;
            for &p in self.cell_prims(w.cell) {
                if !mailbox.first_visit(p) {
                    continue;
                }
                prim_tests += 1;
                best.offer(test(p, best.t));
            }
            if !self.advance(pr, &mut w, best.t) {
                break;
            }
        }
        stats.cell_steps += steps;
        stats.primitive_tests += prim_tests;
        best.hit
    }

    /// True when anything is hit within the ray's range; returns at the first hit.
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
        let Some(mut w) = self.enter(pr, stats) else {
            return false;
        };
        let t_max = pr.ray.t_max;
        let mut mailbox = Mailbox::new();
        let mut steps = 0u64;
        let mut prim_tests = 0u64;
        let mut hit = false;
        'walk: loop {
            steps += 1;
            for &p in self.cell_prims(w.cell) {
                if !mailbox.first_visit(p) {
                    continue;
                }
                prim_tests += 1;
                if test(p, t_max).is_some() {
                    hit = true;
                    break 'walk;
                }
            }
            if !self.advance(pr, &mut w, t_max) {
                break;
            }
        }
        stats.cell_steps += steps;
        stats.primitive_tests += prim_tests;
        hit
    }
}
