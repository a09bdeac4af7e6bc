//! The lane types the SIMD kernels are written against, once: a [`Lanes`] value is `N` `f32`
//! (or one `f32` or `f64`) lanes, with the IEEE operations the kernels need and nothing else.
//! There is one file per width with the same operations: every [`Real`] (one lane,
//! `scalar.rs`), [`X4`] (four lanes in an SSE2 register), [`X8`] (eight in an AVX register) and
//! [`X16`] (sixteen in an AVX-512 register). The intrinsics live in those files and nowhere else:
//! each register width's file is a table of its instructions, from which `register.rs`'s macros
//! write the operations that are one instruction each, plus what differs between widths.
//!
//! Every operation gives each lane the bits the scalar operation gives it: the arithmetic is
//! IEEE-rounded add, subtract, multiply, divide and square root, with no fused multiply-add
//! and no approximate reciprocal, so a kernel written once gives the same bits on every tier.
//! Comparisons are ordered (false when either lane is NaN), as Rust's `<`, `<=`, `>`, `>=`
//! and `==` on floats.
//!
//! A lane type's operations assume the CPU runs its instructions: a kernel uses [`X8`] or
//! [`X16`] only when it is instantiated for the `avx2` or `avx512` tier by
//! [`crate::isa::dispatch`], which enters it only after the CPU was checked, with the tier's
//! instruction sets enabled (so the operations, all `#[inline(always)]`, compile to single
//! instructions). [`X4`] needs SSE2, which every x86-64 CPU has.

use crate::real::Real;
use std::fmt::Debug;
use std::ops::{Add, BitAnd, BitOr, Div, Mul, Sub};

#[cfg(target_arch = "x86_64")]
#[macro_use]
mod register;
mod scalar;
#[cfg(target_arch = "x86_64")]
mod x16;
#[cfg(target_arch = "x86_64")]
mod x4;
#[cfg(target_arch = "x86_64")]
mod x8;

#[cfg(target_arch = "x86_64")]
pub use x16::X16;
#[cfg(target_arch = "x86_64")]
pub use x4::{Mask4, X4};
#[cfg(target_arch = "x86_64")]
pub use x8::{Mask8, X8};

/// The answers of a lane comparison, one per lane: `&` and `|` lane by lane.
pub trait Mask: Copy + Debug + BitAnd<Output = Self> + BitOr<Output = Self> {
    /// `!self & other` lane by lane.
    fn andnot(self, other: Self) -> Self;
    /// Bit `i` set when lane `i` is set (`movemask`).
    fn bits(self) -> u32;
}

/// A mask held as plain bits: `bool` for one lane, `u16` for sixteen (an AVX-512 mask
/// register, bit `i` lane `i`).
macro_rules! plain_mask {
    ($($t:ty),*) => {$(
        impl Mask for $t {
            #[inline(always)]
            fn andnot(self, other: $t) -> $t {
                !self & other
            }
            #[inline(always)]
            fn bits(self) -> u32 {
                u32::from(self)
            }
        }
    )*};
}
plain_mask!(bool, u16);

