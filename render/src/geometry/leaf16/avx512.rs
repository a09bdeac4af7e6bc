//! The `avx512` tier's kernels of [`super`]: the sixteen rays in one AVX-512 register each,
//! comparisons into mask registers instead of the two halves of eight AVX lanes. The same IEEE
//! operations in the same order as the scalar test, lane by lane: no FMA, no approximate
//! reciprocal, `f32::max`'s NaN rule, and edge functions that come out exactly zero redone in
//! `f64` lane by lane.

use super::{Hits16, Rays16, LANES};
use crate::geometry::sphere::Sphere;
use crate::geometry::triangle::edges_f64;
use crate::real::Real;
use crate::vec3::V3;
use std::arch::x86_64::*;

/// The sixteen lanes of `a`.
#[target_feature(enable = "avx512f")]
#[inline]
fn load(a: &[f32; LANES]) -> __m512 {
    // SAFETY: `a` holds sixteen `f32`; the load is unaligned.
    unsafe { _mm512_loadu_ps(a.as_ptr()) }
}

/// Stores the sixteen lanes of `v` into `a`.
#[target_feature(enable = "avx512f")]
#[inline]
fn put(a: &mut [f32; LANES], v: __m512) {
    // SAFETY: `a` holds sixteen `f32`; the store is unaligned.
    unsafe { _mm512_storeu_ps(a.as_mut_ptr(), v) }
}

/// `f32::max` lane by lane (`vmaxps` returns `b` whenever either is NaN).
#[target_feature(enable = "avx512f")]
#[inline]
fn maxnum(a: __m512, b: __m512) -> __m512 {
    let b_nan = _mm512_cmp_ps_mask::<_CMP_UNORD_Q>(b, b);
    _mm512_mask_blend_ps(b_nan, _mm512_max_ps(a, b), a)
}

/// Component `k` (the permuted axis `kx`, `ky` or `kz`) of `p` in each lane.
#[target_feature(enable = "avx512f")]
#[inline]
fn pick(r: &Rays16, k: usize, p: V3<f32>) -> __m512 {
    let yz = _mm512_mask_blend_ps(r.k1_bits[k], _mm512_set1_ps(p.z), _mm512_set1_ps(p.y));
    _mm512_mask_blend_ps(r.k0_bits[k], yz, _mm512_set1_ps(p.x))
}

