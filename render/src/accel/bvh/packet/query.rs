//! What a packet walk asks for each of its rays ([`PacketQuery`]): the closest hit
//! ([`Closest`]) or whether anything blocks it ([`AnyHit`]), with the per-ray state each
//! needs; and the rays a query takes one by one when they cannot go together ([`RayList`]).

use super::rays::PacketRays;
use super::PACKET;
use crate::accel::bvh::Bvh;
use crate::accel::prim_test::PrimTest;
use crate::bits::SetBits;
use crate::geometry::ray_packet::RayPacket;
use crate::geometry::{Nearest, PreparedRay, PrimHit};
use crate::real::Real;
use crate::stats::RayStats;

/// Rays a packet's query can take one by one: prepared rays, or a packet in lanes.
pub(super) trait RayList<R: Real> {
    /// Rays in the list.
    fn count(&self) -> usize;
    /// Ray `i`, prepared.
    fn ray(&self, i: usize) -> PreparedRay<R>;
}

impl<R: Real> RayList<R> for [PreparedRay<R>] {
    fn count(&self) -> usize {
        self.len()
    }
    fn ray(&self, i: usize) -> PreparedRay<R> {
        self[i]
    }
}

impl RayList<f32> for RayPacket {
    fn count(&self) -> usize {
        self.len()
    }
    fn ray(&self, i: usize) -> PreparedRay<f32> {
        self.prepared(i)
    }
}

/// What a packet walk asks of the tree for each of its rays (the closest hit, [`Closest`], or
/// any hit, [`AnyHit`]), with the per-ray state: the leaf test, when to stop, how far boxes
/// are taken and in which order children are visited. Its methods are `#[inline(always)]` so
/// each query's walk is compiled as if written for it.
pub(super) trait PacketQuery<R: Real> {
    /// Children visited nearest first (the closest hit); else in lane order.
    const NEAREST_FIRST: bool;
    /// Ray `i` alone, through the single-ray walk.
    fn alone<T: PrimTest<R>>(
        &mut self,
        bvh: &Bvh,
        i: usize,
        pr: &PreparedRay<R>,
        stats: &mut RayStats,
        test: T,
    );
    /// Ready for the packet `rays`: their ends and slacks (`margin` in scene units).
    fn start<T, S: PacketRays<R, T>>(&mut self, rays: &S, margin: f64);
    /// The distance a node's boxes must be entered within by some ray.
    fn reach(&self) -> R;
    /// Per ray, the distance a leaf's box must be entered within.
    fn reach_rays(&self) -> &[R; PACKET];
    /// The rays still asking, of `all`.
    fn open(&self, all: u32) -> u32;
    /// Whether a subtree or leaf entered at `t` can be skipped.
    fn prune(&self, t: R) -> bool;
    /// Tests a leaf's primitives for the rays of `enter`, counting the tests into `tests` as
    /// the one-at-a-time loop counts them; true when the walk may stop.
    fn leaf<T, S: PacketRays<R, T>>(
        &mut self,
        rays: &S,
        test: &mut T,
        enter: u32,
        prims: &[u32],
        tests: &mut u64,
    ) -> bool;
    /// Writes the answers of a walk's rays.
    fn finish(self);
}

/// The largest of the first `n` of `r`.
#[inline(always)]
fn largest<R: Real>(r: &[R; PACKET], n: usize) -> R {
    r[..n].iter().fold(r[0], |m, &x| m.max(x))
}

/// The closest hit of each ray, into `out`.
pub(super) struct Closest<'a, R> {
    out: &'a mut [Option<PrimHit<R>>],
    n: usize,
    best: [Nearest<R>; PACKET],
    slack: [R; PACKET],
    /// Per ray: its best hit plus the slack (lanes past `n` never reach anything).
    reach_ray: [R; PACKET],
    reach: R,
}

impl<'a, R: Real> Closest<'a, R> {
    pub(super) fn new(out: &'a mut [Option<PrimHit<R>>]) -> Self {
        Closest {
            out,
            n: 0,
            best: [Nearest::new(R::ZERO); PACKET],
            slack: [R::ZERO; PACKET],
            reach_ray: [R::from_f64(-1.0); PACKET],
            reach: R::ZERO,
        }
    }
}

