//! Which slab kernel a precision runs: for `f32` rays on x86-64 the SSE kernels on the `sse2`
//! tier, the AVX node test on `avx2` and `avx512`, and on `avx512` the sixteen-ray test in one
//! AVX-512 register ([`crate::isa`]); the lane-by-lane ones otherwise (`f64`, the `scalar`
//! tier, other targets). Lives above [`crate::real`] so the scalar trait knows nothing of the
//! SIMD code; the choice by type folds away at compile time, the tier is one predictable
//! branch.

use std::any::Any;

use super::slab16::{enter16_f32, enter16_lanes, RayLanes, LANES};
use super::slab8::{slab8_lanes, Box8, SlabRay, WIDTH};
use crate::isa::Isa;
use crate::real::Real;

/// Eight slab tests at once ([`super::slab8`]) with the kernel of the process's tier: every
/// kernel computes exactly what the scalar slab test computes.
#[inline(always)]
pub fn slab8<R: Real>(b: &Box8, r: &SlabRay<R>, t_max: R) -> (u32, [R; WIDTH]) {
    slab8_on(crate::isa::current(), b, r, t_max)
}

/// [`slab8`] with the kernel of `tier`, which must be a tier this CPU runs. The traversal
/// reads the tier once per ray; in a walk compiled for the tier's instruction set the AVX
/// kernels inline.
#[inline(always)]
pub fn slab8_on<R: Real>(tier: Isa, b: &Box8, r: &SlabRay<R>, t_max: R) -> (u32, [R; WIDTH]) {
    #[cfg(target_arch = "x86_64")]
    if let Some(r32) = (r as &dyn Any).downcast_ref::<SlabRay<f32>>() {
        let t_max = t_max.to_f32();
        // R is f32 here: the conversions are the identity.
        let (mask, t) = if tier.avx() {
            // SAFETY: the avx2 and avx512 tiers are only chosen on a CPU with AVX.
            unsafe { super::slab8::slab8_avx(b, r32, t_max) }
        } else if tier.sse2() {
            super::slab8::slab8_sse2(b, r32, t_max)
        } else {
            slab8_lanes(b, r32, t_max)
        };
        return (mask, t.map(R::from_f32));
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = tier;
    slab8_lanes(b, r, t_max)
}

/// One box against the sixteen rays of a packet ([`super::slab16`]): both kernels compute what
/// the scalar slab test computes.
#[inline(always)]
pub fn enter16<R: Real>(l: &RayLanes<R>, lo: &[f32; 3], hi: &[f32; 3], reach: &[R; LANES]) -> u32 {
    let any_l = l as &dyn Any;
    let any_reach = reach as &dyn Any;
    if let (Some(l32), Some(reach32)) = (
        any_l.downcast_ref::<RayLanes<f32>>(),
        any_reach.downcast_ref::<[f32; LANES]>(),
    ) {
        let tier = crate::isa::current();
        #[cfg(target_arch = "x86_64")]
        if tier.avx512() {
            // SAFETY: the avx512 tier is only chosen on a CPU that has AVX-512 F.
            return unsafe { super::slab16::enter16_avx512(l32, lo, hi, reach32) };
        }
        if tier.sse2() {
            return enter16_f32(l32, lo, hi, reach32);
        }
    }
    enter16_lanes(l, lo, hi, reach)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_tier_and_both_precisions_agree_with_the_lane_kernel() {
        let mut b = Box8::EMPTY;
        b.set(0, [-1.0; 3], [1.0; 3]);
        b.set(2, [2.0, -1.0, -1.0], [3.0, 1.0, 1.0]);
        b.set(6, [4.0, -1.0, -1.0], [5.0, 1.0, 1.0]);
        b.set(7, [4.0, 2.0, -1.0], [5.0, 3.0, 1.0]);
        let r32 = SlabRay::<f32> {
            o: [-5.0, 0.25, 0.5],
            inv: [1.0, f32::INFINITY, f32::INFINITY],
            neg: [false; 3],
            t_min: 0.0,
        };
        let want = slab8_lanes(&b, &r32, 100.0);
        assert_eq!(want.0, 0b0100_0101);
        for tier in Isa::supported_tiers() {
            assert_eq!(slab8_on(tier, &b, &r32, 100.0), want, "{tier}");
        }
        let r64 = SlabRay::<f64> {
            o: [-5.0, 0.25, 0.5],
            inv: [1.0, f64::INFINITY, f64::INFINITY],
            neg: [false; 3],
            t_min: 0.0,
        };
        let (mask, _) = slab8(&b, &r64, 100.0);
        assert_eq!(mask, 0b0100_0101);
    }
}
