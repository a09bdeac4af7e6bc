//! Small SSE helpers the four-lane leaf kernels ([`super::triangle4`], [`super::sphere4`],
//! [`super::cone::lanes`]) share: a lane-by-lane select and a store to an array. Every x86-64 CPU has SSE2.

use std::arch::x86_64::*;

/// `if m { a } else { b }` lane by lane (`m` a comparison's all-ones or all-zeros lanes).
///
/// # Safety
/// SSE2 is part of the x86-64 baseline; `unsafe` only because the intrinsics are.
#[inline(always)]
pub unsafe fn select(m: __m128, a: __m128, b: __m128) -> __m128 {
    _mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b))
}

/// The four lanes as an array.
///
/// # Safety
/// As [`select`].
#[inline(always)]
pub unsafe fn store(a: __m128) -> [f32; 4] {
    let mut out = [0.0f32; 4];
    _mm_storeu_ps(out.as_mut_ptr(), a);
    out
}
