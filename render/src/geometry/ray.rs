//! Rays, and a ray prepared once for many tests: reciprocal direction for the slab test and the
//! permutation/shear of the watertight triangle test.

use crate::real::Real;
use crate::vec3::V3;

/// A ray `o + t·d` for `t` in `[t_min, t_max]`.
#[derive(Clone, Copy, Debug)]
pub struct Ray<R> {
    /// Origin.
    pub o: V3<R>,
    /// Direction (unit length for every ray the renderer casts).
    pub d: V3<R>,
    /// Nearest accepted distance.
    pub t_min: R,
    /// Farthest accepted distance.
    pub t_max: R,
}

#[cfg(test)]
impl<R: Real> Ray<R> {
    /// A test ray from `o` along `d` (normalised here), with `t` in `[0, ∞]`.
    pub(crate) fn unbounded(o: [R; 3], d: [R; 3]) -> Ray<R> {
        Ray {
            o: V3::from_array(o),
            d: V3::from_array(d).normalize(),
            t_min: R::ZERO,
            t_max: R::INFINITY,
        }
    }
}

#[cfg(test)]
impl<R: Real> PreparedRay<R> {
    /// [`Ray::unbounded`], prepared.
    pub(crate) fn unbounded(o: [R; 3], d: [R; 3]) -> PreparedRay<R> {
        PreparedRay::new(Ray::unbounded(o, d))
    }
}

/// A ray with the per-ray constants of the box and triangle tests.
#[derive(Clone, Copy, Debug)]
pub struct PreparedRay<R> {
    /// The ray.
    pub ray: Ray<R>,
    /// `1/d` per component (±infinity for a zero component).
    pub inv_d: V3<R>,
    /// Whether each direction component is negative.
    pub neg: [bool; 3],
    /// Axis of the largest direction component (triangle test's z).
    pub kz: usize,
    /// Triangle test's x axis.
    pub kx: usize,
    /// Triangle test's y axis.
    pub ky: usize,
    /// Shear constants of the triangle test.
    pub shear: V3<R>,
}

impl<R: Real> PreparedRay<R> {
    /// Prepares `ray`.
    #[inline]
    pub fn new(ray: Ray<R>) -> Self {
        let d = ray.d;
        let inv_d = V3::new(R::ONE / d.x, R::ONE / d.y, R::ONE / d.z);
        let kz = d.max_abs_axis();
        let mut kx = if kz == 2 { 0 } else { kz + 1 };
        let mut ky = if kx == 2 { 0 } else { kx + 1 };
        if d.get(kz) < R::ZERO {
            std::mem::swap(&mut kx, &mut ky);
        }
        let dz = d.get(kz);
        // 1/dz is the reciprocal already computed for the slab test (the same division).
        let shear = V3::new(d.get(kx) / dz, d.get(ky) / dz, inv_d.get(kz));
        PreparedRay {
            ray,
            inv_d,
            // From the reciprocal, not from `d < 0`: a −0 component gives 1/−0 = −∞, and the
            // slab test must then swap that axis's bounds like for any negative direction.
            neg: [inv_d.x < R::ZERO, inv_d.y < R::ZERO, inv_d.z < R::ZERO],
            kz,
            kx,
            ky,
            shear,
        }
    }
}
