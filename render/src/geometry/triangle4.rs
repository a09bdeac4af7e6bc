//! Four triangles against one ray at once: the watertight test of [`super::triangle`] with one
//! triangle per SIMD lane, for the primitives of a BVH leaf. Every lane does the scalar test's
//! IEEE operations in the same order (no FMA, no reassociation, `max` with the scalar NaN rule,
//! edge functions that come out exactly zero redone in `f64` lane by lane), so each lane's
//! answer — hit or not, `t`, `b1`, `b2` — is bit for bit the scalar [`intersect_triangle`]'s.
//!
//! [`intersect4`] picks the kernel of the process's tier ([`crate::isa`]): AVX (the same
//! instructions in their three-operand VEX form) on `avx2` and `avx512`, SSE2 on `sse2`, and the
//! portable lane-by-lane loop ([`intersect4_lanes`]) on `scalar`, on other targets and for `f64`.
//! [`TriLanes`] holds a leaf's triangles already gathered into lanes, so the rays of a packet
//! that enter the leaf share one gather ([`intersect4_gathered`]).

use super::ray::PreparedRay;
use super::triangle::intersect_triangle;
use crate::real::Real;
use crate::vec3::V3;

/// Triangles per call.
pub const LANES: usize = 4;

/// The answers of the four lanes: bit `i` of `mask` is set when lane `i` is hit; `t`, `b1` and
/// `b2` are valid for set bits only.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hits4<R> {
    /// Lanes hit.
    pub mask: u32,
    /// Distances.
    pub t: [R; LANES],
    /// Barycentrics of vertex 1.
    pub b1: [R; LANES],
    /// Barycentrics of vertex 2.
    pub b2: [R; LANES],
}

/// The triangles of the lanes (unused lanes repeat a used one; `used` says how many count).
pub type Tris4<'a, R> = [&'a [V3<R>; 3]; LANES];

/// Four triangles gathered into lanes: `v[vertex][axis][lane]` (the kernel's layout, so a ray
/// loads each component with one aligned load instead of gathering it from four triangles).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
pub struct TriLanes {
    /// Vertex components by vertex, axis and lane.
    pub v: [[[f32; LANES]; 3]; 3],
}

impl TriLanes {
    /// The lanes of `tris`.
    #[inline(always)]
    pub fn gather(tris: &Tris4<'_, f32>) -> Self {
        let mut v = [[[0.0; LANES]; 3]; 3];
        for (vertex, comps) in v.iter_mut().enumerate() {
            for (axis, lanes) in comps.iter_mut().enumerate() {
                for (lane, c) in lanes.iter_mut().enumerate() {
                    *c = tris[lane][vertex].to_array()[axis];
                }
            }
        }
        TriLanes { v }
    }

    /// Triangle `lane` as vertices.
    #[inline(always)]
    fn triangle(&self, lane: usize) -> [V3<f32>; 3] {
        let p = |k: usize| V3::new(self.v[k][0][lane], self.v[k][1][lane], self.v[k][2][lane]);
        [p(0), p(1), p(2)]
    }
}

/// The portable kernel: the scalar test lane by lane, in any precision.
#[inline(always)]
pub fn intersect4_lanes<R: Real>(
    pr: &PreparedRay<R>,
    tris: &Tris4<'_, R>,
    used: usize,
    t_max: R,
) -> Hits4<R> {
    let mut h = Hits4 {
        mask: 0,
        t: [R::ZERO; LANES],
        b1: [R::ZERO; LANES],
        b2: [R::ZERO; LANES],
    };
    for (i, p) in tris.iter().take(used).enumerate() {
        if let Some(hit) = intersect_triangle(pr, p[0], p[1], p[2], t_max) {
            h.mask |= 1 << i;
            h.t[i] = hit.t;
            h.b1[i] = hit.b1;
            h.b2[i] = hit.b2;
        }
    }
    h
}