impl<R: Real> PacketQuery<R> for Closest<'_, R> {
    const NEAREST_FIRST: bool = true;

    fn alone<T: PrimTest<R>>(
        &mut self,
        bvh: &Bvh,
        i: usize,
        pr: &PreparedRay<R>,
        stats: &mut RayStats,
        test: T,
    ) {
        self.out[i] = bvh.intersect(pr, stats, test);
    }
    #[inline(always)]
    fn start<T, S: PacketRays<R, T>>(&mut self, rays: &S, margin: f64) {
        self.n = rays.len();
        for i in 0..self.n {
            self.best[i] = Nearest::new(rays.t_max(i));
            self.slack[i] = R::from_f64(margin) / rays.d_length(i);
            self.reach_ray[i] = self.best[i].t + self.slack[i];
        }
        self.reach = largest(&self.reach_ray, self.n);
    }
    #[inline(always)]
    fn reach(&self) -> R {
        self.reach
    }
    #[inline(always)]
    fn reach_rays(&self) -> &[R; PACKET] {
        &self.reach_ray
    }
    #[inline(always)]
    fn open(&self, all: u32) -> u32 {
        all
    }
    #[inline(always)]
    fn prune(&self, t: R) -> bool {
        // Beyond every ray's nearest hit so far (ties still go in).
        t > self.reach
    }
    #[inline(always)]
    fn leaf<T, S: PacketRays<R, T>>(
        &mut self,
        rays: &S,
        test: &mut T,
        enter: u32,
        prims: &[u32],
        tests: &mut u64,
    ) -> bool {
        *tests += u64::from(enter.count_ones()) * prims.len() as u64;
        let before = self.best.map(|b| b.t);
        rays.closest(test, enter, prims, &mut self.best);
        let mut improved = false;
        for i in SetBits(enter) {
            improved |= self.best[i].t != before[i];
            self.reach_ray[i] = self.best[i].t + self.slack[i];
        }
        if improved {
            self.reach = largest(&self.reach_ray, self.n);
        }
        false
    }
    #[inline(always)]
    fn finish(self) {
        for i in 0..self.n {
            self.out[i] = self.best[i].hit;
        }
    }
}

/// Whether anything blocks each ray, into `out`: a ray drops out at its first hit, the walk
/// stops when every ray has one.
pub(super) struct AnyHit<'a, R> {
    out: &'a mut [bool],
    n: usize,
    /// Per ray: its end plus the slack (lanes past `n` never reach anything).
    reach: [R; PACKET],
    reach_max: R,
    all: u32,
    done: u32,
}

impl<'a, R: Real> AnyHit<'a, R> {
    pub(super) fn new(out: &'a mut [bool]) -> Self {
        AnyHit {
            out,
            n: 0,
            reach: [R::from_f64(-1.0); PACKET],
            reach_max: R::ZERO,
            all: 0,
            done: 0,
        }
    }
}

impl<R: Real> PacketQuery<R> for AnyHit<'_, R> {
    const NEAREST_FIRST: bool = false;

    fn alone<T: PrimTest<R>>(
        &mut self,
        bvh: &Bvh,
        i: usize,
        pr: &PreparedRay<R>,
        stats: &mut RayStats,
        test: T,
    ) {
        self.out[i] = bvh.occluded(pr, stats, test);
    }
    #[inline(always)]
    fn start<T, S: PacketRays<R, T>>(&mut self, rays: &S, margin: f64) {
        self.n = rays.len();
        self.all = (1 << self.n) - 1;
        for i in 0..self.n {
            self.reach[i] = rays.t_max(i) + R::from_f64(margin) / rays.d_length(i);
        }
        self.reach_max = largest(&self.reach, self.n);
    }
    #[inline(always)]
    fn reach(&self) -> R {
        self.reach_max
    }
    #[inline(always)]
    fn reach_rays(&self) -> &[R; PACKET] {
        &self.reach
    }
    #[inline(always)]
    fn open(&self, all: u32) -> u32 {
        all & !self.done
    }
    #[inline(always)]
    fn prune(&self, _t: R) -> bool {
        false
    }
    #[inline(always)]
    fn leaf<T, S: PacketRays<R, T>>(
        &mut self,
        rays: &S,
        test: &mut T,
        enter: u32,
        prims: &[u32],
        tests: &mut u64,
    ) -> bool {
        let mut first = [0usize; PACKET];
        let blocked = rays.any(test, enter, prims, &mut first);
        // Counted as the one-at-a-time loop counts: up to the first hit.
        *tests += u64::from((enter & !blocked).count_ones()) * prims.len() as u64;
        for i in SetBits(blocked) {
            *tests += first[i] as u64 + 1;
        }
        self.done |= blocked;
        self.done == self.all
    }
    #[inline(always)]
    fn finish(self) {
        for (i, o) in self.out[..self.n].iter_mut().enumerate() {
            *o = self.done & (1 << i) != 0;
        }
    }
}