/// The watertight triangle test ([`crate::geometry::triangle`]) with a ray per lane.
///
/// # Safety
/// The CPU must support AVX-512 F and DQ.
#[target_feature(enable = "avx512f,avx512dq")]
#[inline(never)]
pub unsafe fn triangle16(
    r: &Rays16,
    tri: &[V3<f32>; 3],
    active: u32,
    t_max: &[f32; LANES],
) -> Hits16 {
    let mut out = Hits16::none();
    let live = active as __mmask16;
    if live == 0 {
        return out;
    }
    let zero = _mm512_setzero_ps();
    let (sub, mul, add) = (_mm512_sub_ps, _mm512_mul_ps, _mm512_add_ps);
    let (okx, oky, okz) = (load(&r.ok[0]), load(&r.ok[1]), load(&r.ok[2]));
    let (sx, sy, sz) = (load(&r.s[0]), load(&r.s[1]), load(&r.s[2]));
    let az = sub(pick(r, 2, tri[0]), okz);
    let bz = sub(pick(r, 2, tri[1]), okz);
    let cz = sub(pick(r, 2, tri[2]), okz);
    let ax = sub(sub(pick(r, 0, tri[0]), okx), mul(sx, az));
    let ay = sub(sub(pick(r, 1, tri[0]), oky), mul(sy, az));
    let bx = sub(sub(pick(r, 0, tri[1]), okx), mul(sx, bz));
    let by = sub(sub(pick(r, 1, tri[1]), oky), mul(sy, bz));
    let cx = sub(sub(pick(r, 0, tri[2]), okx), mul(sx, cz));
    let cy = sub(sub(pick(r, 1, tri[2]), oky), mul(sy, cz));
    let mut e0 = sub(mul(bx, cy), mul(by, cx));
    let mut e1 = sub(mul(cx, ay), mul(cy, ax));
    let mut e2 = sub(mul(ax, by), mul(ay, bx));
    let eq = |a, b| _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(a, b);
    let lt = |a, b| _mm512_cmp_ps_mask::<_CMP_LT_OS>(a, b);
    let gt = |a, b| _mm512_cmp_ps_mask::<_CMP_GT_OS>(a, b);
    let le = |a, b| _mm512_cmp_ps_mask::<_CMP_LE_OS>(a, b);
    let redo = (eq(e0, zero) | eq(e1, zero) | eq(e2, zero)) & live;
    if redo != 0 {
        // Exactly on an edge in f32: those lanes decide in double precision, as the scalar
        // test does.
        let mut v = [[0.0f32; LANES]; 6];
        for (lanes, x) in v.iter_mut().zip([ax, ay, bx, by, cx, cy]) {
            put(lanes, x);
        }
        let mut f = [[0.0f32; LANES]; 3];
        for (lanes, x) in f.iter_mut().zip([e0, e1, e2]) {
            put(lanes, x);
        }
        for i in 0..LANES {
            if redo & (1 << i) != 0 {
                let g = edges_f64([0, 1, 2, 3, 4, 5].map(|j| f64::from(v[j][i])));
                for (lanes, g) in f.iter_mut().zip(g) {
                    lanes[i] = g as f32;
                }
            }
        }
        (e0, e1, e2) = (load(&f[0]), load(&f[1]), load(&f[2]));
    }
    // Mixed signs: outside.
    let any_neg = lt(e0, zero) | lt(e1, zero) | lt(e2, zero);
    let any_pos = gt(e0, zero) | gt(e1, zero) | gt(e2, zero);
    let mut reject = any_neg & any_pos;
    let det = add(add(e0, e1), e2);
    reject |= eq(det, zero);
    let (saz, sbz, scz) = (mul(sz, az), mul(sz, bz), mul(sz, cz));
    let t_scaled = add(add(mul(e0, saz), mul(e1, sbz)), mul(e2, scz));
    let g = |n: u32| _mm512_set1_ps(<f32 as Real>::gamma(n));
    let t_max = load(t_max);
    let reach = mul(t_max, _mm512_set1_ps(1.0 + 2.0 * <f32 as Real>::gamma(3)));
    let reach_det = mul(reach, det);
    let det_neg = lt(det, zero);
    let out_neg = _mm512_cmp_ps_mask::<_CMP_GE_OS>(t_scaled, zero) | lt(t_scaled, reach_det);
    let out_pos = le(t_scaled, zero) | gt(t_scaled, reach_det);
    reject |= (det_neg & out_neg) | (!det_neg & out_pos);
    if reject & live == live {
        return out;
    }
    let inv_det = _mm512_div_ps(_mm512_set1_ps(1.0), det);
    let t = mul(t_scaled, inv_det);
    reject |= lt(t, load(&r.t_min)) | gt(t, t_max);
    let b1 = mul(e1, inv_det);
    let b2 = mul(e2, inv_det);
    let abs = _mm512_abs_ps;
    let max_zt = maxnum(maxnum(abs(saz), abs(sbz)), abs(scz));
    let delta_z = mul(g(3), max_zt);
    let max_xt = maxnum(maxnum(abs(ax), abs(bx)), abs(cx));
    let max_yt = maxnum(maxnum(abs(ay), abs(by)), abs(cy));
    let delta_x = mul(g(5), add(max_xt, max_zt));
    let delta_y = mul(g(5), add(max_yt, max_zt));
    let delta_e = mul(
        _mm512_set1_ps(2.0),
        add(
            add(mul(mul(g(2), max_xt), max_yt), mul(delta_y, max_xt)),
            mul(delta_x, max_yt),
        ),
    );
    let max_e = maxnum(maxnum(abs(e0), abs(e1)), abs(e2));
    let delta_t = mul(
        mul(
            _mm512_set1_ps(3.0),
            add(
                add(mul(mul(g(3), max_e), max_zt), mul(delta_e, max_zt)),
                mul(delta_z, max_e),
            ),
        ),
        abs(inv_det),
    );
    reject |= le(t, delta_t);
    put(&mut out.t, t);
    put(&mut out.b1, b1);
    put(&mut out.b2, b2);
    out.mask = u32::from(!reject & live);
    out
}

