//! The primitive test an accelerator calls: one primitive at a time ([`PrimTest::test`]), or a
//! BVH leaf's run of primitives at once ([`PrimTest::closest`], [`PrimTest::any`]), which a
//! scene can answer with SIMD ([`crate::packet::scene_leaf::SceneLeaf`]). Any closure
//! `FnMut(prim, t_max) -> Option<PrimHit>` is a test that goes one primitive at a time;
//! [`RayPrimTest`] is the same for packets, where the ray comes with each call, and can take a
//! leaf against several of the packet's rays at once ([`RayPrimTest::closest_many`],
//! [`RayPrimTest::any_many`]) so work on the leaf is shared.
//!
//! A leaf's answers must be those of the one-at-a-time loop: [`PrimTest::closest`] offers each
//! primitive's hit in order, testing it with `t_max` = the best `t` so far or any larger bound
//! (a hit beyond the best so far never beats it, so testing all of a leaf with the bound it was
//! entered with gives the same nearest hit); [`PrimTest::any`] names the first one hit.

use crate::bits::SetBits;
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

    /// [`Self::closest`] of `prims` for every ray `rays[i]` whose bit `i` is set in `mask`,
    /// into `best[i]`; each ray gets exactly the answer [`Self::closest`] gives it alone.
    #[inline(always)]
    fn closest_many(
        &mut self,
        rays: &[PreparedRay<R>],
        mask: u32,
        prims: &[u32],
        best: &mut [Nearest<R>],
    ) {
        for i in SetBits(mask) {
            self.closest(&rays[i], prims, &mut best[i]);
        }
    }

    /// [`Self::any`] of `prims` for every ray `rays[i]` whose bit `i` is set in `mask`, each
    /// within its own `t_max`: bit `i` of the answer is set when ray `i` is blocked, and then
    /// `first[i]` is [`Self::any`]'s position.
    #[inline(always)]
    fn any_many(
        &mut self,
        rays: &[PreparedRay<R>],
        mask: u32,
        prims: &[u32],
        first: &mut [usize],
    ) -> u32 {
        let mut hit = 0;
        for i in SetBits(mask) {
            let pr = &rays[i];
            if let Some(k) = self.any(pr, prims, pr.ray.t_max) {
                first[i] = k;
                hit |= 1 << i;
            }
        }
        hit
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
