//! Which slab kernel a precision runs: the SSE kernels for `f32` rays on x86-64 on every tier but
//! `scalar` ([`crate::isa`]; the sixteen-ray test in one AVX-512 register on `avx512`), the
//! lane-by-lane ones otherwise (`f64`, the `scalar` tier, other targets). Lives above
//! [`crate::real`] so the scalar trait knows nothing of the SIMD code; the choice by type folds
//! away at compile time, the tier is one predictable branch.

use std::any::Any;

use super::slab16::{enter16_f32, enter16_lanes, RayLanes, LANES};
use super::slab4::{slab4_f32, slab4_lanes, Box4, SlabRay};
use crate::real::Real;

/// Four slab tests at once ([`super::slab4`]): both kernels compute exactly what the scalar slab
/// test computes.
#[inline(always)]
pub fn slab4<R: Real>(b: &Box4, r: &SlabRay<R>, t_max: R) -> (u32, [R; 4]) {
    if let Some(r32) = (r as &dyn Any)
        .downcast_ref::<SlabRay<f32>>()
        .filter(|_| crate::isa::current().sse2())
    {
        // R is f32 here: both conversions are the identity.
        let (mask, t) = slab4_f32(b, r32, t_max.to_f32());
        return (mask, t.map(R::from_f32));
    }
    slab4_lanes(b, r, t_max)
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
    fn both_precisions_agree_with_the_lane_kernel() {
        let mut b = Box4::EMPTY;
        b.set(0, [-1.0; 3], [1.0; 3]);
        b.set(2, [2.0, -1.0, -1.0], [3.0, 1.0, 1.0]);
        let r32 = SlabRay::<f32> {
            o: [-5.0, 0.25, 0.5],
            inv: [1.0, f32::INFINITY, f32::INFINITY],
            neg: [false; 3],
            t_min: 0.0,
        };
        assert_eq!(slab4(&b, &r32, 100.0), slab4_lanes(&b, &r32, 100.0));
        let r64 = SlabRay::<f64> {
            o: [-5.0, 0.25, 0.5],
            inv: [1.0, f64::INFINITY, f64::INFINITY],
            neg: [false; 3],
            t_min: 0.0,
        };
        let (mask, _) = slab4(&b, &r64, 100.0);
        assert_eq!(mask, 0b101);
    }
}
