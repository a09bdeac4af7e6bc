//! One triangle or sphere against up to sixteen rays at once, a ray per AVX-512 lane: the
//! transposed form of [`super::triangle4`] and [`super::sphere4`], for a packet's rays that
//! enter a BVH leaf. Every lane does the scalar test's IEEE operations in the same order (no
//! FMA, no reassociation, `f32::max`'s NaN rule, edge functions that come out exactly zero
//! redone in `f64` lane by lane), so each lane's answer is bit for bit what
//! [`super::triangle::intersect_triangle`] or [`super::sphere::Sphere::intersect`] gives that
//! ray. The rays' axis permutations may differ: each lane picks its vertex components with
//! masks. [`Rays16::new`] is `None` where the CPU has no AVX-512F; the portable kernels
//! ([`triangle16_lanes`], [`sphere16_lanes`]) define the answers and serve the tests.

use super::ray::PreparedRay;
use super::sphere::Sphere;
use super::triangle::intersect_triangle;
use crate::vec3::V3;

/// Rays per call.
pub const LANES: usize = 16;

/// A packet's rays in lanes (lane `i` is ray `i`; lanes past the packet repeat ray 0).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct Rays16 {
    /// Origin components by axis.
    o: [[f32; LANES]; 3],
    /// Direction components by axis.
    d: [[f32; LANES]; 3],
    /// Origin components along each ray's permuted axes `kx`, `ky`, `kz`.
    ok: [[f32; LANES]; 3],
    /// Shear constants.
    s: [[f32; LANES]; 3],
    t_min: [f32; LANES],
    /// `|d|²` as the scalar sphere test computes it.
    a: [f32; LANES],
    /// Per permuted axis (`kx`, `ky`, `kz`): lanes where it is axis 0, and where it is axis 1.
    k0: [u16; 3],
    k1: [u16; 3],
    /// The address and length of the rays these lanes were made from.
    src: usize,
    n: usize,
}

/// The answers of the sixteen lanes: bit `i` of `mask` is set when ray `i` hits; `t`, `b1`,
/// `b2` are valid for set bits (`b1`, `b2` are zero for spheres).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct Hits16 {
    /// Rays hit.
    pub mask: u32,
    /// Distances.
    pub t: [f32; LANES],
    /// Barycentrics of vertex 1.
    pub b1: [f32; LANES],
    /// Barycentrics of vertex 2.
    pub b2: [f32; LANES],
}

impl Hits16 {
    fn none() -> Self {
        Hits16 {
            mask: 0,
            t: [0.0; LANES],
            b1: [0.0; LANES],
            b2: [0.0; LANES],
        }
    }
}

impl Rays16 {
    /// The lanes of `rays` (1..=16), or `None` when there are too many or this CPU has no
    /// AVX-512F.
    #[inline]
    pub fn new(rays: &[PreparedRay<f32>]) -> Option<Self> {
        if rays.is_empty() || rays.len() > LANES || !available() {
            return None;
        }
        Some(Self::lanes(rays))
    }

    /// The lanes of `rays` whatever the CPU (for the portable kernels).
    pub fn lanes(rays: &[PreparedRay<f32>]) -> Self {
        let mut l = Rays16 {
            o: [[0.0; LANES]; 3],
            d: [[0.0; LANES]; 3],
            ok: [[0.0; LANES]; 3],
            s: [[0.0; LANES]; 3],
            t_min: [0.0; LANES],
            a: [0.0; LANES],
            k0: [0; 3],
            k1: [0; 3],
            src: rays.as_ptr() as usize,
            n: rays.len(),
        };
        for i in 0..LANES {
            let pr = rays.get(i).unwrap_or(&rays[0]);
            let (o, d) = (pr.ray.o.to_array(), pr.ray.d.to_array());
            let s = pr.shear.to_array();
            let k = [pr.kx, pr.ky, pr.kz];
            for a in 0..3 {
                l.o[a][i] = o[a];
                l.d[a][i] = d[a];
                l.ok[a][i] = o[k[a]];
                l.s[a][i] = s[a];
                l.k0[a] |= u16::from(k[a] == 0) << i;
                l.k1[a] |= u16::from(k[a] == 1) << i;
            }
            l.t_min[i] = pr.ray.t_min;
            l.a[i] = pr.ray.d.length_squared();
        }
        l
    }

