//! Four triangles against one ray at once: the watertight test of [`super::triangle`] with one
//! triangle per SIMD lane, for the primitives of a BVH leaf. Every lane does the scalar test's
//! IEEE operations in the same order (no FMA, no reassociation, `max` with the scalar NaN rule,
//! edge functions that come out exactly zero redone in `f64` lane by lane), so each lane's
//! answer — hit or not, `t`, `b1`, `b2` — is bit for bit the scalar [`intersect_triangle`]'s.
//!
//! The arithmetic is the one watertight test, `watertight`, on four lanes. [`super::four_lanes::intersect4`]
//! runs it with the code of the process's tier ([`crate::isa::dispatch`]): four SSE2 lanes on
//! `sse2`, the same in their three-operand VEX form on `avx2` and `avx512`, and the portable
//! lane-by-lane loop ([`intersect4_lanes`]) on `scalar`, on other targets and for `f64`.
//! [`LeafTriangles`] holds a leaf's triangles already gathered into lanes, so the rays of a packet
//! that enter the leaf share one gather ([`super::four_lanes::intersect4`] on [`LeafTriangles`]).

use super::four_lanes::{FourLanes, FourOnRay};
use super::ray::PreparedRay;
use super::triangle::{intersect_triangle, watertight};
use crate::lanes::Lanes;
use crate::real::Real;
use crate::vec3::V3;

/// Triangles per call.
pub const LANES: usize = 4;

/// The answers of the four lanes: bit `i` of `mask` is set when lane `i` is hit; `t`, `b1` and
/// `b2` are valid for set bits only.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHits<R> {
    /// Lanes hit.
    pub mask: u32,
    /// Distances.
    pub t: [R; LANES],
    /// Barycentrics of vertex 1.
    pub b1: [R; LANES],
    /// Barycentrics of vertex 2.
    pub b2: [R; LANES],
}

#[cfg(test)]
impl crate::geometry::four_lanes::HitBits for TriangleHits<f32> {
    fn hit_bits(&self) -> Vec<(usize, Vec<u32>)> {
        crate::geometry::four_lanes::lanes_bits(self.mask, &[&self.t, &self.b1, &self.b2])
    }
}

/// The triangles of the lanes (unused lanes repeat a used one; `used` says how many count).
pub type Tris4<'a, R> = [&'a [V3<R>; 3]; LANES];

/// Four triangles gathered into lanes: `v[vertex][axis][lane]` (the kernel's layout, so a ray
/// loads each component with one aligned load instead of gathering it from four triangles).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
pub struct LeafTriangles {
    /// Vertex components by vertex, axis and lane.
    pub v: [[[f32; LANES]; 3]; 3],
}

impl LeafTriangles {
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
        LeafTriangles { v }
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
) -> TriangleHits<R> {
    let mut h = TriangleHits {
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

impl<S: Source> FourLanes for FourOnRay<'_, PreparedRay<f32>, S> {
    type Output = TriangleHits<f32>;

    /// Matches the ray's axis permutation once, like the scalar test, so the gathers use
    /// constant component indices.
    #[inline(always)]
    fn lanes<L: Lanes<Elem = f32>>(self) -> TriangleHits<f32> {
        let (pr, tris, used, t_max) = (self.ray, self.src, self.used, self.t_max);
        match (pr.kx, pr.ky, pr.kz) {
            (1, 2, 0) => kernel::<L, 1, 2, 0, S>(pr, tris, used, t_max),
            (2, 1, 0) => kernel::<L, 2, 1, 0, S>(pr, tris, used, t_max),
            (2, 0, 1) => kernel::<L, 2, 0, 1, S>(pr, tris, used, t_max),
            (0, 2, 1) => kernel::<L, 0, 2, 1, S>(pr, tris, used, t_max),
            (0, 1, 2) => kernel::<L, 0, 1, 2, S>(pr, tris, used, t_max),
            (1, 0, 2) => kernel::<L, 1, 0, 2, S>(pr, tris, used, t_max),
            // `PreparedRay::new` only makes the six permutations above.
            _ => tris.lanes(pr, used, t_max),
        }
    }

    fn portable(self) -> TriangleHits<f32> {
        self.src.lanes(self.ray, self.used, self.t_max)
    }
}

/// Where the kernel reads the triangles' components from: gathered from four triangles on the
/// spot, or loaded from lanes gathered once.
pub trait Source {
    /// Component `K` of vertex `V` of the four triangles, minus the ray origin's component.
    fn rel<L: Lanes<Elem = f32>, const V: usize, const K: usize>(&self, o: f32) -> L;
    /// The portable kernel on the same triangles.
    fn lanes(&self, pr: &PreparedRay<f32>, used: usize, t_max: f32) -> TriangleHits<f32>;
}

impl Source for Tris4<'_, f32> {
    #[inline(always)]
    fn rel<L: Lanes<Elem = f32>, const V: usize, const K: usize>(&self, o: f32) -> L {
        let c = self.map(|t| t[V].get(K));
        L::load(&c) - L::splat(o)
    }

    fn lanes(&self, pr: &PreparedRay<f32>, used: usize, t_max: f32) -> TriangleHits<f32> {
        intersect4_lanes(pr, self, used, t_max)
    }
}

