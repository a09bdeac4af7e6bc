//! A packet's rays as the walk reads them ([`PacketRays`]): prepared rays with their box-test
//! lanes ([`Slice`]) or a packet already in lanes ([`RayPacket`]), and the primitive test a
//! packet in lanes needs ([`LanesPrimTest`]).

use crate::accel::prim_test::RayPrimTest;
use crate::geometry::ray_packet::RayPacket;
use crate::geometry::slab::LeafRays;
use crate::geometry::{Nearest, PreparedRay};
use crate::real::Real;

/// The primitive test of a packet in lanes ([`RayPacket`]): [`RayPrimTest`] (for rays traced one
/// by one, prepared from their lanes) plus a leaf against several of the packet's rays, each
/// with exactly the answer [`RayPrimTest::closest`] or [`RayPrimTest::any`] gives it alone.
pub trait LanesPrimTest: RayPrimTest<f32> {
    /// [`RayPrimTest::closest_many`] for the rays of `rays` whose bits are set in `mask`.
    fn closest_lanes(
        &mut self,
        rays: &RayPacket,
        mask: u32,
        prims: &[u32],
        best: &mut [Nearest<f32>],
    );

    /// [`RayPrimTest::any_many`] for the rays of `rays` whose bits are set in `mask`, each
    /// within its own `t_max`.
    fn any_lanes(&mut self, rays: &RayPacket, mask: u32, prims: &[u32], first: &mut [usize])
        -> u32;
}

/// A packet's rays as the walks read them: a slice of prepared rays with their box-test lanes,
/// or a [`RayPacket`]; `T` is the primitive test the rays go to.
pub(super) trait PacketRays<R: Real, T> {
    /// Rays in the packet.
    fn len(&self) -> usize;
    /// Ray `i`'s end.
    fn t_max(&self, i: usize) -> R;
    /// The length of ray `i`'s direction.
    fn d_length(&self, i: usize) -> R;
    /// The rays' lanes for the box test.
    fn slab(&self) -> &LeafRays<R>;
    /// [`RayPrimTest::closest_many`].
    fn closest(&self, test: &mut T, mask: u32, prims: &[u32], best: &mut [Nearest<R>]);
    /// [`RayPrimTest::any_many`].
    fn any(&self, test: &mut T, mask: u32, prims: &[u32], first: &mut [usize]) -> u32;
}

/// Prepared rays and their box-test lanes.
pub(super) struct Slice<'a, R> {
    rays: &'a [PreparedRay<R>],
    lanes: LeafRays<R>,
}

impl<'a, R: Real> Slice<'a, R> {
    #[inline(always)]
    pub(super) fn new(rays: &'a [PreparedRay<R>], neg: [bool; 3]) -> Self {
        Slice {
            rays,
            lanes: LeafRays::new(rays, neg),
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
    fn slab(&self) -> &LeafRays<R> {
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

impl<T: LanesPrimTest> PacketRays<f32, T> for RayPacket {
    #[inline(always)]
    fn len(&self) -> usize {
        RayPacket::len(self)
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
    fn slab(&self) -> &LeafRays<f32> {
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
