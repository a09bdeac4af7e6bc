//! The watertight ray/triangle test (Woop, Benthin and Wald, JCGT 2013): the triangle is sheared
//! into the ray's frame so that edge functions are evaluated consistently on shared edges and no
//! ray slips between neighbours. Edge functions that come out exactly zero in `f32` are redone in
//! `f64`. A conservative bound on `t`'s error rejects self-intersections (after pbrt-v4).
//!
//! The test is written once, `watertight`, over the lane types of [`crate::lanes`]: the scalar
//! test here, and the SIMD kernels of [`super::leaf_triangles`] (one ray against four triangles) and
//! [`super::packet_prims`] (a packet's rays against one triangle) are its instances.

use super::ray::PreparedRay;
use crate::lanes::{Lanes, Mask};
use crate::real::Real;
use crate::vec3::V3;

/// A triangle hit: distance and barycentrics `(b0, b1, b2)` of the three vertices.
#[derive(Clone, Copy, Debug)]
pub struct TriHit<R> {
    /// Distance along the ray.
    pub t: R,
    /// Barycentric of vertex 1.
    pub b1: R,
    /// Barycentric of vertex 2.
    pub b2: R,
}

/// Intersects the triangle `(p0, p1, p2)` (either side) within `[t_min, t_max]`.
///
/// The ray's axis permutation is matched once so that each of the six cases runs with constant
/// component indices (selecting a vector component by a run-time index cost more than the rest
/// of the shear); the arithmetic is the same in every case.
#[inline(always)]
pub fn intersect_triangle<R: Real>(
    pr: &PreparedRay<R>,
    p0: V3<R>,
    p1: V3<R>,
    p2: V3<R>,
    t_max: R,
) -> Option<TriHit<R>> {
    match (pr.kx, pr.ky, pr.kz) {
        (1, 2, 0) => sheared(pr, p0, p1, p2, t_max, 1, 2, 0),
        (2, 1, 0) => sheared(pr, p0, p1, p2, t_max, 2, 1, 0),
        (2, 0, 1) => sheared(pr, p0, p1, p2, t_max, 2, 0, 1),
        (0, 2, 1) => sheared(pr, p0, p1, p2, t_max, 0, 2, 1),
        (0, 1, 2) => sheared(pr, p0, p1, p2, t_max, 0, 1, 2),
        (1, 0, 2) => sheared(pr, p0, p1, p2, t_max, 1, 0, 2),
        (kx, ky, kz) => sheared(pr, p0, p1, p2, t_max, kx, ky, kz),
    }
}

/// The three edge functions of the sheared vertices `[ax, ay, bx, by, cx, cy]` in double
/// precision: what the test decides with when one of them is exactly 0 in its own precision
/// (the SIMD kernels redo such lanes with this too).
#[inline(always)]
pub fn edges_f64([ax, ay, bx, by, cx, cy]: [f64; 6]) -> [f64; 3] {
    [bx * cy - by * cx, cx * ay - cy * ax, ax * by - ay * bx]
}

/// The test in the ray's frame given by the axes `kx`, `ky`, `kz` (inlined with constants): the
/// lane kernel `watertight` with one lane.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn sheared<R: Real>(
    pr: &PreparedRay<R>,
    p0: V3<R>,
    p1: V3<R>,
    p2: V3<R>,
    t_max: R,
    kx: usize,
    ky: usize,
    kz: usize,
) -> Option<TriHit<R>> {
    let o = pr.ray.o;
    let rel = |p: V3<R>| {
        let a = p - o;
        [a.get(kx), a.get(ky), a.get(kz)]
    };
    let s = pr.shear;
    let h = watertight(
        [rel(p0), rel(p1), rel(p2)],
        [s.x, s.y, s.z],
        pr.ray.t_min,
        t_max,
        1,
    )?;
    (h.mask != 0).then_some(TriHit {
        t: h.t,
        b1: h.b1,
        b2: h.b2,
    })
}

/// The answers of `watertight`: bit `i` of `mask` is set when lane `i` is hit; `t`, `b1` and
/// `b2` are computed in every lane and meaningful in the lanes hit.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LaneHits<L> {
    /// Lanes hit.
    pub mask: u32,
    /// Distances.
    pub t: L,
    /// Barycentrics of vertex 1.
    pub b1: L,
    /// Barycentrics of vertex 2.
    pub b2: L,
}

