//! Spheres: a numerically careful quadratic (the discriminant computed from the ray's closest
//! approach, the roots by the stable formula) and hit points re-projected onto the surface so
//! their error bound is a few ulps of the position.

use super::ray::Ray;
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
    /// The nearest `t` in `[t_min, t_max]` where the ray meets the sphere (either side).
    #[inline(always)]
    pub fn intersect(&self, ray: &Ray<R>, t_max: R) -> Option<R> {
        let f = ray.o - self.center;
        let d = ray.d;
        let b = f.dot(d); // half of the usual b
        let r2 = self.radius * self.radius;
        let c = f.length_squared() - r2;
        // Origin outside and heading away: both roots below are negative (q < 0, so q/a < 0 and
        // c/q < 0), so this returns exactly what the full computation would, without the root
        // and the divisions. Most shadow rays leaving a cluster of spheres end here.
        if c > R::ZERO && b > R::ZERO {
            return None;
        }
        let a = d.length_squared();
        // b² − a·c computed as a·(r² − |f − (b/a)·d|²): no cancellation for distant rays.
        let v = f - d * (b / a);
        let disc = a * (r2 - v.length_squared());
        if disc < R::ZERO {
            return None;
        }
        let root = disc.sqrt();
        let q = -(b + root.copysign(b));
        let (mut t0, mut t1) = if q == R::ZERO {
            (R::ZERO, R::ZERO)
        } else {
            (q / a, c / q)
        };
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        if t0 >= ray.t_min && t0 <= t_max && t0 > R::ZERO {
            Some(t0)
        } else if t1 >= ray.t_min && t1 <= t_max && t1 > R::ZERO {
            Some(t1)
        } else {
            None
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    fn ray(o: [f64; 3], d: [f64; 3]) -> Ray<f64> {
        Ray {
            o: V3::from_array(o),
            d: V3::from_array(d).normalize(),
            t_min: 0.0,
            t_max: f64::INFINITY,
        }
    }

    #[test]
    fn hits_front_then_back() {
        let s = Sphere {
            center: V3::new(0.0, 0.0, 5.0),
            radius: 1.0,
        };
        let t = s.intersect(&ray([0.0, 0.0, 0.0], [0.0, 0.0, 1.0]), f64::INFINITY);
        assert_eq!(t, Some(4.0));
        let inside = s.intersect(&ray([0.0, 0.0, 5.0], [0.0, 0.0, 1.0]), f64::INFINITY);
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
