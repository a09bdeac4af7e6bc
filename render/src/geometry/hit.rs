//! Hit records and the one way secondary rays leave a surface: [`offset_ray_origin`] moves the
//! origin off the surface by the hit's position-error bound, on the side the new ray leaves.

use crate::real::Real;
use crate::vec3::V3;

/// The minimal record of a closest hit, as the accelerators pass it around: distance, primitive,
/// and the primitive's own surface parameters (barycentrics for triangles). Turning it into a
/// full surface description happens once per shaded hit, never per test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrimHit<R> {
    /// Distance along the ray.
    pub t: R,
    /// Primitive index in the scene.
    pub prim: u32,
    /// First surface parameter (triangle: barycentric of vertex 1).
    pub u: R,
    /// Second surface parameter (triangle: barycentric of vertex 2).
    pub v: R,
}

impl<R: Real> PrimHit<R> {
    /// True when `self` should replace `best`: nearer, or equally near with a smaller primitive
    /// index. The tie rule makes every accelerator pick the same primitive.
    #[inline(always)]
    pub fn beats(&self, best_t: R, best_prim: u32) -> bool {
        self.t < best_t || (self.t == best_t && self.prim < best_prim)
    }
}

/// The nearest hit found so far along a ray, kept by the one rule every accelerator shares
/// ([`PrimHit::beats`]), so they all return the same hit.
#[derive(Clone, Copy, Debug)]
pub struct Nearest<R> {
    /// The hit, if any.
    pub hit: Option<PrimHit<R>>,
    /// Its distance, or the ray's `t_max` while there is none: the bound for further tests.
    pub t: R,
    prim: u32,
}

impl<R: Real> Nearest<R> {
    /// Nothing found yet within `t_max`.
    #[inline(always)]
    pub fn new(t_max: R) -> Self {
        Nearest {
            hit: None,
            t: t_max,
            prim: u32::MAX,
        }
    }

    /// Keeps `h` when it beats the current hit.
    #[inline(always)]
    pub fn offer(&mut self, h: Option<PrimHit<R>>) {
        if let Some(h) = h {
            if h.beats(self.t, self.prim) {
                self.t = h.t;
                self.prim = h.prim;
                self.hit = Some(h);
            }
        }
    }
}

/// Moves `p` (with absolute error bound `p_err` per component) off its surface, whose normal is
/// `n`, to the side of direction `w`, far enough that the surface cannot be re-hit, and rounds
/// the result away from the surface.
#[inline]
pub fn offset_ray_origin<R: Real>(p: V3<R>, p_err: V3<R>, n: V3<R>, w: V3<R>) -> V3<R> {
    let d = n.abs().dot(p_err);
    let mut offset = n * d;
    if w.dot(n) < R::ZERO {
        offset = -offset;
    }
    let mut po = p + offset;
    let round = |v: R, off: R| {
        if off > R::ZERO {
            v.next_up()
        } else if off < R::ZERO {
            v.next_down()
        } else {
            v
        }
    };
    po.x = round(po.x, offset.x);
    po.y = round(po.y, offset.y);
    po.z = round(po.z, offset.z);
    po
}
