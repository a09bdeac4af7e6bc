//! Packet traversal: up to [`PACKET`] rays walk the 8-wide BVH together. A node is tested once
//! for the whole packet, with interval bounds of the rays' origins and reciprocal directions
//! (the rays must agree in direction signs and have no zero direction component, and rays whose
//! origins spread too far for their length, [`COHERENCE`], go one by one); at a leaf each
//! ray tests the leaf's box (all rays side by side, each with the scalar slab test's arithmetic)
//! and the rays that enter test the leaf's primitives together
//! ([`RayPrimTest::closest_many`], [`RayPrimTest::any_many`]).
//!
//! Every ray gets exactly the answer the single-ray traversal gives it. The interval test is
//! conservative in floating point, not just in exact arithmetic: `fl(x·y)` and `fl(x − y)` are
//! monotone in each operand, so the smallest of the four corner products of the intervals is at
//! most the ray's own rounded entry distance, and the largest at least its exit distance. A node
//! one ray of the packet would enter is therefore entered, a subtree is pruned only beyond every
//! ray's best hit plus the slack, and each ray's closest hit is the one the shared tie rule
//! ([`crate::geometry::PrimHit::beats`]) picks among all primitives it hits — the same
//! primitive, distance and parameters as alone.

use super::traverse::Stack;
use super::wide::{is_leaf, leaf_range, ChildRef, WIDTH};
use super::Bvh;
use crate::accel::prim_test::{OneRay, RayPrimTest};
use crate::bits::SetBits;
use crate::geometry::slab16::RayLanes;
use crate::geometry::slab8::Box8;
use crate::geometry::slab_dispatch;
use crate::geometry::{Nearest, PreparedRay, PrimHit};
use crate::real::Real;
use crate::stats::RayStats;

/// Most rays in a packet (a 4 × 4 block of pixels).
pub const PACKET: usize = crate::geometry::slab16::LANES;

/// Widest spread of a packet's origins, relative to its shortest ray, that is still traced as a
/// packet. Measured with `parrt bench cast` on the SPD scenes at 0.003, 0.01, 0.03, 0.1 and
/// without a limit: 0.03 was best or within 4 % of best on every scene; without a limit balls-4
/// casts at 5.0 instead of 12.5 Mrays/s (its shadow packets straddle sphere silhouettes).
pub const COHERENCE: f64 = 0.03;

/// Interval bounds of a packet's rays, per axis.
#[derive(Clone, Copy, Debug)]
struct Frustum<R> {
    o_lo: [R; 3],
    o_hi: [R; 3],
    inv_lo: [R; 3],
    inv_hi: [R; 3],
    neg: [bool; 3],
    t_min: R,
}

impl<R: Real> Frustum<R> {
    /// The bounds of `rays`, or `None` when they cannot be bounded this way: mixed direction
    /// signs on an axis, a zero (infinite reciprocal) direction component, or a non-finite
    /// origin or start.
    fn new(rays: &[PreparedRay<R>]) -> Option<Self> {
        let first = rays.first()?;
        let o = |r: &PreparedRay<R>| [r.ray.o.x, r.ray.o.y, r.ray.o.z];
        let inv = |r: &PreparedRay<R>| [r.inv_d.x, r.inv_d.y, r.inv_d.z];
        let mut f = Frustum {
            o_lo: o(first),
            o_hi: o(first),
            inv_lo: inv(first),
            inv_hi: inv(first),
            neg: first.neg,
            t_min: first.ray.t_min,
        };
        // One pass without early exits (a packet is rejected rarely): the bounds, whether
        // every ray can be bounded, and the shortest ray.
        let mut ok = true;
        let mut shortest = R::INFINITY;
        for r in rays {
            ok &= (r.neg == f.neg) & r.ray.t_min.is_finite();
            let (ro, ri) = (o(r), inv(r));
            for a in 0..3 {
                ok &= ro[a].is_finite() & ri[a].is_finite();
                f.o_lo[a] = f.o_lo[a].min(ro[a]);
                f.o_hi[a] = f.o_hi[a].max(ro[a]);
                f.inv_lo[a] = f.inv_lo[a].min(ri[a]);
                f.inv_hi[a] = f.inv_hi[a].max(ri[a]);
            }
            f.t_min = f.t_min.min(r.ray.t_min);
            shortest = shortest.min(r.ray.t_max);
        }
        if !ok {
            return None;
        }
        // Rays whose origins spread widely compared with their length (shadow rays from both
        // sides of a silhouette) make loose bounds that let the packet into far more nodes
        // than any of its rays: those go one by one.
        let mut spread = R::ZERO;
        for a in 0..3 {
            spread = spread.max(f.o_hi[a] - f.o_lo[a]);
        }
        if spread > R::from_f64(COHERENCE) * shortest {
            return None;
        }
        Some(f)
    }

