//! Four spheres against one ray at once: [`Sphere::intersect`] with one sphere per SIMD lane,
//! for BVH leaves of spheres (shells, balls). Every lane does the scalar test's IEEE operations
//! in the same order (no FMA, no reassociation), so each lane's answer is bit for bit the
//! scalar one: the arithmetic is the one sphere test, `nearest_root`, on four lanes.
//! [`super::four_lanes::intersect4`] runs it with the code of the process's tier ([`crate::isa::dispatch`]) like
//! [`super::leaf_triangles`]: four SSE2 lanes (in their VEX form on `avx2` and `avx512`), the
//! portable lane loop ([`distances4`]) on `scalar` and elsewhere.
//! [`LeafSpheres`] holds a leaf's spheres already gathered into lanes, so the rays of a packet
//! that enter the leaf share one gather ([`super::four_lanes::intersect4`] on [`LeafSpheres`]).

use super::distance_hits::{distances4, DistanceHits};
use super::four_lanes::{FourLanes, FourOnRay};
use super::ray::Ray;
use super::sphere::{nearest_root, Sphere};
use crate::lanes::Lanes;

/// Spheres per call.
pub const LANES: usize = 4;

/// The spheres of the lanes (unused lanes repeat a used one; `used` says how many count).
pub type Spheres4<'a, R> = [&'a Sphere<R>; LANES];

/// Four spheres gathered into lanes: centre components by axis, then radii (the kernel's
/// layout).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
pub struct LeafSpheres {
    /// Centre components by axis and lane.
    pub c: [[f32; LANES]; 3],
    /// Radii by lane.
    pub r: [f32; LANES],
}

impl LeafSpheres {
    /// The lanes of `spheres`.
    #[inline(always)]
    pub fn gather(spheres: &Spheres4<'_, f32>) -> Self {
        let mut c = [[0.0; LANES]; 3];
        for (axis, lanes) in c.iter_mut().enumerate() {
            for (lane, v) in lanes.iter_mut().enumerate() {
                *v = spheres[lane].center.to_array()[axis];
            }
        }
        LeafSpheres {
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
    fn scalar_hits(&self, ray: &Ray<f32>, used: usize, t_max: f32) -> DistanceHits<f32> {
        let s = [0, 1, 2, 3].map(|i| self.sphere(i));
        distances4(ray, &[&s[0], &s[1], &s[2], &s[3]], used, t_max)
    }
}

impl<S: Source> FourLanes for FourOnRay<'_, Ray<f32>, S> {
    type Output = DistanceHits<f32>;

    /// The sphere test (`nearest_root`) with a sphere per lane.
    #[inline(always)]
    fn lanes<L: Lanes<Elem = f32>>(self) -> DistanceHits<f32> {
        let (ray, used) = (self.ray, self.used);
        let [cx, cy, cz, r] = self.src.lanes::<L>();
        let f = [
            L::splat(ray.o.x) - cx,
            L::splat(ray.o.y) - cy,
            L::splat(ray.o.z) - cz,
        ];
        let d = [L::splat(ray.d.x), L::splat(ray.d.y), L::splat(ray.d.z)];
        let a = L::splat(ray.d.length_squared());
        let live = (1u32 << used) - 1;
        let mut out = DistanceHits {
            mask: 0,
            t: [0.0; LANES],
        };
        let (t_min, t_max) = (L::splat(ray.t_min), L::splat(self.t_max));
        if let Some(h) = nearest_root(f, d, a, r * r, t_min, t_max, live) {
            out.mask = h.mask;
            h.t.store(&mut out.t);
        }
        out
    }

    fn portable(self) -> DistanceHits<f32> {
        self.src.portable(self.ray, self.used, self.t_max)
    }
}

/// Where the kernel reads the spheres from: gathered from four spheres on the spot, or loaded
/// from lanes gathered once.
pub trait Source {
    /// Centre `x`, `y`, `z` and radius of the four spheres.
    fn lanes<L: Lanes<Elem = f32>>(&self) -> [L; 4];
    /// The portable kernel on the same spheres.
    fn portable(&self, ray: &Ray<f32>, used: usize, t_max: f32) -> DistanceHits<f32>;
}

impl Source for Spheres4<'_, f32> {
    #[inline(always)]
    fn lanes<L: Lanes<Elem = f32>>(&self) -> [L; 4] {
        let (x, y, z) = (
            self.map(|s| s.center.x),
            self.map(|s| s.center.y),
            self.map(|s| s.center.z),
        );
        [
            L::load(&x),
            L::load(&y),
            L::load(&z),
            L::load(&self.map(|s| s.radius)),
        ]
    }

    fn portable(&self, ray: &Ray<f32>, used: usize, t_max: f32) -> DistanceHits<f32> {
        distances4(ray, self, used, t_max)
    }
}

impl Source for LeafSpheres {
    #[inline(always)]
    fn lanes<L: Lanes<Elem = f32>>(&self) -> [L; 4] {
        // SAFETY: the rows of `LeafSpheres` are four `f32` at a multiple of 16 bytes
        // (`align(16)`, rows of 16 bytes).
        unsafe {
            [
                L::load_aligned(&self.c[0]),
                L::load_aligned(&self.c[1]),
                L::load_aligned(&self.c[2]),
                L::load_aligned(&self.r),
            ]
        }
    }

    fn portable(&self, ray: &Ray<f32>, used: usize, t_max: f32) -> DistanceHits<f32> {
        self.scalar_hits(ray, used, t_max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::four_lanes::{assert_agree, every_tier};
    use crate::geometry::test_coords::point;
    use crate::vec3::V3;
    use proptest::prelude::*;

    /// Asserts that every kernel this CPU runs gives the portable kernel's answer bit for bit.
    fn check(ray: &Ray<f32>, s: &Spheres4<'_, f32>, used: usize, t_max: f32) -> u32 {
        let want = distances4(ray, s, used, t_max);
        let lanes = LeafSpheres::gather(s);
        let mut kernels = every_tier(FourOnRay::new(ray, s, used, t_max));
        kernels.extend(every_tier(FourOnRay::new(ray, &lanes, used, t_max)));
        assert_agree(
            &want,
            &kernels,
            &format!("{ray:?} used {used} t_max {t_max}"),
        );
        want.mask
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]
        /// Random spheres (some around the origin, so rays start inside; some touching the
        /// ray), axis-parallel and tangent rays: the kernels agree lane for lane.
        #[test]
        fn kernels_agree_on_random_spheres(
            centers in proptest::array::uniform4(point()),
            radii in proptest::array::uniform4(prop_oneof![0.01f32..3.0, Just(1.0f32)]),
            o in point(),
            d in point(),
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
