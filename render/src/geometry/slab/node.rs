//! One ray against the eight child boxes of a wide BVH node ([`crate::accel::bvh::wide`]): the
//! boxes side by side ([`Box8`]), the ray's constants ([`NodeRay`]) and the test written once
//! over the lanes ([`node`]), which [`super::slab8_on`] instantiates per tier.

use super::{interval, LaneSlab};
use crate::lanes::{splat3, Lanes, Mask};
use crate::real::Real;

/// Lanes of a [`Box8`].
pub const WIDTH: usize = 8;

/// The boxes of eight children, axis by axis (structure of arrays: one AVX register, or two
/// SSE registers, per row). An unused lane holds the empty box (min +∞, max −∞).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct Box8 {
    /// Minimum corner per axis, per lane.
    pub lo: [[f32; WIDTH]; 3],
    /// Maximum corner per axis, per lane.
    pub hi: [[f32; WIDTH]; 3],
}

impl Box8 {
    /// Eight empty lanes.
    pub const EMPTY: Box8 = Box8 {
        lo: [[f32::INFINITY; WIDTH]; 3],
        hi: [[f32::NEG_INFINITY; WIDTH]; 3],
    };

    /// Sets lane `i` to the box `min`..`max`.
    pub fn set(&mut self, i: usize, min: [f32; 3], max: [f32; 3]) {
        for a in 0..3 {
            self.lo[a][i] = min[a];
            self.hi[a][i] = max[a];
        }
    }

    /// Lane `i`'s box as corner arrays.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> ([f32; 3], [f32; 3]) {
        (
            [self.lo[0][i], self.lo[1][i], self.lo[2][i]],
            [self.hi[0][i], self.hi[1][i], self.hi[2][i]],
        )
    }

    /// The near and far rows of axis `a` for a ray with direction signs `neg`.
    #[inline(always)]
    fn rows(&self, neg: &[bool; 3], a: usize) -> (&[f32; WIDTH], &[f32; WIDTH]) {
        if neg[a] {
            (&self.hi[a], &self.lo[a])
        } else {
            (&self.lo[a], &self.hi[a])
        }
    }
}

/// The per-ray constants of the slab test.
#[derive(Clone, Copy, Debug)]
pub struct NodeRay<R> {
    /// Origin.
    pub o: [R; 3],
    /// Reciprocal direction.
    pub inv: [R; 3],
    /// Direction component negative (near plane is the box's maximum).
    pub neg: [bool; 3],
    /// Start of the accepted interval.
    pub t_min: R,
}

/// The eight boxes of `b` against `r` within `[r.t_min, t_max]`, `L::N` boxes per step: bit
/// `i` of the mask is set when box `i` is entered, and then `t[i]` is its entry distance
/// (what the scalar [`super::slab`] answers for box `i`).
#[inline(always)]
pub fn node<L: Lanes>(b: &Box8, r: &NodeRay<L::Elem>, t_max: L::Elem) -> (u32, [L::Elem; WIDTH]) {
    let (x, y, z) = (b.rows(&r.neg, 0), b.rows(&r.neg, 1), b.rows(&r.neg, 2));
    let (near_rows, far_rows) = ([x.0, y.0, z.0], [x.1, y.1, z.1]);
    let (o, inv) = (splat3::<L>(r.o), splat3::<L>(r.inv));
    let (t_min, t_max) = (L::splat(r.t_min), L::splat(t_max));
    let mut mask = 0;
    let mut out = [<L::Elem as Real>::ZERO; WIDTH];
    let mut h = 0;
    while h < WIDTH {
        let near = load3::<L>(&near_rows, h);
        let far = load3::<L>(&far_rows, h);
        let (m, t0) = interval(LaneSlab { o, inv, near, far }, t_min, t_max);
        mask |= m.bits() << h;
        t0.store(&mut out[h..]);
        h += L::N;
    }
    (mask, out)
}

/// Lanes `h..h + L::N` of three rows (no closures in kernels: they would be compiled without
/// the tier's instructions).
#[inline(always)]
fn load3<L: Lanes>(rows: &[&[f32; WIDTH]; 3], h: usize) -> [L; 3] {
    [
        L::from_f32s(&rows[0][h..]),
        L::from_f32s(&rows[1][h..]),
        L::from_f32s(&rows[2][h..]),
    ]
}
