//! Eight `f32` lanes in an AVX register: only for a kernel the `avx2` or `avx512` tier
//! runs ([`crate::isa::dispatch`]), compiled with AVX enabled.

use std::arch::x86_64::*;

// SAFETY (every `unsafe` block of this file and of the macros it calls): an `X8` exists only in
// a kernel compiled for and entered on a CPU with AVX (the module's comment); loads and stores
// check their slice's length first.

simd_lanes! { X8(__m256), 8 lanes, mask Mask8 by _mm256_movemask_ps;
    and _mm256_and_ps, andnot _mm256_andnot_ps, or _mm256_or_ps, xor _mm256_xor_ps;
    add _mm256_add_ps, sub _mm256_sub_ps, mul _mm256_mul_ps, div _mm256_div_ps, sqrt _mm256_sqrt_ps, max _mm256_max_ps, min _mm256_min_ps;
    splat _mm256_set1_ps, zero _mm256_setzero_ps, loadu _mm256_loadu_ps, load _mm256_load_ps, storeu _mm256_storeu_ps;
    compare Mask8: lt _mm256_cmp_ps::<_CMP_LT_OS>, le _mm256_cmp_ps::<_CMP_LE_OS>, gt _mm256_cmp_ps::<_CMP_GT_OS>, ge _mm256_cmp_ps::<_CMP_GE_OS>, eq _mm256_cmp_ps::<_CMP_EQ_OQ>;
    {
        #[inline(always)]
        fn mask_from(lanes: &[f32], _bits: u32) -> Mask8 {
            Mask8(X8::load(lanes).0)
        }
        #[inline(always)]
        fn maxnum(self, o: X8) -> X8 {
            // `vmaxps` alone answers `o` whenever either lane is NaN.
            let o_nan = Mask8(unsafe { _mm256_cmp_ps::<_CMP_UNORD_Q>(o.0, o.0) });
            X8::select(o_nan, self, X8(unsafe { _mm256_max_ps(self.0, o.0) }))
        }
        #[inline(always)]
        fn select(m: Mask8, a: X8, b: X8) -> X8 {
            X8(unsafe { _mm256_blendv_ps(b.0, a.0, m.0) })
        }
    }
}
