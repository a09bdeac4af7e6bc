//! The scalar type the renderer is generic over: `f32` (the fast path) or `f64` (the reference
//! path used by the accuracy study). Everything geometric is written once against [`Real`].
//! Never add a method here that only one of the two types can honour exactly.

use std::fmt::{Debug, Display};
use std::ops::{Add, AddAssign, Div, DivAssign, Mul, MulAssign, Neg, Sub, SubAssign};

/// A floating-point scalar: `f32` or `f64`.
pub trait Real:
    Copy
    + Send
    + Sync
    + Debug
    + Display
    + Default
    + PartialEq
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
    + DivAssign
    + 'static
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// 0.5.
    const HALF: Self;
    /// 2.
    const TWO: Self;
    /// The largest finite value.
    const MAX: Self;
    /// The smallest positive normal value.
    const MIN_POSITIVE: Self;
    /// Positive infinity.
    const INFINITY: Self;
    /// Half a unit in the last place of 1: the unit round-off `u` of error analysis.
    const MACHINE_EPSILON: Self;
    /// Name used in reports (`"f32"` or `"f64"`).
    const NAME: &'static str;

    /// Converts from `f64`, rounding to nearest.
    fn from_f64(v: f64) -> Self;
    /// Converts to `f64` exactly.
    fn to_f64(self) -> f64;
    /// Converts to `f32`, rounding to nearest.
    fn to_f32(self) -> f32;
    /// Converts from `f32` exactly.
    fn from_f32(v: f32) -> Self;
    /// Converts a small integer exactly.
    fn from_u32(v: u32) -> Self;
    /// Square root.
    fn sqrt(self) -> Self;
    /// Absolute value.
    fn abs(self) -> Self;
    /// Minimum (the non-NaN operand if one is NaN).
    fn min(self, o: Self) -> Self;
    /// Maximum (the non-NaN operand if one is NaN).
    fn max(self, o: Self) -> Self;
    /// `self` raised to `e`.
    fn powf(self, e: Self) -> Self;
    /// True when neither NaN nor infinite.
    fn is_finite(self) -> bool;
    /// The next representable value towards +infinity.
    fn next_up(self) -> Self;
    /// The next representable value towards -infinity.
    fn next_down(self) -> Self;
    /// Copies the sign of `sign` onto `self`.
    fn copysign(self, sign: Self) -> Self;
    /// Tangent.
    fn tan(self) -> Self;

    /// `gamma(n) = n·u / (1 − n·u)`, the bound on the relative error of `n` rounded operations.
    #[inline]
    fn gamma(n: u32) -> Self {
        let nu = Self::from_u32(n) * Self::MACHINE_EPSILON;
        nu / (Self::ONE - nu)
    }
}

/// Implements each listed [`Real`] method as the inherent method of the same name of `$t`
/// (whose other operands, if any, are `Self` too).
macro_rules! forward_to_inherent {
    ($t:ty: $(fn $name:ident(self $(, $arg:ident)*) -> $ret:ty;)*) => {
        $(
            #[inline(always)]
            fn $name(self $(, $arg: Self)*) -> $ret {
                <$t>::$name(self $(, $arg)*)
            }
        )*
    };
}

macro_rules! impl_real {
    ($t:ty, $name:literal) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const HALF: Self = 0.5;
            const TWO: Self = 2.0;
            const MAX: Self = <$t>::MAX;
            const MIN_POSITIVE: Self = <$t>::MIN_POSITIVE;
            const INFINITY: Self = <$t>::INFINITY;
            const MACHINE_EPSILON: Self = <$t>::EPSILON * 0.5;
            const NAME: &'static str = $name;

            #[inline(always)]
            fn from_f64(v: f64) -> Self {
                v as $t
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline(always)]
            fn to_f32(self) -> f32 {
                self as f32
            }
            #[inline(always)]
            fn from_f32(v: f32) -> Self {
                v as $t
            }
            #[inline(always)]
            fn from_u32(v: u32) -> Self {
                v as $t
            }
            forward_to_inherent! { $t:
                fn sqrt(self) -> Self;
                fn abs(self) -> Self;
                fn min(self, o) -> Self;
                fn max(self, o) -> Self;
                fn powf(self, e) -> Self;
                fn is_finite(self) -> bool;
                fn next_up(self) -> Self;
                fn next_down(self) -> Self;
                fn copysign(self, sign) -> Self;
                fn tan(self) -> Self;
            }
        }
    };
}

impl_real!(f32, "f32");
impl_real!(f64, "f64");

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gamma_is_small_and_grows() {
        assert!(<f32 as Real>::gamma(3) > 0.0 && <f32 as Real>::gamma(3) < 1e-6);
        assert!(<f64 as Real>::gamma(3) < 1e-15);
        assert!(<f32 as Real>::gamma(7) > <f32 as Real>::gamma(3));
    }

    #[test]
    fn next_up_down_bracket() {
        let x = 1.5f32;
        assert!(Real::next_down(x) < x && x < Real::next_up(x));
    }
}
