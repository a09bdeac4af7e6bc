//! What a four-lane kernel that finds only distances answers (spheres, cones): which lanes were
//! hit and where, and the portable loop that defines those answers ([`distances4`]). The
//! triangle kernels answer surface parameters too ([`super::leaf_triangles::TriangleHits`]).

use super::cone::Cone;
use super::ray::Ray;
use super::sphere::Sphere;
use crate::real::Real;

/// The answers of the four lanes: bit `i` of `mask` is set when lane `i` is hit at `t[i]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DistanceHits<R> {
    /// Lanes hit.
    pub mask: u32,
    /// Distances (valid for set bits).
    pub t: [R; 4],
}

#[cfg(test)]
impl crate::geometry::four_lanes::HitBits for DistanceHits<f32> {
    fn hit_bits(&self) -> Vec<(usize, Vec<u32>)> {
        crate::geometry::four_lanes::lanes_bits(self.mask, &[&self.t])
    }
}

impl<R: Copy + Default> DistanceHits<R> {
    /// The answers of the portable lane loops: lane `i`'s scalar test gave `tests[i]`.
    #[inline(always)]
    pub fn from_tests(tests: impl IntoIterator<Item = Option<R>>) -> Self {
        let mut h = DistanceHits {
            mask: 0,
            t: [R::default(); 4],
        };
        for (i, t) in tests.into_iter().take(4).enumerate() {
            if let Some(t) = t {
                h.mask |= 1 << i;
                h.t[i] = t;
            }
        }
        h
    }
}

/// A primitive whose scalar test answers a distance only: a sphere or a cone.
pub trait DistanceTest<R> {
    /// The nearest hit of `ray` within `t_max`.
    fn distance(&self, ray: &Ray<R>, t_max: R) -> Option<R>;
}

impl<R: Real> DistanceTest<R> for Sphere<R> {
    #[inline(always)]
    fn distance(&self, ray: &Ray<R>, t_max: R) -> Option<R> {
        self.intersect(ray, t_max)
    }
}

impl<R: Real> DistanceTest<R> for Cone<R> {
    #[inline(always)]
    fn distance(&self, ray: &Ray<R>, t_max: R) -> Option<R> {
        self.intersect(ray, t_max)
    }
}

/// The portable four-lane kernel: the scalar test of `ray` against `prims[i]` lane by lane
/// (lanes `0..used`), in any precision.
#[inline(always)]
pub fn distances4<R: Real, P: DistanceTest<R>>(
    ray: &Ray<R>,
    prims: &[&P; 4],
    used: usize,
    t_max: R,
) -> DistanceHits<R> {
    DistanceHits::from_tests(prims.iter().take(used).map(|p| p.distance(ray, t_max)))
}
