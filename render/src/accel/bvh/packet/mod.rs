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
use crate::geometry::ray_packet::RayPacket;
use crate::geometry::slab;
use crate::geometry::{PreparedRay, PrimHit};
use crate::real::Real;
use crate::stats::RayStats;

/// Most rays in a packet (a 4 × 4 block of pixels).
pub const PACKET: usize = crate::geometry::slab::LANES;

/// Widest spread of a packet's origins, relative to its shortest ray, that is still traced as a
/// packet. Measured with `parrt bench cast` on the SPD scenes at 0.003, 0.01, 0.03, 0.1 and
/// without a limit: 0.03 was best or within 4 % of best on every scene; without a limit balls-4
/// casts at 5.0 instead of 12.5 Mrays/s (its shadow packets straddle sphere silhouettes).
pub const COHERENCE: f64 = 0.03;

mod frustum;
mod query;
mod rays;

use frustum::Frustum;
#[cfg(target_arch = "x86_64")]
use frustum::{frustum_avx2, frustum_avx512};
use query::{AnyHit, Closest, PacketQuery, RayList};
pub use rays::LanesPrimTest;
use rays::{PacketRays, Slice};

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

    /// The bounds a packet in lanes is traced together with, or `None` when its rays go one by
    /// one (the same decision as [`Bvh::takes_as_packet`] on its prepared rays).
    fn lanes_bounds(&self, rays: &RayPacket) -> Option<Frustum<f32>> {
        if rays.len() <= 1 || self.nodes.is_empty() {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        if crate::isa::current().avx512() {
            // SAFETY: the avx512 tier is only chosen on a CPU with AVX-512 F, BW, DQ, VL.
            return unsafe { frustum_avx512(rays) };
        }
        #[cfg(target_arch = "x86_64")]
        if crate::isa::current().avx() {
            // SAFETY: the avx2 and avx512 tiers are only chosen on a CPU with AVX and AVX2.
            return unsafe { frustum_avx2(rays) };
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
        test: T,
    ) {
        assert!(rays.len() <= PACKET && out.len() >= rays.len());
        self.packet_slice(rays, stats, test, Closest::new(out));
    }

    /// Closest hits of a packet in lanes into `out` (same indexing): what
    /// [`Bvh::intersect_packet`] gives the packet's prepared rays, without preparing them (a
    /// ray is prepared only when it goes one by one).
    ///
    /// # Panics
    /// When `out` is shorter than the packet.
    pub fn intersect_lanes<T: LanesPrimTest>(
        &self,
        rays: &RayPacket,
        out: &mut [Option<PrimHit<f32>>],
        stats: &mut RayStats,
        test: T,
    ) {
        assert!(out.len() >= rays.len());
        self.packet_lanes(rays, stats, test, Closest::new(out));
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
        test: T,
    ) {
        assert!(rays.len() <= PACKET && out.len() >= rays.len());
        self.packet_slice(rays, stats, test, AnyHit::new(out));
    }

    /// Whether anything blocks each ray of a packet in lanes, into `out`: what
    /// [`Bvh::occluded_packet`] gives the packet's prepared rays.
    ///
    /// # Panics
    /// When `out` is shorter than the packet.
    pub fn occluded_lanes<T: LanesPrimTest>(
        &self,
        rays: &RayPacket,
        out: &mut [bool],
        stats: &mut RayStats,
        test: T,
    ) {
        assert!(out.len() >= rays.len());
        self.packet_lanes(rays, stats, test, AnyHit::new(out));
    }

    /// Query `q` for prepared rays: together when their bounds allow, else one by one.
    #[inline(always)]
    fn packet_slice<R: Real, T: RayPrimTest<R>, Q: PacketQuery<R>>(
        &self,
        rays: &[PreparedRay<R>],
        stats: &mut RayStats,
        test: T,
        q: Q,
    ) {
        match self.packet_bounds(rays) {
            Some(f) => self.packet_walk(&Slice::new(rays, f.neg), stats, test, f, q),
            None => self.one_by_one(rays, stats, test, q),
        }
    }

    /// Query `q` for a packet in lanes: together when its bounds allow, else one by one.
    #[inline(always)]
    fn packet_lanes<T: LanesPrimTest, Q: PacketQuery<f32>>(
        &self,
        rays: &RayPacket,
        stats: &mut RayStats,
        test: T,
        q: Q,
    ) {
        match self.lanes_bounds(rays) {
            Some(f) => self.packet_walk(rays, stats, test, f, q),
            None => self.one_by_one(rays, stats, test, q),
        }
    }

    /// Query `q` for each ray alone, through the single-ray walk.
    fn one_by_one<R: Real, T: RayPrimTest<R>, Q: PacketQuery<R>>(
        &self,
        rays: &(impl RayList<R> + ?Sized),
        stats: &mut RayStats,
        mut test: T,
        mut q: Q,
    ) {
        for i in 0..rays.count() {
            let pr = &rays.ray(i);
            let one = OneRay {
                test: &mut test,
                pr,
            };
            q.alone(self, i, pr, stats, one);
        }
    }

    /// The packet walk for query `q`, in the copy compiled for the process's tier.
    #[inline(always)]
    fn packet_walk<R: Real, T, S: PacketRays<R, T>, Q: PacketQuery<R>>(
        &self,
        rays: &S,
        stats: &mut RayStats,
        test: T,
        frustum: Frustum<R>,
        q: Q,
    ) {
        #[cfg(target_arch = "x86_64")]
        if std::any::TypeId::of::<R>() == std::any::TypeId::of::<f32>()
            && crate::isa::current().avx()
        {
            // SAFETY: the avx2 and avx512 tiers are only chosen on a CPU with AVX and AVX2.
            return unsafe { self.packet_walk_avx(rays, stats, test, frustum, q) };
        }
        self.packet_walk_on(rays, stats, test, frustum, q)
    }

    /// [`Bvh::packet_walk`] compiled for the `avx2` and `avx512` tiers.
    ///
    /// # Safety
    /// The CPU must support AVX and AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,avx2")]
    unsafe fn packet_walk_avx<R: Real, T, S: PacketRays<R, T>, Q: PacketQuery<R>>(
        &self,
        rays: &S,
        stats: &mut RayStats,
        test: T,
        frustum: Frustum<R>,
        q: Q,
    ) {
        self.packet_walk_on(rays, stats, test, frustum, q)
    }

    /// The walk of a packet its bounds can take, for query `q`.
    #[inline(always)]
    fn packet_walk_on<R: Real, T, S: PacketRays<R, T>, Q: PacketQuery<R>>(
        &self,
        rays: &S,
        stats: &mut RayStats,
        mut test: T,
        frustum: Frustum<R>,
        mut q: Q,
    ) {
        let all: u32 = (1 << rays.len()) - 1;
        let lanes = rays.slab();
        q.start(rays, self.margin);
        let mut box_tests = 0u64;
        let mut prim_tests = 0u64;
        let mut stack = Stack::<R>::new();
        let mut cur: ChildRef = 0;
        'walk: loop {
            let node = &self.nodes[cur as usize];
            box_tests += u64::from(node.used);
            let (mask, t) = frustum.test8(&node.bounds, q.reach());
            let mask = mask & node.lanes();
            // Nearest first: the hit children sorted by entry distance, the inner ones pushed
            // after the leaves, farthest first. Any hit: straight from the mask in lane order,
            // each inner child pushed as it comes (the same stack, without building the two
            // arrays at every node; building them cost tree-11's shadow packets 7 %).
            let (sorted, k) = if Q::NEAREST_FIRST {
                sorted_lanes(mask, &t)
            } else {
                ([(R::ZERO, 0); WIDTH], 0)
            };
            let (mut next, mut bits) = (0, mask);
            let mut inner = [(R::ZERO, 0 as ChildRef); WIDTH];
            let mut inner_n = 0;
            loop {
                let (t_lane, lane) = if Q::NEAREST_FIRST {
                    if next == k {
                        break;
                    }
                    next += 1;
                    sorted[next - 1]
                } else {
                    if bits == 0 {
                        break;
                    }
                    let i = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    (t[i], i)
                };
                let c = node.child[lane];
                if !is_leaf(c) {
                    if Q::NEAREST_FIRST {
                        inner[inner_n] = (t_lane, c);
                        inner_n += 1;
                    } else {
                        stack.push(c, t_lane);
                    }
                    continue;
                }
                if q.prune(t_lane) {
                    continue;
                }
                let (lo, hi) = node.bounds.lane(lane);
                let (first, count) = leaf_range(c);
                let prims = &self.order[first..first + count];
                let open = q.open(all);
                box_tests += u64::from(open.count_ones());
                let enter = slab::enter16(lanes, &lo, &hi, q.reach_rays()) & open;
                if enter != 0 && q.leaf(rays, &mut test, enter, prims, &mut prim_tests) {
                    break 'walk;
                }
            }
            for &(t_in, c) in inner[..inner_n].iter().rev() {
                stack.push(c, t_in);
            }
            loop {
                match stack.pop() {
                    Some((c, t_in)) if !q.prune(t_in) => {
                        cur = c;
                        continue 'walk;
                    }
                    Some(_) => {}
                    None => break 'walk,
                }
            }
        }
        q.finish();
        stats.box_tests += box_tests;
        stats.primitive_tests += prim_tests;
    }
}