    /// Whether these lanes were made from `rays` (the same slice).
    #[inline(always)]
    pub fn made_from(&self, rays: &[PreparedRay<f32>]) -> bool {
        self.src == rays.as_ptr() as usize && self.n == rays.len()
    }
}

/// Whether this CPU runs the AVX-512 kernels.
#[inline(always)]
pub fn available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx512f")
    }
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// The triangle `tri` against the rays of `active` (bits of lanes), ray `i` within `t_max[i]`.
#[inline]
pub fn triangle16(
    rays: &Rays16,
    src: &[PreparedRay<f32>],
    tri: &[V3<f32>; 3],
    active: u32,
    t_max: &[f32; LANES],
) -> Hits16 {
    #[cfg(target_arch = "x86_64")]
    if available() {
        // SAFETY: the CPU has AVX-512F (checked just above).
        return unsafe { x86::triangle16(rays, tri, active, t_max) };
    }
    triangle16_lanes(src, tri, active, t_max)
}

/// The sphere `s` against the rays of `active`, ray `i` within `t_max[i]`.
#[inline]
pub fn sphere16(
    rays: &Rays16,
    src: &[PreparedRay<f32>],
    s: &Sphere<f32>,
    active: u32,
    t_max: &[f32; LANES],
) -> Hits16 {
    #[cfg(target_arch = "x86_64")]
    if available() {
        // SAFETY: the CPU has AVX-512F (checked just above).
        return unsafe { x86::sphere16(rays, s, active, t_max) };
    }
    sphere16_lanes(src, s, active, t_max)
}

/// The portable triangle kernel: the scalar test ray by ray.
pub fn triangle16_lanes(
    src: &[PreparedRay<f32>],
    tri: &[V3<f32>; 3],
    active: u32,
    t_max: &[f32; LANES],
) -> Hits16 {
    let mut h = Hits16::none();
    for (i, pr) in src.iter().enumerate().take(LANES) {
        if active & (1 << i) != 0 {
            if let Some(hit) = intersect_triangle(pr, tri[0], tri[1], tri[2], t_max[i]) {
                h.mask |= 1 << i;
                h.t[i] = hit.t;
                h.b1[i] = hit.b1;
                h.b2[i] = hit.b2;
            }
        }
    }
    h
}

/// The portable sphere kernel: the scalar test ray by ray.
pub fn sphere16_lanes(
    src: &[PreparedRay<f32>],
    s: &Sphere<f32>,
    active: u32,
    t_max: &[f32; LANES],
) -> Hits16 {
    let mut h = Hits16::none();
    for (i, pr) in src.iter().enumerate().take(LANES) {
        if active & (1 << i) != 0 {
            if let Some(t) = s.intersect(&pr.ray, t_max[i]) {
                h.mask |= 1 << i;
                h.t[i] = t;
            }
        }
    }
    h
}

