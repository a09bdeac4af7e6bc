//! The primitive test an accelerator calls: one primitive at a time ([`PrimTest::test`]), or a
//! BVH leaf's run of primitives at once ([`PrimTest::closest`], [`PrimTest::any`]), which a
//! scene can answer with SIMD ([`crate::scene_leaf::SceneLeaf`]). Any closure
//! `FnMut(prim, t_max) -> Option<PrimHit>` is a test that goes one primitive at a time;
//! [`RayPrimTest`] is the same for packets, where the ray comes with each call.
//!
//! A leaf's answers must be those of the one-at-a-time loop: [`PrimTest::closest`] offers each
//! primitive's hit in order, testing it with `t_max` = the best `t` so far or any larger bound
//! (a hit beyond the best so far never beats it, so testing all of a leaf with the bound it was
//! entered with gives the same nearest hit); [`PrimTest::any`] names the first one hit.

use crate::geometry::{Nearest, PreparedRay, PrimHit};
use crate::real::Real;

/// The primitive test of one ray.
pub trait PrimTest<R: Real> {
    /// Primitive `prim` within `t_max` (inclusive).
    fn test(&mut self, prim: u32, t_max: R) -> Option<PrimHit<R>>;

    /// Offers the hits of `prims` to `best`, in order.
    #[inline(always)]
    fn closest(&mut self, prims: &[u32], best: &mut Nearest<R>) {
        for &p in prims {
            best.offer(self.test(p, best.t));
        }
    }

    /// The position in `prims` of the first primitive hit within `t_max`.
    #[inline(always)]
    fn any(&mut self, prims: &[u32], t_max: R) -> Option<usize> {
        prims.iter().position(|&p| self.test(p, t_max).is_some())
    }
}

impl<R: Real, F: FnMut(u32, R) -> Option<PrimHit<R>>> PrimTest<R> for F {
    #[inline(always)]
    fn test(&mut self, prim: u32, t_max: R) -> Option<PrimHit<R>> {
        self(prim, t_max)
    }
}

/// The primitive test of a packet's rays: [`PrimTest`] with the ray passed in.
pub trait RayPrimTest<R: Real> {
    /// Primitive `prim` against `pr` within `t_max` (inclusive).
    fn test(&mut self, pr: &PreparedRay<R>, prim: u32, t_max: R) -> Option<PrimHit<R>>;

    /// [`PrimTest::closest`] for `pr`.
    #[inline(always)]
    fn closest(&mut self, pr: &PreparedRay<R>, prims: &[u32], best: &mut Nearest<R>) {
        for &p in prims {
            best.offer(self.test(pr, p, best.t));
        }
    }

    /// [`PrimTest::any`] for `pr`.
    #[inline(always)]
    fn any(&mut self, pr: &PreparedRay<R>, prims: &[u32], t_max: R) -> Option<usize> {
        prims
            .iter()
            .position(|&p| self.test(pr, p, t_max).is_some())
    }

    /// [`RayPrimTest::closest`] for each ray `rays[i]` whose bit `i` is set in `which`, into
    /// `best[i]`, all at once (a packet's rays entering a leaf); `false`, having done nothing,
    /// when this test has no way to take these rays together (the caller then goes ray by ray).
    #[inline(always)]
    fn closest_rays(
        &mut self,
        _rays: &[PreparedRay<R>],
        _which: u32,
        _prims: &[u32],
        _best: &mut [Nearest<R>],
    ) -> bool {
        false
    }

    /// [`RayPrimTest::any`] for each ray `rays[i]` whose bit `i` is set in `which`, within the
    /// ray's own `t_max`, all at once: the bits of the rays hit, with the primitive tests added
    /// to `tests` as the one-at-a-time loop counts them (up to each ray's first hit); `None`,
    /// having done nothing, as [`RayPrimTest::closest_rays`] says.
    #[inline(always)]
    fn any_rays(
        &mut self,
        _rays: &[PreparedRay<R>],
        _which: u32,
        _prims: &[u32],
        _tests: &mut u64,
    ) -> Option<u32> {
        None
    }
}

impl<R: Real, F: FnMut(&PreparedRay<R>, u32, R) -> Option<PrimHit<R>>> RayPrimTest<R> for F {
    #[inline(always)]
    fn test(&mut self, pr: &PreparedRay<R>, prim: u32, t_max: R) -> Option<PrimHit<R>> {
        self(pr, prim, t_max)
    }
}

/// A packet test used for one ray of the packet.
pub struct OneRay<'a, R, T> {
    /// The packet's test.
    pub test: &'a mut T,
    /// The ray.
    pub pr: &'a PreparedRay<R>,
}

impl<R: Real, T: RayPrimTest<R>> PrimTest<R> for OneRay<'_, R, T> {
    #[inline(always)]
    fn test(&mut self, prim: u32, t_max: R) -> Option<PrimHit<R>> {
        self.test.test(self.pr, prim, t_max)
    }

    #[inline(always)]
    fn closest(&mut self, prims: &[u32], best: &mut Nearest<R>) {
        self.test.closest(self.pr, prims, best)
    }

    #[inline(always)]
    fn any(&mut self, prims: &[u32], t_max: R) -> Option<usize> {
        self.test.any(self.pr, prims, t_max)
    }
}
