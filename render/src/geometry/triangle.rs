//! The watertight ray/triangle test (Woop, Benthin and Wald, JCGT 2013): the triangle is sheared
//! into the ray's frame so that edge functions are evaluated consistently on shared edges and no
//! ray slips between neighbours. Edge functions that come out exactly zero in `f32` are redone in
//! `f64`. A conservative bound on `t`'s error rejects self-intersections (after pbrt-v4).

use super::ray::PreparedRay;
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

/// The test in the ray's frame given by the axes `kx`, `ky`, `kz` (inlined with constants).
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
    let s = pr.shear;
    let a = p0 - o;
    let b = p1 - o;
    let c = p2 - o;
    let (az, bz, cz) = (a.get(kz), b.get(kz), c.get(kz));
    let ax = a.get(kx) - s.x * az;
    let ay = a.get(ky) - s.y * az;
    let bx = b.get(kx) - s.x * bz;
    let by = b.get(ky) - s.y * bz;
    let cx = c.get(kx) - s.x * cz;
    let cy = c.get(ky) - s.y * cz;
    let mut e0 = bx * cy - by * cx;
    let mut e1 = cx * ay - cy * ax;
    let mut e2 = ax * by - ay * bx;
    if e0 == R::ZERO || e1 == R::ZERO || e2 == R::ZERO {
        // Exactly on an edge in this precision: decide in double precision.
        let [f0, f1, f2] = edges_f64([ax, ay, bx, by, cx, cy].map(R::to_f64));
        (e0, e1, e2) = (R::from_f64(f0), R::from_f64(f1), R::from_f64(f2));
    }
    if (e0 < R::ZERO || e1 < R::ZERO || e2 < R::ZERO)
        && (e0 > R::ZERO || e1 > R::ZERO || e2 > R::ZERO)
    {
        return None;
    }
    let det = e0 + e1 + e2;
    if det == R::ZERO {
        return None;
    }
    let (saz, sbz, scz) = (s.z * az, s.z * bz, s.z * cz);
    let t_scaled = e0 * saz + e1 * sbz + e2 * scz;
    // Range checks on the scaled distance avoid a division for most misses. They are only a
    // filter, widened so they never reject a hit whose computed `t` is ≤ `t_max`: the exact
    // check is on `t` itself, so `t_max` is inclusive of the very `t` this test returns (the
    // accelerators' tie rule re-tests primitives with `t_max` = the best `t` so far).
    let reach = t_max * (R::ONE + R::TWO * R::gamma(3));
    if det < R::ZERO {
        if t_scaled >= R::ZERO || t_scaled < reach * det {
            return None;
        }
    } else if t_scaled <= R::ZERO || t_scaled > reach * det {
        return None;
    }
    let inv_det = R::ONE / det;
    let t = t_scaled * inv_det;
    if t < pr.ray.t_min || t > t_max {
        return None;
    }
    let b1 = e1 * inv_det;
    let b2 = e2 * inv_det;
    // Conservative bound on t's rounding error: reject hits indistinguishable from t = 0.
    let max_zt = saz.abs().max(sbz.abs()).max(scz.abs());
    let delta_z = R::gamma(3) * max_zt;
    let max_xt = ax.abs().max(bx.abs()).max(cx.abs());
    let max_yt = ay.abs().max(by.abs()).max(cy.abs());
    let delta_x = R::gamma(5) * (max_xt + max_zt);
    let delta_y = R::gamma(5) * (max_yt + max_zt);
    let delta_e = R::TWO * (R::gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    // The bound is in terms of the edge functions themselves (scale length²), not the
    // barycentrics: using b (scale-free) made it wrong by the square of the scene's scale.
    let max_e = e0.abs().max(e1.abs()).max(e2.abs());
    let delta_t = R::from_u32(3)
        * (R::gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e)
        * inv_det.abs();
    if t <= delta_t {
        return None;
    }
    Some(TriHit { t, b1, b2 })
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

    fn pr(o: [f32; 3], d: [f32; 3]) -> PreparedRay<f32> {
        PreparedRay::new(Ray {
            o: V3::from_array(o),
            d: V3::from_array(d).normalize(),
            t_min: 0.0,
            t_max: f32::INFINITY,
        })
    }

    #[test]
    fn hits_inside_misses_outside() {
        let (a, b, c) = (
            V3::new(0.0, 0.0, 0.0),
            V3::new(1.0, 0.0, 0.0),
            V3::new(0.0, 1.0, 0.0),
        );
        let h = intersect_triangle(
            &pr([0.2, 0.2, 1.0], [0.0, 0.0, -1.0]),
            a,
            b,
            c,
            f32::INFINITY,
        )
        .expect("hit");
        assert!((h.t - 1.0).abs() < 1e-6);
        assert!((h.b1 - 0.2).abs() < 1e-6 && (h.b2 - 0.2).abs() < 1e-6);
        assert!(intersect_triangle(
            &pr([0.8, 0.8, 1.0], [0.0, 0.0, -1.0]),
            a,
            b,
            c,
            f32::INFINITY
        )
        .is_none());
        // Both sides.
        assert!(intersect_triangle(
            &pr([0.2, 0.2, -1.0], [0.0, 0.0, 1.0]),
            a,
            b,
            c,
            f32::INFINITY
        )
        .is_some());
        // Behind the origin.
        assert!(intersect_triangle(
            &pr([0.2, 0.2, -1.0], [0.0, 0.0, -1.0]),
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
            let r = pr([s, s, 1.0], [0.0, 0.0, -1.0]);
            let h1 = intersect_triangle(&r, p[0], p[1], p[2], f32::INFINITY).is_some();
            let h2 = intersect_triangle(&r, p[0], p[2], p[3], f32::INFINITY).is_some();
            assert!(h1 || h2, "ray at {s} leaked");
        }
    }
}