#[cfg(target_arch = "x86_64")]
pub use x86::{sphere16 as sphere16_avx512, triangle16 as triangle16_avx512};

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{Hits16, Rays16, LANES};
    use crate::geometry::sphere::Sphere;
    use crate::real::Real;
    use crate::vec3::V3;
    use std::arch::x86_64::*;

    #[target_feature(enable = "avx512f")]
    #[inline]
    unsafe fn load(a: &[f32; LANES]) -> __m512 {
        _mm512_loadu_ps(a.as_ptr())
    }

    #[target_feature(enable = "avx512f")]
    #[inline]
    unsafe fn store(a: __m512) -> [f32; LANES] {
        let mut out = [0.0f32; LANES];
        _mm512_storeu_ps(out.as_mut_ptr(), a);
        out
    }

    /// `f32::max` lane by lane (`vmaxps` returns `b` whenever either is NaN, as `maxps`).
    #[target_feature(enable = "avx512f")]
    #[inline]
    unsafe fn maxnum(a: __m512, b: __m512) -> __m512 {
        let m = _mm512_max_ps(a, b);
        _mm512_mask_blend_ps(_mm512_cmp_ps_mask::<_CMP_UNORD_Q>(b, b), m, a)
    }

    /// Component `k` (the permuted axis `kx`, `ky` or `kz`) of `p` in each lane.
    #[target_feature(enable = "avx512f")]
    #[inline]
    unsafe fn pick(r: &Rays16, k: usize, p: V3<f32>) -> __m512 {
        let yz = _mm512_mask_blend_ps(r.k1[k], _mm512_set1_ps(p.z), _mm512_set1_ps(p.y));
        _mm512_mask_blend_ps(r.k0[k], yz, _mm512_set1_ps(p.x))
    }

    /// The watertight triangle test ([`crate::geometry::triangle`]) with a ray per lane.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    #[inline(never)]
    pub unsafe fn triangle16(
        r: &Rays16,
        tri: &[V3<f32>; 3],
        active: u32,
        t_max: &[f32; LANES],
    ) -> Hits16 {
        let live = active as __mmask16;
        let zero = _mm512_setzero_ps();
        let (okx, oky, okz) = (load(&r.ok[0]), load(&r.ok[1]), load(&r.ok[2]));
        let (sx, sy, sz) = (load(&r.s[0]), load(&r.s[1]), load(&r.s[2]));
        let az = _mm512_sub_ps(pick(r, 2, tri[0]), okz);
        let bz = _mm512_sub_ps(pick(r, 2, tri[1]), okz);
        let cz = _mm512_sub_ps(pick(r, 2, tri[2]), okz);
        let rel = |v: V3<f32>, k: usize, o: __m512| _mm512_sub_ps(pick(r, k, v), o);
        let ax = _mm512_sub_ps(rel(tri[0], 0, okx), _mm512_mul_ps(sx, az));
        let ay = _mm512_sub_ps(rel(tri[0], 1, oky), _mm512_mul_ps(sy, az));
        let bx = _mm512_sub_ps(rel(tri[1], 0, okx), _mm512_mul_ps(sx, bz));
        let by = _mm512_sub_ps(rel(tri[1], 1, oky), _mm512_mul_ps(sy, bz));
        let cx = _mm512_sub_ps(rel(tri[2], 0, okx), _mm512_mul_ps(sx, cz));
        let cy = _mm512_sub_ps(rel(tri[2], 1, oky), _mm512_mul_ps(sy, cz));
        let mut e0 = _mm512_sub_ps(_mm512_mul_ps(bx, cy), _mm512_mul_ps(by, cx));
        let mut e1 = _mm512_sub_ps(_mm512_mul_ps(cx, ay), _mm512_mul_ps(cy, ax));
        let mut e2 = _mm512_sub_ps(_mm512_mul_ps(ax, by), _mm512_mul_ps(ay, bx));
        let eq0 = |e| _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(e, zero);
        let redo = (eq0(e0) | eq0(e1) | eq0(e2)) & live;
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
                    let (ax, ay, bx, by, cx, cy) = (
                        f64::from(ax_[i]),
                        f64::from(ay_[i]),
                        f64::from(bx_[i]),
                        f64::from(by_[i]),
                        f64::from(cx_[i]),
                        f64::from(cy_[i]),
                    );
                    f0[i] = (bx * cy - by * cx) as f32;
                    f1[i] = (cx * ay - cy * ax) as f32;
                    f2[i] = (ax * by - ay * bx) as f32;
                }
            }
            e0 = load(&f0);
            e1 = load(&f1);
            e2 = load(&f2);
        }
        let lt0 = |e| _mm512_cmp_ps_mask::<_CMP_LT_OS>(e, zero);
        let gt0 = |e| _mm512_cmp_ps_mask::<_CMP_GT_OS>(e, zero);
        // Mixed signs: outside.
        let mut reject = (lt0(e0) | lt0(e1) | lt0(e2)) & (gt0(e0) | gt0(e1) | gt0(e2));
        let det = _mm512_add_ps(_mm512_add_ps(e0, e1), e2);
        reject |= eq0(det);
        let (saz, sbz, scz) = (
            _mm512_mul_ps(sz, az),
            _mm512_mul_ps(sz, bz),
            _mm512_mul_ps(sz, cz),
        );
        let t_scaled = _mm512_add_ps(
            _mm512_add_ps(_mm512_mul_ps(e0, saz), _mm512_mul_ps(e1, sbz)),
            _mm512_mul_ps(e2, scz),
        );
        let g = |n: u32| _mm512_set1_ps(<f32 as Real>::gamma(n));
        let t_max = load(t_max);
        let reach = _mm512_mul_ps(t_max, _mm512_set1_ps(1.0 + 2.0 * <f32 as Real>::gamma(3)));
        let reach_det = _mm512_mul_ps(reach, det);
        let det_neg = lt0(det);
        let out_neg = _mm512_cmp_ps_mask::<_CMP_GE_OS>(t_scaled, zero)
            | _mm512_cmp_ps_mask::<_CMP_LT_OS>(t_scaled, reach_det);
        let out_pos = _mm512_cmp_ps_mask::<_CMP_LE_OS>(t_scaled, zero)
            | _mm512_cmp_ps_mask::<_CMP_GT_OS>(t_scaled, reach_det);
        reject |= (det_neg & out_neg) | (!det_neg & out_pos);
        if reject & live == live {
            return Hits16::none();
        }
        let inv_det = _mm512_div_ps(_mm512_set1_ps(1.0), det);
        let t = _mm512_mul_ps(t_scaled, inv_det);
        reject |= _mm512_cmp_ps_mask::<_CMP_LT_OS>(t, load(&r.t_min))
            | _mm512_cmp_ps_mask::<_CMP_GT_OS>(t, t_max);
        let b1 = _mm512_mul_ps(e1, inv_det);
        let b2 = _mm512_mul_ps(e2, inv_det);
        let abs = |a| _mm512_abs_ps(a);
        let max_zt = maxnum(maxnum(abs(saz), abs(sbz)), abs(scz));
        let delta_z = _mm512_mul_ps(g(3), max_zt);
        let max_xt = maxnum(maxnum(abs(ax), abs(bx)), abs(cx));
        let max_yt = maxnum(maxnum(abs(ay), abs(by)), abs(cy));
        let delta_x = _mm512_mul_ps(g(5), _mm512_add_ps(max_xt, max_zt));
        let delta_y = _mm512_mul_ps(g(5), _mm512_add_ps(max_yt, max_zt));
        let delta_e = _mm512_mul_ps(
            _mm512_set1_ps(2.0),
            _mm512_add_ps(
                _mm512_add_ps(
                    _mm512_mul_ps(_mm512_mul_ps(g(2), max_xt), max_yt),
                    _mm512_mul_ps(delta_y, max_xt),
                ),
                _mm512_mul_ps(delta_x, max_yt),
            ),
        );
        let max_e = maxnum(maxnum(abs(e0), abs(e1)), abs(e2));
        let delta_t = _mm512_mul_ps(
            _mm512_mul_ps(
                _mm512_set1_ps(3.0),
                _mm512_add_ps(
                    _mm512_add_ps(
                        _mm512_mul_ps(_mm512_mul_ps(g(3), max_e), max_zt),
                        _mm512_mul_ps(delta_e, max_zt),
                    ),
                    _mm512_mul_ps(delta_z, max_e),
                ),
            ),
            abs(inv_det),
        );
        reject |= _mm512_cmp_ps_mask::<_CMP_LE_OS>(t, delta_t);
        Hits16 {
            mask: u32::from(!reject & live),
            t: store(t),
            b1: store(b1),
            b2: store(b2),
        }
    }

    /// The sphere test ([`Sphere::intersect`]) with a ray per lane.
    ///
    /// # Safety
    /// The CPU must support AVX-512F.
    #[target_feature(enable = "avx512f")]
    #[inline(never)]
    pub unsafe fn sphere16(
        r: &Rays16,
        s: &Sphere<f32>,
        active: u32,
        t_max: &[f32; LANES],
    ) -> Hits16 {
        let live = active as __mmask16;
        let zero = _mm512_setzero_ps();
        let (dx, dy, dz) = (load(&r.d[0]), load(&r.d[1]), load(&r.d[2]));
        let fx = _mm512_sub_ps(load(&r.o[0]), _mm512_set1_ps(s.center.x));
        let fy = _mm512_sub_ps(load(&r.o[1]), _mm512_set1_ps(s.center.y));
        let fz = _mm512_sub_ps(load(&r.o[2]), _mm512_set1_ps(s.center.z));
        let dot = |ax, ay, az, bx, by, bz| {
            _mm512_add_ps(
                _mm512_add_ps(_mm512_mul_ps(ax, bx), _mm512_mul_ps(ay, by)),
                _mm512_mul_ps(az, bz),
            )
        };
        let b = dot(fx, fy, fz, dx, dy, dz);
        let r2 = _mm512_set1_ps(s.radius * s.radius);
        let c = _mm512_sub_ps(dot(fx, fy, fz, fx, fy, fz), r2);
        let gt0 = |v| _mm512_cmp_ps_mask::<_CMP_GT_OS>(v, zero);
        // Outside and heading away.
        let mut reject = gt0(c) & gt0(b);
        if reject & live == live {
            return Hits16::none();
        }
        let a = load(&r.a);
        let ba = _mm512_div_ps(b, a);
        let vx = _mm512_sub_ps(fx, _mm512_mul_ps(dx, ba));
        let vy = _mm512_sub_ps(fy, _mm512_mul_ps(dy, ba));
        let vz = _mm512_sub_ps(fz, _mm512_mul_ps(dz, ba));
        let disc = _mm512_mul_ps(a, _mm512_sub_ps(r2, dot(vx, vy, vz, vx, vy, vz)));
        reject |= _mm512_cmp_ps_mask::<_CMP_LT_OS>(disc, zero);
        let root = _mm512_sqrt_ps(disc);
        // q = −(b + root.copysign(b)), by bits (AVX-512F has no float bitwise operations).
        let sign = _mm512_set1_epi32(i32::MIN);
        let bits = |v| _mm512_castps_si512(v);
        let signed_root = _mm512_castsi512_ps(_mm512_or_si512(
            _mm512_andnot_si512(sign, bits(root)),
            _mm512_and_si512(sign, bits(b)),
        ));
        let q = _mm512_castsi512_ps(_mm512_xor_si512(bits(_mm512_add_ps(b, signed_root)), sign));
        let q_zero = _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(q, zero);
        let t0 = _mm512_mask_blend_ps(q_zero, _mm512_div_ps(q, a), zero);
        let t1 = _mm512_mask_blend_ps(q_zero, _mm512_div_ps(c, q), zero);
        let swap = _mm512_cmp_ps_mask::<_CMP_GT_OS>(t0, t1);
        let (t0, t1) = (
            _mm512_mask_blend_ps(swap, t0, t1),
            _mm512_mask_blend_ps(swap, t1, t0),
        );
        let (t_min, t_max) = (load(&r.t_min), load(t_max));
        let ok = |t| {
            _mm512_cmp_ps_mask::<_CMP_GE_OS>(t, t_min)
                & _mm512_cmp_ps_mask::<_CMP_LE_OS>(t, t_max)
                & gt0(t)
        };
        let (ok0, ok1) = (ok(t0), ok(t1));
        let t = _mm512_mask_blend_ps(ok0, t1, t0);
        Hits16 {
            mask: u32::from(!reject & (ok0 | ok1) & live),
            t: store(t),
            b1: [0.0; LANES],
            b2: [0.0; LANES],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ray::Ray;
    use proptest::prelude::*;

    /// Asserts that the AVX-512 kernels (where this CPU runs them) give the portable kernels'
    /// answers bit for bit; returns the rays hit.
    fn check(
        rays: &[PreparedRay<f32>],
        tri: &[V3<f32>; 3],
        active: u32,
        t_max: &[f32; LANES],
    ) -> u32 {
        let lanes = Rays16::lanes(rays);
        let want = triangle16_lanes(rays, tri, active, t_max);
        let s = Sphere {
            center: tri[0],
            radius: (tri[1] - tri[0]).length().max(1e-3),
        };
        let want_s = sphere16_lanes(rays, &s, active, t_max);
        let got = triangle16(&lanes, rays, tri, active, t_max);
        let got_s = sphere16(&lanes, rays, &s, active, t_max);
        for (got, want) in [(got, want), (got_s, want_s)] {
            assert_eq!(got.mask, want.mask, "{rays:?} {tri:?} {active:#x}");
            for i in 0..LANES {
                if want.mask & (1 << i) != 0 {
                    assert_eq!(got.t[i].to_bits(), want.t[i].to_bits());
                    assert_eq!(got.b1[i].to_bits(), want.b1[i].to_bits());
                    assert_eq!(got.b2[i].to_bits(), want.b2[i].to_bits());
                }
            }
        }
        want.mask | want_s.mask
    }

    /// Rays through a unit triangle's vertices, edges and inside from all sides, with every
    /// axis permutation in one packet, partial masks and bounds before and at the hit.
    #[test]
    fn kernels_agree_on_edges_vertices_and_mixed_axes() {
        let tri = [
            V3::new(0.0f32, 0.0, 0.0),
            V3::new(1.0, 0.0, 0.0),
            V3::new(0.0, 1.0, 0.0),
        ];
        let targets = [
            [0.0f32, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.5, 0.5, 0.0],
            [0.5, 0.0, 0.0],
            [0.0, 0.25, 0.0],
            [0.25, 0.25, 0.0],
            [2.0, 2.0, 0.0],
        ];
        let offsets = [
            [0.0f32, 0.0, 2.0],
            [0.0, 0.0, -2.0],
            [3.0, 0.5, 1.0],
            [0.5, -3.0, 1.0],
            [-1.0, 1.0, 0.5],
        ];
        let mut rays = Vec::new();
        for t in targets {
            for o in offsets {
                let t = V3::from_array(t);
                let o = t + V3::from_array(o);
                rays.push(PreparedRay::new(Ray {
                    o,
                    d: (t - o).normalize(),
                    t_min: 0.0,
                    t_max: f32::INFINITY,
                }));
            }
        }
        let mut hits = 0;
        for packet in rays.chunks(LANES) {
            for active in [u32::MAX, 0x5555, 0xaaaa, 1, 0x8000] {
                let active = active & ((1u32 << packet.len()) - 1);
                for bound in [f32::INFINITY, 2.5, 2.0, 0.5] {
                    hits += check(packet, &tri, active, &[bound; LANES]).count_ones();
                }
            }
        }
        assert!(hits > 100, "{hits}");
    }

    fn coord() -> impl Strategy<Value = f32> {
        prop_oneof![
            4 => -4.0f32..4.0,
            1 => Just(0.0f32),
            1 => Just(1.0f32),
            1 => -1.0e-3f32..1.0e-3,
            1 => -3.0e4f32..3.0e4,
        ]
    }

    fn v3() -> impl Strategy<Value = [f32; 3]> {
        proptest::array::uniform3(coord())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        /// Random triangles and spheres against sixteen random rays (each with its own origin,
        /// direction, axis permutation and bound; some aimed at a vertex).
        #[test]
        fn kernels_agree_on_random_rays(
            verts in proptest::array::uniform3(v3()),
            origins in proptest::collection::vec(v3(), LANES),
            dirs in proptest::collection::vec(v3(), LANES),
            aims in proptest::collection::vec(0usize..5, LANES),
            bounds in proptest::collection::vec(prop_oneof![Just(f32::INFINITY), 0.0f32..50.0], LANES),
            n in 1usize..=LANES,
            active in any::<u32>(),
        ) {
            let tri = verts.map(V3::from_array);
            let mut rays = Vec::new();
            for i in 0..n {
                let o = V3::from_array(origins[i]);
                let d = if aims[i] < 3 { tri[aims[i]] - o } else { V3::from_array(dirs[i]) };
                if d.length() > 0.0 && d.length().is_finite() {
                    rays.push(PreparedRay::new(Ray { o, d: d.normalize(), t_min: 0.0, t_max: bounds[i] }));
                }
            }
            prop_assume!(!rays.is_empty());
            let mut t_max = [0.0; LANES];
            for (t, r) in t_max.iter_mut().zip(&rays) {
                *t = r.ray.t_max;
            }
            check(&rays, &tri, active & ((1u32 << rays.len()) - 1), &t_max);
        }
    }
}