    /// The children of a node against the packet: bit `i` is set when some ray of the packet
    /// may enter lane `i` before `t_max`; the distances are lower bounds of every ray's entry
    /// distance into the lane.
    #[inline(always)]
    fn test8(&self, b: &Box8, t_max: R) -> (u32, [R; WIDTH]) {
        let widen = R::ONE + R::TWO * R::gamma(3);
        let mut t0 = [self.t_min; WIDTH];
        let mut t1 = [t_max; WIDTH];
        for a in 0..3 {
            let (near, far) = if self.neg[a] {
                (&b.hi[a], &b.lo[a])
            } else {
                (&b.lo[a], &b.hi[a])
            };
            let (il, ih) = (self.inv_lo[a], self.inv_hi[a]);
            for i in 0..WIDTH {
                let n = R::from_f32(near[i]);
                let (xl, xh) = (n - self.o_hi[a], n - self.o_lo[a]);
                let lo = (xl * il).min(xl * ih).min((xh * il).min(xh * ih));
                let f = R::from_f32(far[i]);
                let (yl, yh) = (f - self.o_hi[a], f - self.o_lo[a]);
                let hi = (yl * il).max(yl * ih).max((yh * il).max(yh * ih)) * widen;
                t0[i] = t0[i].max(lo);
                t1[i] = t1[i].min(hi);
            }
        }
        let mut mask = 0;
        for i in 0..WIDTH {
            if t0[i] <= t1[i] {
                mask |= 1 << i;
            }
        }
        (mask, t0)
    }
}

