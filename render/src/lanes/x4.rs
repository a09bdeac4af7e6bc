//! Four `f32` lanes in an SSE2 register (every x86-64 CPU has SSE2; a kernel compiled with AVX
//! enabled gets the same operations in their three-operand VEX form).

use super::{Lanes, Mask};
use std::arch::x86_64::*;
use std::ops::{Add, BitAnd, BitOr, Div, Mul, Sub};

/// Four `f32` lanes.
#[derive(Clone, Copy, Debug)]
pub struct X4(__m128);

/// The answers of a comparison of [`X4`]: lanes of all-one or all-zero bits.
#[derive(Clone, Copy, Debug)]
pub struct Mask4(__m128);

// SAFETY (every `unsafe` block of this file): SSE2 is part of the x86-64 baseline; loads and
// stores check their slice's length first.

macro_rules! op {
    ($tr:ident, $f:ident, $t:ident, $intr:ident) => {
        impl $tr for $t {
            type Output = $t;
            #[inline(always)]
            fn $f(self, o: $t) -> $t {
                $t(unsafe { $intr(self.0, o.0) })
            }
        }
    };
}
op!(Add, add, X4, _mm_add_ps);
op!(Sub, sub, X4, _mm_sub_ps);
op!(Mul, mul, X4, _mm_mul_ps);
op!(Div, div, X4, _mm_div_ps);
op!(BitAnd, bitand, Mask4, _mm_and_ps);
op!(BitOr, bitor, Mask4, _mm_or_ps);

impl Mask for Mask4 {
    #[inline(always)]
    fn andnot(self, other: Mask4) -> Mask4 {
        Mask4(unsafe { _mm_andnot_ps(self.0, other.0) })
    }
    #[inline(always)]
    fn bits(self) -> u32 {
        unsafe { _mm_movemask_ps(self.0) as u32 }
    }
}

impl Lanes for X4 {
    type Elem = f32;
    type Mask = Mask4;
    const N: usize = 4;

    #[inline(always)]
    fn splat(x: f32) -> X4 {
        X4(unsafe { _mm_set1_ps(x) })
    }
    #[inline(always)]
    fn load(a: &[f32]) -> X4 {
        X4(unsafe { _mm_loadu_ps(a[..4].as_ptr()) })
    }
    #[inline(always)]
    unsafe fn load_aligned(a: &[f32]) -> X4 {
        X4(_mm_load_ps(a[..4].as_ptr()))
    }
    #[inline(always)]
    fn store(self, out: &mut [f32]) {
        unsafe { _mm_storeu_ps(out[..4].as_mut_ptr(), self.0) }
    }
    #[inline(always)]
    fn mask_from(lanes: &[f32], _bits: u32) -> Mask4 {
        Mask4(X4::load(lanes).0)
    }
    #[inline(always)]
    fn sqrt(self) -> X4 {
        X4(unsafe { _mm_sqrt_ps(self.0) })
    }
    #[inline(always)]
    fn abs(self) -> X4 {
        X4(unsafe { _mm_andnot_ps(_mm_set1_ps(-0.0), self.0) })
    }
    #[inline(always)]
    fn copysign(self, sign: X4) -> X4 {
        let s = unsafe { _mm_set1_ps(-0.0) };
        X4(unsafe { _mm_or_ps(_mm_andnot_ps(s, self.0), _mm_and_ps(s, sign.0)) })
    }
    #[inline(always)]
    fn neg(self) -> X4 {
        X4(unsafe { _mm_xor_ps(self.0, _mm_set1_ps(-0.0)) })
    }
    #[inline(always)]
    fn maxnum(self, o: X4) -> X4 {
        // `maxps` alone answers `o` whenever either lane is NaN.
        let m = X4(unsafe { _mm_max_ps(self.0, o.0) });
        X4::select(Mask4(unsafe { _mm_cmpunord_ps(o.0, o.0) }), self, m)
    }
    #[inline(always)]
    fn max_or(self, o: X4) -> X4 {
        X4(unsafe { _mm_max_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn min_or(self, o: X4) -> X4 {
        X4(unsafe { _mm_min_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn from_f32s(a: &[f32]) -> X4 {
        X4::load(a)
    }
    #[inline(always)]
    fn lt(self, o: X4) -> Mask4 {
        Mask4(unsafe { _mm_cmplt_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn le(self, o: X4) -> Mask4 {
        Mask4(unsafe { _mm_cmple_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn gt(self, o: X4) -> Mask4 {
        Mask4(unsafe { _mm_cmpgt_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn ge(self, o: X4) -> Mask4 {
        Mask4(unsafe { _mm_cmpge_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn eq(self, o: X4) -> Mask4 {
        Mask4(unsafe { _mm_cmpeq_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn select(m: Mask4, a: X4, b: X4) -> X4 {
        // SSE2 has no blend: (m & a) | (!m & b).
        X4(unsafe { _mm_or_ps(_mm_and_ps(m.0, a.0), _mm_andnot_ps(m.0, b.0)) })
    }
    #[inline(always)]
    fn zero() -> X4 {
        X4(unsafe { _mm_setzero_ps() })
    }
}
