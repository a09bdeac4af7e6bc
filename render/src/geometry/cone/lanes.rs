//! Four cones against one ray, or one cone against four rays, at once: [`Cone::intersect`] with
//! one cone per SIMD lane for BVH leaves of cones and cylinders (rings, tree, jacks), or one ray
//! per lane for a packet's rays entering a leaf with a cone. The arithmetic is the one cone
//! test, `lateral_hits`, on four lanes, so each lane's answer is bit for bit the scalar one.
//! [`crate::geometry::four_lanes::intersect4`] and [`intersect_rays4`] run it with the code of the process's tier
//! ([`crate::isa::dispatch`]) like [`crate::geometry::leaf_spheres`]: four SSE2 lanes (in
//! their VEX form on `avx2` and `avx512`), the portable lane loops
//! ([`crate::geometry::distance_hits::distances4`], [`intersect_rays4_lanes`]) on `scalar`
//! and elsewhere.

use super::{lateral_hits, Cone, ConeLanes, ConeRays};
use crate::geometry::distance_hits::{distances4, DistanceHits};
use crate::geometry::four_lanes::{four, FourLanes, FourOnRay};
use crate::geometry::ray::Ray;
use crate::lanes::{splat3, Lanes, Mask};
use crate::real::Real;
use crate::vec3::V3;

/// Cones per call.
pub const LANES: usize = 4;

/// The cones of the lanes (unused lanes repeat a used one; `used` says how many count).
pub type Cones4<'a, R> = [&'a Cone<R>; LANES];

/// The portable kernel of one cone against up to four rays (lane `i`: `rays[i]` within
/// `t_max[i]`), the scalar test lane by lane.
#[inline(always)]
pub fn intersect_rays4_lanes<R: Real>(
    cone: &Cone<R>,
    rays: &[&Ray<R>; LANES],
    used: usize,
    t_max: [R; LANES],
) -> DistanceHits<R> {
    DistanceHits::from_tests(
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
) -> DistanceHits<f32> {
    four(FourRays {
        cone,
        rays,
        used,
        t_max,
    })
}

impl FourLanes for FourOnRay<'_, Ray<f32>, Cones4<'_, f32>> {
    type Output = DistanceHits<f32>;

    /// The lateral surface test (`lateral_hits`) with a cone per lane.
    #[inline(always)]
    fn lanes<L: Lanes<Elem = f32>>(self) -> DistanceHits<f32> {
        let (ray, cones) = (self.ray, self.src);
        let c = ConeLanes {
            base: gather3(cones, |c| c.base),
            axis: gather3(cones, |c| c.axis),
            height: gather(cones, |c| c.height),
            r0: gather(cones, |c| c.r0),
            slope: gather(cones, |c| c.slope),
        };
        let r = ConeRays {
            o: splat3(ray.o.to_array()),
            d: splat3(ray.d.to_array()),
            t_min: L::splat(ray.t_min),
            t_max: L::splat(self.t_max),
        };
        finish(lateral_hits(&c, &r), self.used)
    }

    fn portable(self) -> DistanceHits<f32> {
        distances4(self.ray, self.src, self.used, self.t_max)
    }
}

/// One cone against four rays: the kernel [`crate::isa::dispatch`] runs.
#[derive(Clone, Copy)]
struct FourRays<'a> {
    cone: &'a Cone<f32>,
    rays: &'a [&'a Ray<f32>; LANES],
    used: usize,
    t_max: [f32; LANES],
}

impl FourLanes for FourRays<'_> {
    type Output = DistanceHits<f32>;

    /// The lateral surface test (`lateral_hits`) with a ray per lane.
    #[inline(always)]
    fn lanes<L: Lanes<Elem = f32>>(self) -> DistanceHits<f32> {
        let rays = self.rays;
        let c = ConeLanes::splat(&self.cone.lanes());
        let r = ConeRays {
            o: gather3(rays, |r| r.o),
            d: gather3(rays, |r| r.d),
            t_min: gather(rays, |r| r.t_min),
            t_max: L::load(&self.t_max),
        };
        finish(lateral_hits(&c, &r), self.used)
    }

    fn portable(self) -> DistanceHits<f32> {
        intersect_rays4_lanes(self.cone, self.rays, self.used, self.t_max)
    }
}

/// Field `f` of the four lanes' values, as lanes (`f` a plain function, not a closure, so that
/// it compiles inside the tier's entry).
#[inline(always)]
fn gather<T, L: Lanes<Elem = f32>>(items: &[&T; LANES], f: fn(&T) -> f32) -> L {
    L::load(&[f(items[0]), f(items[1]), f(items[2]), f(items[3])])
}

/// Vector `f` of the four lanes' values, as lanes by axis ([`gather`] three times over).
#[inline(always)]
fn gather3<T, L: Lanes<Elem = f32>>(items: &[&T; LANES], f: fn(&T) -> V3<f32>) -> [L; 3] {
    let p = [f(items[0]), f(items[1]), f(items[2]), f(items[3])];
    [
        L::load(&[p[0].x, p[1].x, p[2].x, p[3].x]),
        L::load(&[p[0].y, p[1].y, p[2].y, p[3].y]),
        L::load(&[p[0].z, p[1].z, p[2].z, p[3].z]),
    ]
}

/// The used lanes' answers.
#[inline(always)]
fn finish<L: Lanes<Elem = f32>>((hit, t): (L::Mask, L), used: usize) -> DistanceHits<f32> {
    let mut out = DistanceHits {
        mask: hit.bits() & ((1u32 << used) - 1),
        t: [0.0; LANES],
    };
    t.store(&mut out.t);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::four_lanes::{assert_agree, every_tier};
    use crate::geometry::test_coords::point;
    use crate::vec3::V3;
    use proptest::prelude::*;

    /// Asserts that every kernel this CPU runs gives the portable kernel's answer bit for bit.
    fn check(ray: &Ray<f32>, c: &Cones4<'_, f32>, used: usize, t_max: f32) -> u32 {
        let want = distances4(ray, c, used, t_max);
        let kernels = every_tier(FourOnRay::new(ray, c, used, t_max));
        assert_agree(
            &want,
            &kernels,
            &format!("{ray:?} used {used} t_max {t_max}"),
        );
        want.mask
    }

    /// [`check`] for the one-cone, four-ray kernels.
    fn check_rays(c: &Cone<f32>, rays: &[&Ray<f32>; LANES], used: usize, t_max: [f32; 4]) -> u32 {
        let want = intersect_rays4_lanes(c, rays, used, t_max);
        let kernels = every_tier(FourRays {
            cone: c,
            rays,
            used,
            t_max,
        });
        let case = format!("{c:?} {rays:?} used {used} t_max {t_max:?}");
        assert_agree(&want, &kernels, &case);
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

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]
        /// Random cones, cylinders and true cones (some around the ray's origin, some far),
        /// rays along an axis, parallel to a generator line and aimed at a rim: the kernels
        /// agree lane for lane.
        #[test]
        fn kernels_agree_on_random_cones(
            ends in proptest::array::uniform4(proptest::array::uniform2(
                point())),
            radii in proptest::array::uniform4(proptest::array::uniform2(
                prop_oneof![0.01f32..3.0, Just(1.0f32), Just(0.0f32)])),
            o in point(),
            d in point(),
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
            ends in proptest::array::uniform2(point()),
            radii in proptest::array::uniform2(prop_oneof![0.01f32..3.0, Just(1.0f32), Just(0.0f32)]),
            o in proptest::array::uniform4(point()),
            d in proptest::array::uniform4(point()),
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