/// The `f32` test of `used` (1..=4) triangles, with the kernel of the process's tier.
#[inline]
pub fn intersect4(
    pr: &PreparedRay<f32>,
    tris: &Tris4<'_, f32>,
    used: usize,
    t_max: f32,
) -> Hits4<f32> {
    #[cfg(target_arch = "x86_64")]
    {
        x86::dispatch(pr, tris, used, t_max)
    }
    #[cfg(not(target_arch = "x86_64"))]
    intersect4_lanes(pr, tris, used, t_max)
}

/// [`intersect4`] on triangles already gathered into lanes: the same answers bit for bit.
#[inline]
pub fn intersect4_gathered(
    pr: &PreparedRay<f32>,
    tris: &TriLanes,
    used: usize,
    t_max: f32,
) -> Hits4<f32> {
    #[cfg(target_arch = "x86_64")]
    {
        x86::dispatch(pr, tris, used, t_max)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let t = [0, 1, 2, 3].map(|i| tris.triangle(i));
        intersect4_lanes(pr, &[&t[0], &t[1], &t[2], &t[3]], used, t_max)
    }
}

#[cfg(target_arch = "x86_64")]
pub use x86::{avx, sse2};

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{Hits4, TriLanes, Tris4, LANES};
    use crate::geometry::ray::PreparedRay;
    use crate::geometry::sse4::{select, store};
    use crate::geometry::triangle::edges_f64;
    use crate::real::Real;
    use std::arch::x86_64::*;

    /// The SSE2 kernel (every x86-64 CPU has SSE2), on four triangles or lanes gathered
    /// once.
    #[inline(never)]
    pub fn sse2<S: Source>(pr: &PreparedRay<f32>, src: &S, used: usize, t_max: f32) -> Hits4<f32> {
        // SAFETY: SSE2 is part of the x86-64 baseline.
        unsafe { permuted(pr, src, used, t_max) }
    }

    /// The same kernel compiled for AVX (VEX encodings; no FMA: the scalar test has none).
    ///
    /// # Safety
    /// The CPU must support AVX.
    #[target_feature(enable = "avx")]
    #[inline(never)]
    pub unsafe fn avx<S: Source>(
        pr: &PreparedRay<f32>,
        src: &S,
        used: usize,
        t_max: f32,
    ) -> Hits4<f32> {
        permuted(pr, src, used, t_max)
    }

    /// The kernel of the process's tier ([`crate::isa`]).
    #[inline(always)]
    pub fn dispatch<S: Source>(
        pr: &PreparedRay<f32>,
        src: &S,
        used: usize,
        t_max: f32,
    ) -> Hits4<f32> {
        let tier = crate::isa::current();
        if tier.avx() {
            // SAFETY: the AVX tiers are only chosen on a CPU that has AVX.
            return unsafe { avx(pr, src, used, t_max) };
        }
        if tier.sse2() {
            return sse2(pr, src, used, t_max);
        }
        src.lanes(pr, used, t_max)
    }

    /// Where the kernel reads the triangles' components from: gathered from four triangles
    /// on the spot, or loaded from lanes gathered once.
    pub trait Source {
        /// Component `K` of vertex `V` of the four triangles, minus the ray origin's
        /// component.
        unsafe fn rel<const V: usize, const K: usize>(&self, o: f32) -> __m128;
        /// The portable kernel on the same triangles.
        fn lanes(&self, pr: &PreparedRay<f32>, used: usize, t_max: f32) -> Hits4<f32>;
    }

    impl Source for Tris4<'_, f32> {
        #[inline(always)]
        unsafe fn rel<const V: usize, const K: usize>(&self, o: f32) -> __m128 {
            let c = |i: usize| {
                let p = self[i][V];
                match K {
                    0 => p.x,
                    1 => p.y,
                    _ => p.z,
                }
            };
            _mm_sub_ps(_mm_setr_ps(c(0), c(1), c(2), c(3)), _mm_set1_ps(o))
        }

        fn lanes(&self, pr: &PreparedRay<f32>, used: usize, t_max: f32) -> Hits4<f32> {
            super::intersect4_lanes(pr, self, used, t_max)
        }
    }

    impl Source for TriLanes {
        #[inline(always)]
        unsafe fn rel<const V: usize, const K: usize>(&self, o: f32) -> __m128 {
            _mm_sub_ps(_mm_load_ps(self.v[V][K].as_ptr()), _mm_set1_ps(o))
        }

        fn lanes(&self, pr: &PreparedRay<f32>, used: usize, t_max: f32) -> Hits4<f32> {
            let t = [0, 1, 2, 3].map(|i| self.triangle(i));
            super::intersect4_lanes(pr, &[&t[0], &t[1], &t[2], &t[3]], used, t_max)
        }
    }

    /// Matches the ray's axis permutation once, like the scalar test, so the gathers use
    /// constant component indices.
    #[inline(always)]
    unsafe fn permuted<S: Source>(
        pr: &PreparedRay<f32>,
        tris: &S,
        used: usize,
        t_max: f32,
    ) -> Hits4<f32> {
        match (pr.kx, pr.ky, pr.kz) {
            (1, 2, 0) => kernel::<1, 2, 0, S>(pr, tris, used, t_max),
            (2, 1, 0) => kernel::<2, 1, 0, S>(pr, tris, used, t_max),
            (2, 0, 1) => kernel::<2, 0, 1, S>(pr, tris, used, t_max),
            (0, 2, 1) => kernel::<0, 2, 1, S>(pr, tris, used, t_max),
            (0, 1, 2) => kernel::<0, 1, 2, S>(pr, tris, used, t_max),
            (1, 0, 2) => kernel::<1, 0, 2, S>(pr, tris, used, t_max),
            // `PreparedRay::new` only makes the six permutations above.
            _ => tris.lanes(pr, used, t_max),
        }
    }

    /// `f32::max` lane by lane: the larger value, or the operand that is not NaN (`maxps`
    /// alone returns `b` whenever either is NaN).
    #[inline(always)]
    unsafe fn maxnum(a: __m128, b: __m128) -> __m128 {
        let m = _mm_max_ps(a, b);
        select(_mm_cmpunord_ps(b, b), a, m)
    }

    #[inline(always)]
    unsafe fn abs(a: __m128) -> __m128 {
        _mm_andnot_ps(_mm_set1_ps(-0.0), a)
    }

    /// The scalar test's arithmetic (see [`crate::geometry::triangle`]) in four lanes.
    #[inline(always)]
    unsafe fn kernel<const KX: usize, const KY: usize, const KZ: usize, S: Source>(
        pr: &PreparedRay<f32>,
        tris: &S,
        used: usize,
        t_max: f32,
    ) -> Hits4<f32> {
        let o = [pr.ray.o.x, pr.ray.o.y, pr.ray.o.z];
        let s = pr.shear;
        let zero = _mm_setzero_ps();
        let (sx, sy, sz) = (_mm_set1_ps(s.x), _mm_set1_ps(s.y), _mm_set1_ps(s.z));
        let az = tris.rel::<0, KZ>(o[KZ]);
        let bz = tris.rel::<1, KZ>(o[KZ]);
        let cz = tris.rel::<2, KZ>(o[KZ]);
        let ax = _mm_sub_ps(tris.rel::<0, KX>(o[KX]), _mm_mul_ps(sx, az));
        let ay = _mm_sub_ps(tris.rel::<0, KY>(o[KY]), _mm_mul_ps(sy, az));
        let bx = _mm_sub_ps(tris.rel::<1, KX>(o[KX]), _mm_mul_ps(sx, bz));
        let by = _mm_sub_ps(tris.rel::<1, KY>(o[KY]), _mm_mul_ps(sy, bz));
        let cx = _mm_sub_ps(tris.rel::<2, KX>(o[KX]), _mm_mul_ps(sx, cz));
        let cy = _mm_sub_ps(tris.rel::<2, KY>(o[KY]), _mm_mul_ps(sy, cz));
        let mut e0 = _mm_sub_ps(_mm_mul_ps(bx, cy), _mm_mul_ps(by, cx));
        let mut e1 = _mm_sub_ps(_mm_mul_ps(cx, ay), _mm_mul_ps(cy, ax));
        let mut e2 = _mm_sub_ps(_mm_mul_ps(ax, by), _mm_mul_ps(ay, bx));
        let used_mask = (1u32 << used) - 1;
        let on_edge = _mm_or_ps(
            _mm_or_ps(_mm_cmpeq_ps(e0, zero), _mm_cmpeq_ps(e1, zero)),
            _mm_cmpeq_ps(e2, zero),
        );
        let redo = _mm_movemask_ps(on_edge) as u32 & used_mask;
        if redo != 0 {
            // Exactly on an edge in f32: those lanes decide in double precision, as the
            // scalar test does.
            let (ax_, ay_, bx_, by_, cx_, cy_) = (
                store(ax),
                store(ay),
                store(bx),
                store(by),
                store(cx),
                store(cy),
            );
            let (mut f0, mut f1, mut f2) = (store(e0), store(e1), store(e2));
            for i in 0..LANES {
                if redo & (1 << i) != 0 {
                    let v = [ax_[i], ay_[i], bx_[i], by_[i], cx_[i], cy_[i]].map(f64::from);
                    let [g0, g1, g2] = edges_f64(v);
                    (f0[i], f1[i], f2[i]) = (g0 as f32, g1 as f32, g2 as f32);
                }
            }
            e0 = _mm_loadu_ps(f0.as_ptr());
            e1 = _mm_loadu_ps(f1.as_ptr());
            e2 = _mm_loadu_ps(f2.as_ptr());
        }
        // Mixed signs: outside.
        let any_neg = _mm_or_ps(
            _mm_or_ps(_mm_cmplt_ps(e0, zero), _mm_cmplt_ps(e1, zero)),
            _mm_cmplt_ps(e2, zero),
        );
        let any_pos = _mm_or_ps(
            _mm_or_ps(_mm_cmpgt_ps(e0, zero), _mm_cmpgt_ps(e1, zero)),
            _mm_cmpgt_ps(e2, zero),
        );
        let mut reject = _mm_and_ps(any_neg, any_pos);
        let det = _mm_add_ps(_mm_add_ps(e0, e1), e2);
        reject = _mm_or_ps(reject, _mm_cmpeq_ps(det, zero));
        let (saz, sbz, scz) = (_mm_mul_ps(sz, az), _mm_mul_ps(sz, bz), _mm_mul_ps(sz, cz));
        let t_scaled = _mm_add_ps(
            _mm_add_ps(_mm_mul_ps(e0, saz), _mm_mul_ps(e1, sbz)),
            _mm_mul_ps(e2, scz),
        );
        let g = |n: u32| _mm_set1_ps(<f32 as Real>::gamma(n));
        let reach = _mm_set1_ps(t_max * (1.0 + 2.0 * <f32 as Real>::gamma(3)));
        let reach_det = _mm_mul_ps(reach, det);
        let det_neg = _mm_cmplt_ps(det, zero);
        let out_neg = _mm_or_ps(
            _mm_cmpge_ps(t_scaled, zero),
            _mm_cmplt_ps(t_scaled, reach_det),
        );
        let out_pos = _mm_or_ps(
            _mm_cmple_ps(t_scaled, zero),
            _mm_cmpgt_ps(t_scaled, reach_det),
        );
        reject = _mm_or_ps(
            reject,
            _mm_or_ps(
                _mm_and_ps(det_neg, out_neg),
                _mm_andnot_ps(det_neg, out_pos),
            ),
        );
        if _mm_movemask_ps(reject) as u32 & used_mask == used_mask {
            // Most leaves are missed by the filters above: no division.
            return Hits4 {
                mask: 0,
                t: [0.0; LANES],
                b1: [0.0; LANES],
                b2: [0.0; LANES],
            };
        }
        let inv_det = _mm_div_ps(_mm_set1_ps(1.0), det);
        let t = _mm_mul_ps(t_scaled, inv_det);
        reject = _mm_or_ps(
            reject,
            _mm_or_ps(
                _mm_cmplt_ps(t, _mm_set1_ps(pr.ray.t_min)),
                _mm_cmpgt_ps(t, _mm_set1_ps(t_max)),
            ),
        );
        let b1 = _mm_mul_ps(e1, inv_det);
        let b2 = _mm_mul_ps(e2, inv_det);
        let max_zt = maxnum(maxnum(abs(saz), abs(sbz)), abs(scz));
        let delta_z = _mm_mul_ps(g(3), max_zt);
        let max_xt = maxnum(maxnum(abs(ax), abs(bx)), abs(cx));
        let max_yt = maxnum(maxnum(abs(ay), abs(by)), abs(cy));
        let delta_x = _mm_mul_ps(g(5), _mm_add_ps(max_xt, max_zt));
        let delta_y = _mm_mul_ps(g(5), _mm_add_ps(max_yt, max_zt));
        let delta_e = _mm_mul_ps(
            _mm_set1_ps(2.0),
            _mm_add_ps(
                _mm_add_ps(
                    _mm_mul_ps(_mm_mul_ps(g(2), max_xt), max_yt),
                    _mm_mul_ps(delta_y, max_xt),
                ),
                _mm_mul_ps(delta_x, max_yt),
            ),
        );
        let max_e = maxnum(maxnum(abs(e0), abs(e1)), abs(e2));
        let delta_t = _mm_mul_ps(
            _mm_mul_ps(
                _mm_set1_ps(3.0),
                _mm_add_ps(
                    _mm_add_ps(
                        _mm_mul_ps(_mm_mul_ps(g(3), max_e), max_zt),
                        _mm_mul_ps(delta_e, max_zt),
                    ),
                    _mm_mul_ps(delta_z, max_e),
                ),
            ),
            abs(inv_det),
        );
        reject = _mm_or_ps(reject, _mm_cmple_ps(t, delta_t));
        Hits4 {
            mask: !(_mm_movemask_ps(reject) as u32) & used_mask,
            t: store(t),
            b1: store(b1),
            b2: store(b2),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ray::Ray;
    use proptest::prelude::*;

    fn pr(o: [f32; 3], d: [f32; 3]) -> PreparedRay<f32> {
        PreparedRay::new(Ray {
            o: V3::from_array(o),
            d: V3::from_array(d).normalize(),
            t_min: 0.0,
            t_max: f32::INFINITY,
        })
    }

    /// Asserts that every kernel this CPU runs gives the portable kernel's answer bit for bit;
    /// returns the lanes hit.
    fn check(r: &PreparedRay<f32>, tris: &Tris4<'_, f32>, used: usize, t_max: f32) -> u32 {
        let want = intersect4_lanes(r, tris, used, t_max);
        let lanes = TriLanes::gather(tris);
        let mut kernels = vec![
            intersect4(r, tris, used, t_max),
            intersect4_gathered(r, &lanes, used, t_max),
        ];
        #[cfg(target_arch = "x86_64")]
        {
            kernels.push(sse2(r, tris, used, t_max));
            kernels.push(sse2(r, &lanes, used, t_max));
            if crate::isa::Isa::Avx2.supported() {
                // SAFETY: the CPU has AVX.
                kernels.push(unsafe { avx(r, tris, used, t_max) });
                // SAFETY: as above.
                kernels.push(unsafe { avx(r, &lanes, used, t_max) });
            }
        }
        for got in kernels {
            assert_eq!(got.mask, want.mask, "{r:?} used {used} t_max {t_max}");
            for i in 0..LANES {
                if want.mask & (1 << i) != 0 {
                    assert_eq!(got.t[i].to_bits(), want.t[i].to_bits());
                    assert_eq!(got.b1[i].to_bits(), want.b1[i].to_bits());
                    assert_eq!(got.b2[i].to_bits(), want.b2[i].to_bits());
                }
            }
        }
        want.mask
    }

    /// Hits, misses, a shared edge, a vertex, both sides, fewer than four used lanes and a
    /// range ending before or exactly at the hit.
    #[test]
    fn kernels_agree_on_edges_and_vertices() {
        let t0 = [
            V3::new(0.0f32, 0.0, 0.0),
            V3::new(1.0, 0.0, 0.0),
            V3::new(1.0, 1.0, 0.0),
        ];
        let t1 = [t0[0], t0[2], V3::new(0.0, 1.0, 0.0)];
        let t2 = [
            V3::new(5.0f32, 5.0, 1.0),
            V3::new(6.0, 5.0, 1.0),
            V3::new(5.0, 6.0, 1.0),
        ];
        let t3 = [
            V3::new(0.0f32, 0.0, -1.0),
            V3::new(2.0, 0.0, -1.0),
            V3::new(0.0, 2.0, -1.0),
        ];
        let tris: Tris4<'_, f32> = [&t0, &t1, &t2, &t3];
        let origins = [
            [0.5f32, 0.5, 2.0],
            [1.0, 1.0, 2.0],
            [0.0, 0.0, 2.0],
            [0.25, 0.75, 2.0],
            [5.2, 5.2, 3.0],
            [9.0, 9.0, 2.0],
            [0.5, 0.5, -2.0],
        ];
        let dirs = [
            [0.0f32, 0.0, -1.0],
            [0.0, 0.0, 1.0],
            [0.1, -0.2, -1.0],
            [0.0, -1.0, -0.001],
            [-1.0, 0.5, 0.25],
        ];
        let (mut hits, mut edge_hits) = (0, 0);
        for o in origins {
            for d in dirs {
                let r = pr(o, d);
                for used in 1..=LANES {
                    for t_max in [f32::INFINITY, 2.0, 1.0, 0.5] {
                        let m = check(&r, &tris, used, t_max);
                        hits += m.count_ones();
                        if (o[0] == o[1] || o[0] == 0.0) && m & 3 != 0 {
                            edge_hits += 1;
                        }
                    }
                }
            }
        }
        assert!(
            hits > 60 && edge_hits > 20,
            "{hits} hits, {edge_hits} on edges"
        );
    }

    fn coord() -> impl Strategy<Value = f32> {
        prop_oneof![
            4 => -4.0f32..4.0,
            1 => Just(0.0f32),
            1 => Just(1.0f32),
            1 => Just(-1.0f32),
            1 => -1.0e-3f32..1.0e-3,
            1 => -3.0e4f32..3.0e4,
        ]
    }

    fn v3() -> impl Strategy<Value = [f32; 3]> {
        proptest::array::uniform3(coord())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]
        /// Random triangles sharing vertices (so rays through a shared corner or edge come up),
        /// axis-parallel rays and rays aimed at a vertex: the kernels agree lane for lane.
        #[test]
        fn kernels_agree_on_random_triangles(
            verts in proptest::array::uniform6(v3()),
            pick in proptest::array::uniform12(0usize..6),
            o in v3(),
            d in v3(),
            aim in 0usize..7,
            used in 1usize..=4,
            t_max in prop_oneof![Just(f32::INFINITY), 0.0f32..50.0],
        ) {
            let vs = verts.map(V3::from_array);
            let tri = |i: usize| [vs[pick[3 * i]], vs[pick[3 * i + 1]], vs[pick[3 * i + 2]]];
            let (t0, t1, t2, t3) = (tri(0), tri(1), tri(2), tri(3));
            let o = V3::from_array(o);
            // Aim at a vertex for aim < 6, else the random direction.
            let d = if aim < 6 { vs[aim] - o } else { V3::from_array(d) };
            prop_assume!(d.length() > 0.0 && d.length().is_finite());
            let r = PreparedRay::new(Ray { o, d: d.normalize(), t_min: 0.0, t_max });
            check(&r, &[&t0, &t1, &t2, &t3], used, t_max);
        }
    }
}
