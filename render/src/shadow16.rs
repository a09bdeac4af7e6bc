//! The shadow rays of a packet's hits towards one light, made sixteen lanes at a time straight
//! into a [`Lanes16`] packet: the hit points, their error bounds and geometric normals in lanes
//! ([`SurfaceLanes`]), and per lane exactly what `cast::shadow_ray` computes for that
//! hit — the normal turned towards the eye, the cull test, the origin offset off the surface and
//! rounded away from it ([`crate::geometry::offset_ray_origin`]), the unit direction and the
//! distance — in the same IEEE operations and order. The rays that exist go into the packet in
//! lane order. The `avx512` tier ([`crate::isa`]) computes the sixteen lanes in one register per
//! component; the other tiers run the portable loop over the lanes hit.

use crate::geometry::lanes16::{Lanes16, LANES};
use crate::geometry::Ray;
use crate::isa::Isa;
use crate::scene::Surface;
use crate::vec3::V3;

/// The surfaces a packet's rays hit, by lane (lanes without a hit hold anything).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct SurfaceLanes {
    /// Hit points, per axis.
    pub p: [[f32; LANES]; 3],
    /// Their absolute error bounds, per axis.
    pub p_err: [[f32; LANES]; 3],
    /// Unit geometric normals, per axis.
    pub ng: [[f32; LANES]; 3],
    /// Lanes with a hit.
    pub mask: u32,
}

impl Default for SurfaceLanes {
    fn default() -> Self {
        SurfaceLanes {
            p: [[0.0; LANES]; 3],
            p_err: [[0.0; LANES]; 3],
            ng: [[0.0; LANES]; 3],
            mask: 0,
        }
    }
}

impl SurfaceLanes {
    /// Puts the surface `s` into lane `i` and marks it hit.
    #[inline(always)]
    pub fn set(&mut self, i: usize, s: &Surface<f32>) {
        let (p, e, n) = (s.p.to_array(), s.p_err.to_array(), s.ng.to_array());
        for a in 0..3 {
            self.p[a][i] = p[a];
            self.p_err[a][i] = e[a];
            self.ng[a][i] = n[a];
        }
        self.mask |= 1 << i;
    }
}

/// The shadow rays from the hits of `s` (made by the rays of `eye`) to the light at `light`,
/// culled (when `cull`) where the surface faces away from it, into `out` (emptied first, then
/// prepared).
pub fn shadow_lanes(
    out: &mut Lanes16,
    eye: &Lanes16,
    s: &SurfaceLanes,
    light: V3<f32>,
    cull: bool,
) {
    shadow_lanes_on(crate::isa::current(), out, eye, s, light, cull)
}

