//! Open truncated cones and cylinders (no caps). The quadratic is solved in a frame moved to the
//! ray's closest approach to the cone's centre, so distant rays keep their precision; hit points
//! are re-projected onto the surface.

use super::ray::Ray;
use crate::real::Real;
use crate::vec3::V3;

/// A cone from `base` (radius `r0`) along unit `axis` for `height` to the apex circle (`r1`).
#[derive(Clone, Copy, Debug)]
pub struct Cone<R> {
    /// Centre of the base circle.
    pub base: V3<R>,
    /// Unit axis from base to apex.
    pub axis: V3<R>,
    /// Distance from base to apex.
    pub height: R,
    /// Base radius (≥ 0).
    pub r0: R,
    /// Radius change per unit height: `(r1 − r0) / height`.
    pub slope: R,
}

impl<R: Real> Cone<R> {
    /// Builds a cone from its end circles; `None` when base and apex coincide or both radii are 0.
    pub fn new(base: V3<R>, r0: R, apex: V3<R>, r1: R) -> Option<Self> {
        let axis = apex - base;
        let height = axis.length();
        if !(height > R::ZERO) || !(r0 > R::ZERO || r1 > R::ZERO) {
            return None;
        }
        Some(Cone {
            base,
            axis: axis / height,
            height,
            r0,
            slope: (r1 - r0) / height,
        })
    }

    /// Radius at axial coordinate `z` (0 at the base).
    #[inline(always)]
    fn radius_at(&self, z: R) -> R {
        self.r0 + self.slope * z
    }

    /// The nearest `t` in `[t_min, t_max]` where the ray meets the lateral surface.
    #[inline]
    pub fn intersect(&self, ray: &Ray<R>, t_max: R) -> Option<R> {
        let a = self.axis;
        // Move the origin along the ray to its closest approach to the cone's middle.
        let mid = self.base + a * (self.height * R::HALF);
        let dd = ray.d.length_squared();
        let shift = (mid - ray.o).dot(ray.d) / dd;
        let o = ray.o + ray.d * shift;
        let w = o - self.base;
        let d = ray.d;
        let wz = w.dot(a);
        let dz = d.dot(a);
        let wp = w - a * wz;
        let dp = d - a * dz;
        let rw = self.radius_at(wz);
        let k = self.slope;
        let qa = dp.length_squared() - k * k * dz * dz;
        let qb = wp.dot(dp) - k * rw * dz; // half b
        let qc = wp.length_squared() - rw * rw;
        let (t0, t1) = if qa.abs() <= R::gamma(8) * (dp.length_squared() + k * k * dz * dz) {
            // Ray parallel to a generator line: one root of the linear equation.
            if qb == R::ZERO {
                return None;
            }
            let t = -qc / (R::TWO * qb);
            (t, t)
        } else {
            let disc = qb * qb - qa * qc;
            if disc < R::ZERO {
                return None;
            }
            let root = disc.sqrt();
            let q = -(qb + root.copysign(qb));
            if q == R::ZERO {
                return None;
            }
            let (x, y) = (q / qa, qc / q);
            if x < y {
                (x, y)
            } else {
                (y, x)
            }
        };
        for tl in [t0, t1] {
            let t = tl + shift;
            if t < ray.t_min || t > t_max || t <= R::ZERO {
                continue;
            }
            let z = wz + dz * tl;
            if z >= R::ZERO && z <= self.height && self.radius_at(z) >= R::ZERO {
                return Some(t);
            }
        }
        None
    }

    /// The hit point re-projected onto the surface, its error bound, and the outward normal.
    #[inline]
    pub fn surface(&self, ray: &Ray<R>, t: R) -> (V3<R>, V3<R>, V3<R>) {
        let p = ray.o + ray.d * t;
        let rel = p - self.base;
        let z = rel.dot(self.axis).max(R::ZERO).min(self.height);
        let radial = rel - self.axis * rel.dot(self.axis);
        let len = radial.length();
        let dir = if len > R::ZERO {
            radial / len
        } else {
            // On the axis (the tip of a true cone): any perpendicular.
            let helper = if self.axis.x.abs() < R::HALF {
                V3::new(R::ONE, R::ZERO, R::ZERO)
            } else {
                V3::new(R::ZERO, R::ONE, R::ZERO)
            };
            self.axis.cross(helper).normalize()
        };
        let r = self.radius_at(z);
        let p = self.base + self.axis * z + dir * r;
        let err = (p.abs() + self.base.abs() + V3::splat(self.height + r)) * R::gamma(10);
        let n = (dir - self.axis * self.slope).normalize();
        (p, err, n)
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
    fn cylinder_hits_and_misses_beyond_ends() {
        let c = Cone::new(V3::new(0.0, 0.0, 0.0), 1.0, V3::new(0.0, 0.0, 2.0), 1.0).unwrap();
        assert_eq!(
            c.intersect(&ray([-5.0, 0.0, 1.0], [1.0, 0.0, 0.0]), f64::INFINITY),
            Some(4.0)
        );
        assert_eq!(
            c.intersect(&ray([-5.0, 0.0, 2.5], [1.0, 0.0, 0.0]), f64::INFINITY),
            None
        );
        // Open: a ray down the axis passes through.
        assert_eq!(
            c.intersect(&ray([0.0, 0.0, -5.0], [0.0, 0.0, 1.0]), f64::INFINITY),
            None
        );
    }

    #[test]
    fn true_cone_with_zero_apex() {
        let c = Cone::new(V3::new(0.0, 0.0, 0.0), 1.0, V3::new(0.0, 0.0, 1.0), 0.0).unwrap();
        let t = c
            .intersect(&ray([-5.0, 0.0, 0.5], [1.0, 0.0, 0.0]), f64::INFINITY)
            .unwrap();
        assert!((t - 4.5).abs() < 1e-12);
        let (p, _, n) = c.surface(&ray([-5.0, 0.0, 0.5], [1.0, 0.0, 0.0]), t);
        assert!((p.x + 0.5).abs() < 1e-12);
        assert!(n.x < 0.0 && n.z > 0.0);
    }

    #[test]
    fn far_away_cone_in_f32() {
        let c = Cone::new(
            V3::new(1.0e5f32, 0.0, 0.0),
            0.1,
            V3::new(1.0e5, 0.0, 1.0),
            0.1,
        )
        .unwrap();
        let r = Ray {
            o: V3::new(0.0f32, 0.0, 0.5),
            d: V3::new(1.0, 0.0, 0.0),
            t_min: 0.0,
            t_max: f32::INFINITY,
        };
        let t = c.intersect(&r, f32::INFINITY).expect("hits");
        assert!((t - (1.0e5 - 0.1)).abs() < 0.02, "t = {t}");
    }
}
