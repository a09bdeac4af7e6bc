//! Spheres: a numerically careful quadratic (the discriminant computed from the ray's closest
//! approach, the roots by the stable formula) and hit points re-projected onto the surface so
//! their error bound is a few ulps of the position.
//!
//! The test is written once, `nearest_root`, over the lane types of [`crate::lanes`]: the
//! scalar test here, and the SIMD kernels of [`super::leaf_spheres`] (one ray against four spheres)
//! and [`super::packet_prims`] (a packet's rays against one sphere) are its instances.

use super::ray::Ray;
use crate::lanes::{dot3 as dot, Lanes, Mask};
use crate::real::Real;
use crate::vec3::V3;

/// A sphere in the renderer's precision.
#[derive(Clone, Copy, Debug)]
pub struct Sphere<R> {
    /// Centre.
    pub center: V3<R>,
    /// Radius (positive).
    pub radius: R,
}

impl<R: Real> Sphere<R> {
    /// The nearest `t` in `[t_min, t_max]` where the ray meets the sphere (either side): the
    /// lane kernel `nearest_root` with one lane.
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray<R>, t_max: R) -> Option<R> {
        let f = ray.o - self.center;
        let (f, d) = (f.to_array(), ray.d.to_array());
        let r2 = self.radius * self.radius;
        let a = ray.d.length_squared();
        let h = nearest_root(f, d, a, r2, ray.t_min, t_max, 1)?;
        (h.mask != 0).then_some(h.t)
    }

    /// The hit point re-projected onto the sphere, its error bound, and the outward normal.
    #[inline]
    pub fn surface(&self, ray: &Ray<R>, t: R) -> (V3<R>, V3<R>, V3<R>) {
        let p = ray.o + ray.d * t;
        let rel = p - self.center;
        let len = rel.length();
        let rel = if len > R::ZERO {
            rel * (self.radius / len)
        } else {
            V3::new(self.radius, R::ZERO, R::ZERO)
        };
        let p = self.center + rel;
        let err = (rel.abs() + self.center.abs()) * R::gamma(6);
        (p, err, rel / self.radius)
    }
}

/// The answers of `nearest_root`: bit `i` of `mask` is set when lane `i` is hit, at `t`
/// (computed in every lane, meaningful in the lanes hit).
#[derive(Clone, Copy, Debug)]
pub(crate) struct RootHits<L> {
    /// Lanes hit.
    pub mask: u32,
    /// Distances.
    pub t: L,
}

/// The sphere test, written once for every lane type ([`crate::lanes`]): [`Sphere::intersect`]
/// is its one-lane instance, the SIMD kernels (one ray against four spheres, a packet's rays
/// against one sphere) its four-, eight- and sixteen-lane instances, so every lane does the
/// same IEEE operations in the same order and gives the same bits.
///
/// `f` is the origin minus the centre, `d` the direction, `a` is `|d|²`, `r2` the squared
/// radius; the lanes
/// of `live` (bits) count. `None` when every live lane misses (no lane hit).
#[inline(always)]
pub(crate) fn nearest_root<L: Lanes>(
    f: [L; 3],
    d: [L; 3],
    a: L,
    r2: L,
    t_min: L,
    t_max: L,
    live: u32,
) -> Option<RootHits<L>> {
    let zero = L::zero();
    // No closures over lane operations here: a closure is compiled apart from the tier's entry,
    // without its instruction sets, and its lane operations would become calls.
    let b = dot(f, d); // half of the usual b
    let c = dot(f, f) - r2;
    // Origin outside and heading away: both roots below are negative (q < 0, so q/a < 0 and
    // c/q < 0), so this returns exactly what the full computation would, without the root and
    // the divisions. Most shadow rays leaving a cluster of spheres end here.
    let mut reject = c.gt(zero) & b.gt(zero);
    if reject.bits() & live == live {
        return None;
    }
    // b² − a·c computed as a·(r² − |f − (b/a)·d|²): no cancellation for distant rays.
    let ba = b / a;
    let v = [f[0] - d[0] * ba, f[1] - d[1] * ba, f[2] - d[2] * ba];
    let disc = a * (r2 - dot(v, v));
    reject = reject | disc.lt(zero);
    // Every live lane missed: return before the root and the two divisions. For one lane (the
    // scalar test) this is the miss's early return, most of a shadow ray's work among spheres;
    // without it lattice-12 cast 8 % slower on `avx512`, whose packet leaves of mixed spheres
    // and cones test the spheres one ray at a time.
    if reject.bits() & live == live {
        return None;
    }
    let root = disc.sqrt();
    let q = (b + root.copysign(b)).neg();
    let q_zero = q.eq(zero);
    let t0 = L::select(q_zero, zero, q / a);
    let t1 = L::select(q_zero, zero, c / q);
    let swap = t0.gt(t1);
    let (t0, t1) = (L::select(swap, t1, t0), L::select(swap, t0, t1));
    let ok0 = t0.ge(t_min) & t0.le(t_max) & t0.gt(zero);
    let ok1 = t1.ge(t_min) & t1.le(t_max) & t1.gt(zero);
    Some(RootHits {
        mask: reject.andnot(ok0 | ok1).bits() & live,
        t: L::select(ok0, t0, t1),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_front_then_back() {
        let s = Sphere {
            center: V3::new(0.0, 0.0, 5.0),
            radius: 1.0,
        };
        let t = s.intersect(
            &Ray::unbounded([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            f64::INFINITY,
        );
        assert_eq!(t, Some(4.0));
        let inside = s.intersect(
            &Ray::unbounded([0.0, 0.0, 5.0], [0.0, 0.0, 1.0]),
            f64::INFINITY,
        );
        assert_eq!(inside, Some(1.0));
    }

    #[test]
    fn far_away_sphere_is_accurate_in_f32() {
        // A unit sphere 1e5 away: the naive quadratic loses everything in f32.
        let s = Sphere {
            center: V3::new(0.0f32, 0.0, 1.0e5),
            radius: 1.0,
        };
        let r = Ray {
            o: V3::zero(),
            d: V3::new(0.0f32, 0.5, 1.0e5).normalize(),
            t_min: 0.0,
            t_max: f32::INFINITY,
        };
        let t = s.intersect(&r, f32::INFINITY).expect("hits");
        let (p, _, _) = s.surface(&r, t);
        assert!(((p - s.center).length() - 1.0).abs() < 1e-3);
        assert!((t - 99999.13).abs() < 0.05, "t = {t}");
    }
}
