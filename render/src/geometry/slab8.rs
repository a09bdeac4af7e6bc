//! Eight slab tests at once: one ray against the eight child boxes of a wide BVH node
//! ([`crate::accel::bvh::wide`]). Three kernels ([`super::slab_dispatch`] picks by tier): lane
//! by lane in any precision (the `scalar` tier, `f64` rays, other targets), SSE in two halves of
//! four (`sse2`) and AVX in one register (`avx2` and `avx512`: an AVX-512VL version, the
//! comparison into a mask register, was no faster). Every lane computes exactly what the scalar
//! [`super::aabb::slab`] computes — the same operations in the same order, a NaN (0·∞ for a
//! ray lying in a slab plane) leaving the interval as it was — so a box is accepted by one
//! exactly when it is accepted by any other, at the same entry distance.

use crate::real::Real;

/// Lanes of a [`Box8`].
pub const WIDTH: usize = 8;

/// The boxes of eight children, axis by axis (structure of arrays: one AVX register, or two
/// SSE registers, per row). An unused lane holds the empty box (min +∞, max −∞).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct Box8 {
    /// Minimum corner per axis, per lane.
    pub lo: [[f32; WIDTH]; 3],
    /// Maximum corner per axis, per lane.
    pub hi: [[f32; WIDTH]; 3],
}

impl Box8 {
    /// Eight empty lanes.
    pub const EMPTY: Box8 = Box8 {
        lo: [[f32::INFINITY; WIDTH]; 3],
        hi: [[f32::NEG_INFINITY; WIDTH]; 3],
    };

    /// Sets lane `i` to the box `min`..`max`.
    pub fn set(&mut self, i: usize, min: [f32; 3], max: [f32; 3]) {
        for a in 0..3 {
            self.lo[a][i] = min[a];
            self.hi[a][i] = max[a];
        }
    }

    /// Lane `i`'s box as corner arrays.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> ([f32; 3], [f32; 3]) {
        (
            [self.lo[0][i], self.lo[1][i], self.lo[2][i]],
            [self.hi[0][i], self.hi[1][i], self.hi[2][i]],
        )
    }
}

/// The per-ray constants of the slab test.
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

/// The near and far rows of axis `a` for a ray with direction signs `neg`.
#[inline(always)]
fn rows<'b>(b: &'b Box8, neg: &[bool; 3], a: usize) -> (&'b [f32; WIDTH], &'b [f32; WIDTH]) {
    if neg[a] {
        (&b.hi[a], &b.lo[a])
    } else {
        (&b.lo[a], &b.hi[a])
    }
}

