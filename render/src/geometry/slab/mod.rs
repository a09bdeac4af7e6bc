//! The box slab test, written once: the scalar test ([`slab`], one ray and one box in the ray's
//! precision), the same arithmetic over lanes ([`interval`]), and its two uses — one ray against
//! a wide node's eight boxes ([`node`], through [`slab8_on`]) and one box against a packet's
//! sixteen rays ([`packet`], through [`enter16`]). The lane type is chosen per tier in one
//! place ([`crate::isa`]): eight `f32` lanes on `avx2` and `avx512` for the node test, sixteen
//! on `avx512` and eight on `avx2` for the packet test, four on `sse2`, one lane at a time on
//! `scalar` and for `f64` rays.
//!
//! The test is robust: a NaN distance (0·∞ for a ray lying in a slab plane) leaves the interval
//! as it was ([`crate::lanes::Lanes::max_or`]), and the far distance is widened by 1 + 2γ₃ so
//! rounding never loses a box the ray meets. Every lane computes exactly what [`slab`]
//! computes — the same operations in the same order — so a box is accepted by one kernel
//! exactly when it is accepted by any other, at the same entry distance.

use std::any::Any;

use super::ray::PreparedRay;
use crate::isa::{self, Isa, Kernel, Tier};
use crate::lanes::Lanes;
use crate::real::Real;

pub mod node;
pub mod packet;

pub use node::{Box8, NodeRay, WIDTH};
pub use packet::{LeafRays, LANES};

/// The slab test on a box given by its corners, in the ray's precision: `Some(t_near)` when
/// the ray meets the box within `[t_min, t_max]`.
#[inline(always)]
pub fn slab<R: Real>(min: &[f32; 3], max: &[f32; 3], pr: &PreparedRay<R>, t_max: R) -> Option<R> {
    let o = pr.ray.o;
    let mut t0 = pr.ray.t_min;
    let mut t1 = t_max;
    let widen = R::ONE + R::TWO * R::gamma(3);
    for a in 0..3 {
        let (lo, hi) = if pr.neg[a] {
            (max[a], min[a])
        } else {
            (min[a], max[a])
        };
        let inv = pr.inv_d.get(a);
        let oa = o.get(a);
        let t_near = (R::from_f32(lo) - oa) * inv;
        let t_far = (R::from_f32(hi) - oa) * inv * widen;
        // NaN (0·∞ for a ray lying in a slab plane) compares false and leaves the interval as is.
        if t_near > t0 {
            t0 = t_near;
        }
        if t_far < t1 {
            t1 = t_far;
        }
        if t0 > t1 {
            return None;
        }
    }
    Some(t0)
}

/// Rays and boxes in lanes, per axis: origin, reciprocal direction, near and far planes.
#[derive(Clone, Copy, Debug)]
pub struct LaneSlab<L> {
    /// Ray origins.
    pub o: [L; 3],
    /// Reciprocal directions.
    pub inv: [L; 3],
    /// The planes entered first (the box's minimum on an axis the ray goes up).
    pub near: [L; 3],
    /// The planes left last.
    pub far: [L; 3],
}

/// [`slab`]'s arithmetic lane by lane, from the interval `[t0, t1]`: which lanes enter, and
/// their entry distances (valid where the mask is set).
#[inline(always)]
pub fn interval<L: Lanes>(s: LaneSlab<L>, mut t0: L, mut t1: L) -> (L::Mask, L) {
    let one = <L::Elem as Real>::ONE;
    let widen = L::splat(one + <L::Elem as Real>::TWO * <L::Elem as Real>::gamma(3));
    for a in 0..3 {
        let t_near = (s.near[a] - s.o[a]) * s.inv[a];
        let t_far = (s.far[a] - s.o[a]) * s.inv[a] * widen;
        t0 = t_near.max_or(t0);
        t1 = t_far.min_or(t1);
    }
    (t0.le(t1), t0)
}

/// The eight boxes of `b` against `r` ([`node::node`]) with the kernel of the process's tier.
#[inline(always)]
pub fn slab8<R: Real>(b: &Box8, r: &NodeRay<R>, t_max: R) -> (u32, [R; WIDTH]) {
    slab8_on(isa::current(), b, r, t_max)
}

/// [`slab8`] with the kernel of `tier`, which must be a tier this CPU runs, inline in the
/// caller: the walks read the tier once per ray, and in a walk compiled for AVX the eight-lane
/// kernel is a few instructions.
#[inline(always)]
pub fn slab8_on<R: Real>(tier: Isa, b: &Box8, r: &NodeRay<R>, t_max: R) -> (u32, [R; WIDTH]) {
    // SAFETY: the caller passes a tier this CPU runs (the process's tier, or one checked).
    unsafe { isa::run_inline(tier, NodeTest { b, r, t_max }) }
}

