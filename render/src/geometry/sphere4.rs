//! Four spheres against one ray at once: [`Sphere::intersect`] with one sphere per SIMD lane,
//! for BVH leaves of spheres (shells, balls). Every lane does the scalar test's IEEE operations
//! in the same order (no FMA, no reassociation), so each lane's answer is bit for bit the
//! scalar one. [`intersect4`] picks the kernel of the process's tier ([`crate::isa`]) like
//! [`super::triangle4`]: AVX on `avx2` and `avx512`, SSE2 on `sse2`, the portable lane loop
//! ([`intersect4_lanes`]) on `scalar` and elsewhere.
//! [`SphereLanes`] holds a leaf's spheres already gathered into lanes, so the rays of a packet
//! that enter the leaf share one gather ([`intersect4_gathered`]).

use super::hits4::DistanceHits4;
use super::ray::Ray;
use super::sphere::Sphere;
use crate::real::Real;

/// Spheres per call.
pub const LANES: usize = 4;

/// The spheres of the lanes (unused lanes repeat a used one; `used` says how many count).
pub type Spheres4<'a, R> = [&'a Sphere<R>; LANES];

/// Four spheres gathered into lanes: centre components by axis, then radii (the kernel's
/// layout).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
pub struct SphereLanes {
    /// Centre components by axis and lane.
    pub c: [[f32; LANES]; 3],
    /// Radii by lane.
    pub r: [f32; LANES],
}

impl SphereLanes {
    /// The lanes of `spheres`.
    #[inline(always)]
    pub fn gather(spheres: &Spheres4<'_, f32>) -> Self {
        let mut c = [[0.0; LANES]; 3];
        for (axis, lanes) in c.iter_mut().enumerate() {
            for (lane, v) in lanes.iter_mut().enumerate() {
                *v = spheres[lane].center.to_array()[axis];
            }
        }
        SphereLanes {
            c,
            r: spheres.map(|s| s.radius),
        }
    }

    /// The sphere of lane `i`.
    #[inline(always)]
    fn sphere(&self, i: usize) -> Sphere<f32> {
        Sphere {
            center: crate::vec3::V3::new(self.c[0][i], self.c[1][i], self.c[2][i]),
            radius: self.r[i],
        }
    }

    /// The portable kernel on these lanes.
    fn scalar_hits(&self, ray: &Ray<f32>, used: usize, t_max: f32) -> DistanceHits4<f32> {
        let s = [0, 1, 2, 3].map(|i| self.sphere(i));
        intersect4_lanes(ray, &[&s[0], &s[1], &s[2], &s[3]], used, t_max)
    }
}

/// The portable kernel: the scalar test lane by lane, in any precision.
#[inline(always)]
pub fn intersect4_lanes<R: Real>(
    ray: &Ray<R>,
    spheres: &Spheres4<'_, R>,
    used: usize,
    t_max: R,
) -> DistanceHits4<R> {
    DistanceHits4::from_tests(spheres.iter().take(used).map(|s| s.intersect(ray, t_max)))
}

/// The `f32` test of `used` (1..=4) spheres, with the kernel of the process's tier.
#[inline]
pub fn intersect4(
    ray: &Ray<f32>,
    spheres: &Spheres4<'_, f32>,
    used: usize,
    t_max: f32,
) -> DistanceHits4<f32> {
    #[cfg(target_arch = "x86_64")]
    {
        x86::dispatch(ray, spheres, used, t_max)
    }
    #[cfg(not(target_arch = "x86_64"))]
    intersect4_lanes(ray, spheres, used, t_max)
}

/// [`intersect4`] on spheres already gathered into lanes: the same answers bit for bit.
#[inline]
pub fn intersect4_gathered(
    ray: &Ray<f32>,
    spheres: &SphereLanes,
    used: usize,
    t_max: f32,
) -> DistanceHits4<f32> {
    #[cfg(target_arch = "x86_64")]
    {
        x86::dispatch(ray, spheres, used, t_max)
    }
    #[cfg(not(target_arch = "x86_64"))]
    spheres.scalar_hits(ray, used, t_max)
}

