//! Four cones against one ray, or one cone against four rays, at once: [`Cone::intersect`] with
//! one cone per SIMD lane for BVH leaves of cones and cylinders (rings, tree, jacks), or one ray
//! per lane for a packet's rays entering a leaf with a cone. Every lane does the scalar test's IEEE
//! operations in the same order (no FMA, no reassociation) and takes the same branch outcomes
//! (a ray parallel to a generator, a negative discriminant, `q == 0`, the two roots in order,
//! the `t` and height ranges) as lane masks, so each lane's answer is bit for bit the scalar
//! one. [`intersect4`] and [`intersect_rays4`] pick the kernel of the process's tier
//! ([`crate::isa`]) like [`super::sphere4`]: AVX on `avx2` and `avx512`, SSE2 on `sse2`, the
//! portable lane loops ([`intersect4_lanes`], [`intersect_rays4_lanes`]) on `scalar` and
//! elsewhere.

use super::cone::Cone;
use super::hits4::DistanceHits4;
use super::ray::Ray;
use crate::real::Real;

/// Cones per call.
pub const LANES: usize = 4;

/// The cones of the lanes (unused lanes repeat a used one; `used` says how many count).
pub type Cones4<'a, R> = [&'a Cone<R>; LANES];

/// The portable kernel: the scalar test lane by lane, in any precision.
#[inline(always)]
pub fn intersect4_lanes<R: Real>(
    ray: &Ray<R>,
    cones: &Cones4<'_, R>,
    used: usize,
    t_max: R,
) -> DistanceHits4<R> {
    DistanceHits4::from_tests(cones.iter().take(used).map(|c| c.intersect(ray, t_max)))
}

/// The `f32` test of `used` (1..=4) cones, with the kernel of the process's tier.
#[inline]
pub fn intersect4(
    ray: &Ray<f32>,
    cones: &Cones4<'_, f32>,
    used: usize,
    t_max: f32,
) -> DistanceHits4<f32> {
    #[cfg(target_arch = "x86_64")]
    {
        let tier = crate::isa::current();
        if tier.avx() {
            // SAFETY: the AVX tiers are only chosen on a CPU that has AVX.
            return unsafe { x86::intersect4_avx(ray, cones, used, t_max) };
        }
        if tier.sse2() {
            return x86::intersect4_sse2(ray, cones, used, t_max);
        }
    }
    intersect4_lanes(ray, cones, used, t_max)
}

/// The portable kernel of one cone against up to four rays (lane `i`: `rays[i]` within
/// `t_max[i]`), the scalar test lane by lane.
#[inline(always)]
pub fn intersect_rays4_lanes<R: Real>(
    cone: &Cone<R>,
    rays: &[&Ray<R>; LANES],
    used: usize,
    t_max: [R; LANES],
) -> DistanceHits4<R> {
    DistanceHits4::from_tests(
        rays.iter()
            .zip(t_max)
            .take(used)
            .map(|(r, t)| cone.intersect(r, t)),
    )
}

/// One `f32` cone against `used` (1..=4) rays (a packet's rays entering a leaf), with the
/// kernel of the process's tier; lane `i` is [`Cone::intersect`] of `rays[i]` within `t_max[i]`.
#[inline]
pub fn intersect_rays4(
    cone: &Cone<f32>,
    rays: &[&Ray<f32>; LANES],
    used: usize,
    t_max: [f32; LANES],
) -> DistanceHits4<f32> {
    #[cfg(target_arch = "x86_64")]
    {
        let tier = crate::isa::current();
        if tier.avx() {
            // SAFETY: the AVX tiers are only chosen on a CPU that has AVX.
            return unsafe { x86::intersect_rays4_avx(cone, rays, used, t_max) };
        }
        if tier.sse2() {
            return x86::intersect_rays4_sse2(cone, rays, used, t_max);
        }
    }
    intersect_rays4_lanes(cone, rays, used, t_max)
}

