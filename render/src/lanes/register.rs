//! The operations every SIMD register width does with one instruction each, written once: a
//! width's file names its intrinsics in a table ([`simd_lanes!`], [`simd_mask!`]) and writes by
//! hand only what differs between widths (the NaN rule of `maxnum`, `select`, how a mask is
//! held). Each generated operation is `#[inline(always)]` and wraps exactly the intrinsic named,
//! so a table row reads as the instruction the operation compiles to.
//!
//! Every `unsafe` block these macros write calls one intrinsic of the width's instruction set;
//! the width's file states why its instruction set is present (its `SAFETY` note). Loads and
//! stores index their slice to `N` lanes first, so a short slice panics instead of reading past
//! its end.

/// A lane mask held as lanes of all-one or all-zero bits in register `$reg`: `&`, `|`,
/// `andnot` and `bits` (the sign bits, `movemask`) by one intrinsic each.
macro_rules! simd_mask {
    ($mask:ident($reg:ty): and $and:expr, or $or:expr, andnot $andnot:expr, movemask $movemask:expr) => {
        #[doc = concat!("The answers of a comparison: lanes of all-one or all-zero bits in a `", stringify!($reg), "`.")]
        #[derive(Clone, Copy, Debug)]
        pub struct $mask($reg);

        impl std::ops::BitAnd for $mask {
            type Output = $mask;
            #[inline(always)]
            fn bitand(self, o: $mask) -> $mask {
                $mask(unsafe { $and(self.0, o.0) })
            }
        }

        impl std::ops::BitOr for $mask {
            type Output = $mask;
            #[inline(always)]
            fn bitor(self, o: $mask) -> $mask {
                $mask(unsafe { $or(self.0, o.0) })
            }
        }

        impl $crate::lanes::Mask for $mask {
            #[inline(always)]
            fn andnot(self, other: $mask) -> $mask {
                $mask(unsafe { $andnot(self.0, other.0) })
            }
            #[inline(always)]
            fn bits(self) -> u32 {
                unsafe { $movemask(self.0) as u32 }
            }
        }
    };
}

/// `$lanes`, `$n` `f32` lanes in register `$reg`, with [`Lanes`](crate::lanes::Lanes) for it:
/// the arithmetic, memory, sign-bit and comparison operations from the intrinsics named
/// (`$cmp` turns a comparison intrinsic's answer into the width's mask type), and the rest of
/// the trait's items (`mask_from`, `maxnum`, `select`, …) from the `{ … }` block as written.
/// With `mask Name by movemask`, the mask type is declared too, held in the same register
/// ([`simd_mask!`]).
macro_rules! simd_lanes {
    (
        $lanes:ident($reg:ty), $n:literal lanes, mask $mask:ident by $movemask:expr;
        and $and:expr, andnot $andnot:expr, or $or:expr, xor $xor:expr;
        $($rest:tt)*
    ) => {
        simd_mask!($mask($reg): and $and, or $or, andnot $andnot, movemask $movemask);
        simd_lanes! {
            $lanes($reg), $n lanes, mask $mask;
            and $and, andnot $andnot, or $or, xor $xor;
            $($rest)*
        }
    };
    (
        $lanes:ident($reg:ty), $n:literal lanes, mask $mask:ty;
        and $and:expr, andnot $andnot:expr, or $or:expr, xor $xor:expr;
        add $add:expr, sub $sub:expr, mul $mul:expr, div $div:expr, sqrt $sqrt:expr, max $max:expr, min $min:expr;
        splat $splat:expr, zero $zero:expr, loadu $loadu:expr, load $load:expr, storeu $storeu:expr;
        compare $cmp:path: lt $lt:expr, le $le:expr, gt $gt:expr, ge $ge:expr, eq $eq:expr;
        { $($rest:tt)* }
    ) => {
        #[doc = concat!(stringify!($n), " `f32` lanes in a `", stringify!($reg), "`.")]
        #[derive(Clone, Copy, Debug)]
        pub struct $lanes($reg);

        simd_lanes!(@op $lanes, Add add $add, Sub sub $sub, Mul mul $mul, Div div $div);

        impl $crate::lanes::Lanes for $lanes {
            type Elem = f32;
            type Mask = $mask;
            const N: usize = $n;

            #[inline(always)]
            fn splat(x: f32) -> $lanes {
                $lanes(unsafe { $splat(x) })
            }
            #[inline(always)]
            fn zero() -> $lanes {
                $lanes(unsafe { $zero() })
            }
            #[inline(always)]
            fn load(a: &[f32]) -> $lanes {
                $lanes(unsafe { $loadu(a[..$n].as_ptr()) })
            }
            #[inline(always)]
            unsafe fn load_aligned(a: &[f32]) -> $lanes {
                $lanes(unsafe { $load(a[..$n].as_ptr()) })
            }
            #[inline(always)]
            fn store(self, out: &mut [f32]) {
                unsafe { $storeu(out[..$n].as_mut_ptr(), self.0) }
            }
            #[inline(always)]
            fn from_f32s(a: &[f32]) -> $lanes {
                <$lanes as $crate::lanes::Lanes>::load(a)
            }
            #[inline(always)]
            fn sqrt(self) -> $lanes {
                $lanes(unsafe { $sqrt(self.0) })
            }
            #[inline(always)]
            fn max_or(self, o: $lanes) -> $lanes {
                $lanes(unsafe { $max(self.0, o.0) })
            }
            #[inline(always)]
            fn min_or(self, o: $lanes) -> $lanes {
                $lanes(unsafe { $min(self.0, o.0) })
            }
            #[inline(always)]
            fn abs(self) -> $lanes {
                $lanes(unsafe { $andnot($splat(-0.0), self.0) })
            }
            #[inline(always)]
            fn copysign(self, sign: $lanes) -> $lanes {
                let s = unsafe { $splat(-0.0) };
                $lanes(unsafe { $or($andnot(s, self.0), $and(s, sign.0)) })
            }
            #[inline(always)]
            fn neg(self) -> $lanes {
                $lanes(unsafe { $xor(self.0, $splat(-0.0)) })
            }
            simd_lanes!(@cmp $lanes, $cmp, lt $lt, le $le, gt $gt, ge $ge, eq $eq);
            $($rest)*
        }
    };
    (@op $lanes:ident, $($tr:ident $f:ident $intr:expr),*) => {$(
        impl std::ops::$tr for $lanes {
            type Output = $lanes;
            #[inline(always)]
            fn $f(self, o: $lanes) -> $lanes {
                $lanes(unsafe { $intr(self.0, o.0) })
            }
        }
    )*};
    (@cmp $lanes:ident, $cmp:path, $($f:ident $intr:expr),*) => {$(
        #[inline(always)]
        fn $f(self, o: $lanes) -> <$lanes as $crate::lanes::Lanes>::Mask {
            $cmp(unsafe { $intr(self.0, o.0) })
        }
    )*};
}