/// The watertight test, written once for every lane type ([`crate::lanes`]): the scalar test
/// is its one-lane instance, the SIMD kernels (one ray against four triangles, a packet's rays
/// against one triangle) its four-, eight- and sixteen-lane instances, so every lane does the
/// same IEEE operations in the same order and gives the same bits.
///
/// `v[vertex]` holds the vertex's components along the ray's permuted axes `kx`, `ky`, `kz`
/// minus the origin's, `s` the shear; the lanes of `live` (bits) count. `None` when every live
/// lane is rejected before the division (most tests of a leaf end there: outside an edge, or
/// out of range).
#[inline(always)]
pub(crate) fn watertight<L: Lanes>(
    v: [[L; 3]; 3],
    s: [L; 3],
    t_min: L,
    t_max: L,
    live: u32,
) -> Option<LaneHits<L>> {
    // No closures over lane operations here: a closure is compiled apart from the tier's entry,
    // without its instruction sets, and its lane operations would become calls.
    let zero = L::zero();
    let [sx, sy, sz] = s;
    let [[ax, ay, az], [bx, by, bz], [cx, cy, cz]] = v;
    let (ax, ay) = (ax - sx * az, ay - sy * az);
    let (bx, by) = (bx - sx * bz, by - sy * bz);
    let (cx, cy) = (cx - sx * cz, cy - sy * cz);
    let mut e = [bx * cy - by * cx, cx * ay - cy * ax, ax * by - ay * bx];
    let redo = (e[0].eq(zero) | e[1].eq(zero) | e[2].eq(zero)).bits() & live;
    if redo != 0 {
        // Exactly on an edge in this precision: those lanes decide in double precision.
        e = edges_redone(redo, [ax, ay, bx, by, cx, cy], e);
    }
    let [e0, e1, e2] = e;
    // Mixed signs: outside.
    let any_neg = e0.lt(zero) | e1.lt(zero) | e2.lt(zero);
    let any_pos = e0.gt(zero) | e1.gt(zero) | e2.gt(zero);
    let mut reject = any_neg & any_pos;
    if reject.bits() & live == live {
        return None;
    }
    let det = e0 + e1 + e2;
    reject = reject | det.eq(zero);
    let (saz, sbz, scz) = (sz * az, sz * bz, sz * cz);
    let t_scaled = e0 * saz + e1 * sbz + e2 * scz;
    // Range checks on the scaled distance avoid a division for most misses. They are only a
    // filter, widened so they never reject a hit whose computed `t` is ≤ `t_max`: the exact
    // check is on `t` itself, so `t_max` is inclusive of the very `t` this test returns (the
    // accelerators' tie rule re-tests primitives with `t_max` = the best `t` so far).
    let reach_det = t_max * L::splat(L::Elem::ONE + L::Elem::TWO * L::Elem::gamma(3)) * det;
    let det_neg = det.lt(zero);
    let out_neg = t_scaled.ge(zero) | t_scaled.lt(reach_det);
    let out_pos = t_scaled.le(zero) | t_scaled.gt(reach_det);
    reject = reject | ((det_neg & out_neg) | det_neg.andnot(out_pos));
    if reject.bits() & live == live {
        return None;
    }
    let inv_det = L::splat(L::Elem::ONE) / det;
    let t = t_scaled * inv_det;
    reject = reject | (t.lt(t_min) | t.gt(t_max));
    let b1 = e1 * inv_det;
    let b2 = e2 * inv_det;
    // Conservative bound on t's rounding error: reject hits indistinguishable from t = 0.
    let max_zt = max3(saz, sbz, scz);
    let delta_z = gamma::<L>(3) * max_zt;
    let max_xt = max3(ax, bx, cx);
    let max_yt = max3(ay, by, cy);
    let delta_x = gamma::<L>(5) * (max_xt + max_zt);
    let delta_y = gamma::<L>(5) * (max_yt + max_zt);
    let delta_e = L::splat(L::Elem::TWO)
        * (gamma::<L>(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    // The bound is in terms of the edge functions themselves (scale length²), not the
    // barycentrics: using b (scale-free) made it wrong by the square of the scene's scale.
    let max_e = max3(e0, e1, e2);
    let delta_t = L::splat(L::Elem::from_u32(3))
        * (gamma::<L>(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e)
        * inv_det.abs();
    reject = reject | t.le(delta_t);
    Some(LaneHits {
        mask: !reject.bits() & live,
        t,
        b1,
        b2,
    })
}

/// γ(n) in every lane.
#[inline(always)]
fn gamma<L: Lanes>(n: u32) -> L {
    L::splat(L::Elem::gamma(n))
}

/// The largest of the three lanes' magnitudes, lane by lane ([`Lanes::maxnum`]'s NaN rule).
#[inline(always)]
fn max3<L: Lanes>(a: L, b: L, c: L) -> L {
    a.abs().maxnum(b.abs()).maxnum(c.abs())
}

/// The edge functions `e` with the lanes of `redo` recomputed by [`edges_f64`] from the sheared
/// vertices `[ax, ay, bx, by, cx, cy]`.
#[inline(always)]
fn edges_redone<L: Lanes>(redo: u32, v: [L; 6], e: [L; 3]) -> [L; 3] {
    const MAX: usize = 16;
    let mut vs = [[L::Elem::ZERO; MAX]; 6];
    let mut es = [[L::Elem::ZERO; MAX]; 3];
    for (lanes, x) in vs.iter_mut().zip(v) {
        x.store(lanes);
    }
    for (lanes, x) in es.iter_mut().zip(e) {
        x.store(lanes);
    }
    for i in 0..L::N {
        if redo & (1 << i) != 0 {
            let g = edges_f64(vs.map(|lanes| lanes[i].to_f64()));
            for (lanes, g) in es.iter_mut().zip(g) {
                lanes[i] = L::Elem::from_f64(g);
            }
        }
    }
    [L::load(&es[0]), L::load(&es[1]), L::load(&es[2])]
}

/// The hit point from barycentrics, and its absolute error bound (pbrt's γ₇ bound).
#[inline]
pub fn triangle_point<R: Real>(p: [V3<R>; 3], b1: R, b2: R) -> (V3<R>, V3<R>) {
    let b0 = R::ONE - b1 - b2;
    let (q0, q1, q2) = (p[0] * b0, p[1] * b1, p[2] * b2);
    let point = q0 + q1 + q2;
    let err = (q0.abs() + q1.abs() + q2.abs()) * R::gamma(7);
    (point, err)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ray::Ray;

    #[test]
    fn hits_inside_misses_outside() {
        let (a, b, c) = (
            V3::new(0.0, 0.0, 0.0),
            V3::new(1.0, 0.0, 0.0),
            V3::new(0.0, 1.0, 0.0),
        );
        let h = intersect_triangle(
            &PreparedRay::unbounded([0.2, 0.2, 1.0], [0.0, 0.0, -1.0]),
            a,
            b,
            c,
            f32::INFINITY,
        )
        .expect("hit");
        assert!((h.t - 1.0).abs() < 1e-6);
        assert!((h.b1 - 0.2).abs() < 1e-6 && (h.b2 - 0.2).abs() < 1e-6);
        assert!(intersect_triangle(
            &PreparedRay::unbounded([0.8, 0.8, 1.0], [0.0, 0.0, -1.0]),
            a,
            b,
            c,
            f32::INFINITY
        )
        .is_none());
        // Both sides.
        assert!(intersect_triangle(
            &PreparedRay::unbounded([0.2, 0.2, -1.0], [0.0, 0.0, 1.0]),
            a,
            b,
            c,
            f32::INFINITY
        )
        .is_some());
        // Behind the origin.
        assert!(intersect_triangle(
            &PreparedRay::unbounded([0.2, 0.2, -1.0], [0.0, 0.0, -1.0]),
            a,
            b,
            c,
            f32::INFINITY
        )
        .is_none());
    }

    #[test]
    fn tiny_triangle_far_from_its_size_is_hit_in_f32() {
        // Regression (hard case "scene scaled by 2^-10"): the t error bound used barycentrics
        // where the edge functions belong, so small-scale triangles were rejected as
        // self-intersections. Scaling by a power of two must not change the answer.
        for scale in [1.0f32, 1.0 / 1024.0, 1.0 / 65536.0, 1024.0] {
            let (a, b, c) = (
                V3::new(0.625f32, 0.0, 0.782486) * scale,
                V3::new(0.75, 0.0, 0.908892) * scale,
                V3::new(0.75, 0.125, 0.644322) * scale,
            );
            let o = V3::new(-1.6f32, 1.6, 1.7) * scale;
            let target = (a + b + c) * (1.0 / 3.0);
            let r = PreparedRay::new(Ray {
                o,
                d: (target - o).normalize(),
                t_min: 0.0,
                t_max: f32::INFINITY,
            });
            let h = intersect_triangle(&r, a, b, c, f32::INFINITY).expect("hit");
            assert!(((h.t - (target - o).length()) / (target - o).length()).abs() < 1e-5);
        }
    }

    #[test]
    fn shared_edge_is_watertight() {
        // Two triangles sharing the diagonal of the unit square; rays exactly on the diagonal.
        let p = [
            V3::new(0.0f32, 0.0, 0.0),
            V3::new(1.0, 0.0, 0.0),
            V3::new(1.0, 1.0, 0.0),
            V3::new(0.0, 1.0, 0.0),
        ];
        for i in 1..100 {
            let s = i as f32 / 100.0;
            let r = PreparedRay::unbounded([s, s, 1.0], [0.0, 0.0, -1.0]);
            let h1 = intersect_triangle(&r, p[0], p[1], p[2], f32::INFINITY).is_some();
            let h2 = intersect_triangle(&r, p[0], p[2], p[3], f32::INFINITY).is_some();
            assert!(h1 || h2, "ray at {s} leaked");
        }
    }
}
