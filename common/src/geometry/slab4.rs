//! Four slab tests at once: one ray against the four child boxes of a wide BVH node. `f32` rays
//! use SSE on x86-64 (part of its baseline, so no runtime detection); `f64` rays and other
//! targets run the same arithmetic lane by lane. Every lane computes exactly what the scalar
//! [`super::aabb::slab`] computes — the same operations in the same order, a NaN (0·∞ for a ray
//! lying in a slab plane) leaving the interval as it was — so a box is accepted by one exactly
//! when it is accepted by the other.

use crate::real::Real;

/// The boxes of four children, axis by axis (structure of arrays, one SSE register per row).
/// An unused lane holds the empty box (min +∞, max −∞), which no ray enters.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
pub struct Box4 {
    /// Minimum corner per axis, per lane.
    pub lo: [[f32; 4]; 3],
    /// Maximum corner per axis, per lane.
    pub hi: [[f32; 4]; 3],
}

impl Box4 {
    /// Four empty lanes.
    pub const EMPTY: Box4 = Box4 {
        lo: [[f32::INFINITY; 4]; 3],
        hi: [[f32::NEG_INFINITY; 4]; 3],
    };

    /// Sets lane `i` to the box `min`..`max`.
    pub fn set(&mut self, i: usize, min: [f32; 3], max: [f32; 3]) {
        for a in 0..3 {
            self.lo[a][i] = min[a];
            self.hi[a][i] = max[a];
        }
    }
}

/// The per-ray constants of the four-lane slab test.
#[derive(Clone, Copy, Debug)]
pub struct SlabRay<R> {
    /// Origin.
    pub o: [R; 3],
    /// Reciprocal direction.
    pub inv: [R; 3],
    /// Direction component negative (near plane is the box's maximum).
    pub neg: [bool; 3],
    /// Start of the accepted interval.
    pub t_min: R,
}

/// Lane by lane, in any precision: bit `i` of the mask is set when lane `i` is entered within
/// `[t_min, t_max]`; the entry distances are valid for set bits.
#[inline(always)]
pub fn slab4_lanes<R: Real>(b: &Box4, r: &SlabRay<R>, t_max: R) -> (u32, [R; 4]) {
    let widen = R::ONE + R::TWO * R::gamma(3);
    let mut t0 = [r.t_min; 4];
    let mut t1 = [t_max; 4];
    for a in 0..3 {
        let (near, far) = if r.neg[a] {
            (&b.hi[a], &b.lo[a])
        } else {
            (&b.lo[a], &b.hi[a])
        };
        for i in 0..4 {
            let t_near = (R::from_f32(near[i]) - r.o[a]) * r.inv[a];
            let t_far = (R::from_f32(far[i]) - r.o[a]) * r.inv[a] * widen;
            if t_near > t0[i] {
                t0[i] = t_near;
            }
            if t_far < t1[i] {
                t1[i] = t_far;
            }
        }
    }
    let mut mask = 0;
    for i in 0..4 {
        if t0[i] <= t1[i] {
            mask |= 1 << i;
        }
    }
    (mask, t0)
}

