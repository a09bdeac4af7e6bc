//! Sixteen `f32` lanes in an AVX-512 register: only for a kernel the `avx512` tier runs
//! ([`crate::isa::dispatch`]), compiled with AVX-512 F, BW, DQ and VL enabled. Comparisons
//! answer a mask register (a `u16`, bit `i` lane `i`).

use std::arch::x86_64::*;

// SAFETY (every `unsafe` block of this file and of the macros it calls): an `X16` exists only in
// a kernel compiled for and entered on a CPU with AVX-512 F, BW, DQ and VL (the module's
// comment); loads and stores check their slice's length first.

simd_lanes! { X16(__m512), 16 lanes, mask u16;
    and _mm512_and_ps, andnot _mm512_andnot_ps, or _mm512_or_ps, xor _mm512_xor_ps;
    add _mm512_add_ps, sub _mm512_sub_ps, mul _mm512_mul_ps, div _mm512_div_ps, sqrt _mm512_sqrt_ps, max _mm512_max_ps, min _mm512_min_ps;
    splat _mm512_set1_ps, zero _mm512_setzero_ps, loadu _mm512_loadu_ps, load _mm512_load_ps, storeu _mm512_storeu_ps;
    compare u16::from: lt _mm512_cmp_ps_mask::<_CMP_LT_OS>, le _mm512_cmp_ps_mask::<_CMP_LE_OS>, gt _mm512_cmp_ps_mask::<_CMP_GT_OS>, ge _mm512_cmp_ps_mask::<_CMP_GE_OS>, eq _mm512_cmp_ps_mask::<_CMP_EQ_OQ>;
    {
        #[inline(always)]
        fn mask_from(_lanes: &[f32], bits: u32) -> u16 {
            bits as u16
        }
        #[inline(always)]
        fn maxnum(self, o: X16) -> X16 {
            // `vmaxps` alone answers `o` whenever either lane is NaN.
            let o_nan = unsafe { _mm512_cmp_ps_mask::<_CMP_UNORD_Q>(o.0, o.0) };
            X16::select(o_nan, self, X16(unsafe { _mm512_max_ps(self.0, o.0) }))
        }
        #[inline(always)]
        fn select(m: u16, a: X16, b: X16) -> X16 {
            X16(unsafe { _mm512_mask_blend_ps(m, b.0, a.0) })
        }
        #[inline(always)]
        fn next_up(self) -> X16 {
            X16(unsafe { next_toward(self.0, false) })
        }
        #[inline(always)]
        fn next_down(self) -> X16 {
            X16(unsafe { next_toward(self.0, true) })
        }
    }
}

/// `f32::next_up` (`down` false) or `f32::next_down` (`down` true) on the bits of each lane:
/// one step away from zero on the bits of the side the step goes to, one towards it on the
/// other; from `±0` the smallest value of the step's sign; NaN and the infinity the step goes
/// to unchanged.
#[inline(always)]
unsafe fn next_toward(v: __m512, down: bool) -> __m512 {
    let bits = _mm512_castps_si512(v);
    let (zero, one) = (_mm512_setzero_si512(), _mm512_set1_epi32(1));
    let negative = _mm512_cmplt_epi32_mask(bits, zero);
    let abs = _mm512_and_si512(bits, _mm512_set1_epi32(0x7fff_ffff));
    let zero_abs = _mm512_cmpeq_epi32_mask(abs, zero);
    let nan = _mm512_cmp_ps_mask::<_CMP_UNORD_Q>(v, v);
    // Where the bits go down: a negative value stepping up, a positive one stepping down.
    let (minus_where, from_zero, end) = if down {
        (!negative, 0x8000_0001u32 as i32, 0xff80_0000u32 as i32)
    } else {
        (negative, 1, 0x7f80_0000)
    };
    let plus = _mm512_add_epi32(bits, one);
    let r = _mm512_mask_blend_epi32(minus_where, plus, _mm512_sub_epi32(bits, one));
    let r = _mm512_mask_blend_epi32(zero_abs, r, _mm512_set1_epi32(from_zero));
    let fixed = nan | _mm512_cmpeq_epi32_mask(bits, _mm512_set1_epi32(end));
    _mm512_castsi512_ps(_mm512_mask_blend_epi32(fixed, r, bits))
}
