//! Four `f32` lanes in an SSE2 register (every x86-64 CPU has SSE2; a kernel compiled with AVX
//! enabled gets the same operations in their three-operand VEX form).

use std::arch::x86_64::*;

// SAFETY (every `unsafe` block of this file and of the macros it calls): SSE2 is part of the
// x86-64 baseline; loads and stores check their slice's length first.

simd_lanes! { X4(__m128), 4 lanes, mask Mask4 by _mm_movemask_ps;
    and _mm_and_ps, andnot _mm_andnot_ps, or _mm_or_ps, xor _mm_xor_ps;
    add _mm_add_ps, sub _mm_sub_ps, mul _mm_mul_ps, div _mm_div_ps, sqrt _mm_sqrt_ps, max _mm_max_ps, min _mm_min_ps;
    splat _mm_set1_ps, zero _mm_setzero_ps, loadu _mm_loadu_ps, load _mm_load_ps, storeu _mm_storeu_ps;
    compare Mask4: lt _mm_cmplt_ps, le _mm_cmple_ps, gt _mm_cmpgt_ps, ge _mm_cmpge_ps, eq _mm_cmpeq_ps;
    {
        #[inline(always)]
        fn mask_from(lanes: &[f32], _bits: u32) -> Mask4 {
            Mask4(X4::load(lanes).0)
        }
        #[inline(always)]
        fn maxnum(self, o: X4) -> X4 {
            // `maxps` alone answers `o` whenever either lane is NaN.
            let m = X4(unsafe { _mm_max_ps(self.0, o.0) });
            X4::select(Mask4(unsafe { _mm_cmpunord_ps(o.0, o.0) }), self, m)
        }
        #[inline(always)]
        fn select(m: Mask4, a: X4, b: X4) -> X4 {
            // SSE2 has no blend: (m & a) | (!m & b).
            X4(unsafe { _mm_or_ps(_mm_and_ps(m.0, a.0), _mm_andnot_ps(m.0, b.0)) })
        }
    }
}