/// The sphere test ([`Sphere::intersect`]) with a ray per lane.
///
/// # Safety
/// The CPU must support AVX-512 F and DQ.
#[target_feature(enable = "avx512f,avx512dq")]
#[inline(never)]
pub unsafe fn sphere16(r: &Rays16, s: &Sphere<f32>, active: u32, t_max: &[f32; LANES]) -> Hits16 {
    let mut out = Hits16::none();
    let live = active as __mmask16;
    if live == 0 {
        return out;
    }
    let zero = _mm512_setzero_ps();
    let sign = _mm512_set1_ps(-0.0);
    let (sub, mul, add) = (_mm512_sub_ps, _mm512_mul_ps, _mm512_add_ps);
    let (dx, dy, dz) = (load(&r.d[0]), load(&r.d[1]), load(&r.d[2]));
    let fx = sub(load(&r.o[0]), _mm512_set1_ps(s.center.x));
    let fy = sub(load(&r.o[1]), _mm512_set1_ps(s.center.y));
    let fz = sub(load(&r.o[2]), _mm512_set1_ps(s.center.z));
    let dot = |ax, ay, az, bx, by, bz| add(add(mul(ax, bx), mul(ay, by)), mul(az, bz));
    let gt = |a, b| _mm512_cmp_ps_mask::<_CMP_GT_OS>(a, b);
    let b = dot(fx, fy, fz, dx, dy, dz);
    let r2 = _mm512_set1_ps(s.radius * s.radius);
    let c = sub(dot(fx, fy, fz, fx, fy, fz), r2);
    // Outside and heading away.
    let mut reject = gt(c, zero) & gt(b, zero);
    if reject & live == live {
        return out;
    }
    let a = load(&r.a);
    let ba = _mm512_div_ps(b, a);
    let vx = sub(fx, mul(dx, ba));
    let vy = sub(fy, mul(dy, ba));
    let vz = sub(fz, mul(dz, ba));
    let disc = mul(a, sub(r2, dot(vx, vy, vz, vx, vy, vz)));
    reject |= _mm512_cmp_ps_mask::<_CMP_LT_OS>(disc, zero);
    let root = _mm512_sqrt_ps(disc);
    let signed_root = _mm512_or_ps(_mm512_andnot_ps(sign, root), _mm512_and_ps(sign, b));
    let q = _mm512_xor_ps(add(b, signed_root), sign);
    let q_nonzero = _mm512_cmp_ps_mask::<_CMP_NEQ_UQ>(q, zero);
    let t0 = _mm512_maskz_div_ps(q_nonzero, q, a);
    let t1 = _mm512_maskz_div_ps(q_nonzero, c, q);
    let swap = gt(t0, t1);
    let (t0, t1) = (
        _mm512_mask_blend_ps(swap, t0, t1),
        _mm512_mask_blend_ps(swap, t1, t0),
    );
    let (t_min, t_max) = (load(&r.t_min), load(t_max));
    let ok = |t| {
        _mm512_cmp_ps_mask::<_CMP_GE_OS>(t, t_min)
            & _mm512_cmp_ps_mask::<_CMP_LE_OS>(t, t_max)
            & gt(t, zero)
    };
    let (ok0, ok1) = (ok(t0), ok(t1));
    put(&mut out.t, _mm512_mask_blend_ps(ok0, t1, t0));
    out.mask = u32::from(!reject & (ok0 | ok1) & live);
    out
}
