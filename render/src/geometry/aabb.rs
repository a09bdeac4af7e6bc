//! Axis-aligned boxes in `f32` (the accelerators' storage precision), always rounded outward from
//! the exact primitive bounds, and the robust slab test: NaN-safe for zero direction components
//! and conservative at the far end (t_far widened by 1 + 2γ₃).

use super::ray::PreparedRay;
use super::slab::slab;
use crate::real::Real;
use crate::vec3::V3;

/// An axis-aligned box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Minimum corner.
    pub min: [f32; 3],
    /// Maximum corner.
    pub max: [f32; 3],
}

/// Rounds `v` down to an `f32` that is ≤ `v`.
#[inline]
pub fn f32_down(v: f64) -> f32 {
    let f = v as f32;
    if f as f64 > v {
        f.next_down()
    } else {
        f
    }
}

/// Rounds `v` up to an `f32` that is ≥ `v`.
#[inline]
pub fn f32_up(v: f64) -> f32 {
    let f = v as f32;
    if (f as f64) < v {
        f.next_up()
    } else {
        f
    }
}

impl Aabb {
    /// The empty box.
    pub const EMPTY: Aabb = Aabb {
        min: [f32::INFINITY; 3],
        max: [f32::NEG_INFINITY; 3],
    };

    /// The smallest `f32` box containing the exact `f64` box `[lo, hi]`.
    pub fn from_f64(lo: V3<f64>, hi: V3<f64>) -> Self {
        Aabb {
            min: [f32_down(lo.x), f32_down(lo.y), f32_down(lo.z)],
            max: [f32_up(hi.x), f32_up(hi.y), f32_up(hi.z)],
        }
    }

    /// Grows to contain `o`.
    #[inline]
    pub fn union(&self, o: &Aabb) -> Aabb {
        let mut r = *self;
        for i in 0..3 {
            r.min[i] = r.min[i].min(o.min[i]);
            r.max[i] = r.max[i].max(o.max[i]);
        }
        r
    }

    /// Grows to contain point `p`.
    #[inline]
    pub fn add_point(&mut self, p: [f32; 3]) {
        for (i, v) in p.into_iter().enumerate() {
            self.min[i] = self.min[i].min(v);
            self.max[i] = self.max[i].max(v);
        }
    }

    /// The centre.
    #[inline]
    pub fn centroid(&self) -> [f32; 3] {
        [
            0.5 * (self.min[0] + self.max[0]),
            0.5 * (self.min[1] + self.max[1]),
            0.5 * (self.min[2] + self.max[2]),
        ]
    }

    /// Half the surface area (the SAH only needs ratios).
    #[inline]
    pub fn half_area(&self) -> f32 {
        let dx = (self.max[0] - self.min[0]).max(0.0);
        let dy = (self.max[1] - self.min[1]).max(0.0);
        let dz = (self.max[2] - self.min[2]).max(0.0);
        dx * dy + dy * dz + dz * dx
    }

    /// True when nothing was added.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.min[0] > self.max[0]
    }

    /// Slab test: `Some(t_near)` when the ray meets the box within `[t_min, t_max]`.
    #[inline(always)]
    pub fn hit<R: Real>(&self, pr: &PreparedRay<R>, t_max: R) -> Option<R> {
        slab(&self.min, &self.max, pr, t_max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether `b` is hit by the ray from `o` along `d`.
    fn hits(b: &Aabb, o: [f32; 3], d: [f32; 3]) -> bool {
        b.hit(&PreparedRay::unbounded(o, d), f32::INFINITY)
            .is_some()
    }

    #[test]
    fn axis_parallel_rays() {
        let b = Aabb {
            min: [0.0; 3],
            max: [1.0; 3],
        };
        let up = [0.0, 0.0, 1.0];
        assert!(hits(&b, [0.5, 0.5, -1.0], up));
        assert!(!hits(&b, [1.5, 0.5, -1.0], up));
        // Lying exactly in the box's face plane: counted as a hit (conservative).
        assert!(hits(&b, [0.0, 0.5, -1.0], up));
        assert!(!hits(&b, [0.5, 0.5, 2.0], up));
    }

    #[test]
    fn negative_zero_direction_components() {
        // Regression (hard case "axis-parallel rays"): a ray along −z built as −(0, 0, 1) has
        // −0 in x and y; 1/−0 = −∞ and the box was missed.
        let b = Aabb {
            min: [-1.0, -1.0, 0.0],
            max: [1.0, 1.0, 0.0],
        };
        for d in [[-0.0, -0.0, -1.0], [0.0, -0.0, -1.0], [-0.0, 0.0, -1.0]] {
            assert!(hits(&b, [0.3, 0.2, 5.0], d), "{d:?}");
        }
        assert!(hits(&b, [0.3, 0.2, -5.0], [-0.0, -0.0, 1.0]));
    }

    #[test]
    fn outward_rounding() {
        let b = Aabb::from_f64(V3::new(0.1, 0.1, 0.1), V3::new(0.3, 0.3, 0.3));
        assert!((b.min[0] as f64) <= 0.1 && (b.max[0] as f64) >= 0.3);
    }
}
