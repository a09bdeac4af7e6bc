//! One box against the sixteen rays of a packet: the leaf test of packet traversal
//! ([`crate::accel::bvh::packet`]). The rays side by side ([`LeafRays`]) share their direction
//! signs, so the near and far planes are the same for all of them; the test is written once
//! over the lanes ([`enter`]) and [`super::enter16`] instantiates it per tier.

use super::{interval, LaneSlab};
use crate::geometry::ray::PreparedRay;
use crate::lanes::{splat3, Lanes, Mask};
use crate::real::Real;

/// Rays in one packet.
pub const LANES: usize = 16;

/// The rays of a packet side by side (structure of arrays). Lanes past the packet's length
/// repeat its first ray.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub struct LeafRays<R> {
    /// Origins, per axis.
    pub o: [[R; LANES]; 3],
    /// Reciprocal directions, per axis.
    pub inv: [[R; LANES]; 3],
    /// Starts of the rays' intervals.
    pub t_min: [R; LANES],
    /// Direction sign per axis, shared by all rays.
    pub neg: [bool; 3],
}

impl<R: Real> LeafRays<R> {
    /// The lanes of `rays` (at least one, at most [`LANES`], all with direction signs `neg`).
    pub fn new(rays: &[PreparedRay<R>], neg: [bool; 3]) -> Self {
        let mut l = LeafRays {
            o: [[R::ZERO; LANES]; 3],
            inv: [[R::ZERO; LANES]; 3],
            t_min: [R::ZERO; LANES],
            neg,
        };
        for i in 0..LANES {
            let r = rays.get(i).unwrap_or(&rays[0]);
            for a in 0..3 {
                l.o[a][i] = r.ray.o.get(a);
                l.inv[a][i] = r.inv_d.get(a);
            }
            l.t_min[i] = r.ray.t_min;
        }
        l
    }
}

/// The box `lo`..`hi` against the rays of `l`, `L::N` rays per step: bit `i` is set when ray
/// `i` enters the box within `[t_min, reach[i]]` (what the scalar [`super::slab`] answers for
/// ray `i`).
#[inline(always)]
pub fn enter<L: Lanes>(
    l: &LeafRays<L::Elem>,
    lo: &[f32; 3],
    hi: &[f32; 3],
    reach: &[L::Elem; LANES],
) -> u32 {
    let mut near = [0.0f32; 3];
    let mut far = [0.0f32; 3];
    for a in 0..3 {
        (near[a], far[a]) = if l.neg[a] {
            (hi[a], lo[a])
        } else {
            (lo[a], hi[a])
        };
    }
    let near = splat3::<L>(near.map(<L::Elem as Real>::from_f32));
    let far = splat3::<L>(far.map(<L::Elem as Real>::from_f32));
    let mut mask = 0;
    let mut h = 0;
    while h < LANES {
        let o = load3::<L>(&l.o, h);
        let inv = load3::<L>(&l.inv, h);
        let t0 = L::load(&l.t_min[h..]);
        let t1 = L::load(&reach[h..]);
        mask |= interval(LaneSlab { o, inv, near, far }, t0, t1).0.bits() << h;
        h += L::N;
    }
    mask
}

/// Lanes `h..h + L::N` of three rows (no closures in kernels: they would be compiled without
/// the tier's instructions).
#[inline(always)]
fn load3<L: Lanes>(rows: &[[L::Elem; LANES]; 3], h: usize) -> [L; 3] {
    [
        L::load(&rows[0][h..]),
        L::load(&rows[1][h..]),
        L::load(&rows[2][h..]),
    ]
}