/// `N` lanes of [`Lanes::Elem`], with the operations the kernels use. `+`, `-`, `*` and `/` are
/// the IEEE operations lane by lane.
pub trait Lanes:
    Copy + Debug + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self>
{
    /// The scalar of a lane.
    type Elem: Real;
    /// The answers of a comparison.
    type Mask: Mask;
    /// Lanes per value.
    const N: usize;

    /// `x` in every lane.
    fn splat(x: Self::Elem) -> Self;
    /// Lanes `0..N` of `a` (`a` holds at least `N`; no alignment needed).
    fn load(a: &[Self::Elem]) -> Self;
    /// Lanes `0..N` of `a` from an address aligned to the register's size.
    ///
    /// # Safety
    /// `a` holds at least `N` values and starts at a multiple of `N × size_of::<Elem>()`
    /// bytes (16 for [`X4`]).
    unsafe fn load_aligned(a: &[Self::Elem]) -> Self;
    /// Writes the lanes to `out[0..N]` (`out` holds at least `N`; no alignment needed).
    fn store(self, out: &mut [Self::Elem]);
    /// A lane mask stored both ways a kernel may hold one: as lanes of all-one or all-zero bits
    /// (`lanes[0..N]`) and as bits (`bits`, bit `i` lane `i`): each width reads the form its
    /// comparisons make.
    fn mask_from(lanes: &[Self::Elem], bits: u32) -> Self::Mask;

    /// The square root, correctly rounded.
    fn sqrt(self) -> Self;
    /// The absolute value (the sign bit cleared, NaN too).
    fn abs(self) -> Self;
    /// `self` with the sign bit of `sign` (`f32::copysign`).
    fn copysign(self, sign: Self) -> Self;
    /// `-self`: the sign bit flipped (`0.0` to `-0.0`, NaN too).
    fn neg(self) -> Self;
    /// `f32::max`'s rule: the larger lane, or the lane that is not NaN when one is NaN (`NaN`
    /// only when both are); between `0.0` and `-0.0` either may come out.
    fn maxnum(self, o: Self) -> Self;
    /// `if self > o { self } else { o }` lane by lane: `o` whenever either lane is NaN (SSE's
    /// `maxps`). The slab test's rule: with the interval bound as `o`, a NaN distance (0·∞, a
    /// ray in a slab plane) leaves the interval as it was.
    fn max_or(self, o: Self) -> Self;
    /// `if self < o { self } else { o }` lane by lane: `o` whenever either lane is NaN (SSE's
    /// `minps`), the mirror image of [`Lanes::max_or`].
    fn min_or(self, o: Self) -> Self;
    /// Lanes `0..N` of `a` in the lanes' precision (`a` holds at least `N`; the boxes are
    /// stored in `f32` whatever the ray's precision).
    fn from_f32s(a: &[f32]) -> Self;

    /// `self < o`.
    fn lt(self, o: Self) -> Self::Mask;
    /// `self <= o`.
    fn le(self, o: Self) -> Self::Mask;
    /// `self > o`.
    fn gt(self, o: Self) -> Self::Mask;
    /// `self >= o`.
    fn ge(self, o: Self) -> Self::Mask;
    /// `self == o`.
    fn eq(self, o: Self) -> Self::Mask;
    /// `if m { a } else { b }` lane by lane.
    fn select(m: Self::Mask, a: Self, b: Self) -> Self;

    /// `f32::next_up` lane by lane: the least value above (the smallest positive from `±0`;
    /// NaN and `+∞` unchanged). This portable form goes through memory; a width whose kernels
    /// need it fast computes it on the bits.
    #[inline(always)]
    fn next_up(self) -> Self {
        each(self, Real::next_up)
    }
    /// `f32::next_down` lane by lane: the mirror image of [`Lanes::next_up`].
    #[inline(always)]
    fn next_down(self) -> Self {
        each(self, Real::next_down)
    }

    /// Zero in every lane.
    #[inline(always)]
    fn zero() -> Self {
        Self::splat(<Self::Elem as Real>::ZERO)
    }
}

/// `f` on each lane of `v`, through memory (for the operations a width has no instruction
/// for).
#[inline(always)]
fn each<L: Lanes>(v: L, f: fn(L::Elem) -> L::Elem) -> L {
    let mut a = [<L::Elem as Real>::ZERO; 16];
    v.store(&mut a);
    for x in &mut a[..L::N] {
        *x = f(*x);
    }
    L::load(&a)
}

/// `u · v` in the order the scalar vector type sums it: `(x + y) + z`.
#[inline(always)]
pub(crate) fn dot3<L: Lanes>(u: [L; 3], v: [L; 3]) -> L {
    u[0] * v[0] + u[1] * v[1] + u[2] * v[2]
}

/// `x` in every lane of each of three values.
#[inline(always)]
pub(crate) fn splat3<L: Lanes>(x: [L::Elem; 3]) -> [L; 3] {
    [L::splat(x[0]), L::splat(x[1]), L::splat(x[2])]
}