impl Source for LeafTriangles {
    #[inline(always)]
    fn rel<L: Lanes<Elem = f32>, const V: usize, const K: usize>(&self, o: f32) -> L {
        // SAFETY: the rows of `LeafTriangles` are four `f32` at a multiple of 16 bytes
        // (`align(16)`, rows of 16 bytes).
        unsafe { L::load_aligned(&self.v[V][K]) - L::splat(o) }
    }

    fn lanes(&self, pr: &PreparedRay<f32>, used: usize, t_max: f32) -> TriangleHits<f32> {
        let t = [0, 1, 2, 3].map(|i| self.triangle(i));
        intersect4_lanes(pr, &[&t[0], &t[1], &t[2], &t[3]], used, t_max)
    }
}

/// The watertight test (`watertight`) with a triangle per lane.
#[inline(always)]
fn kernel<L: Lanes<Elem = f32>, const KX: usize, const KY: usize, const KZ: usize, S: Source>(
    pr: &PreparedRay<f32>,
    tris: &S,
    used: usize,
    t_max: f32,
) -> TriangleHits<f32> {
    let o = pr.ray.o.to_array();
    let s = pr.shear;
    let v = [
        [
            tris.rel::<L, 0, KX>(o[KX]),
            tris.rel::<L, 0, KY>(o[KY]),
            tris.rel::<L, 0, KZ>(o[KZ]),
        ],
        [
            tris.rel::<L, 1, KX>(o[KX]),
            tris.rel::<L, 1, KY>(o[KY]),
            tris.rel::<L, 1, KZ>(o[KZ]),
        ],
        [
            tris.rel::<L, 2, KX>(o[KX]),
            tris.rel::<L, 2, KY>(o[KY]),
            tris.rel::<L, 2, KZ>(o[KZ]),
        ],
    ];
    let s = [L::splat(s.x), L::splat(s.y), L::splat(s.z)];
    let live = (1u32 << used) - 1;
    let mut out = TriangleHits {
        mask: 0,
        t: [0.0; LANES],
        b1: [0.0; LANES],
        b2: [0.0; LANES],
    };
    // Most leaves are missed before the division: all lanes zero then.
    if let Some(h) = watertight(v, s, L::splat(pr.ray.t_min), L::splat(t_max), live) {
        out.mask = h.mask;
        h.t.store(&mut out.t);
        h.b1.store(&mut out.b1);
        h.b2.store(&mut out.b2);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::four_lanes::{assert_agree, every_tier};
    use crate::geometry::ray::Ray;
    use crate::geometry::test_coords::point;
    use proptest::prelude::*;

    /// Asserts that every kernel this CPU runs gives the portable kernel's answer bit for bit;
    /// returns the lanes hit.
    fn check(r: &PreparedRay<f32>, tris: &Tris4<'_, f32>, used: usize, t_max: f32) -> u32 {
        let want = intersect4_lanes(r, tris, used, t_max);
        let lanes = LeafTriangles::gather(tris);
        let mut kernels = every_tier(FourOnRay::new(r, tris, used, t_max));
        kernels.extend(every_tier(FourOnRay::new(r, &lanes, used, t_max)));
        assert_agree(&want, &kernels, &format!("{r:?} used {used} t_max {t_max}"));
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
                let r = PreparedRay::unbounded(o, d);
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

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]
        /// Random triangles sharing vertices (so rays through a shared corner or edge come up),
        /// axis-parallel rays and rays aimed at a vertex: the kernels agree lane for lane.
        #[test]
        fn kernels_agree_on_random_triangles(
            verts in proptest::array::uniform6(point()),
            pick in proptest::array::uniform12(0usize..6),
            o in point(),
            d in point(),
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
