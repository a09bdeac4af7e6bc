//! Eight `f32` lanes in an AVX register: only for a kernel the `avx2` or `avx512` tier
//! runs ([`crate::isa::dispatch`]), compiled with AVX enabled.

use super::{Lanes, Mask};
use std::arch::x86_64::*;
use std::ops::{Add, BitAnd, BitOr, Div, Mul, Sub};

/// Eight `f32` lanes.
#[derive(Clone, Copy, Debug)]
pub struct X8(__m256);

/// The answers of a comparison of [`X8`]: lanes of all-one or all-zero bits.
#[derive(Clone, Copy, Debug)]
pub struct Mask8(__m256);

// SAFETY (every `unsafe` block of this file): an `X8` exists only in a kernel compiled for and
// entered on a CPU with AVX (the module's comment); loads and stores check their slice's length
// first.

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
op!(Add, add, X8, _mm256_add_ps);
op!(Sub, sub, X8, _mm256_sub_ps);
op!(Mul, mul, X8, _mm256_mul_ps);
op!(Div, div, X8, _mm256_div_ps);
op!(BitAnd, bitand, Mask8, _mm256_and_ps);
op!(BitOr, bitor, Mask8, _mm256_or_ps);

impl Mask for Mask8 {
    #[inline(always)]
    fn andnot(self, other: Mask8) -> Mask8 {
        Mask8(unsafe { _mm256_andnot_ps(self.0, other.0) })
    }
    #[inline(always)]
    fn bits(self) -> u32 {
        unsafe { _mm256_movemask_ps(self.0) as u32 }
    }
}

impl Lanes for X8 {
    type Elem = f32;
    type Mask = Mask8;
    const N: usize = 8;

    #[inline(always)]
    fn splat(x: f32) -> X8 {
        X8(unsafe { _mm256_set1_ps(x) })
    }
    #[inline(always)]
    fn load(a: &[f32]) -> X8 {
        X8(unsafe { _mm256_loadu_ps(a[..8].as_ptr()) })
    }
    #[inline(always)]
    unsafe fn load_aligned(a: &[f32]) -> X8 {
        X8(_mm256_load_ps(a[..8].as_ptr()))
    }
    #[inline(always)]
    fn store(self, out: &mut [f32]) {
        unsafe { _mm256_storeu_ps(out[..8].as_mut_ptr(), self.0) }
    }
    #[inline(always)]
    fn mask_from(lanes: &[f32], _bits: u32) -> Mask8 {
        Mask8(X8::load(lanes).0)
    }
    #[inline(always)]
    fn sqrt(self) -> X8 {
        X8(unsafe { _mm256_sqrt_ps(self.0) })
    }
    #[inline(always)]
    fn abs(self) -> X8 {
        X8(unsafe { _mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0) })
    }
    #[inline(always)]
    fn copysign(self, sign: X8) -> X8 {
        let s = unsafe { _mm256_set1_ps(-0.0) };
        X8(unsafe { _mm256_or_ps(_mm256_andnot_ps(s, self.0), _mm256_and_ps(s, sign.0)) })
    }
    #[inline(always)]
    fn neg(self) -> X8 {
        X8(unsafe { _mm256_xor_ps(self.0, _mm256_set1_ps(-0.0)) })
    }
    #[inline(always)]
    fn maxnum(self, o: X8) -> X8 {
        // `vmaxps` alone answers `o` whenever either lane is NaN.
        let m = X8(unsafe { _mm256_max_ps(self.0, o.0) });
        X8::select(
            Mask8(unsafe { _mm256_cmp_ps::<_CMP_UNORD_Q>(o.0, o.0) }),
            self,
            m,
        )
    }
    #[inline(always)]
    fn max_or(self, o: X8) -> X8 {
        X8(unsafe { _mm256_max_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn min_or(self, o: X8) -> X8 {
        X8(unsafe { _mm256_min_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn from_f32s(a: &[f32]) -> X8 {
        X8::load(a)
    }
    #[inline(always)]
    fn lt(self, o: X8) -> Mask8 {
        Mask8(unsafe { _mm256_cmp_ps::<_CMP_LT_OS>(self.0, o.0) })
    }
    #[inline(always)]
    fn le(self, o: X8) -> Mask8 {
        Mask8(unsafe { _mm256_cmp_ps::<_CMP_LE_OS>(self.0, o.0) })
    }
    #[inline(always)]
    fn gt(self, o: X8) -> Mask8 {
        Mask8(unsafe { _mm256_cmp_ps::<_CMP_GT_OS>(self.0, o.0) })
    }
    #[inline(always)]
    fn ge(self, o: X8) -> Mask8 {
        Mask8(unsafe { _mm256_cmp_ps::<_CMP_GE_OS>(self.0, o.0) })
    }
    #[inline(always)]
    fn eq(self, o: X8) -> Mask8 {
        Mask8(unsafe { _mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, o.0) })
    }
    #[inline(always)]
    fn select(m: Mask8, a: X8, b: X8) -> X8 {
        X8(unsafe { _mm256_blendv_ps(b.0, a.0, m.0) })
    }
    #[inline(always)]
    fn zero() -> X8 {
        X8(unsafe { _mm256_setzero_ps() })
    }
}
