//! Open truncated cones and cylinders (no caps). The quadratic is solved in a frame moved to the
//! ray's closest approach to the cone's centre, so distant rays keep their precision; hit points
//! are re-projected onto the surface. Rays whose line passes the axis well outside the largest
//! radius are turned away first, without a division or a square root.
//!
//! The lateral surface test is written once, `lateral_hits`, over the lane types of
//! [`crate::lanes`]: the scalar test here and the SIMD kernels of [`lanes`] (four cones against
//! one ray, one cone against four rays) and of [`crate::geometry::packet_prims`] (one cone
//! against a packet's rays) are its instances.

pub mod lanes;

use super::ray::Ray;
use crate::lanes::{dot3 as dot, splat3, Lanes, Mask};
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

    /// True when the ray's line passes the cone's axis line farther than the cone's largest
    /// radius and a margin: then it misses the lateral surface, and the full test
    /// ([`Cone::solve`]) says so too, so this only saves work and never changes a result. No
    /// division and no square root.
    ///
    /// The margin covers the full test's own roundings, which grow with the cone's length and
    /// the coordinates' magnitude (a 27 000-long cylinder of radius 0.01 "hits" rays in `f32`
    /// that pass it at several radii): 1/16 of the radius, a square root of γ₂₅₆ of the
    /// length (a grazing root's error) and γ₂₅₆ of the coordinates, the last two times
    /// 1 + |slope| (how far a root's error moves the radius). Steep cones (|slope| > 16, flat
    /// as discs) always take the full test.
    #[inline(always)]
    fn misses_far(&self, ray: &Ray<R>) -> bool {
        let k = self.slope.abs();
        if !(k <= R::from_f64(16.0)) {
            return false;
        }
        let sum = |v: V3<R>| v.x.abs() + v.y.abs() + v.z.abs();
        let n = ray.d.cross(self.axis);
        let g = self.base - ray.o;
        let coords = sum(g) + sum(ray.o) + sum(self.base);
        // |g·n| / |n| is the lines' distance; the bound of this product's rounding taken off.
        let s = g.dot(n).abs() - R::gamma(64) * coords * sum(ray.d);
        let rmax = self.r0.max(self.radius_at(self.height));
        let slack = (R::ONE + k)
            * (R::gamma(256).sqrt() * (self.height + rmax)
                + R::gamma(256) * (coords + self.height));
        let reach = rmax * R::from_f64(1.0625) + slack;
        s > R::ZERO && s * s > reach * reach * n.length_squared()
    }

    /// The nearest `t` in `[t_min, t_max]` where the ray meets the lateral surface.
    #[inline]
    pub fn intersect(&self, ray: &Ray<R>, t_max: R) -> Option<R> {
        if self.misses_far(ray) {
            return None;
        }
        self.solve(ray, t_max)
    }

    /// The full test behind [`Cone::intersect`]: the lane kernel [`lateral_hits`] with one lane.
    #[inline(always)]
    fn solve(&self, ray: &Ray<R>, t_max: R) -> Option<R> {
        let (hit, t) = lateral_hits(&self.lanes(), &ConeRays::of(ray, t_max));
        hit.then_some(t)
    }

    /// The cone in one lane.
    #[inline(always)]
    pub(crate) fn lanes(&self) -> ConeLanes<R> {
        ConeLanes {
            base: self.base.to_array(),
            axis: self.axis.to_array(),
            height: self.height,
            r0: self.r0,
            slope: self.slope,
        }
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

/// A cone's fields in lanes: one cone per lane, or one cone in all.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ConeLanes<L> {
    /// Centre of the base circle, by axis.
    pub base: [L; 3],
    /// Unit axis, by axis.
    pub axis: [L; 3],
    /// Distance from base to apex.
    pub height: L,
    /// Base radius.
    pub r0: L,
    /// Radius change per unit height.
    pub slope: L,
}

impl<L: Lanes> ConeLanes<L> {
    /// One cone (`one`) in every lane.
    #[inline(always)]
    pub(crate) fn splat(one: &ConeLanes<L::Elem>) -> Self {
        ConeLanes {
            base: splat3(one.base),
            axis: splat3(one.axis),
            height: L::splat(one.height),
            r0: L::splat(one.r0),
            slope: L::splat(one.slope),
        }
    }
}