#[cfg(target_arch = "x86_64")]
pub use x86::{avx, sse2};

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{DistanceHits4, SphereLanes, Spheres4, LANES};
    use crate::geometry::ray::Ray;
    use crate::geometry::sse4::{select, store};
    use std::arch::x86_64::*;

    /// The SSE2 kernel (every x86-64 CPU has SSE2), on four spheres or lanes gathered
    /// once.
    #[inline(never)]
    pub fn sse2<S: Source>(ray: &Ray<f32>, src: &S, used: usize, t_max: f32) -> DistanceHits4<f32> {
        // SAFETY: SSE2 is part of the x86-64 baseline.
        unsafe { kernel(ray, src, used, t_max) }
    }

    /// The same kernel compiled for AVX (VEX encodings; no FMA: the scalar test has none).
    ///
    /// # Safety
    /// The CPU must support AVX.
    #[target_feature(enable = "avx")]
    #[inline(never)]
    pub unsafe fn avx<S: Source>(
        ray: &Ray<f32>,
        src: &S,
        used: usize,
        t_max: f32,
    ) -> DistanceHits4<f32> {
        kernel(ray, src, used, t_max)
    }

    /// The kernel of the process's tier ([`crate::isa`]).
    #[inline(always)]
    pub fn dispatch<S: Source>(
        ray: &Ray<f32>,
        src: &S,
        used: usize,
        t_max: f32,
    ) -> DistanceHits4<f32> {
        let tier = crate::isa::current();
        if tier.avx() {
            // SAFETY: the AVX tiers are only chosen on a CPU that has AVX.
            return unsafe { avx(ray, src, used, t_max) };
        }
        if tier.sse2() {
            return sse2(ray, src, used, t_max);
        }
        src.portable(ray, used, t_max)
    }

    /// Where the kernel reads the spheres from: gathered from four spheres on the spot, or
    /// loaded from lanes gathered once.
    pub trait Source {
        /// Centre `x`, `y`, `z` and radius of the four spheres.
        unsafe fn lanes(&self) -> [__m128; 4];
        /// The portable kernel on the same spheres.
        fn portable(&self, ray: &Ray<f32>, used: usize, t_max: f32) -> DistanceHits4<f32>;
    }

    impl Source for Spheres4<'_, f32> {
        #[inline(always)]
        unsafe fn lanes(&self) -> [__m128; 4] {
            let lane = |f: &dyn Fn(usize) -> f32| _mm_setr_ps(f(0), f(1), f(2), f(3));
            [
                lane(&|i| self[i].center.x),
                lane(&|i| self[i].center.y),
                lane(&|i| self[i].center.z),
                lane(&|i| self[i].radius),
            ]
        }

        fn portable(&self, ray: &Ray<f32>, used: usize, t_max: f32) -> DistanceHits4<f32> {
            super::intersect4_lanes(ray, self, used, t_max)
        }
    }

    impl Source for SphereLanes {
        #[inline(always)]
        unsafe fn lanes(&self) -> [__m128; 4] {
            [
                _mm_load_ps(self.c[0].as_ptr()),
                _mm_load_ps(self.c[1].as_ptr()),
                _mm_load_ps(self.c[2].as_ptr()),
                _mm_load_ps(self.r.as_ptr()),
            ]
        }

        fn portable(&self, ray: &Ray<f32>, used: usize, t_max: f32) -> DistanceHits4<f32> {
            self.scalar_hits(ray, used, t_max)
        }
    }

    /// The scalar test's arithmetic (see [`crate::geometry::sphere`]) in four lanes.
    #[inline(always)]
    unsafe fn kernel<S: Source>(
        ray: &Ray<f32>,
        spheres: &S,
        used: usize,
        t_max: f32,
    ) -> DistanceHits4<f32> {
        let [cx, cy, cz, r] = spheres.lanes();
        let zero = _mm_setzero_ps();
        let sign = _mm_set1_ps(-0.0);
        let (dx, dy, dz) = (
            _mm_set1_ps(ray.d.x),
            _mm_set1_ps(ray.d.y),
            _mm_set1_ps(ray.d.z),
        );
        let fx = _mm_sub_ps(_mm_set1_ps(ray.o.x), cx);
        let fy = _mm_sub_ps(_mm_set1_ps(ray.o.y), cy);
        let fz = _mm_sub_ps(_mm_set1_ps(ray.o.z), cz);
        let dot = |ax, ay, az, bx, by, bz| {
            _mm_add_ps(
                _mm_add_ps(_mm_mul_ps(ax, bx), _mm_mul_ps(ay, by)),
                _mm_mul_ps(az, bz),
            )
        };
        let b = dot(fx, fy, fz, dx, dy, dz);
        let r2 = _mm_mul_ps(r, r);
        let c = _mm_sub_ps(dot(fx, fy, fz, fx, fy, fz), r2);
        let used_mask = (1u32 << used) - 1;
        // Outside and heading away.
        let mut reject = _mm_and_ps(_mm_cmpgt_ps(c, zero), _mm_cmpgt_ps(b, zero));
        if _mm_movemask_ps(reject) as u32 & used_mask == used_mask {
            return DistanceHits4 {
                mask: 0,
                t: [0.0; LANES],
            };
        }
        let a_s = ray.d.length_squared();
        let a = _mm_set1_ps(a_s);
        let ba = _mm_div_ps(b, a);
        let vx = _mm_sub_ps(fx, _mm_mul_ps(dx, ba));
        let vy = _mm_sub_ps(fy, _mm_mul_ps(dy, ba));
        let vz = _mm_sub_ps(fz, _mm_mul_ps(dz, ba));
        let disc = _mm_mul_ps(a, _mm_sub_ps(r2, dot(vx, vy, vz, vx, vy, vz)));
        reject = _mm_or_ps(reject, _mm_cmplt_ps(disc, zero));
        let root = _mm_sqrt_ps(disc);
        let signed_root = _mm_or_ps(_mm_andnot_ps(sign, root), _mm_and_ps(sign, b));
        let q = _mm_xor_ps(_mm_add_ps(b, signed_root), sign);
        let q_zero = _mm_cmpeq_ps(q, zero);
        let t0 = select(q_zero, zero, _mm_div_ps(q, a));
        let t1 = select(q_zero, zero, _mm_div_ps(c, q));
        let swap = _mm_cmpgt_ps(t0, t1);
        let (t0, t1) = (select(swap, t1, t0), select(swap, t0, t1));
        let (t_min, t_max) = (_mm_set1_ps(ray.t_min), _mm_set1_ps(t_max));
        let ok = |t| {
            _mm_and_ps(
                _mm_and_ps(_mm_cmpge_ps(t, t_min), _mm_cmple_ps(t, t_max)),
                _mm_cmpgt_ps(t, zero),
            )
        };
        let (ok0, ok1) = (ok(t0), ok(t1));
        let t = select(ok0, t0, t1);
        let hit = _mm_andnot_ps(reject, _mm_or_ps(ok0, ok1));
        DistanceHits4 {
            mask: _mm_movemask_ps(hit) as u32 & used_mask,
            t: store(t),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::vec3::V3;
    use proptest::prelude::*;

    /// Asserts that every kernel this CPU runs gives the portable kernel's answer bit for bit.
    fn check(ray: &Ray<f32>, s: &Spheres4<'_, f32>, used: usize, t_max: f32) -> u32 {
        let want = intersect4_lanes(ray, s, used, t_max);
        let lanes = SphereLanes::gather(s);
        let mut kernels = vec![
            intersect4(ray, s, used, t_max),
            intersect4_gathered(ray, &lanes, used, t_max),
        ];
        #[cfg(target_arch = "x86_64")]
        {
            kernels.push(sse2(ray, s, used, t_max));
            kernels.push(sse2(ray, &lanes, used, t_max));
            if crate::isa::Isa::Avx2.supported() {
                // SAFETY: the CPU has AVX.
                kernels.push(unsafe { avx(ray, s, used, t_max) });
                // SAFETY: as above.
                kernels.push(unsafe { avx(ray, &lanes, used, t_max) });
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
        /// Random spheres (some around the origin, so rays start inside; some touching the
        /// ray), axis-parallel and tangent rays: the kernels agree lane for lane.
        #[test]
        fn kernels_agree_on_random_spheres(
            centers in proptest::array::uniform4(proptest::array::uniform3(coord())),
            radii in proptest::array::uniform4(prop_oneof![0.01f32..3.0, Just(1.0f32)]),
            o in proptest::array::uniform3(coord()),
            d in proptest::array::uniform3(coord()),
            tangent in 0usize..5,
            used in 1usize..=4,
            t_max in prop_oneof![Just(f32::INFINITY), 0.0f32..50.0],
        ) {
            let mut spheres = [Sphere { center: V3::zero(), radius: 1.0f32 }; 4];
            for i in 0..4 {
                spheres[i] = Sphere { center: V3::from_array(centers[i]), radius: radii[i] };
            }
            let o = V3::from_array(o);
            let mut d = V3::from_array(d);
            if tangent < 4 {
                // Aimed at a point on the sphere's silhouette seen along the z axis.
                let s = spheres[tangent];
                d = s.center + V3::new(s.radius, 0.0, 0.0) - o;
            }
            prop_assume!(d.length() > 0.0 && d.length().is_finite());
            let ray = Ray { o, d: d.normalize(), t_min: 0.0, t_max };
            let refs = [&spheres[0], &spheres[1], &spheres[2], &spheres[3]];
            check(&ray, &refs, used, t_max);
        }
    }

    #[test]
    fn kernels_agree_inside_outside_and_behind() {
        let s = [
            Sphere {
                center: V3::new(0.0f32, 0.0, 5.0),
                radius: 1.0,
            },
            Sphere {
                center: V3::new(0.0, 0.0, 0.0),
                radius: 2.0,
            },
            Sphere {
                center: V3::new(0.0, 0.0, -5.0),
                radius: 1.0,
            },
            Sphere {
                center: V3::new(1.0, 0.0, 5.0),
                radius: 1.0,
            },
        ];
        let refs = [&s[0], &s[1], &s[2], &s[3]];
        let mut hits = 0;
        for d in [
            [0.0f32, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            [1.0, 0.0, 0.0],
            [0.2, 0.0, 1.0],
        ] {
            let ray = Ray {
                o: V3::zero(),
                d: V3::from_array(d).normalize(),
                t_min: 0.0,
                t_max: f32::INFINITY,
            };
            for used in 1..=4 {
                for t_max in [f32::INFINITY, 4.0, 2.0, 1.0] {
                    hits += check(&ray, &refs, used, t_max).count_ones();
                }
            }
        }
        assert!(hits > 30, "{hits}");
    }
}
