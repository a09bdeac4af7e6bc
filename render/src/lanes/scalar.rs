//! One lane: [`Lanes`] for every [`Real`] (`f32`, `f64`) itself, so a kernel written for lanes is also
//! the scalar test (a comparison answers a `bool`).

use super::Lanes;
use crate::real::Real;

/// The lane operations that are the scalar's own method of the same name.
macro_rules! by_real {
    ($($f:ident),*) => {$(
        #[inline(always)]
        fn $f(self) -> R {
            Real::$f(self)
        }
    )*};
}

impl<R: Real> Lanes for R {
    type Elem = R;
    type Mask = bool;
    const N: usize = 1;

    by_real!(sqrt, abs, next_up, next_down);

    #[inline(always)]
    fn splat(x: R) -> R {
        x
    }
    #[inline(always)]
    fn load(a: &[R]) -> R {
        a[0]
    }
    #[inline(always)]
    unsafe fn load_aligned(a: &[R]) -> R {
        a[0]
    }
    #[inline(always)]
    fn store(self, out: &mut [R]) {
        out[0] = self;
    }
    #[inline(always)]
    fn mask_from(lanes: &[R], _bits: u32) -> bool {
        // All-one bits are a NaN, which is not zero.
        lanes[0] != R::ZERO
    }
    #[inline(always)]
    fn copysign(self, sign: R) -> R {
        Real::copysign(self, sign)
    }
    #[inline(always)]
    fn neg(self) -> R {
        -self
    }
    #[inline(always)]
    fn maxnum(self, o: R) -> R {
        Real::max(self, o)
    }
    #[inline(always)]
    fn max_or(self, o: R) -> R {
        Lanes::select(self > o, self, o)
    }
    #[inline(always)]
    fn min_or(self, o: R) -> R {
        Lanes::select(self < o, self, o)
    }
    #[inline(always)]
    fn from_f32s(a: &[f32]) -> R {
        R::from_f32(a[0])
    }
    #[inline(always)]
    fn lt(self, o: R) -> bool {
        self < o
    }
    #[inline(always)]
    fn le(self, o: R) -> bool {
        self <= o
    }
    #[inline(always)]
    fn gt(self, o: R) -> bool {
        self > o
    }
    #[inline(always)]
    fn ge(self, o: R) -> bool {
        self >= o
    }
    #[inline(always)]
    fn eq(self, o: R) -> bool {
        self == o
    }
    #[inline(always)]
    fn select(m: bool, a: R, b: R) -> R {
        if m {
            a
        } else {
            b
        }
    }
}
