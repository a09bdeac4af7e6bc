//! Eight `f32` lanes in an AVX register: only for a kernel the `avx2` or `avx512` tier
//! runs ([`crate::isa::dispatch`]), compiled with AVX and AVX2 enabled.

use std::arch::x86_64::*;

// SAFETY (every `unsafe` block of this file and of the macros it calls): an `X8` exists only in
// a kernel compiled for and entered on a CPU with AVX and AVX2 (the module's comment); loads and
// stores check their slice's length first.

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
        #[inline(always)]
        fn next_up(self) -> X8 {
            X8(unsafe { next_toward(self.0, false) })
        }
        #[inline(always)]
        fn next_down(self) -> X8 {
            X8(unsafe { next_toward(self.0, true) })
        }
    }
}

/// `f32::next_up` (`down` false) or `f32::next_down` (`down` true) on the bits of each lane, in
/// AVX2's integer lanes (the portable form goes through memory, a lane at a time): one step
/// away from zero on the bits of the side the step goes to, one towards it on the other; from
/// `±0` the smallest value of the step's sign; NaN and the infinity the step goes to unchanged.
#[inline(always)]
unsafe fn next_toward(v: __m256, down: bool) -> __m256 {
    let bits = _mm256_castps_si256(v);
    let (zero, one) = (_mm256_setzero_si256(), _mm256_set1_epi32(1));
    let negative = _mm256_cmpgt_epi32(zero, bits);
    let abs = _mm256_and_si256(bits, _mm256_set1_epi32(0x7fff_ffff));
    let zero_abs = _mm256_cmpeq_epi32(abs, zero);
    let nan = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_UNORD_Q>(v, v));
    // Where the bits go down: a negative value stepping up, a positive one stepping down.
    let (minus_where, from_zero, end) = if down {
        let all = _mm256_set1_epi32(-1);
        (
            _mm256_xor_si256(negative, all),
            0x8000_0001u32 as i32,
            0xff80_0000u32 as i32,
        )
    } else {
        (negative, 1, 0x7f80_0000)
    };
    let plus = _mm256_add_epi32(bits, one);
    // Every mask below is whole lanes of ones or zeros, so a byte blend is a lane blend.
    let r = _mm256_blendv_epi8(plus, _mm256_sub_epi32(bits, one), minus_where);
    let r = _mm256_blendv_epi8(r, _mm256_set1_epi32(from_zero), zero_abs);
    let fixed = _mm256_or_si256(nan, _mm256_cmpeq_epi32(bits, _mm256_set1_epi32(end)));
    _mm256_castsi256_ps(_mm256_blendv_epi8(r, bits, fixed))
}
