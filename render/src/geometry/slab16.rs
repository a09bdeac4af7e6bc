//! One box against sixteen rays at once: the leaf test of packet traversal
//! ([`crate::accel::bvh::packet`]). The rays of a packet share their direction signs, so the
//! near and far planes are the same for all of them; each lane computes exactly what the scalar
//! [`super::aabb::slab`] computes, with SSE for `f32` on x86-64 (AVX-512, one register for the
//! sixteen rays, on the `avx512` tier) and lane by lane otherwise.

use super::ray::PreparedRay;
use crate::real::Real;

/// Rays in one packet.
pub const LANES: usize = 16;

/// The rays of a packet side by side (structure of arrays). Lanes past the packet's length
/// repeat its first ray.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub struct RayLanes<R> {
    /// Origins, per axis.
    pub o: [[R; LANES]; 3],
    /// Reciprocal directions, per axis.
    pub inv: [[R; LANES]; 3],
    /// Starts of the rays' intervals.
    pub t_min: [R; LANES],
    /// Direction sign per axis, shared by all rays.
    pub neg: [bool; 3],
}

impl<R: Real> RayLanes<R> {
    /// The lanes of `rays` (at least one, at most [`LANES`], all with direction signs `neg`).
    pub fn new(rays: &[PreparedRay<R>], neg: [bool; 3]) -> Self {
        let mut l = RayLanes {
            o: [[R::ZERO; LANES]; 3],
            inv: [[R::ZERO; LANES]; 3],
            t_min: [R::ZERO; LANES],
            neg,
        };
        for i in 0..LANES {
            let r = rays.get(i).unwrap_or(&rays[0]);
            for a in 0..3 {
                l.o[a][i] = r.ray.o.get(a);
                l.inv[a][i] = r.inv_d.get(a);
            }
            l.t_min[i] = r.ray.t_min;
        }
        l
    }
}

/// Lane by lane, in any precision: bit `i` is set when ray `i` enters the box `lo`..`hi`
/// within `[t_min, reach[i]]`.
#[inline(always)]
pub fn enter16_lanes<R: Real>(
    l: &RayLanes<R>,
    lo: &[f32; 3],
    hi: &[f32; 3],
    reach: &[R; LANES],
) -> u32 {
    let widen = R::ONE + R::TWO * R::gamma(3);
    let mut t0 = l.t_min;
    let mut t1 = *reach;
    for a in 0..3 {
        let (near, far) = if l.neg[a] {
            (hi[a], lo[a])
        } else {
            (lo[a], hi[a])
        };
        let (near, far) = (R::from_f32(near), R::from_f32(far));
        for i in 0..LANES {
            let t_near = (near - l.o[a][i]) * l.inv[a][i];
            let t_far = (far - l.o[a][i]) * l.inv[a][i] * widen;
            if t_near > t0[i] {
                t0[i] = t_near;
            }
            if t_far < t1[i] {
                t1[i] = t_far;
            }
        }
    }
    let mut mask = 0;
    for i in 0..LANES {
        if t0[i] <= t1[i] {
            mask |= 1 << i;
        }
    }
    mask
}

/// The `f32` test with SSE: the same operations as [`enter16_lanes`], four rays per
/// instruction (`maxps`/`minps` keep the interval when the new bound is NaN, like the scalar
/// test).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub fn enter16_f32(l: &RayLanes<f32>, lo: &[f32; 3], hi: &[f32; 3], reach: &[f32; LANES]) -> u32 {
    use std::arch::x86_64::*;
    let widen = 1.0 + 2.0 * <f32 as Real>::gamma(3);
    let mut mask = 0u32;
    // SAFETY: SSE is part of the x86-64 baseline; every load reads four `f32` inside a
    // `[f32; 16]` (unaligned loads, so no alignment is assumed).
    unsafe {
        let w = _mm_set1_ps(widen);
        for q in 0..LANES / 4 {
            let k = q * 4;
            let mut t0 = _mm_loadu_ps(l.t_min.as_ptr().add(k));
            let mut t1 = _mm_loadu_ps(reach.as_ptr().add(k));
            for a in 0..3 {
                let (near, far) = if l.neg[a] {
                    (hi[a], lo[a])
                } else {
                    (lo[a], hi[a])
                };
                let o = _mm_loadu_ps(l.o[a].as_ptr().add(k));
                let inv = _mm_loadu_ps(l.inv[a].as_ptr().add(k));
                let t_near = _mm_mul_ps(_mm_sub_ps(_mm_set1_ps(near), o), inv);
                let t_far = _mm_mul_ps(_mm_mul_ps(_mm_sub_ps(_mm_set1_ps(far), o), inv), w);
                t0 = _mm_max_ps(t_near, t0);
                t1 = _mm_min_ps(t_far, t1);
            }
            mask |= (_mm_movemask_ps(_mm_cmple_ps(t0, t1)) as u32) << k;
        }
    }
    mask
}