/// The `f32` test with SSE: the same operations as [`slab4_lanes`], four lanes per instruction.
/// `maxps`/`minps` return their second operand when the first is NaN, which is the scalar
/// test's "a NaN leaves the interval as it was".
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub fn slab4_f32(b: &Box4, r: &SlabRay<f32>, t_max: f32) -> (u32, [f32; 4]) {
    use std::arch::x86_64::*;
    let widen = 1.0 + 2.0 * <f32 as Real>::gamma(3);
    // SAFETY: SSE is part of the x86-64 baseline; the loads read 16 aligned bytes of a
    // `[f32; 4]` row of `Box4` (which is `align(16)`), and the store writes into a `[f32; 4]`.
    unsafe {
        let mut t0 = _mm_set1_ps(r.t_min);
        let mut t1 = _mm_set1_ps(t_max);
        let w = _mm_set1_ps(widen);
        for a in 0..3 {
            let (near, far) = if r.neg[a] {
                (&b.hi[a], &b.lo[a])
            } else {
                (&b.lo[a], &b.hi[a])
            };
            let o = _mm_set1_ps(r.o[a]);
            let inv = _mm_set1_ps(r.inv[a]);
            let t_near = _mm_mul_ps(_mm_sub_ps(_mm_load_ps(near.as_ptr()), o), inv);
            let t_far = _mm_mul_ps(_mm_mul_ps(_mm_sub_ps(_mm_load_ps(far.as_ptr()), o), inv), w);
            t0 = _mm_max_ps(t_near, t0);
            t1 = _mm_min_ps(t_far, t1);
        }
        let mask = _mm_movemask_ps(_mm_cmple_ps(t0, t1)) as u32;
        let mut out = [0.0f32; 4];
        _mm_storeu_ps(out.as_mut_ptr(), t0);
        (mask, out)
    }
}

/// The `f32` test on targets without the SSE path.
#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
pub fn slab4_f32(b: &Box4, r: &SlabRay<f32>, t_max: f32) -> (u32, [f32; 4]) {
    slab4_lanes(b, r, t_max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::aabb::slab;
    use crate::geometry::{PreparedRay, Ray};
    use crate::vec3::V3;
    use proptest::prelude::*;

    fn slab_ray(pr: &PreparedRay<f32>) -> SlabRay<f32> {
        SlabRay {
            o: [pr.ray.o.x, pr.ray.o.y, pr.ray.o.z],
            inv: [pr.inv_d.x, pr.inv_d.y, pr.inv_d.z],
            neg: pr.neg,
            t_min: pr.ray.t_min,
        }
    }

    fn coord() -> impl Strategy<Value = f32> {
        prop_oneof![
            4 => -10.0f32..10.0,
            1 => Just(0.0f32),
            1 => Just(1.0f32),
            1 => Just(-1.0f32),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        /// SSE, lane-by-lane and the scalar slab test agree on every lane, axis-parallel rays
        /// and rays in a box face included.
        #[test]
        fn simd_lanes_and_scalar_agree(
            o in proptest::array::uniform3(coord()),
            d in proptest::array::uniform3(coord()),
            corners in proptest::array::uniform4((proptest::array::uniform3(coord()), proptest::array::uniform3(0.0f32..5.0))),
            used in 0usize..=4,
            t_max in prop_oneof![Just(f32::INFINITY), 0.0f32..30.0],
        ) {
            prop_assume!(d.iter().any(|&c| c != 0.0));
            let pr = PreparedRay::new(Ray {
                o: V3::from_array(o),
                d: V3::from_array(d),
                t_min: 0.0,
                t_max,
            });
            let mut b = Box4::EMPTY;
            let mut boxes = Vec::new();
            for (i, (lo, ext)) in corners.iter().take(used).enumerate() {
                let hi = [lo[0] + ext[0], lo[1] + ext[1], lo[2] + ext[2]];
                b.set(i, *lo, hi);
                boxes.push((*lo, hi));
            }
            let sr = slab_ray(&pr);
            let (m_simd, t_simd) = slab4_f32(&b, &sr, t_max);
            let (m_lanes, t_lanes) = slab4_lanes(&b, &sr, t_max);
            prop_assert_eq!(m_simd, m_lanes);
            for i in 0..4 {
                let scalar = boxes.get(i).and_then(|(lo, hi)| slab(lo, hi, &pr, t_max));
                prop_assert_eq!(m_simd & (1 << i) != 0, scalar.is_some(), "lane {}", i);
                if let Some(t) = scalar {
                    prop_assert_eq!(t_simd[i].to_bits(), t.to_bits());
                    prop_assert_eq!(t_lanes[i].to_bits(), t.to_bits());
                }
            }
        }
    }
}
