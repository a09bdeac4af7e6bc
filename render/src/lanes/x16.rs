//! Sixteen `f32` lanes in an AVX-512 register: only for a kernel the `avx512` tier runs
//! ([`crate::isa::dispatch`]), compiled with AVX-512 F, BW, DQ and VL enabled. Comparisons
//! answer a mask register (a `u16`, bit `i` lane `i`).

use super::{Lanes, Mask};
use std::arch::x86_64::*;
use std::ops::{Add, Div, Mul, Sub};

/// Sixteen `f32` lanes.
#[derive(Clone, Copy, Debug)]
pub struct X16(__m512);

// SAFETY (every `unsafe` block of this file): an `X16` exists only in a kernel compiled for and
// entered on a CPU with AVX-512 F, BW, DQ and VL (the module's comment); loads and stores check
// their slice's length first.

macro_rules! op {
    ($tr:ident, $f:ident, $intr:ident) => {
        impl $tr for X16 {
            type Output = X16;
            #[inline(always)]
            fn $f(self, o: X16) -> X16 {
                X16(unsafe { $intr(self.0, o.0) })
            }
        }
    };
}
op!(Add, add, _mm512_add_ps);
op!(Sub, sub, _mm512_sub_ps);
op!(Mul, mul, _mm512_mul_ps);
op!(Div, div, _mm512_div_ps);

impl Mask for u16 {
    #[inline(always)]
    fn andnot(self, other: u16) -> u16 {
        !self & other
    }
    #[inline(always)]
    fn bits(self) -> u32 {
        u32::from(self)
    }
}

impl Lanes for X16 {
    type Elem = f32;
    type Mask = u16;
    const N: usize = 16;

    #[inline(always)]
    fn splat(x: f32) -> X16 {
        X16(unsafe { _mm512_set1_ps(x) })
    }
    #[inline(always)]
    fn load(a: &[f32]) -> X16 {
        X16(unsafe { _mm512_loadu_ps(a[..16].as_ptr()) })
    }
    #[inline(always)]
    unsafe fn load_aligned(a: &[f32]) -> X16 {
        X16(_mm512_load_ps(a[..16].as_ptr()))
    }
    #[inline(always)]
    fn store(self, out: &mut [f32]) {
        unsafe { _mm512_storeu_ps(out[..16].as_mut_ptr(), self.0) }
    }
    #[inline(always)]
    fn mask_from(_lanes: &[f32], bits: u32) -> u16 {
        bits as u16
    }
    #[inline(always)]
    fn sqrt(self) -> X16 {
        X16(unsafe { _mm512_sqrt_ps(self.0) })
    }
    #[inline(always)]
    fn abs(self) -> X16 {
        X16(unsafe { _mm512_abs_ps(self.0) })
    }
    #[inline(always)]
    fn copysign(self, sign: X16) -> X16 {
        let s = unsafe { _mm512_set1_ps(-0.0) };
        X16(unsafe { _mm512_or_ps(_mm512_andnot_ps(s, self.0), _mm512_and_ps(s, sign.0)) })
    }
    #[inline(always)]
    fn neg(self) -> X16 {
        X16(unsafe { _mm512_xor_ps(self.0, _mm512_set1_ps(-0.0)) })
    }
    #[inline(always)]
    fn maxnum(self, o: X16) -> X16 {
        // `vmaxps` alone answers `o` whenever either lane is NaN.
        let o_nan = unsafe { _mm512_cmp_ps_mask::<_CMP_UNORD_Q>(o.0, o.0) };
        X16::select(o_nan, self, X16(unsafe { _mm512_max_ps(self.0, o.0) }))
    }
    #[inline(always)]
    fn lt(self, o: X16) -> u16 {
        unsafe { _mm512_cmp_ps_mask::<_CMP_LT_OS>(self.0, o.0) }
    }
    #[inline(always)]
    fn le(self, o: X16) -> u16 {
        unsafe { _mm512_cmp_ps_mask::<_CMP_LE_OS>(self.0, o.0) }
    }
    #[inline(always)]
    fn gt(self, o: X16) -> u16 {
        unsafe { _mm512_cmp_ps_mask::<_CMP_GT_OS>(self.0, o.0) }
    }
    #[inline(always)]
    fn ge(self, o: X16) -> u16 {
        unsafe { _mm512_cmp_ps_mask::<_CMP_GE_OS>(self.0, o.0) }
    }
    #[inline(always)]
    fn eq(self, o: X16) -> u16 {
        unsafe { _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(self.0, o.0) }
    }
    #[inline(always)]
    fn select(m: u16, a: X16, b: X16) -> X16 {
        X16(unsafe { _mm512_mask_blend_ps(m, b.0, a.0) })
    }
    #[inline(always)]
    fn zero() -> X16 {
        X16(unsafe { _mm512_setzero_ps() })
    }
}
