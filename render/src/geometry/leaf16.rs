//! One triangle or sphere against up to sixteen rays at once, a ray per SIMD lane: the
//! transposed form of [`super::triangle4`] and [`super::sphere4`], for a packet's rays that
//! enter a BVH leaf. Every lane does the scalar test's IEEE operations in the same order (no
//! FMA, no reassociation, `f32::max`'s NaN rule, edge functions that come out exactly zero
//! redone in `f64` lane by lane), so each lane's answer is bit for bit what
//! [`super::triangle::intersect_triangle`] or [`super::sphere::Sphere::intersect`] gives that
//! ray. The rays' axis permutations may differ: each lane picks its vertex components with
//! masks. The `avx512` tier ([`crate::isa`]) runs the sixteen rays in one AVX-512 register
//! (`avx512`); the `avx2` tier in two halves of eight AVX lanes. [`Rays16::new`] is `None`
//! unless the process's tier runs AVX; the portable kernels ([`triangle16_lanes`],
//! [`sphere16_lanes`]) define the answers and serve the tests.

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
    pub(crate) o: [[f32; LANES]; 3],
    /// Direction components by axis.
    pub(crate) d: [[f32; LANES]; 3],
    /// Origin components along each ray's permuted axes `kx`, `ky`, `kz`.
    pub(crate) ok: [[f32; LANES]; 3],
    /// Shear constants.
    pub(crate) s: [[f32; LANES]; 3],
    pub(crate) t_min: [f32; LANES],
    /// `|d|²` as the scalar sphere test computes it.
    pub(crate) a: [f32; LANES],
    /// Per permuted axis (`kx`, `ky`, `kz`): all ones in lanes where it is axis 0, and where
    /// it is axis 1 (lane masks for the kernels' selects).
    pub(crate) k0: [[f32; LANES]; 3],
    pub(crate) k1: [[f32; LANES]; 3],
    /// The same lane masks as bits (bit `i` is lane `i`), for the AVX-512 kernels.
    pub(crate) k0_bits: [u16; 3],
    pub(crate) k1_bits: [u16; 3],
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
    /// The lanes of `rays` (1..=16), or `None` when there are too many or the process's tier
    /// runs no AVX.
    #[inline]
    pub fn new(rays: &[PreparedRay<f32>]) -> Option<Self> {
        if rays.is_empty() || rays.len() > LANES || !available() {
            return None;
        }
        Some(Self::lanes(rays))
    }

    /// Lanes of zeros, made from no slice (filled by [`super::lanes16::Lanes16`]).
    pub(crate) fn empty() -> Self {
        Rays16 {
            o: [[0.0; LANES]; 3],
            d: [[0.0; LANES]; 3],
            ok: [[0.0; LANES]; 3],
            s: [[0.0; LANES]; 3],
            t_min: [0.0; LANES],
            a: [0.0; LANES],
            k0: [[0.0; LANES]; 3],
            k1: [[0.0; LANES]; 3],
            k0_bits: [0; 3],
            k1_bits: [0; 3],
            src: 0,
            n: 0,
        }
    }

    /// Whether lane `i` holds the same bits as lane `j` of `other` (for tests).
    #[cfg(test)]
    pub(crate) fn same_lane(&self, i: usize, other: &Rays16, j: usize) -> bool {
        let rows = |r: &Rays16, k: usize| {
            let mut v = Vec::new();
            for a in 0..3 {
                v.extend([
                    r.o[a][k], r.d[a][k], r.ok[a][k], r.s[a][k], r.k0[a][k], r.k1[a][k],
                ]);
            }
            v.extend([r.t_min[k], r.a[k]]);
            let bits: Vec<u32> = v.iter().map(|x| x.to_bits()).collect();
            let masks = [0, 1, 2].map(|a| (r.k0_bits[a] >> k & 1, r.k1_bits[a] >> k & 1));
            (bits, masks)
        };
        rows(self, i) == rows(other, j)
    }

    /// The lanes of `rays` whatever the CPU (for the portable kernels).
    pub fn lanes(rays: &[PreparedRay<f32>]) -> Self {
        let mut l = Rays16 {
            src: rays.as_ptr() as usize,
            n: rays.len(),
            ..Self::empty()
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
                let ones = |on: bool| f32::from_bits(if on { u32::MAX } else { 0 });
                l.k0[a][i] = ones(k[a] == 0);
                l.k1[a][i] = ones(k[a] == 1);
                l.k0_bits[a] |= u16::from(k[a] == 0) << i;
                l.k1_bits[a] |= u16::from(k[a] == 1) << i;
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

/// Whether the process's tier ([`crate::isa`]) runs the AVX kernels (`avx2`, `avx512`).
#[inline(always)]
pub fn available() -> bool {
    cfg!(target_arch = "x86_64") && crate::isa::current().avx()
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
        if crate::isa::current().avx512() {
            // SAFETY: the avx512 tier is only chosen on a CPU that has AVX-512 F, BW, DQ, VL.
            return unsafe { avx512::triangle16(rays, tri, active, t_max) };
        }
        // SAFETY: the AVX tiers are only chosen on a CPU that has AVX.
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
        if crate::isa::current().avx512() {
            // SAFETY: the avx512 tier is only chosen on a CPU that has AVX-512 F, BW, DQ, VL.
            return unsafe { avx512::sphere16(rays, s, active, t_max) };
        }
        // SAFETY: the AVX tiers are only chosen on a CPU that has AVX.
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
mod avx512;

#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{Hits16, Rays16, LANES};
    use crate::geometry::sphere::Sphere;
    use crate::geometry::triangle::edges_f64;
    use crate::real::Real;
    use crate::vec3::V3;
    use std::arch::x86_64::*;

    /// Lanes per AVX register: the sixteen rays go in two halves.
    const HALF: usize = 8;

    /// Lanes `h·8 .. h·8 + 8` of `a`.
    #[target_feature(enable = "avx")]
    #[inline]
    unsafe fn load(a: &[f32; LANES], h: usize) -> __m256 {
        _mm256_loadu_ps(a[h * HALF..].as_ptr())
    }

    /// Stores `v` into lanes `h·8 .. h·8 + 8` of `a`.
    #[target_feature(enable = "avx")]
    #[inline]
    unsafe fn put(a: &mut [f32; LANES], h: usize, v: __m256) {
        _mm256_storeu_ps(a[h * HALF..].as_mut_ptr(), v)
    }

    #[target_feature(enable = "avx")]
    #[inline]
    unsafe fn store(a: __m256) -> [f32; HALF] {
        let mut out = [0.0f32; HALF];
        _mm256_storeu_ps(out.as_mut_ptr(), a);
        out
    }

    /// `if m { a } else { b }` lane by lane.
    #[target_feature(enable = "avx")]
    #[inline]
    unsafe fn select(m: __m256, a: __m256, b: __m256) -> __m256 {
        _mm256_blendv_ps(b, a, m)
    }

    /// `f32::max` lane by lane (`vmaxps` returns `b` whenever either is NaN).
    #[target_feature(enable = "avx")]
    #[inline]
    unsafe fn maxnum(a: __m256, b: __m256) -> __m256 {
        let m = _mm256_max_ps(a, b);
        select(_mm256_cmp_ps::<_CMP_UNORD_Q>(b, b), a, m)
    }

    #[target_feature(enable = "avx")]
    #[inline]
    unsafe fn abs(a: __m256) -> __m256 {
        _mm256_andnot_ps(_mm256_set1_ps(-0.0), a)
    }

    /// Component `k` (the permuted axis `kx`, `ky` or `kz`) of `p` in each lane of half `h`.
    #[target_feature(enable = "avx")]
    #[inline]
    unsafe fn pick(r: &Rays16, k: usize, h: usize, p: V3<f32>) -> __m256 {
        let yz = select(load(&r.k1[k], h), _mm256_set1_ps(p.y), _mm256_set1_ps(p.z));
        select(load(&r.k0[k], h), _mm256_set1_ps(p.x), yz)
    }

    /// The watertight triangle test ([`crate::geometry::triangle`]) with a ray per lane.
    ///
    /// # Safety
    /// The CPU must support AVX.
    #[target_feature(enable = "avx")]
    #[inline(never)]
    pub unsafe fn triangle16(
        r: &Rays16,
        tri: &[V3<f32>; 3],
        active: u32,
        t_max: &[f32; LANES],
    ) -> Hits16 {
        let mut out = Hits16::none();
        for h in 0..2 {
            let live = (active >> (h * HALF)) & 0xff;
            if live != 0 {
                out.mask |= triangle8(r, tri, h, live, t_max, &mut out) << (h * HALF);
            }
        }
        out
    }

    /// Half `h` of [`triangle16`]: the lanes hit (bits 0..8); `t`, `b1`, `b2` into `out`.
    #[target_feature(enable = "avx")]
    #[inline]
    unsafe fn triangle8(
        r: &Rays16,
        tri: &[V3<f32>; 3],
        h: usize,
        live: u32,
        t_max: &[f32; LANES],
        out: &mut Hits16,
    ) -> u32 {
        let zero = _mm256_setzero_ps();
        let (okx, oky, okz) = (load(&r.ok[0], h), load(&r.ok[1], h), load(&r.ok[2], h));
        let (sx, sy, sz) = (load(&r.s[0], h), load(&r.s[1], h), load(&r.s[2], h));
        let az = _mm256_sub_ps(pick(r, 2, h, tri[0]), okz);
        let bz = _mm256_sub_ps(pick(r, 2, h, tri[1]), okz);
        let cz = _mm256_sub_ps(pick(r, 2, h, tri[2]), okz);
        let ax = _mm256_sub_ps(
            _mm256_sub_ps(pick(r, 0, h, tri[0]), okx),
            _mm256_mul_ps(sx, az),
        );
        let ay = _mm256_sub_ps(
            _mm256_sub_ps(pick(r, 1, h, tri[0]), oky),
            _mm256_mul_ps(sy, az),
        );
        let bx = _mm256_sub_ps(
            _mm256_sub_ps(pick(r, 0, h, tri[1]), okx),
            _mm256_mul_ps(sx, bz),
        );
        let by = _mm256_sub_ps(
            _mm256_sub_ps(pick(r, 1, h, tri[1]), oky),
            _mm256_mul_ps(sy, bz),
        );
        let cx = _mm256_sub_ps(
            _mm256_sub_ps(pick(r, 0, h, tri[2]), okx),
            _mm256_mul_ps(sx, cz),
        );
        let cy = _mm256_sub_ps(
            _mm256_sub_ps(pick(r, 1, h, tri[2]), oky),
            _mm256_mul_ps(sy, cz),
        );
        let mut e0 = _mm256_sub_ps(_mm256_mul_ps(bx, cy), _mm256_mul_ps(by, cx));
        let mut e1 = _mm256_sub_ps(_mm256_mul_ps(cx, ay), _mm256_mul_ps(cy, ax));
        let mut e2 = _mm256_sub_ps(_mm256_mul_ps(ax, by), _mm256_mul_ps(ay, bx));
        let on_edge = _mm256_or_ps(
            _mm256_or_ps(
                _mm256_cmp_ps::<_CMP_EQ_OQ>(e0, zero),
                _mm256_cmp_ps::<_CMP_EQ_OQ>(e1, zero),
            ),
            _mm256_cmp_ps::<_CMP_EQ_OQ>(e2, zero),
        );
        let redo = _mm256_movemask_ps(on_edge) as u32 & live;
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
            for i in 0..HALF {
                if redo & (1 << i) != 0 {
                    let v = [ax_[i], ay_[i], bx_[i], by_[i], cx_[i], cy_[i]].map(f64::from);
                    let [g0, g1, g2] = edges_f64(v);
                    (f0[i], f1[i], f2[i]) = (g0 as f32, g1 as f32, g2 as f32);
                }
            }
            e0 = _mm256_loadu_ps(f0.as_ptr());
            e1 = _mm256_loadu_ps(f1.as_ptr());
            e2 = _mm256_loadu_ps(f2.as_ptr());
        }
        let lt = |a, b| _mm256_cmp_ps::<_CMP_LT_OS>(a, b);
        let gt = |a, b| _mm256_cmp_ps::<_CMP_GT_OS>(a, b);
        // Mixed signs: outside.
        let any_neg = _mm256_or_ps(_mm256_or_ps(lt(e0, zero), lt(e1, zero)), lt(e2, zero));
        let any_pos = _mm256_or_ps(_mm256_or_ps(gt(e0, zero), gt(e1, zero)), gt(e2, zero));
        let mut reject = _mm256_and_ps(any_neg, any_pos);
        let det = _mm256_add_ps(_mm256_add_ps(e0, e1), e2);
        reject = _mm256_or_ps(reject, _mm256_cmp_ps::<_CMP_EQ_OQ>(det, zero));
        let (saz, sbz, scz) = (
            _mm256_mul_ps(sz, az),
            _mm256_mul_ps(sz, bz),
            _mm256_mul_ps(sz, cz),
        );
        let t_scaled = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(e0, saz), _mm256_mul_ps(e1, sbz)),
            _mm256_mul_ps(e2, scz),
        );
        let g = |n: u32| _mm256_set1_ps(<f32 as Real>::gamma(n));
        let t_max = load(t_max, h);
        let reach = _mm256_mul_ps(t_max, _mm256_set1_ps(1.0 + 2.0 * <f32 as Real>::gamma(3)));
        let reach_det = _mm256_mul_ps(reach, det);
        let det_neg = lt(det, zero);
        let out_neg = _mm256_or_ps(
            _mm256_cmp_ps::<_CMP_GE_OS>(t_scaled, zero),
            lt(t_scaled, reach_det),
        );
        let out_pos = _mm256_or_ps(
            _mm256_cmp_ps::<_CMP_LE_OS>(t_scaled, zero),
            gt(t_scaled, reach_det),
        );
        reject = _mm256_or_ps(
            reject,
            _mm256_or_ps(
                _mm256_and_ps(det_neg, out_neg),
                _mm256_andnot_ps(det_neg, out_pos),
            ),
        );
        if _mm256_movemask_ps(reject) as u32 & live == live {
            return 0;
        }
        let inv_det = _mm256_div_ps(_mm256_set1_ps(1.0), det);
        let t = _mm256_mul_ps(t_scaled, inv_det);
        reject = _mm256_or_ps(reject, _mm256_or_ps(lt(t, load(&r.t_min, h)), gt(t, t_max)));
        let b1 = _mm256_mul_ps(e1, inv_det);
        let b2 = _mm256_mul_ps(e2, inv_det);
        let max_zt = maxnum(maxnum(abs(saz), abs(sbz)), abs(scz));
        let delta_z = _mm256_mul_ps(g(3), max_zt);
        let max_xt = maxnum(maxnum(abs(ax), abs(bx)), abs(cx));
        let max_yt = maxnum(maxnum(abs(ay), abs(by)), abs(cy));
        let delta_x = _mm256_mul_ps(g(5), _mm256_add_ps(max_xt, max_zt));
        let delta_y = _mm256_mul_ps(g(5), _mm256_add_ps(max_yt, max_zt));
        let delta_e = _mm256_mul_ps(
            _mm256_set1_ps(2.0),
            _mm256_add_ps(
                _mm256_add_ps(
                    _mm256_mul_ps(_mm256_mul_ps(g(2), max_xt), max_yt),
                    _mm256_mul_ps(delta_y, max_xt),
                ),
                _mm256_mul_ps(delta_x, max_yt),
            ),
        );
        let max_e = maxnum(maxnum(abs(e0), abs(e1)), abs(e2));
        let delta_t = _mm256_mul_ps(
            _mm256_mul_ps(
                _mm256_set1_ps(3.0),
                _mm256_add_ps(
                    _mm256_add_ps(
                        _mm256_mul_ps(_mm256_mul_ps(g(3), max_e), max_zt),
                        _mm256_mul_ps(delta_e, max_zt),
                    ),
                    _mm256_mul_ps(delta_z, max_e),
                ),
            ),
            abs(inv_det),
        );
        reject = _mm256_or_ps(reject, _mm256_cmp_ps::<_CMP_LE_OS>(t, delta_t));
        put(&mut out.t, h, t);
        put(&mut out.b1, h, b1);
        put(&mut out.b2, h, b2);
        !(_mm256_movemask_ps(reject) as u32) & live
    }

    /// The sphere test ([`Sphere::intersect`]) with a ray per lane.
    ///
    /// # Safety
    /// The CPU must support AVX.
    #[target_feature(enable = "avx")]
    #[inline(never)]
    pub unsafe fn sphere16(
        r: &Rays16,
        s: &Sphere<f32>,
        active: u32,
        t_max: &[f32; LANES],
    ) -> Hits16 {
        let mut out = Hits16::none();
        for h in 0..2 {
            let live = (active >> (h * HALF)) & 0xff;
            if live != 0 {
                out.mask |= sphere8(r, s, h, live, t_max, &mut out.t) << (h * HALF);
            }
        }
        out
    }

    /// Half `h` of [`sphere16`]: the lanes hit (bits 0..8); `t` into `out_t`.
    #[target_feature(enable = "avx")]
    #[inline]
    unsafe fn sphere8(
        r: &Rays16,
        s: &Sphere<f32>,
        h: usize,
        live: u32,
        t_max: &[f32; LANES],
        out_t: &mut [f32; LANES],
    ) -> u32 {
        let zero = _mm256_setzero_ps();
        let sign = _mm256_set1_ps(-0.0);
        let (dx, dy, dz) = (load(&r.d[0], h), load(&r.d[1], h), load(&r.d[2], h));
        let fx = _mm256_sub_ps(load(&r.o[0], h), _mm256_set1_ps(s.center.x));
        let fy = _mm256_sub_ps(load(&r.o[1], h), _mm256_set1_ps(s.center.y));
        let fz = _mm256_sub_ps(load(&r.o[2], h), _mm256_set1_ps(s.center.z));
        let dot = |ax, ay, az, bx, by, bz| {
            _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(ax, bx), _mm256_mul_ps(ay, by)),
                _mm256_mul_ps(az, bz),
            )
        };
        let gt = |a, b| _mm256_cmp_ps::<_CMP_GT_OS>(a, b);
        let b = dot(fx, fy, fz, dx, dy, dz);
        let r2 = _mm256_set1_ps(s.radius * s.radius);
        let c = _mm256_sub_ps(dot(fx, fy, fz, fx, fy, fz), r2);
        // Outside and heading away.
        let mut reject = _mm256_and_ps(gt(c, zero), gt(b, zero));
        if _mm256_movemask_ps(reject) as u32 & live == live {
            return 0;
        }
        let a = load(&r.a, h);
        let ba = _mm256_div_ps(b, a);
        let vx = _mm256_sub_ps(fx, _mm256_mul_ps(dx, ba));
        let vy = _mm256_sub_ps(fy, _mm256_mul_ps(dy, ba));
        let vz = _mm256_sub_ps(fz, _mm256_mul_ps(dz, ba));
        let disc = _mm256_mul_ps(a, _mm256_sub_ps(r2, dot(vx, vy, vz, vx, vy, vz)));
        reject = _mm256_or_ps(reject, _mm256_cmp_ps::<_CMP_LT_OS>(disc, zero));
        let root = _mm256_sqrt_ps(disc);
        let signed_root = _mm256_or_ps(_mm256_andnot_ps(sign, root), _mm256_and_ps(sign, b));
        let q = _mm256_xor_ps(_mm256_add_ps(b, signed_root), sign);
        let q_zero = _mm256_cmp_ps::<_CMP_EQ_OQ>(q, zero);
        let t0 = select(q_zero, zero, _mm256_div_ps(q, a));
        let t1 = select(q_zero, zero, _mm256_div_ps(c, q));
        let swap = gt(t0, t1);
        let (t0, t1) = (select(swap, t1, t0), select(swap, t0, t1));
        let (t_min, t_max) = (load(&r.t_min, h), load(t_max, h));
        let ok = |t| {
            _mm256_and_ps(
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_GE_OS>(t, t_min),
                    _mm256_cmp_ps::<_CMP_LE_OS>(t, t_max),
                ),
                gt(t, zero),
            )
        };
        let (ok0, ok1) = (ok(t0), ok(t1));
        put(out_t, h, select(ok0, t0, t1));
        let hit = _mm256_andnot_ps(reject, _mm256_or_ps(ok0, ok1));
        _mm256_movemask_ps(hit) as u32 & live
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ray::Ray;
    use proptest::prelude::*;

    /// The answers of every kernel this CPU runs, the process's tier aside: the dispatched
    /// kernel, the AVX halves and the AVX-512 kernel.
    fn kernels(
        lanes: &Rays16,
        rays: &[PreparedRay<f32>],
        tri: &[V3<f32>; 3],
        s: &Sphere<f32>,
        active: u32,
        t_max: &[f32; LANES],
    ) -> Vec<(&'static str, Hits16, Hits16)> {
        let mut out = vec![(
            "dispatched",
            triangle16(lanes, rays, tri, active, t_max),
            sphere16(lanes, rays, s, active, t_max),
        )];
        #[cfg(target_arch = "x86_64")]
        {
            use crate::isa::Isa;
            if Isa::Avx2.supported() {
                // SAFETY: this CPU has AVX.
                let got = unsafe {
                    (
                        x86::triangle16(lanes, tri, active, t_max),
                        x86::sphere16(lanes, s, active, t_max),
                    )
                };
                out.push(("avx", got.0, got.1));
            }
            if Isa::Avx512.supported() {
                // SAFETY: this CPU has AVX-512 F, BW, DQ and VL.
                let got = unsafe {
                    (
                        avx512::triangle16(lanes, tri, active, t_max),
                        avx512::sphere16(lanes, s, active, t_max),
                    )
                };
                out.push(("avx512", got.0, got.1));
            }
        }
        out
    }

    /// Asserts that every SIMD kernel this CPU runs gives the portable kernels' answers bit for
    /// bit; returns the rays hit.
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
        for (kernel, got, got_s) in kernels(&lanes, rays, tri, &s, active, t_max) {
            for (got, want) in [(got, want), (got_s, want_s)] {
                assert_eq!(
                    got.mask, want.mask,
                    "{kernel}: {rays:?} {tri:?} {active:#x}"
                );
                for i in 0..LANES {
                    if want.mask & (1 << i) != 0 {
                        assert_eq!(got.t[i].to_bits(), want.t[i].to_bits(), "{kernel}");
                        assert_eq!(got.b1[i].to_bits(), want.b1[i].to_bits(), "{kernel}");
                        assert_eq!(got.b2[i].to_bits(), want.b2[i].to_bits(), "{kernel}");
                    }
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
        for o in offsets {
            for t in targets {
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
        // Packets mixing axis permutations, and packets of one offset (one direction).
        for packet in rays.chunks(LANES).chain(rays.chunks(targets.len())) {
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
