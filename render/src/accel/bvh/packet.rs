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
use crate::geometry::lanes16::Lanes16;
use crate::geometry::slab;
use crate::geometry::slab::Box8;
use crate::geometry::slab::RayLanes;
use crate::geometry::{Nearest, PreparedRay, PrimHit};
use crate::real::Real;
use crate::stats::RayStats;

/// Most rays in a packet (a 4 × 4 block of pixels).
pub const PACKET: usize = crate::geometry::slab::LANES;

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

    /// [`Frustum::new`] of a packet in lanes (its lanes past the packet repeat lane 0, so
    /// the bounds over all sixteen are the bounds of its rays).
    #[inline(always)]
    fn from_lanes(l: &Lanes16) -> Option<Frustum<f32>> {
        let s = &l.slab;
        let mut f = Frustum {
            o_lo: [0.0; 3],
            o_hi: [0.0; 3],
            inv_lo: [0.0; 3],
            inv_hi: [0.0; 3],
            neg: s.neg,
            t_min: s.t_min[0],
        };
        let mut ok = true;
        for a in 0..3 {
            let (o, inv) = (&s.o[a], &s.inv[a]);
            let (mut o_lo, mut o_hi, mut i_lo, mut i_hi) = (o[0], o[0], inv[0], inv[0]);
            for i in 0..PACKET {
                ok &= o[i].is_finite() & inv[i].is_finite() & ((inv[i] < 0.0) == s.neg[a]);
                o_lo = o_lo.min(o[i]);
                o_hi = o_hi.max(o[i]);
                i_lo = i_lo.min(inv[i]);
                i_hi = i_hi.max(inv[i]);
            }
            (f.o_lo[a], f.o_hi[a], f.inv_lo[a], f.inv_hi[a]) = (o_lo, o_hi, i_lo, i_hi);
        }
        let mut shortest = f32::INFINITY;
        for i in 0..PACKET {
            ok &= s.t_min[i].is_finite();
            f.t_min = f.t_min.min(s.t_min[i]);
            shortest = shortest.min(l.t_max[i]);
        }
        if !ok {
            return None;
        }
        let mut spread = 0.0f32;
        for a in 0..3 {
            spread = spread.max(f.o_hi[a] - f.o_lo[a]);
        }
        if spread > COHERENCE as f32 * shortest {
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

/// [`Frustum::from_lanes`] for the `avx512` tier: each bound a reduction of one register
/// (`vminps`/`vmaxps`: the bounds of finite lanes, where the order of the reduction changes
/// at most the sign of a zero bound, which no comparison of the walk sees), each check one
/// mask. An end that is NaN counts as +∞ for the shortest ray, as `f32::min` takes it.
///
/// # Safety
/// The CPU must support AVX-512 F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn frustum_avx512(l: &Lanes16) -> Option<Frustum<f32>> {
    use std::arch::x86_64::*;
    let s = &l.slab;
    // SAFETY: every load reads sixteen `f32` of a `[f32; 16]` (unaligned loads).
    let load = |a: &[f32; PACKET]| unsafe { _mm512_loadu_ps(a.as_ptr()) };
    let inf = _mm512_set1_ps(f32::INFINITY);
    let finite = |v: __m512| _mm512_cmp_ps_mask::<_CMP_LT_OQ>(_mm512_abs_ps(v), inf);
    let zero = _mm512_setzero_ps();
    let mut ok = 0xffffu16;
    let mut f = Frustum {
        o_lo: [0.0; 3],
        o_hi: [0.0; 3],
        inv_lo: [0.0; 3],
        inv_hi: [0.0; 3],
        neg: s.neg,
        t_min: 0.0,
    };
    for a in 0..3 {
        let (o, inv) = (load(&s.o[a]), load(&s.inv[a]));
        let neg = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(inv, zero);
        ok &= finite(o) & finite(inv) & if s.neg[a] { neg } else { !neg };
        f.o_lo[a] = _mm512_reduce_min_ps(o);
        f.o_hi[a] = _mm512_reduce_max_ps(o);
        f.inv_lo[a] = _mm512_reduce_min_ps(inv);
        f.inv_hi[a] = _mm512_reduce_max_ps(inv);
    }
    let t_min = load(&s.t_min);
    ok &= finite(t_min);
    if ok != 0xffff {
        return None;
    }
    f.t_min = _mm512_reduce_min_ps(t_min);
    let t_max = load(&l.t_max);
    let nan = _mm512_cmp_ps_mask::<_CMP_UNORD_Q>(t_max, t_max);
    let shortest = _mm512_reduce_min_ps(_mm512_mask_blend_ps(nan, t_max, inf));
    let mut spread = 0.0f32;
    for a in 0..3 {
        spread = spread.max(f.o_hi[a] - f.o_lo[a]);
    }
    if spread > COHERENCE as f32 * shortest {
        return None;
    }
    Some(f)
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

/// The primitive test of a packet in lanes ([`Lanes16`]): [`RayPrimTest`] (for rays traced one
/// by one, prepared from their lanes) plus a leaf against several of the packet's rays, each
/// with exactly the answer [`RayPrimTest::closest`] or [`RayPrimTest::any`] gives it alone.
pub trait LanesPrimTest: RayPrimTest<f32> {
    /// [`RayPrimTest::closest_many`] for the rays of `rays` whose bits are set in `mask`.
    fn closest_lanes(
        &mut self,
        rays: &Lanes16,
        mask: u32,
        prims: &[u32],
        best: &mut [Nearest<f32>],
    );

    /// [`RayPrimTest::any_many`] for the rays of `rays` whose bits are set in `mask`, each
    /// within its own `t_max`.
    fn any_lanes(&mut self, rays: &Lanes16, mask: u32, prims: &[u32], first: &mut [usize]) -> u32;
}

/// A packet's rays as the walks read them: a slice of prepared rays with their box-test lanes,
/// or a [`Lanes16`]; `T` is the primitive test the rays go to.
trait PacketRays<R: Real, T> {
    /// Rays in the packet.
    fn len(&self) -> usize;
    /// Ray `i`'s end.
    fn t_max(&self, i: usize) -> R;
    /// The length of ray `i`'s direction.
    fn d_length(&self, i: usize) -> R;
    /// The rays' lanes for the box test.
    fn slab(&self) -> &RayLanes<R>;
    /// [`RayPrimTest::closest_many`].
    fn closest(&self, test: &mut T, mask: u32, prims: &[u32], best: &mut [Nearest<R>]);
    /// [`RayPrimTest::any_many`].
    fn any(&self, test: &mut T, mask: u32, prims: &[u32], first: &mut [usize]) -> u32;
}

/// Prepared rays and their box-test lanes.
struct Slice<'a, R> {
    rays: &'a [PreparedRay<R>],
    lanes: RayLanes<R>,
}

impl<'a, R: Real> Slice<'a, R> {
    #[inline(always)]
    fn new(rays: &'a [PreparedRay<R>], neg: [bool; 3]) -> Self {
        Slice {
            rays,
            lanes: RayLanes::new(rays, neg),
        }
    }
}

impl<R: Real, T: RayPrimTest<R>> PacketRays<R, T> for Slice<'_, R> {
    #[inline(always)]
    fn len(&self) -> usize {
        self.rays.len()
    }
    #[inline(always)]
    fn t_max(&self, i: usize) -> R {
        self.rays[i].ray.t_max
    }
    #[inline(always)]
    fn d_length(&self, i: usize) -> R {
        self.rays[i].ray.d.length()
    }
    #[inline(always)]
    fn slab(&self) -> &RayLanes<R> {
        &self.lanes
    }
    #[inline(always)]
    fn closest(&self, test: &mut T, mask: u32, prims: &[u32], best: &mut [Nearest<R>]) {
        test.closest_many(self.rays, mask, prims, best)
    }
    #[inline(always)]
    fn any(&self, test: &mut T, mask: u32, prims: &[u32], first: &mut [usize]) -> u32 {
        test.any_many(self.rays, mask, prims, first)
    }
}