/// The `f32` test with AVX-512 for the `avx512` tier: the sixteen rays in one register, the same
/// operations as [`enter16_f32`] (`vmaxps`/`vminps` keep the interval when the new bound is
/// NaN).
///
/// # Safety
/// The CPU must support AVX-512 F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
pub unsafe fn enter16_avx512(
    l: &RayLanes<f32>,
    lo: &[f32; 3],
    hi: &[f32; 3],
    reach: &[f32; LANES],
) -> u32 {
    use std::arch::x86_64::*;
    let w = _mm512_set1_ps(1.0 + 2.0 * <f32 as Real>::gamma(3));
    // SAFETY: every load reads sixteen `f32` of a `[f32; 16]` (unaligned loads).
    let load = |a: &[f32; LANES]| unsafe { _mm512_loadu_ps(a.as_ptr()) };
    let mut t0 = load(&l.t_min);
    let mut t1 = load(reach);
    for a in 0..3 {
        let (near, far) = if l.neg[a] {
            (hi[a], lo[a])
        } else {
            (lo[a], hi[a])
        };
        let o = load(&l.o[a]);
        let inv = load(&l.inv[a]);
        let t_near = _mm512_mul_ps(_mm512_sub_ps(_mm512_set1_ps(near), o), inv);
        let t_far = _mm512_mul_ps(_mm512_mul_ps(_mm512_sub_ps(_mm512_set1_ps(far), o), inv), w);
        t0 = _mm512_max_ps(t_near, t0);
        t1 = _mm512_min_ps(t_far, t1);
    }
    u32::from(_mm512_cmp_ps_mask::<_CMP_LE_OS>(t0, t1))
}

/// The `f32` test on targets without the SSE path.
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
pub fn enter16_f32(l: &RayLanes<f32>, lo: &[f32; 3], hi: &[f32; 3], reach: &[f32; LANES]) -> u32 {
    enter16_lanes(l, lo, hi, reach)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::aabb::slab;
    use crate::geometry::Ray;
    use crate::vec3::V3;
    use proptest::prelude::*;

    fn coord() -> impl Strategy<Value = f32> {
        prop_oneof![
            4 => -10.0f32..10.0,
            1 => Just(0.0f32),
            1 => Just(1.0f32),
            1 => Just(-1.0f32),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(1000))]
        /// SSE, lane-by-lane and the scalar slab test agree for every ray of a packet, rays in
        /// a box face and axis-parallel rays included.
        #[test]
        fn simd_lanes_and_scalar_agree(
            rays in proptest::collection::vec(
                (proptest::array::uniform3(coord()), proptest::array::uniform3(coord()),
                 prop_oneof![Just(f32::INFINITY), 0.0f32..30.0]),
                1..=LANES),
            dir_signs in proptest::array::uniform3(any::<bool>()),
            lo in proptest::array::uniform3(coord()),
            ext in proptest::array::uniform3(0.0f32..5.0),
        ) {
            // One set of direction signs for the packet: flip components to match.
            let prs: Vec<_> = rays
                .iter()
                .map(|(o, d, t_max)| {
                    let d = [0, 1, 2].map(|a| {
                        let c = d[a].abs();
                        if dir_signs[a] { -c } else { c }
                    });
                    PreparedRay::new(Ray { o: V3::from_array(*o), d: V3::from_array(d), t_min: 0.0, t_max: *t_max })
                })
                .collect();
            // A +0 component with a negative sign wanted stays +0 (1/+0 = +∞): skip those.
            let neg = prs[0].neg;
            prop_assume!(prs.iter().all(|p| p.neg == neg));
            let hi = [lo[0] + ext[0], lo[1] + ext[1], lo[2] + ext[2]];
            let lanes = RayLanes::new(&prs, neg);
            let mut reach = [0.0f32; LANES];
            for (i, r) in reach.iter_mut().enumerate() {
                *r = prs.get(i).unwrap_or(&prs[0]).ray.t_max;
            }
            let m_simd = enter16_f32(&lanes, &lo, &hi, &reach);
            let m_lanes = enter16_lanes(&lanes, &lo, &hi, &reach);
            prop_assert_eq!(m_simd, m_lanes);
            #[cfg(target_arch = "x86_64")]
            if crate::isa::Isa::Avx512.supported() {
                // SAFETY: this CPU runs the avx512 tier.
                let m_512 = unsafe { enter16_avx512(&lanes, &lo, &hi, &reach) };
                prop_assert_eq!(m_512, m_lanes);
            }
            for (i, pr) in prs.iter().enumerate() {
                let scalar = slab(&lo, &hi, pr, pr.ray.t_max).is_some();
                prop_assert_eq!(m_simd & (1 << i) != 0, scalar, "ray {}", i);
            }
        }
    }
}