/// One box against the rays of a packet ([`packet::enter`]) with the kernel of the process's
/// tier: bit `i` set when ray `i` enters within `reach[i]`.
#[inline(always)]
pub fn enter16<R: Real>(l: &LeafRays<R>, lo: &[f32; 3], hi: &[f32; 3], reach: &[R; LANES]) -> u32 {
    let tier = isa::current();
    let k = PacketTest { l, lo, hi, reach };
    if tier.avx512() && (l as &dyn Any).is::<LeafRays<f32>>() {
        // Sixteen lanes need AVX-512 enabled, which the packet walk is not compiled with: the
        // tier's own compiled entry.
        return isa::dispatch(k);
    }
    // SAFETY: the process's tier is one this CPU runs.
    unsafe { isa::run_inline(tier, k) }
}

/// One ray against eight boxes: the kernel [`slab8_on`] runs.
struct NodeTest<'a, R> {
    b: &'a Box8,
    r: &'a NodeRay<R>,
    t_max: R,
}

impl<R: Real> Kernel for NodeTest<'_, R> {
    type Output = (u32, [R; WIDTH]);

    /// For `f32` rays: eight lanes where AVX runs, four on `sse2`; one lane otherwise.
    #[inline(always)]
    fn run<T: Tier>(self) -> (u32, [R; WIDTH]) {
        #[cfg(target_arch = "x86_64")]
        if let Some(r32) = (self.r as &dyn Any).downcast_ref::<NodeRay<f32>>() {
            use crate::lanes::{X4, X8};
            let t_max = self.t_max.to_f32();
            // R is f32 here: the conversions are the identity.
            let (mask, t) = if T::ISA.avx() {
                node::node::<X8>(self.b, r32, t_max)
            } else if T::ISA.sse2() {
                node::node::<X4>(self.b, r32, t_max)
            } else {
                node::node::<f32>(self.b, r32, t_max)
            };
            return (mask, t.map(R::from_f32));
        }
        node::node::<R>(self.b, self.r, self.t_max)
    }
}

/// One box against a packet's rays: the kernel [`enter16`] runs.
struct PacketTest<'a, R> {
    l: &'a LeafRays<R>,
    lo: &'a [f32; 3],
    hi: &'a [f32; 3],
    reach: &'a [R; LANES],
}

impl<R: Real> Kernel for PacketTest<'_, R> {
    type Output = u32;

    /// For `f32` rays: sixteen lanes on `avx512`, eight on `avx2`, four on `sse2`; one lane
    /// otherwise.
    #[inline(always)]
    fn run<T: Tier>(self) -> u32 {
        let PacketTest { l, lo, hi, reach } = self;
        #[cfg(target_arch = "x86_64")]
        if let (Some(l32), Some(reach32)) = (
            (l as &dyn Any).downcast_ref::<LeafRays<f32>>(),
            (reach as &dyn Any).downcast_ref::<[f32; LANES]>(),
        ) {
            use crate::lanes::{X16, X4, X8};
            return if T::ISA.avx512() {
                packet::enter::<X16>(l32, lo, hi, reach32)
            } else if T::ISA.avx() {
                packet::enter::<X8>(l32, lo, hi, reach32)
            } else if T::ISA.sse2() {
                packet::enter::<X4>(l32, lo, hi, reach32)
            } else {
                packet::enter::<f32>(l32, lo, hi, reach32)
            };
        }
        packet::enter::<R>(l, lo, hi, reach)
    }
}

/// [`slab8`] with the code of `tier`, or `None` when this CPU does not run `tier` (for the
/// tests that compare the tiers).
#[cfg(test)]
fn slab8_tier<R: Real>(tier: Isa, b: &Box8, r: &NodeRay<R>, t_max: R) -> Option<(u32, [R; WIDTH])> {
    isa::dispatch_on(tier, NodeTest { b, r, t_max })
}

/// [`enter16`] with the code of `tier`, or `None` when this CPU does not run `tier`.
#[cfg(test)]
fn enter16_tier<R: Real>(
    tier: Isa,
    l: &LeafRays<R>,
    lo: &[f32; 3],
    hi: &[f32; 3],
    reach: &[R; LANES],
) -> Option<u32> {
    isa::dispatch_on(tier, PacketTest { l, lo, hi, reach })
}

#[cfg(test)]
mod tests;