impl<T: LanesPrimTest> PacketRays<f32, T> for Lanes16 {
    #[inline(always)]
    fn len(&self) -> usize {
        Lanes16::len(self)
    }
    #[inline(always)]
    fn t_max(&self, i: usize) -> f32 {
        self.t_max[i]
    }
    #[inline(always)]
    fn d_length(&self, i: usize) -> f32 {
        // `|d|²` as `V3::length_squared` computes it: the same square root as `d.length()`.
        self.tri.a[i].sqrt()
    }
    #[inline(always)]
    fn slab(&self) -> &RayLanes<f32> {
        &self.slab
    }
    #[inline(always)]
    fn closest(&self, test: &mut T, mask: u32, prims: &[u32], best: &mut [Nearest<f32>]) {
        test.closest_lanes(self, mask, prims, best)
    }
    #[inline(always)]
    fn any(&self, test: &mut T, mask: u32, prims: &[u32], first: &mut [usize]) -> u32 {
        test.any_lanes(self, mask, prims, first)
    }
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

    /// The bounds a packet in lanes is traced together with, or `None` when its rays go one by
    /// one (the same decision as [`Bvh::takes_as_packet`] on its prepared rays).
    fn lanes_bounds(&self, rays: &Lanes16) -> Option<Frustum<f32>> {
        if rays.len() <= 1 || self.nodes.is_empty() {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        if crate::isa::current().avx512() {
            // SAFETY: the avx512 tier is only chosen on a CPU with AVX-512 F, BW, DQ, VL.
            return unsafe { frustum_avx512(rays) };
        }
        Frustum::<f32>::from_lanes(rays)
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
        let src = Slice::new(rays, frustum.neg);
        self.intersect_packet_walk(&src, out, stats, test, frustum);
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
        let src = Slice::new(rays, frustum.neg);
        self.intersect_packet_walk(&src, out, stats, test, frustum)
    }

    /// Closest hits of a packet in lanes into `out` (same indexing): what
    /// [`Bvh::intersect_packet`] gives the packet's prepared rays, without preparing them (a
    /// ray is prepared only when it goes one by one).
    ///
    /// # Panics
    /// When `out` is shorter than the packet.
    pub fn intersect_lanes<T: LanesPrimTest>(
        &self,
        rays: &Lanes16,
        out: &mut [Option<PrimHit<f32>>],
        stats: &mut RayStats,
        mut test: T,
    ) {
        assert!(out.len() >= rays.len());
        let Some(frustum) = self.lanes_bounds(rays) else {
            for (i, o) in out[..rays.len()].iter_mut().enumerate() {
                let pr = &rays.prepared(i);
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
        if crate::isa::current().avx() {
            // SAFETY: the avx2 and avx512 tiers are only chosen on a CPU with AVX and AVX2.
            return unsafe { self.intersect_lanes_walk_avx(rays, out, stats, test, frustum) };
        }
        self.intersect_packet_walk(rays, out, stats, test, frustum);
    }

    /// [`Bvh::intersect_lanes`]'s walk compiled for the `avx2` and `avx512` tiers.
    ///
    /// # Safety
    /// The CPU must support AVX and AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    unsafe fn intersect_lanes_walk_avx<T: LanesPrimTest>(
        &self,
        rays: &Lanes16,
        out: &mut [Option<PrimHit<f32>>],
        stats: &mut RayStats,
        test: T,
        frustum: Frustum<f32>,
    ) {
        self.intersect_packet_walk(rays, out, stats, test, frustum)
    }

    /// The walk of [`Bvh::intersect_packet`] for a packet its bounds can take.
    #[inline(always)]
    fn intersect_packet_walk<R: Real, T, S: PacketRays<R, T>>(
        &self,
        rays: &S,
        out: &mut [Option<PrimHit<R>>],
        stats: &mut RayStats,
        mut test: T,
        frustum: Frustum<R>,
    ) {
        let n = rays.len();
        let lanes = rays.slab();
        let mut best = [Nearest::new(R::ZERO); PACKET];
        let mut slack = [R::ZERO; PACKET];
        // Per ray: its best hit plus the slack (lanes past `n` never reach anything).
        let mut reach_ray = [R::from_f64(-1.0); PACKET];
        for i in 0..n {
            best[i] = Nearest::new(rays.t_max(i));
            slack[i] = R::from_f64(self.margin) / rays.d_length(i);
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
                let enter = slab::enter16(lanes, &lo, &hi, &reach_ray) & all;
                if enter == 0 {
                    continue;
                }
                prim_tests += u64::from(enter.count_ones()) * prims.len() as u64;
                let before = best.map(|b| b.t);
                rays.closest(&mut test, enter, prims, &mut best);
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
        let src = Slice::new(rays, frustum.neg);
        self.occluded_packet_walk(&src, out, stats, test, frustum);
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
        let src = Slice::new(rays, frustum.neg);
        self.occluded_packet_walk(&src, out, stats, test, frustum)
    }

    /// Whether anything blocks each ray of a packet in lanes, into `out`: what
    /// [`Bvh::occluded_packet`] gives the packet's prepared rays.
    ///
    /// # Panics
    /// When `out` is shorter than the packet.
    pub fn occluded_lanes<T: LanesPrimTest>(
        &self,
        rays: &Lanes16,
        out: &mut [bool],
        stats: &mut RayStats,
        mut test: T,
    ) {
        assert!(out.len() >= rays.len());
        let Some(frustum) = self.lanes_bounds(rays) else {
            for (i, o) in out[..rays.len()].iter_mut().enumerate() {
                let pr = &rays.prepared(i);
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
        if crate::isa::current().avx() {
            // SAFETY: the avx2 and avx512 tiers are only chosen on a CPU with AVX and AVX2.
            return unsafe { self.occluded_lanes_walk_avx(rays, out, stats, test, frustum) };
        }
        self.occluded_packet_walk(rays, out, stats, test, frustum);
    }

    /// [`Bvh::occluded_lanes`]'s walk compiled for the `avx2` and `avx512` tiers.
    ///
    /// # Safety
    /// The CPU must support AVX and AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    unsafe fn occluded_lanes_walk_avx<T: LanesPrimTest>(
        &self,
        rays: &Lanes16,
        out: &mut [bool],
        stats: &mut RayStats,
        test: T,
        frustum: Frustum<f32>,
    ) {
        self.occluded_packet_walk(rays, out, stats, test, frustum)
    }

    /// The walk of [`Bvh::occluded_packet`] for a packet its bounds can take.
    #[inline(always)]
    fn occluded_packet_walk<R: Real, T, S: PacketRays<R, T>>(
        &self,
        rays: &S,
        out: &mut [bool],
        stats: &mut RayStats,
        mut test: T,
        frustum: Frustum<R>,
    ) {
        let n = rays.len();
        let all: u32 = (1 << n) - 1;
        let mut done = 0u32;
        let lanes = rays.slab();
        let mut reach = [R::from_f64(-1.0); PACKET];
        for (i, r) in reach[..n].iter_mut().enumerate() {
            *r = rays.t_max(i) + R::from_f64(self.margin) / rays.d_length(i);
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
                let open = slab::enter16(lanes, &lo, &hi, &reach) & all & !done;
                if open == 0 {
                    continue;
                }
                let mut first = [0usize; PACKET];
                let blocked = rays.any(&mut test, open, prims, &mut first);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Ray;
    use crate::vec3::V3;
    use proptest::prelude::*;

    fn comp() -> impl Strategy<Value = f32> {
        prop_oneof![
            6 => 0.1f32..4.0,
            1 => Just(0.0f32),
            1 => Just(-0.0f32),
            1 => Just(f32::INFINITY),
            1 => Just(f32::NAN),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        /// The AVX-512 bounds of a packet in lanes are the portable ones: the same decision
        /// (signs, finiteness, coherence) and the same bound values.
        #[test]
        fn avx512_bounds_are_the_portable_bounds(
            base in proptest::array::uniform3(-5.0f32..5.0),
            signs in proptest::array::uniform3(any::<bool>()),
            rays in proptest::collection::vec(
                (proptest::array::uniform3(prop_oneof![4 => 0.0f32..0.01, 1 => 0.0f32..2.0]),
                 proptest::array::uniform3(comp()), any::<bool>(),
                 prop_oneof![Just(f32::INFINITY), Just(f32::NAN), 0.0f32..50.0, 0.0f32..0.5],
                 prop_oneof![4 => Just(0.0f32), 1 => 0.0f32..1.0, 1 => Just(f32::NAN)]),
                1..=PACKET),
        ) {
            #[cfg(target_arch = "x86_64")]
            if crate::isa::Isa::Avx512.supported() {
                let mut l = Lanes16::new();
                for &(jitter, d, flip, t_max, t_min) in &rays {
                    let o = V3::from_array([0, 1, 2].map(|a| base[a] + jitter[a]));
                    let mut d = [0, 1, 2].map(|a| if signs[a] { -d[a] } else { d[a] });
                    if flip {
                        d[0] = -d[0];
                    }
                    l.push(&Ray { o, d: V3::from_array(d), t_min, t_max });
                }
                l.prepare();
                let want = Frustum::<f32>::from_lanes(&l);
                // SAFETY: this CPU has AVX-512 F.
                let got = unsafe { frustum_avx512(&l) };
                prop_assert_eq!(want.is_some(), got.is_some(), "{:?} {:?}", want, got);
                if let (Some(w), Some(g)) = (want, got) {
                    // Values, not bits: the sign of a zero bound may differ (see frustum_avx512).
                    prop_assert!(w.o_lo == g.o_lo && w.o_hi == g.o_hi, "{:?} {:?}", w, g);
                    prop_assert!(w.inv_lo == g.inv_lo && w.inv_hi == g.inv_hi, "{:?} {:?}", w, g);
                    prop_assert!(w.neg == g.neg && w.t_min == g.t_min, "{:?} {:?}", w, g);
                }
            }
        }
    }
}