/// A ray's fields and `t` range in lanes: one ray per lane, or one ray in all.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ConeRays<L> {
    /// Origin, by axis.
    pub o: [L; 3],
    /// Direction, by axis.
    pub d: [L; 3],
    /// Nearest `t` that counts.
    pub t_min: L,
    /// Farthest `t` that counts.
    pub t_max: L,
}

impl<R: Real> ConeRays<R> {
    /// `ray` within `t_max` in one lane.
    #[inline(always)]
    pub(crate) fn of(ray: &Ray<R>, t_max: R) -> Self {
        ConeRays {
            o: ray.o.to_array(),
            d: ray.d.to_array(),
            t_min: ray.t_min,
            t_max,
        }
    }
}

/// `u − v · s` by axis.
#[inline(always)]
fn sub_scaled<L: Lanes>(u: [L; 3], v: [L; 3], s: L) -> [L; 3] {
    [u[0] - v[0] * s, u[1] - v[1] * s, u[2] - v[2] * s]
}

/// Whether a root `tl` (in the moved frame) is taken: its `t` in range (not `t < t_min`, not
/// `t > t_max`, not `t <= 0`: a NaN `t` passes here and fails the height test) and its point
/// within the height on a non-negative radius. The answer and the root's `t`.
#[inline(always)]
fn accept<L: Lanes>(
    c: &ConeLanes<L>,
    r: &ConeRays<L>,
    wz: L,
    dz: L,
    shift: L,
    tl: L,
) -> (L::Mask, L) {
    let zero = L::zero();
    let t = tl + shift;
    let t_out = t.lt(r.t_min) | t.gt(r.t_max) | t.le(zero);
    let z = wz + dz * tl;
    let z_ok = z.ge(zero) & z.le(c.height) & (c.r0 + c.slope * z).ge(zero);
    (t_out.andnot(z_ok), t)
}