/// [`shadow_lanes`] with the code of `tier`, which must be a tier this CPU runs.
#[inline(always)]
fn shadow_lanes_on(
    tier: Isa,
    out: &mut Lanes16,
    eye: &Lanes16,
    s: &SurfaceLanes,
    light: V3<f32>,
    cull: bool,
) {
    let mut rays = Rays::default();
    #[cfg(target_arch = "x86_64")]
    {
        if tier.avx512() {
            // SAFETY: the avx512 tier is only chosen on a CPU with AVX-512 F, BW, DQ, VL.
            unsafe { rays_avx512(&mut rays, eye, s, light, cull) };
        } else {
            rays_lanes(&mut rays, eye, s, light, cull);
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = tier;
        rays_lanes(&mut rays, eye, s, light, cull);
    }
    out.clear();
    for i in crate::bits::SetBits(rays.valid & s.mask) {
        out.push(&Ray {
            o: V3::new(rays.o[0][i], rays.o[1][i], rays.o[2][i]),
            d: V3::new(rays.d[0][i], rays.d[1][i], rays.d[2][i]),
            t_min: 0.0,
            t_max: rays.len[i],
        });
    }
    if !out.is_empty() {
        out.prepare();
    }
}

/// Every lane's shadow ray, before the lanes that have one are packed.
#[derive(Default)]
#[repr(C, align(64))]
struct Rays {
    o: [[f32; LANES]; 3],
    d: [[f32; LANES]; 3],
    len: [f32; LANES],
    /// Lanes with a ray (not culled, light off the surface).
    valid: u32,
}

/// [`rays_lanes`] for the `avx512` tier, the sixteen lanes in one register per component:
/// the same operations (sign flips by the sign bit, as `-x` is; `f32::next_up`/`next_down`
/// on the bits, their NaN and infinity cases kept).
///
/// # Safety
/// The CPU must support AVX-512 F, BW, DQ and VL.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,avx2,avx512f,avx512bw,avx512dq,avx512vl")]
unsafe fn rays_avx512(r: &mut Rays, eye: &Lanes16, s: &SurfaceLanes, light: V3<f32>, cull: bool) {
    use std::arch::x86_64::*;
    // SAFETY: every load and store covers sixteen `f32` of a `[f32; 16]` (unaligned).
    let ld = |a: &[f32; LANES]| unsafe { _mm512_loadu_ps(a.as_ptr()) };
    let ld3 = |v: &[[f32; LANES]; 3]| [ld(&v[0]), ld(&v[1]), ld(&v[2])];
    let zero = _mm512_setzero_ps();
    let sign = _mm512_set1_ps(-0.0);
    let dot = |a: [__m512; 3], b: [__m512; 3]| {
        _mm512_add_ps(
            _mm512_add_ps(_mm512_mul_ps(a[0], b[0]), _mm512_mul_ps(a[1], b[1])),
            _mm512_mul_ps(a[2], b[2]),
        )
    };
    let lt = |a, b| _mm512_cmp_ps_mask::<_CMP_LT_OQ>(a, b);
    let gt = |a, b| _mm512_cmp_ps_mask::<_CMP_GT_OQ>(a, b);
    let flip = |v: __m512, k: __mmask16| _mm512_mask_xor_ps(v, k, v, sign);
    let (p, p_err, ng) = (ld3(&s.p), ld3(&s.p_err), ld3(&s.ng));
    let back = ld3(&eye.tri.d).map(|c| _mm512_xor_ps(c, sign));
    let turn = lt(dot(ng, back), zero);
    let n = ng.map(|c| flip(c, turn));
    let pos = light.to_array().map(|c| _mm512_set1_ps(c));
    let to = [0, 1, 2].map(|a| _mm512_sub_ps(pos[a], p[a]));
    let culled = if cull {
        _mm512_cmp_ps_mask::<_CMP_LE_OQ>(dot(n, to), zero)
    } else {
        0
    };
    let dist = _mm512_sqrt_ps(dot(to, to));
    let valid = !culled & gt(dist, zero);
    let w = to.map(|c| _mm512_div_ps(c, dist));
    let off_len = dot(ng.map(|c| _mm512_andnot_ps(sign, c)), p_err);
    let away = lt(dot(w, ng), zero);
    let off = ng.map(|c| flip(_mm512_mul_ps(c, off_len), away));
    let one = _mm512_set1_epi32(1);
    let o = [0, 1, 2].map(|a| {
        let v = _mm512_add_ps(p[a], off[a]);
        let bits = _mm512_castps_si512(v);
        let negative = _mm512_cmplt_epi32_mask(bits, _mm512_setzero_si512());
        let zero_abs = _mm512_cmpeq_epi32_mask(
            _mm512_and_si512(bits, _mm512_set1_epi32(0x7fff_ffff)),
            _mm512_setzero_si512(),
        );
        let nan = _mm512_cmp_ps_mask::<_CMP_UNORD_Q>(v, v);
        let eq = |x: i32| _mm512_cmpeq_epi32_mask(bits, _mm512_set1_epi32(x));
        let plus = _mm512_add_epi32(bits, one);
        let minus = _mm512_sub_epi32(bits, one);
        // `next_up`: +1 on the bits of a positive value, −1 of a negative one, the smallest
        // positive from ±0, unchanged for NaN and +∞.
        let up = _mm512_mask_blend_epi32(negative, plus, minus);
        let up = _mm512_mask_blend_epi32(zero_abs, up, one);
        let up = _mm512_mask_blend_epi32(nan | eq(0x7f80_0000), up, bits);
        // `next_down`: the mirror image.
        let down = _mm512_mask_blend_epi32(negative, minus, plus);
        let down =
            _mm512_mask_blend_epi32(zero_abs, down, _mm512_set1_epi32(0x8000_0001u32 as i32));
        let down = _mm512_mask_blend_epi32(nan | eq(0xff80_0000u32 as i32), down, bits);
        let rounded = _mm512_mask_blend_epi32(gt(off[a], zero), bits, up);
        let rounded = _mm512_mask_blend_epi32(lt(off[a], zero), rounded, down);
        _mm512_castsi512_ps(rounded)
    });
    let d = [0, 1, 2].map(|a| _mm512_sub_ps(pos[a], o[a]));
    let len = _mm512_sqrt_ps(dot(d, d));
    // SAFETY: as the loads.
    let st = |a: &mut [f32; LANES], v| unsafe { _mm512_storeu_ps(a.as_mut_ptr(), v) };
    for a in 0..3 {
        st(&mut r.o[a], o[a]);
        st(&mut r.d[a], _mm512_div_ps(d[a], len));
    }
    st(&mut r.len, len);
    r.valid = u32::from(valid);
}

/// `cast::shadow_ray` lane by lane for the lanes with a hit; `valid` says which have a ray.
/// (The compiler does not vectorise this loop: below the `avx512` tier it runs only the lanes
/// hit, one by one.)
#[inline(always)]
fn rays_lanes(r: &mut Rays, eye: &Lanes16, s: &SurfaceLanes, light: V3<f32>, cull: bool) {
    let pos = light.to_array();
    let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let mut valid = [false; LANES];
    for i in crate::bits::SetBits(s.mask) {
        let get = |v: &[[f32; LANES]; 3]| [v[0][i], v[1][i], v[2][i]];
        let (p, p_err, ng) = (get(&s.p), get(&s.p_err), get(&s.ng));
        let back = get(&eye.tri.d).map(|c| -c);
        // `face_forward(-ray.d)`.
        let n = if dot(ng, back) < 0.0 {
            ng.map(|c| -c)
        } else {
            ng
        };
        let to = [0, 1, 2].map(|a| pos[a] - p[a]);
        let culled = cull & (dot(n, to) <= 0.0);
        let dist = dot(to, to).sqrt();
        valid[i] = !culled & (dist > 0.0);
        let w = to.map(|c| c / dist);
        // `offset_ray_origin(p, p_err, ng, w)`, with the normal as the surface gives it.
        let off_len = dot(ng.map(f32::abs), p_err);
        let mut off = ng.map(|c| c * off_len);
        if dot(w, ng) < 0.0 {
            off = off.map(|c| -c);
        }
        let o = [0, 1, 2].map(|a| {
            let v = p[a] + off[a];
            if off[a] > 0.0 {
                v.next_up()
            } else if off[a] < 0.0 {
                v.next_down()
            } else {
                v
            }
        });
        let d = [0, 1, 2].map(|a| pos[a] - o[a]);
        let len = dot(d, d).sqrt();
        for a in 0..3 {
            r.o[a][i] = o[a];
            r.d[a][i] = d[a] / len;
        }
        r.len[i] = len;
    }
    r.valid = 0;
    for (i, &v) in valid.iter().enumerate() {
        r.valid |= u32::from(v) << i;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cast::shadow_ray;
    use proptest::prelude::*;

    fn comp() -> impl Strategy<Value = f32> {
        prop_oneof![
            6 => -4.0f32..4.0,
            1 => Just(0.0f32),
            1 => Just(-0.0f32),
            1 => -1.0e-6f32..1.0e-6,
        ]
    }

    /// Random vectors, and vectors on a grid of small integers, where a light in the
    /// surface's tangent plane (an exactly zero dot product) and zero offsets are common.
    fn v3() -> impl Strategy<Value = V3<f32>> {
        prop_oneof![
            proptest::array::uniform3(comp()),
            proptest::array::uniform3((-2i8..=2).prop_map(f32::from)),
        ]
        .prop_map(V3::from_array)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(500))]
        /// Every tier's shadow packet is the rays `shadow_ray` makes one by one, bit for bit,
        /// in lane order: lights on the surface, behind it, culled or not.
        #[test]
        fn shadow_lanes_are_shadow_rays_one_by_one(
            hits in proptest::collection::vec((v3(), v3(), v3(), v3(), any::<bool>()), 1..=LANES),
            light in v3(),
            cull in any::<bool>(),
        ) {
            let mut eye = Lanes16::new();
            let mut s = SurfaceLanes::default();
            let mut want = Vec::new();
            for (i, &(p, err, ng, d, hit)) in hits.iter().enumerate() {
                let ray = Ray { o: V3::zero(), d, t_min: 0.0, t_max: f32::INFINITY };
                eye.push(&ray);
                let surface = Surface { p, p_err: err.abs(), ng, ns: ng, material: 0 };
                if hit {
                    s.set(i, &surface);
                    want.extend(shadow_ray(light, &ray, &surface, cull));
                }
            }
            for tier in Isa::supported_tiers() {
                let mut out = Lanes16::new();
                shadow_lanes_on(tier, &mut out, &eye, &s, light, cull);
                prop_assert_eq!(out.len(), want.len(), "{}", tier);
                for (k, w) in want.iter().enumerate() {
                    prop_assert_eq!(format!("{:?}", out.ray(k)), format!("{:?}", w), "{}", tier);
                    let bits = |r: Ray<f32>| [r.o.to_array(), r.d.to_array()].map(|v| v.map(f32::to_bits));
                    prop_assert_eq!(bits(out.ray(k)), bits(*w), "{}", tier);
                    prop_assert_eq!(out.t_max[k].to_bits(), w.t_max.to_bits(), "{}", tier);
                }
            }
        }
    }
}