#[cfg(target_arch = "x86_64")]
pub use x86::{intersect4_avx, intersect4_sse2, intersect_rays4_avx, intersect_rays4_sse2};

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{Cones4, DistanceHits4, LANES};
    use crate::geometry::cone::Cone;
    use crate::geometry::ray::Ray;
    use crate::geometry::sse4::{select, store};
    use crate::real::Real;
    use std::arch::x86_64::*;

    /// The SSE2 kernel of four cones and one ray (every x86-64 CPU has SSE2).
    #[inline(never)]
    pub fn intersect4_sse2(
        ray: &Ray<f32>,
        cones: &Cones4<'_, f32>,
        used: usize,
        t_max: f32,
    ) -> DistanceHits4<f32> {
        // SAFETY: SSE2 is part of the x86-64 baseline.
        unsafe { cones_kernel(ray, cones, used, t_max) }
    }

    /// The same kernel compiled for AVX (VEX encodings; no FMA: the scalar test has none).
    ///
    /// # Safety
    /// The CPU must support AVX.
    #[target_feature(enable = "avx")]
    #[inline(never)]
    pub unsafe fn intersect4_avx(
        ray: &Ray<f32>,
        cones: &Cones4<'_, f32>,
        used: usize,
        t_max: f32,
    ) -> DistanceHits4<f32> {
        cones_kernel(ray, cones, used, t_max)
    }

    /// The SSE2 kernel of one cone and four rays.
    #[inline(never)]
    pub fn intersect_rays4_sse2(
        cone: &Cone<f32>,
        rays: &[&Ray<f32>; LANES],
        used: usize,
        t_max: [f32; LANES],
    ) -> DistanceHits4<f32> {
        // SAFETY: SSE2 is part of the x86-64 baseline.
        unsafe { rays_kernel(cone, rays, used, t_max) }
    }

    /// The same kernel compiled for AVX.
    ///
    /// # Safety
    /// The CPU must support AVX.
    #[target_feature(enable = "avx")]
    #[inline(never)]
    pub unsafe fn intersect_rays4_avx(
        cone: &Cone<f32>,
        rays: &[&Ray<f32>; LANES],
        used: usize,
        t_max: [f32; LANES],
    ) -> DistanceHits4<f32> {
        rays_kernel(cone, rays, used, t_max)
    }

    /// A cone's fields, one cone per lane or one cone in all.
    struct ConeLanes {
        base: [__m128; 3],
        axis: [__m128; 3],
        height: __m128,
        r0: __m128,
        slope: __m128,
    }

    /// A ray's fields and `t` range, one ray per lane or one ray in all.
    struct RayLanes {
        o: [__m128; 3],
        d: [__m128; 3],
        t_min: __m128,
        t_max: __m128,
    }

    /// Four cones against one ray.
    #[inline(always)]
    unsafe fn cones_kernel(
        ray: &Ray<f32>,
        cones: &Cones4<'_, f32>,
        used: usize,
        t_max: f32,
    ) -> DistanceHits4<f32> {
        let lane = |f: &dyn Fn(usize) -> f32| _mm_setr_ps(f(0), f(1), f(2), f(3));
        let c = ConeLanes {
            base: [
                lane(&|i| cones[i].base.x),
                lane(&|i| cones[i].base.y),
                lane(&|i| cones[i].base.z),
            ],
            axis: [
                lane(&|i| cones[i].axis.x),
                lane(&|i| cones[i].axis.y),
                lane(&|i| cones[i].axis.z),
            ],
            height: lane(&|i| cones[i].height),
            r0: lane(&|i| cones[i].r0),
            slope: lane(&|i| cones[i].slope),
        };
        let r = RayLanes {
            o: [
                _mm_set1_ps(ray.o.x),
                _mm_set1_ps(ray.o.y),
                _mm_set1_ps(ray.o.z),
            ],
            d: [
                _mm_set1_ps(ray.d.x),
                _mm_set1_ps(ray.d.y),
                _mm_set1_ps(ray.d.z),
            ],
            t_min: _mm_set1_ps(ray.t_min),
            t_max: _mm_set1_ps(t_max),
        };
        finish(kernel(&c, &r), used)
    }

    /// One cone against four rays.
    #[inline(always)]
    unsafe fn rays_kernel(
        cone: &Cone<f32>,
        rays: &[&Ray<f32>; LANES],
        used: usize,
        t_max: [f32; LANES],
    ) -> DistanceHits4<f32> {
        let lane = |f: &dyn Fn(usize) -> f32| _mm_setr_ps(f(0), f(1), f(2), f(3));
        let c = ConeLanes {
            base: [
                _mm_set1_ps(cone.base.x),
                _mm_set1_ps(cone.base.y),
                _mm_set1_ps(cone.base.z),
            ],
            axis: [
                _mm_set1_ps(cone.axis.x),
                _mm_set1_ps(cone.axis.y),
                _mm_set1_ps(cone.axis.z),
            ],
            height: _mm_set1_ps(cone.height),
            r0: _mm_set1_ps(cone.r0),
            slope: _mm_set1_ps(cone.slope),
        };
        let r = RayLanes {
            o: [
                lane(&|i| rays[i].o.x),
                lane(&|i| rays[i].o.y),
                lane(&|i| rays[i].o.z),
            ],
            d: [
                lane(&|i| rays[i].d.x),
                lane(&|i| rays[i].d.y),
                lane(&|i| rays[i].d.z),
            ],
            t_min: lane(&|i| rays[i].t_min),
            t_max: _mm_loadu_ps(t_max.as_ptr()),
        };
        finish(kernel(&c, &r), used)
    }

    /// The used lanes' answers.
    #[inline(always)]
    unsafe fn finish((hit, t): (__m128, __m128), used: usize) -> DistanceHits4<f32> {
        DistanceHits4 {
            mask: _mm_movemask_ps(hit) as u32 & ((1u32 << used) - 1),
            t: store(t),
        }
    }

    /// The scalar test's arithmetic (see [`crate::geometry::cone`]) in four lanes; each of its
    /// early returns is a lane mask. Returns the lanes hit and their `t`.
    #[inline(always)]
    unsafe fn kernel(c: &ConeLanes, r: &RayLanes) -> (__m128, __m128) {
        let [bx, by, bz] = c.base;
        let [ax, ay, az] = c.axis;
        let (height, r0, k) = (c.height, c.r0, c.slope);
        let [rox, roy, roz] = r.o;
        let [rdx, rdy, rdz] = r.d;
        let zero = _mm_setzero_ps();
        let sign = _mm_set1_ps(-0.0);
        let (add, sub, mul, div) = (_mm_add_ps, _mm_sub_ps, _mm_mul_ps, _mm_div_ps);
        let dot = |ax, ay, az, bx, by, bz| add(add(mul(ax, bx), mul(ay, by)), mul(az, bz));
        // mid = base + a * (height * 1/2); shift = (mid − o)·d / |d|².
        let hh = mul(height, _mm_set1_ps(0.5));
        let mx = add(bx, mul(ax, hh));
        let my = add(by, mul(ay, hh));
        let mz = add(bz, mul(az, hh));
        let dd = dot(rdx, rdy, rdz, rdx, rdy, rdz);
        let shift = div(
            dot(sub(mx, rox), sub(my, roy), sub(mz, roz), rdx, rdy, rdz),
            dd,
        );
        // o = ray.o + d * shift; w = o − base.
        let wx = sub(add(rox, mul(rdx, shift)), bx);
        let wy = sub(add(roy, mul(rdy, shift)), by);
        let wz_ = sub(add(roz, mul(rdz, shift)), bz);
        let wz = dot(wx, wy, wz_, ax, ay, az);
        let dz = dot(rdx, rdy, rdz, ax, ay, az);
        let (wpx, wpy, wpz) = (
            sub(wx, mul(ax, wz)),
            sub(wy, mul(ay, wz)),
            sub(wz_, mul(az, wz)),
        );
        let (dpx, dpy, dpz) = (
            sub(rdx, mul(ax, dz)),
            sub(rdy, mul(ay, dz)),
            sub(rdz, mul(az, dz)),
        );
        let rw = add(r0, mul(k, wz));
        let dp2 = dot(dpx, dpy, dpz, dpx, dpy, dpz);
        let kkdd = mul(mul(mul(k, k), dz), dz);
        let qa = sub(dp2, kkdd);
        let qb = sub(dot(wpx, wpy, wpz, dpx, dpy, dpz), mul(mul(k, rw), dz));
        let qc = sub(dot(wpx, wpy, wpz, wpx, wpy, wpz), mul(rw, rw));
        // A ray parallel to a generator line: t = −qc / (2 qb), missed when qb == 0.
        let gamma8 = _mm_set1_ps(<f32 as Real>::gamma(8));
        let parallel = _mm_cmple_ps(_mm_andnot_ps(sign, qa), mul(gamma8, add(dp2, kkdd)));
        let t_lin = div(_mm_xor_ps(qc, sign), mul(_mm_set1_ps(2.0), qb));
        let miss_lin = _mm_cmpeq_ps(qb, zero);
        // Otherwise the two roots, missed when disc < 0 or q == 0.
        let disc = sub(mul(qb, qb), mul(qa, qc));
        let root = _mm_sqrt_ps(disc);
        let signed_root = _mm_or_ps(_mm_andnot_ps(sign, root), _mm_and_ps(sign, qb));
        let q = _mm_xor_ps(add(qb, signed_root), sign);
        let miss_quad = _mm_or_ps(_mm_cmplt_ps(disc, zero), _mm_cmpeq_ps(q, zero));
        let (x, y) = (div(q, qa), div(qc, q));
        let lt = _mm_cmplt_ps(x, y);
        let (t0, t1) = (select(lt, x, y), select(lt, y, x));
        let t0 = select(parallel, t_lin, t0);
        let t1 = select(parallel, t_lin, t1);
        let miss = select(parallel, miss_lin, miss_quad);
        // The first root (in order) whose t is in range and whose point is within the height.
        let (t_min, t_max) = (r.t_min, r.t_max);
        let accept = |tl| {
            let t = add(tl, shift);
            // Not (t < t_min or t > t_max or t <= 0): a NaN t passes here, as in the scalar
            // loop, and fails the height test.
            let t_ok = _mm_and_ps(
                _mm_and_ps(_mm_cmpnlt_ps(t, t_min), _mm_cmpngt_ps(t, t_max)),
                _mm_cmpnle_ps(t, zero),
            );
            let z = add(wz, mul(dz, tl));
            let z_ok = _mm_and_ps(
                _mm_and_ps(_mm_cmpge_ps(z, zero), _mm_cmple_ps(z, height)),
                _mm_cmpge_ps(add(r0, mul(k, z)), zero),
            );
            (_mm_and_ps(t_ok, z_ok), t)
        };
        let ((ok0, ta), (ok1, tb)) = (accept(t0), accept(t1));
        (
            _mm_andnot_ps(miss, _mm_or_ps(ok0, ok1)),
            select(ok0, ta, tb),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vec3::V3;
    use proptest::prelude::*;

    /// Asserts that every kernel this CPU runs gives the portable kernel's answer bit for bit.
    fn check(ray: &Ray<f32>, c: &Cones4<'_, f32>, used: usize, t_max: f32) -> u32 {
        let want = intersect4_lanes(ray, c, used, t_max);
        let mut kernels = vec![intersect4(ray, c, used, t_max)];
        #[cfg(target_arch = "x86_64")]
        {
            kernels.push(intersect4_sse2(ray, c, used, t_max));
            if crate::isa::Isa::Avx2.supported() {
                // SAFETY: the CPU has AVX.
                kernels.push(unsafe { intersect4_avx(ray, c, used, t_max) });
            }
        }
        for got in kernels {
            assert_eq!(got.mask, want.mask, "{ray:?} used {used} t_max {t_max}");
            for i in 0..LANES {
                if want.mask & (1 << i) != 0 {
                    assert_eq!(got.t[i].to_bits(), want.t[i].to_bits(), "lane {i}");
                }
            }
        }
        want.mask
    }

    /// [`check`] for the one-cone, four-ray kernels.
    fn check_rays(c: &Cone<f32>, rays: &[&Ray<f32>; LANES], used: usize, t_max: [f32; 4]) -> u32 {
        let want = intersect_rays4_lanes(c, rays, used, t_max);
        let mut kernels = vec![intersect_rays4(c, rays, used, t_max)];
        #[cfg(target_arch = "x86_64")]
        {
            kernels.push(intersect_rays4_sse2(c, rays, used, t_max));
            if crate::isa::Isa::Avx2.supported() {
                // SAFETY: the CPU has AVX.
                kernels.push(unsafe { intersect_rays4_avx(c, rays, used, t_max) });
            }
        }
        for got in kernels {
            assert_eq!(
                got.mask, want.mask,
                "{c:?} {rays:?} used {used} t_max {t_max:?}"
            );
            for i in 0..LANES {
                if want.mask & (1 << i) != 0 {
                    assert_eq!(got.t[i].to_bits(), want.t[i].to_bits(), "lane {i}");
                }
            }
        }
        want.mask
    }

    /// A direction from `o` that, by `aim`, runs along the cone's axis, along a generator
    /// line (the parallel-ray branch), at the base rim, or is `d` as given.
    fn aimed(c: &Cone<f32>, o: V3<f32>, d: V3<f32>, aim: usize) -> V3<f32> {
        let apex = c.base + c.axis * c.height;
        let side = c.axis.cross(V3::new(0.3, 0.5, 0.8)).normalize();
        match aim {
            0 => c.axis,
            1 => apex + side * (c.r0 + c.slope * c.height) - (c.base + side * c.r0),
            2 => c.base + side * c.r0 - o,
            _ => d,
        }
    }

    fn coord() -> impl Strategy<Value = f32> {
        prop_oneof![
            4 => -4.0f32..4.0,
            1 => Just(0.0f32),
            1 => Just(1.0f32),
            1 => -3.0e4f32..3.0e4,
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]
        /// Random cones, cylinders and true cones (some around the ray's origin, some far),
        /// rays along an axis, parallel to a generator line and aimed at a rim: the kernels
        /// agree lane for lane.
        #[test]
        fn kernels_agree_on_random_cones(
            ends in proptest::array::uniform4(proptest::array::uniform2(
                proptest::array::uniform3(coord()))),
            radii in proptest::array::uniform4(proptest::array::uniform2(
                prop_oneof![0.01f32..3.0, Just(1.0f32), Just(0.0f32)])),
            o in proptest::array::uniform3(coord()),
            d in proptest::array::uniform3(coord()),
            aim in 0usize..13,
            used in 1usize..=4,
            t_max in prop_oneof![Just(f32::INFINITY), 0.0f32..50.0],
        ) {
            let mut cones = Vec::new();
            for i in 0..4 {
                let (r0, r1) = (radii[i][0], radii[i][1]);
                let c = Cone::new(V3::from_array(ends[i][0]), r0, V3::from_array(ends[i][1]), r1);
                cones.push(c.unwrap_or_else(|| {
                    Cone::new(V3::zero(), 1.0, V3::new(0.0, 0.0, 1.0), 0.5).unwrap()
                }));
            }
            let o = V3::from_array(o);
            let d = aimed(&cones[aim % 4], o, V3::from_array(d), aim / 4);
            prop_assume!(d.length() > 0.0 && d.length().is_finite());
            let ray = Ray { o, d: d.normalize(), t_min: 0.0, t_max };
            let refs = [&cones[0], &cones[1], &cones[2], &cones[3]];
            check(&ray, &refs, used, t_max);
        }

        /// One random cone against four random rays, each aimed as above and with its own
        /// `t_max`: the one-cone kernels agree lane for lane.
        #[test]
        fn ray_kernels_agree_on_random_rays(
            ends in proptest::array::uniform2(proptest::array::uniform3(coord())),
            radii in proptest::array::uniform2(prop_oneof![0.01f32..3.0, Just(1.0f32), Just(0.0f32)]),
            o in proptest::array::uniform4(proptest::array::uniform3(coord())),
            d in proptest::array::uniform4(proptest::array::uniform3(coord())),
            aim in proptest::array::uniform4(0usize..5),
            used in 1usize..=4,
            t_max in proptest::array::uniform4(prop_oneof![Just(f32::INFINITY), 0.0f32..50.0]),
        ) {
            let c = Cone::new(V3::from_array(ends[0]), radii[0], V3::from_array(ends[1]), radii[1]);
            let c = c.unwrap_or_else(|| Cone::new(V3::zero(), 1.0, V3::new(0.0, 0.0, 1.0), 0.5).unwrap());
            let mut rays = [Ray { o: V3::zero(), d: V3::new(1.0f32, 0.0, 0.0), t_min: 0.0, t_max: 0.0 }; 4];
            for i in 0..4 {
                let o = V3::from_array(o[i]);
                let d = aimed(&c, o, V3::from_array(d[i]), aim[i]);
                prop_assume!(d.length() > 0.0 && d.length().is_finite());
                rays[i] = Ray { o, d: d.normalize(), t_min: 0.0, t_max: t_max[i] };
            }
            let refs = [&rays[0], &rays[1], &rays[2], &rays[3]];
            check_rays(&c, &refs, used, t_max);
        }
    }

    #[test]
    fn kernels_agree_through_sides_ends_and_axis() {
        let c = [
            Cone::new(V3::new(0.0f32, 0.0, 5.0), 1.0, V3::new(0.0, 0.0, 7.0), 1.0),
            Cone::new(V3::new(0.0, 0.0, -1.0), 2.0, V3::new(0.0, 0.0, 1.0), 0.0),
            Cone::new(V3::new(0.0, -3.0, 0.0), 0.5, V3::new(0.0, 3.0, 0.0), 1.5),
            Cone::new(V3::new(1.0e5, 0.0, 0.0), 0.1, V3::new(1.0e5, 0.0, 1.0), 0.1),
        ]
        .map(|c| c.unwrap());
        let refs = [&c[0], &c[1], &c[2], &c[3]];
        let mut hits = 0;
        for o in [[0.0f32, 0.0, 0.0], [-5.0, 0.0, 0.5], [0.0, 0.0, 6.0]] {
            for d in [
                [0.0f32, 0.0, 1.0],
                [0.0, 0.0, -1.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.2, 0.0, 1.0],
                [1.0, 0.0, 1.0],
            ] {
                let ray = Ray {
                    o: V3::from_array(o),
                    d: V3::from_array(d).normalize(),
                    t_min: 0.0,
                    t_max: f32::INFINITY,
                };
                for used in 1..=4 {
                    for t_max in [f32::INFINITY, 1.0e5, 4.0, 1.0] {
                        hits += check(&ray, &refs, used, t_max).count_ones();
                        let rays = [&ray; 4];
                        let t4 = [t_max, f32::INFINITY, 1.0, 4.0];
                        for c in &c {
                            hits += check_rays(c, &rays, used, t4).count_ones();
                        }
                    }
                }
            }
        }
        assert!(hits > 30, "{hits}");
    }
}