/// The cone's lateral surface test, written once for every lane type ([`crate::lanes`]): the
/// scalar [`Cone::intersect`] (past its far-miss filter) is its one-lane instance, the SIMD
/// kernels of [`lanes`] its four-lane instances, the packet kernel of
/// [`crate::geometry::packet_prims`] its eight- and sixteen-lane ones. The quadratic is solved in a frame moved to
/// the ray's closest approach to the cone's middle; each early answer of the scalar reasoning
/// (a ray parallel to a generator, a negative discriminant, `q == 0`, the roots in order, the
/// `t` and height ranges) is a lane mask. The lanes hit, and their `t` (meaningful in the lanes
/// hit).
#[inline(always)]
pub(crate) fn lateral_hits<L: Lanes>(c: &ConeLanes<L>, r: &ConeRays<L>) -> (L::Mask, L) {
    // No closures over lane operations here: a closure is compiled apart from the tier's entry,
    // without its instruction sets, and its lane operations would become calls.
    let zero = L::zero();
    let (a, d, k) = (c.axis, r.d, c.slope);
    // Move the origin along the ray to its closest approach to the cone's middle.
    let hh = c.height * L::splat(<L::Elem as Real>::HALF);
    let mid = [
        c.base[0] + a[0] * hh,
        c.base[1] + a[1] * hh,
        c.base[2] + a[2] * hh,
    ];
    let dd = dot(d, d);
    let to_mid = [mid[0] - r.o[0], mid[1] - r.o[1], mid[2] - r.o[2]];
    let shift = dot(to_mid, d) / dd;
    let w = [
        r.o[0] + d[0] * shift - c.base[0],
        r.o[1] + d[1] * shift - c.base[1],
        r.o[2] + d[2] * shift - c.base[2],
    ];
    let wz = dot(w, a);
    let dz = dot(d, a);
    let wp = sub_scaled(w, a, wz);
    let dp = sub_scaled(d, a, dz);
    let rw = c.r0 + k * wz;
    let dp2 = dot(dp, dp);
    let kkdd = k * k * dz * dz;
    let qa = dp2 - kkdd;
    let qb = dot(wp, dp) - k * rw * dz; // half b
    let qc = dot(wp, wp) - rw * rw;
    // A ray parallel to a generator line: one root of the linear equation, t = −qc / (2 qb),
    // missed when qb == 0.
    let gamma8 = L::splat(<L::Elem as Real>::gamma(8));
    let parallel = qa.abs().le(gamma8 * (dp2 + kkdd));
    let t_lin = qc.neg() / (L::splat(<L::Elem as Real>::TWO) * qb);
    let miss_lin = qb.eq(zero);
    // Otherwise the two roots, missed when disc < 0 or q == 0.
    let disc = qb * qb - qa * qc;
    let root = disc.sqrt();
    let q = (qb + root.copysign(qb)).neg();
    let miss_quad = disc.lt(zero) | q.eq(zero);
    let (x, y) = (q / qa, qc / q);
    let x_first = x.lt(y);
    let (t0, t1) = (L::select(x_first, x, y), L::select(x_first, y, x));
    let t0 = L::select(parallel, t_lin, t0);
    let t1 = L::select(parallel, t_lin, t1);
    let miss = (parallel & miss_lin) | parallel.andnot(miss_quad);
    // The first root (in order) whose t is in range and whose point is within the height.
    let (ok0, ta) = accept(c, r, wz, dz, shift, t0);
    let (ok1, tb) = accept(c, r, wz, dz, shift, t1);
    (miss.andnot(ok0 | ok1), L::select(ok0, ta, tb))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cylinder_hits_and_misses_beyond_ends() {
        let c = Cone::new(V3::new(0.0, 0.0, 0.0), 1.0, V3::new(0.0, 0.0, 2.0), 1.0).unwrap();
        assert_eq!(
            c.intersect(
                &Ray::unbounded([-5.0, 0.0, 1.0], [1.0, 0.0, 0.0]),
                f64::INFINITY
            ),
            Some(4.0)
        );
        assert_eq!(
            c.intersect(
                &Ray::unbounded([-5.0, 0.0, 2.5], [1.0, 0.0, 0.0]),
                f64::INFINITY
            ),
            None
        );
        // Open: a ray down the axis passes through.
        assert_eq!(
            c.intersect(
                &Ray::unbounded([0.0, 0.0, -5.0], [0.0, 0.0, 1.0]),
                f64::INFINITY
            ),
            None
        );
    }

    #[test]
    fn true_cone_with_zero_apex() {
        let c = Cone::new(V3::new(0.0, 0.0, 0.0), 1.0, V3::new(0.0, 0.0, 1.0), 0.0).unwrap();
        let t = c
            .intersect(
                &Ray::unbounded([-5.0, 0.0, 0.5], [1.0, 0.0, 0.0]),
                f64::INFINITY,
            )
            .unwrap();
        assert!((t - 4.5).abs() < 1e-12);
        let (p, _, n) = c.surface(&Ray::unbounded([-5.0, 0.0, 0.5], [1.0, 0.0, 0.0]), t);
        assert!((p.x + 0.5).abs() < 1e-12);
        assert!(n.x < 0.0 && n.z > 0.0);
    }

    /// Rays aimed at points near the surface, just inside and just outside it, from near and
    /// far, at cylinders and cones small and large, in f32 and f64: the quick miss test never
    /// turns away a ray the full test hits (it only saves work), and it does turn misses away
    /// (over a thousand of each precision's 20 000 rays; most of the other misses pass the
    /// axis within the radius beyond an end, or meet a long cone's wide margin).
    #[test]
    fn the_quick_miss_test_never_changes_a_result() {
        use rand::{Rng, SeedableRng};
        fn v(rng: &mut rand::rngs::StdRng, s: f64) -> V3<f64> {
            V3::new(
                rng.gen_range(-s..s),
                rng.gen_range(-s..s),
                rng.gen_range(-s..s),
            )
        }
        fn check<R: Real>(rng: &mut rand::rngs::StdRng) -> (u32, u32, u32) {
            let (mut hits, mut quick, mut misses) = (0, 0, 0);
            for _ in 0..20_000 {
                let scale = 10f64.powi(rng.gen_range(-2..4));
                let (far, long) = (rng.gen_range(0..3), rng.gen_range(0..4));
                let base = v(rng, 50.0 * scale * 10f64.powi(far));
                let apex = base + v(rng, scale * 10f64.powi(long));
                let r0 = scale * rng.gen_range(0.01..0.5);
                let r1 = match rng.gen_range(0..3) {
                    0 => r0,
                    1 => 0.0,
                    _ => scale * rng.gen_range(0.0..0.5),
                };
                let Some(c64) = Cone::new(base, r0, apex, r1) else {
                    continue;
                };
                // A point on a circle of the cone at a radius just off its own.
                let z = c64.height * rng.gen_range(-0.1..1.1);
                let rim = c64.r0 + c64.slope * z.clamp(0.0, c64.height);
                let helper = if c64.axis.x.abs() < 0.5 {
                    V3::new(1.0, 0.0, 0.0)
                } else {
                    V3::new(0.0, 1.0, 0.0)
                };
                let u = c64.axis.cross(helper).normalize();
                let w = c64.axis.cross(u);
                let phi = rng.gen_range(0.0..std::f64::consts::TAU);
                let off = rim * rng.gen_range(0.9..2.0);
                let target = base + c64.axis * z + u * (off * phi.cos()) + w * (off * phi.sin());
                let away = scale * 10f64.powi(rng.gen_range(0..4));
                let o = if rng.gen_bool(0.5) {
                    target + v(rng, away)
                } else {
                    // Across the axis, so the line's closest approach to it is at the target.
                    let across =
                        u * -phi.sin() + w * phi.cos() + c64.axis * rng.gen_range(-2.0..2.0);
                    target - across.normalize() * away
                };
                let Some(c) = Cone::new(
                    V3::from_f64(base),
                    R::from_f64(r0),
                    V3::from_f64(apex),
                    R::from_f64(r1),
                ) else {
                    continue;
                };
                let ray = Ray {
                    o: V3::from_f64(o),
                    d: V3::from_f64((target - o).normalize()),
                    t_min: R::ZERO,
                    t_max: R::from_f64(f64::INFINITY),
                };
                let full = c.solve(&ray, ray.t_max);
                assert_eq!(
                    c.intersect(&ray, ray.t_max).map(|t| t.to_f64()),
                    full.map(|t| t.to_f64()),
                    "{c:?} {ray:?}"
                );
                if full.is_some() {
                    hits += 1;
                } else if c.misses_far(&ray) {
                    quick += 1;
                } else {
                    misses += 1;
                }
            }
            (hits, quick, misses)
        }
        let mut rng = rand::rngs::StdRng::seed_from_u64(18);
        for (hits, quick, misses) in [check::<f32>(&mut rng), check::<f64>(&mut rng)] {
            assert!(
                hits > 4000 && quick > 1000,
                "{hits} hits, {quick} quick, {misses}"
            );
        }
    }

    /// rings-7's cylinders (radius 0.074, length 1.1, about 3 units from the origin) seen from
    /// 20 units away: rays passing at 1.2 radii go no further than the quick test in `f32`,
    /// rays at 0.99 radii hit.
    #[test]
    fn rays_passing_a_cylinder_by_a_fifth_of_its_radius_take_the_quick_test() {
        let c = Cone::new(
            V3::new(0.93f32, 2.61, 0.0),
            0.074,
            V3::new(0.29, 1.73, 0.0),
            0.074,
        )
        .unwrap();
        let side = c.axis.cross(V3::new(0.0, 0.0, 1.0)).normalize();
        for i in 0..100 {
            let z = c.height * (i as f32 + 0.5) / 100.0;
            let on_axis = c.base + c.axis * z;
            for (off, quick) in [(1.2f32, true), (0.99, false)] {
                let o = on_axis + V3::new(0.0, 0.0, off * 0.074) + side * 20.0;
                let ray = Ray {
                    o,
                    d: -side,
                    t_min: 0.0,
                    t_max: f32::INFINITY,
                };
                assert_eq!(c.misses_far(&ray), quick, "{z} {off}");
                assert_eq!(
                    c.intersect(&ray, f32::INFINITY).is_some(),
                    !quick,
                    "{z} {off}"
                );
            }
        }
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