/// Lane by lane, in any precision: bit `i` of the mask is set when lane `i` is entered within
/// `[t_min, t_max]`; the entry distances are valid for set bits.
#[inline(always)]
pub fn slab8_lanes<R: Real>(b: &Box8, r: &SlabRay<R>, t_max: R) -> (u32, [R; WIDTH]) {
    let widen = R::ONE + R::TWO * R::gamma(3);
    let mut t0 = [r.t_min; WIDTH];
    let mut t1 = [t_max; WIDTH];
    for a in 0..3 {
        let (near, far) = rows(b, &r.neg, a);
        for i in 0..WIDTH {
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
    for i in 0..WIDTH {
        if t0[i] <= t1[i] {
            mask |= 1 << i;
        }
    }
    (mask, t0)
}

/// The `f32` test with SSE, two halves of four lanes: the operations of [`slab8_lanes`].
/// `maxps`/`minps` return their second operand when the first is NaN, which is the scalar
/// test's "a NaN leaves the interval as it was".
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub fn slab8_sse2(b: &Box8, r: &SlabRay<f32>, t_max: f32) -> (u32, [f32; WIDTH]) {
    use std::arch::x86_64::*;
    let widen = 1.0 + 2.0 * <f32 as Real>::gamma(3);
    let mut out = [0.0f32; WIDTH];
    let mut mask = 0;
    // SAFETY: SSE is part of the x86-64 baseline; the loads read 16 bytes at lane 0 or 4 of a
    // `[f32; 8]` row of `Box8` (which is `align(32)`, so both are 16-byte aligned), and the
    // stores write four `f32` into `out` at lane 0 or 4.
    unsafe {
        let w = _mm_set1_ps(widen);
        for h in [0, 4] {
            let mut t0 = _mm_set1_ps(r.t_min);
            let mut t1 = _mm_set1_ps(t_max);
            for a in 0..3 {
                let (near, far) = rows(b, &r.neg, a);
                let o = _mm_set1_ps(r.o[a]);
                let inv = _mm_set1_ps(r.inv[a]);
                let near = _mm_load_ps(near.as_ptr().add(h));
                let far = _mm_load_ps(far.as_ptr().add(h));
                let t_near = _mm_mul_ps(_mm_sub_ps(near, o), inv);
                let t_far = _mm_mul_ps(_mm_mul_ps(_mm_sub_ps(far, o), inv), w);
                t0 = _mm_max_ps(t_near, t0);
                t1 = _mm_min_ps(t_far, t1);
            }
            mask |= (_mm_movemask_ps(_mm_cmple_ps(t0, t1)) as u32) << h;
            _mm_storeu_ps(out.as_mut_ptr().add(h), t0);
        }
    }
    (mask, out)
}

/// The `f32` test with AVX, the eight lanes in one register: the operations of
/// [`slab8_lanes`] (`vmaxps`/`vminps` keep the interval when the new bound is NaN).
///
/// # Safety
/// The CPU must support AVX.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
pub unsafe fn slab8_avx(b: &Box8, r: &SlabRay<f32>, t_max: f32) -> (u32, [f32; WIDTH]) {
    use std::arch::x86_64::*;
    let w = _mm256_set1_ps(1.0 + 2.0 * <f32 as Real>::gamma(3));
    let mut t0 = _mm256_set1_ps(r.t_min);
    let mut t1 = _mm256_set1_ps(t_max);
    for a in 0..3 {
        let (near, far) = rows(b, &r.neg, a);
        let o = _mm256_set1_ps(r.o[a]);
        let inv = _mm256_set1_ps(r.inv[a]);
        // SAFETY: 32 bytes of a `[f32; 8]` row of `Box8`, which is `align(32)`.
        let (near, far) = unsafe { (_mm256_load_ps(near.as_ptr()), _mm256_load_ps(far.as_ptr())) };
        let t_near = _mm256_mul_ps(_mm256_sub_ps(near, o), inv);
        let t_far = _mm256_mul_ps(_mm256_mul_ps(_mm256_sub_ps(far, o), inv), w);
        t0 = _mm256_max_ps(t_near, t0);
        t1 = _mm256_min_ps(t_far, t1);
    }
    let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OS>(t0, t1)) as u32;
    let mut out = [0.0f32; WIDTH];
    // SAFETY: writes eight `f32` into `out`.
    unsafe { _mm256_storeu_ps(out.as_mut_ptr(), t0) };
    (mask, out)
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

    /// A slab kernel for `f32` rays.
    type Kernel = fn(&Box8, &SlabRay<f32>, f32) -> (u32, [f32; WIDTH]);

    /// Every kernel this CPU runs, by name, with the lane-by-lane one first.
    fn kernels() -> Vec<(&'static str, Kernel)> {
        let mut k: Vec<(&'static str, Kernel)> = vec![("lanes", slab8_lanes::<f32>)];
        #[cfg(target_arch = "x86_64")]
        {
            k.push(("sse2", slab8_sse2));
            if crate::isa::Isa::Avx2.supported() {
                // SAFETY: this CPU runs AVX.
                k.push(("avx", |b, r, t| unsafe { slab8_avx(b, r, t) }));
            }
        }
        k
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        /// Every kernel and the scalar slab test agree on every lane — mask bit and entry
        /// distance — axis-parallel rays and rays in a box face included.
        #[test]
        fn every_kernel_agrees_with_the_scalar_test(
            o in proptest::array::uniform3(coord()),
            d in proptest::array::uniform3(coord()),
            corners in proptest::collection::vec(
                (proptest::array::uniform3(coord()), proptest::array::uniform3(0.0f32..5.0)),
                0..=WIDTH),
            t_max in prop_oneof![Just(f32::INFINITY), 0.0f32..30.0],
        ) {
            prop_assume!(d.iter().any(|&c| c != 0.0));
            let pr = PreparedRay::new(Ray {
                o: V3::from_array(o),
                d: V3::from_array(d),
                t_min: 0.0,
                t_max,
            });
            let mut b = Box8::EMPTY;
            let mut boxes = Vec::new();
            for (i, (lo, ext)) in corners.iter().enumerate() {
                let hi = [lo[0] + ext[0], lo[1] + ext[1], lo[2] + ext[2]];
                b.set(i, *lo, hi);
                boxes.push((*lo, hi));
            }
            let sr = slab_ray(&pr);
            for (name, k) in kernels() {
                let (mask, t) = k(&b, &sr, t_max);
                for (i, t_i) in t.iter().enumerate() {
                    let scalar = boxes.get(i).and_then(|(lo, hi)| slab(lo, hi, &pr, t_max));
                    prop_assert_eq!(mask & (1 << i) != 0, scalar.is_some(), "{} lane {}", name, i);
                    if let Some(t_s) = scalar {
                        prop_assert_eq!(t_i.to_bits(), t_s.to_bits(), "{} lane {}", name, i);
                    }
                }
            }
        }
    }

    /// The lane kernel in `f64` takes the same boxes as the scalar test in `f64`.
    #[test]
    fn the_f64_lanes_agree_with_the_scalar_test() {
        let mut b = Box8::EMPTY;
        b.set(0, [-1.0; 3], [1.0; 3]);
        b.set(3, [2.0, -1.0, -1.0], [3.0, 1.0, 1.0]);
        b.set(7, [2.0, 5.0, -1.0], [3.0, 6.0, 1.0]);
        let pr = PreparedRay::<f64>::new(Ray {
            o: V3::new(-5.0, 0.25, 0.5),
            d: V3::new(1.0, 0.0, 0.0),
            t_min: 0.0,
            t_max: 100.0,
        });
        let sr = SlabRay {
            o: [pr.ray.o.x, pr.ray.o.y, pr.ray.o.z],
            inv: [pr.inv_d.x, pr.inv_d.y, pr.inv_d.z],
            neg: pr.neg,
            t_min: pr.ray.t_min,
        };
        let (mask, t) = slab8_lanes(&b, &sr, 100.0);
        assert_eq!(mask, 0b1001);
        assert_eq!(Some(t[0]), slab(&[-1.0; 3], &[1.0; 3], &pr, 100.0));
        assert_eq!(t[3], 7.0);
    }
}