/// The hit children of a node in ascending bound (insertion sort; ties keep lane order), with
/// their lanes.
#[inline(always)]
fn sorted_lanes<R: Real>(mask: u32, t: &[R; WIDTH]) -> ([(R, usize); WIDTH], usize) {
    let mut hits = [(R::ZERO, 0); WIDTH];
    let mut k = 0;
    for i in SetBits(mask) {
        let e = (t[i], i);
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
    /// Whether `rays` would be traced together (more than one ray, bounds the interval test
    /// can take, origins close enough) rather than one by one.
    pub fn takes_as_packet<R: Real>(&self, rays: &[PreparedRay<R>]) -> bool {
        self.packet_bounds(rays).is_some()
    }

    /// The bounds `rays` are traced together with, or `None` when they go one by one.
    fn packet_bounds<R: Real>(&self, rays: &[PreparedRay<R>]) -> Option<Frustum<R>> {
        if rays.len() > 1 && rays.len() <= PACKET && !self.nodes.is_empty() {
            Frustum::new(rays)
        } else {
            None
        }
    }

    /// Closest hits of a packet of at most [`PACKET`] rays into `out` (same indexing);
    /// `test(ray, prim, t_max)` is the primitive test. Rays the interval bounds cannot take
    /// together are traced one by one.
    ///
    /// # Panics
    /// When `rays` is longer than [`PACKET`] or `out` shorter than `rays`.
    pub fn intersect_packet<R: Real, T: RayPrimTest<R>>(
        &self,
        rays: &[PreparedRay<R>],
        out: &mut [Option<PrimHit<R>>],
        stats: &mut RayStats,
        mut test: T,
    ) {
        assert!(rays.len() <= PACKET && out.len() >= rays.len());
        let Some(frustum) = self.packet_bounds(rays) else {
            for (pr, o) in rays.iter().zip(out.iter_mut()) {
                *o = self.intersect(
                    pr,
                    stats,
                    OneRay {
                        test: &mut test,
                        pr,
                    },
                );
            }
            return;
        };
        #[cfg(target_arch = "x86_64")]
        if std::any::TypeId::of::<R>() == std::any::TypeId::of::<f32>()
            && crate::isa::current().avx()
        {
            // SAFETY: the avx2 and avx512 tiers are only chosen on a CPU with AVX and AVX2.
            return unsafe { self.intersect_packet_walk_avx(rays, out, stats, test, frustum) };
        }
        self.intersect_packet_walk(rays, out, stats, test, frustum);
    }

    /// [`Bvh::intersect_packet`]'s walk compiled for the `avx2` and `avx512` tiers.
    ///
    /// # Safety
    /// The CPU must support AVX and AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    unsafe fn intersect_packet_walk_avx<R: Real, T: RayPrimTest<R>>(
        &self,
        rays: &[PreparedRay<R>],
        out: &mut [Option<PrimHit<R>>],
        stats: &mut RayStats,
        test: T,
        frustum: Frustum<R>,
    ) {
        self.intersect_packet_walk(rays, out, stats, test, frustum)
    }

    /// The walk of [`Bvh::intersect_packet`] for a packet its bounds can take.
    #[inline(always)]
    fn intersect_packet_walk<R: Real, T: RayPrimTest<R>>(
        &self,
        rays: &[PreparedRay<R>],
        out: &mut [Option<PrimHit<R>>],
        stats: &mut RayStats,
        mut test: T,
        frustum: Frustum<R>,
    ) {
        let n = rays.len();
        let lanes = RayLanes::new(rays, frustum.neg);
        let mut best = [Nearest::new(R::ZERO); PACKET];
        let mut slack = [R::ZERO; PACKET];
        // Per ray: its best hit plus the slack (lanes past `n` never reach anything).
        let mut reach_ray = [R::from_f64(-1.0); PACKET];
        for i in 0..n {
            best[i] = Nearest::new(rays[i].ray.t_max);
            slack[i] = R::from_f64(self.margin) / rays[i].ray.d.length();
            reach_ray[i] = best[i].t + slack[i];
        }
        let reach_all = |r: &[R; PACKET]| r[..n].iter().fold(r[0], |m, &x| m.max(x));
        let all: u32 = (1 << n) - 1;
        let mut reach = reach_all(&reach_ray);
        let mut box_tests = 0u64;
        let mut prim_tests = 0u64;
        let mut stack = Stack::<R>::new();
        let mut cur: ChildRef = 0;
        'walk: loop {
            let node = &self.nodes[cur as usize];
            box_tests += u64::from(node.used);
            let (mask, t) = frustum.test8(&node.bounds, reach);
            let mask = mask & node.lanes();
            let (hits, k) = sorted_lanes(mask, &t);
            let mut inner = [(R::ZERO, 0 as ChildRef); WIDTH];
            let mut inner_n = 0;
            for &(t_lane, lane) in &hits[..k] {
                let c = node.child[lane];
                if !is_leaf(c) {
                    inner[inner_n] = (t_lane, c);
                    inner_n += 1;
                    continue;
                }
                if t_lane > reach {
                    continue;
                }
                let (lo, hi) = node.bounds.lane(lane);
                let (first, count) = leaf_range(c);
                let prims = &self.order[first..first + count];
                box_tests += n as u64;
                let enter = slab_dispatch::enter16(&lanes, &lo, &hi, &reach_ray) & all;
                if enter == 0 {
                    continue;
                }
                prim_tests += u64::from(enter.count_ones()) * prims.len() as u64;
                let before = best.map(|b| b.t);
                test.closest_many(rays, enter, prims, &mut best);
                let mut improved = false;
                for i in SetBits(enter) {
                    improved |= best[i].t != before[i];
                    reach_ray[i] = best[i].t + slack[i];
                }
                if improved {
                    reach = reach_all(&reach_ray);
                }
            }
            for &(t_in, c) in inner[..inner_n].iter().rev() {
                stack.push(c, t_in);
            }
            loop {
                match stack.pop() {
                    // Skip a subtree that starts beyond every ray's nearest hit so far.
                    Some((c, t_in)) if t_in <= reach => {
                        cur = c;
                        continue 'walk;
                    }
                    Some(_) => {}
                    None => break 'walk,
                }
            }
        }
        for i in 0..n {
            out[i] = best[i].hit;
        }
        stats.box_tests += box_tests;
        stats.primitive_tests += prim_tests;
    }

    /// Whether anything blocks each ray of a packet of at most [`PACKET`] rays, into `out`;
    /// `test(ray, prim, t_max)` is the primitive test.
    ///
    /// # Panics
    /// When `rays` is longer than [`PACKET`] or `out` shorter than `rays`.
    pub fn occluded_packet<R: Real, T: RayPrimTest<R>>(
        &self,
        rays: &[PreparedRay<R>],
        out: &mut [bool],
        stats: &mut RayStats,
        mut test: T,
    ) {
        assert!(rays.len() <= PACKET && out.len() >= rays.len());
        let Some(frustum) = self.packet_bounds(rays) else {
            for (pr, o) in rays.iter().zip(out.iter_mut()) {
                *o = self.occluded(
                    pr,
                    stats,
                    OneRay {
                        test: &mut test,
                        pr,
                    },
                );
            }
            return;
        };
        #[cfg(target_arch = "x86_64")]
        if std::any::TypeId::of::<R>() == std::any::TypeId::of::<f32>()
            && crate::isa::current().avx()
        {
            // SAFETY: the avx2 and avx512 tiers are only chosen on a CPU with AVX and AVX2.
            return unsafe { self.occluded_packet_walk_avx(rays, out, stats, test, frustum) };
        }
        self.occluded_packet_walk(rays, out, stats, test, frustum);
    }

    /// [`Bvh::occluded_packet`]'s walk compiled for the `avx2` and `avx512` tiers.
    ///
    /// # Safety
    /// The CPU must support AVX and AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    unsafe fn occluded_packet_walk_avx<R: Real, T: RayPrimTest<R>>(
        &self,
        rays: &[PreparedRay<R>],
        out: &mut [bool],
        stats: &mut RayStats,
        test: T,
        frustum: Frustum<R>,
    ) {
        self.occluded_packet_walk(rays, out, stats, test, frustum)
    }

    /// The walk of [`Bvh::occluded_packet`] for a packet its bounds can take.
    #[inline(always)]
    fn occluded_packet_walk<R: Real, T: RayPrimTest<R>>(
        &self,
        rays: &[PreparedRay<R>],
        out: &mut [bool],
        stats: &mut RayStats,
        mut test: T,
        frustum: Frustum<R>,
    ) {
        let n = rays.len();
        let all: u32 = (1 << n) - 1;
        let mut done = 0u32;
        let lanes = RayLanes::new(rays, frustum.neg);
        let mut reach = [R::from_f64(-1.0); PACKET];
        for i in 0..n {
            reach[i] = rays[i].ray.t_max + R::from_f64(self.margin) / rays[i].ray.d.length();
        }
        let reach_max = reach[..n].iter().fold(reach[0], |m, &r| m.max(r));
        let mut box_tests = 0u64;
        let mut prim_tests = 0u64;
        let mut stack = Stack::<R>::new();
        let mut cur: ChildRef = 0;
        'walk: loop {
            let node = &self.nodes[cur as usize];
            box_tests += u64::from(node.used);
            let (mask, _) = frustum.test8(&node.bounds, reach_max);
            for lane in SetBits(mask & node.lanes()) {
                let c = node.child[lane];
                if !is_leaf(c) {
                    stack.push(c, R::ZERO);
                    continue;
                }
                let (lo, hi) = node.bounds.lane(lane);
                let (first, count) = leaf_range(c);
                let prims = &self.order[first..first + count];
                box_tests += u64::from((all & !done).count_ones());
                let open = slab_dispatch::enter16(&lanes, &lo, &hi, &reach) & all & !done;
                if open == 0 {
                    continue;
                }
                let mut first = [0usize; PACKET];
                let blocked = test.any_many(rays, open, prims, &mut first);
                // Counted as the one-at-a-time loop counts: up to the first hit.
                prim_tests += u64::from((open & !blocked).count_ones()) * prims.len() as u64;
                for i in SetBits(blocked) {
                    prim_tests += first[i] as u64 + 1;
                }
                done |= blocked;
                if done == all {
                    break 'walk;
                }
            }
            match stack.pop() {
                Some((c, _)) => cur = c,
                None => break 'walk,
            }
        }
        for (i, o) in out[..n].iter_mut().enumerate() {
            *o = done & (1 << i) != 0;
        }
        stats.box_tests += box_tests;
        stats.primitive_tests += prim_tests;
    }
}
