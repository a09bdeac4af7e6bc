//! A packet's rays set up sixteen at a time: the per-ray constants of [`PreparedRay::new`]
//! (reciprocal direction, direction signs, the triangle test's axis permutation and shear) for
//! up to sixteen rays ([`prepare`]), and the prepared eye rays of a block of pixel centres
//! ([`eye_block`], [`Camera::ray`] then [`PreparedRay::new`]). On the `avx512` tier
//! ([`crate::isa`]) and in `f32` each component of the sixteen rays is one AVX-512 register, so
//! the divisions and square roots run sixteen to an instruction instead of one after another;
//! elsewhere each ray is made alone. Every lane does the scalar code's IEEE operations in its
//! order (correctly rounded division and square root, no FMA, the same comparisons), so each
//! ray is bit for bit the one made alone. Nothing here allocates.

use super::ray::{PreparedRay, Ray};
use crate::camera::Camera;
use crate::real::Real;
use std::any::{Any, TypeId};

/// Most rays per call.
pub const LANES: usize = 16;

/// Whether the process's tier runs the AVX-512 set-up.
#[inline(always)]
pub fn available() -> bool {
    cfg!(target_arch = "x86_64") && crate::isa::current().avx512()
}

/// `s` as `f32` items when `T<R>` is `T<f32>` (`R` is `f32`).
#[inline(always)]
fn as_f32<R: Real, A: 'static, B: 'static>(s: &mut [A]) -> Option<&mut [B]> {
    if TypeId::of::<R>() == TypeId::of::<f32>() && TypeId::of::<A>() == TypeId::of::<B>() {
        // SAFETY: `A` and `B` are the same type.
        Some(unsafe { &mut *(s as *mut [A] as *mut [B]) })
    } else {
        None
    }
}

/// Prepares `rays` (at most [`LANES`]) into `out` (same indexing): `out[i]` is
/// `PreparedRay::new(rays[i])`, bit for bit.
///
/// # Panics
/// When `rays` is longer than [`LANES`] or `out` shorter than `rays`.
#[inline]
pub fn prepare<R: Real>(rays: &[Ray<R>], out: &mut [PreparedRay<R>]) {
    assert!(rays.len() <= LANES && out.len() >= rays.len());
    #[cfg(target_arch = "x86_64")]
    if rays.len() > 1 && available() && TypeId::of::<R>() == TypeId::of::<f32>() {
        // SAFETY: `R` is `f32`, so `Ray<R>` is `Ray<f32>`.
        let r32 = unsafe { &*(rays as *const [Ray<R>] as *const [Ray<f32>]) };
        if let Some(o32) = as_f32::<R, PreparedRay<R>, PreparedRay<f32>>(out) {
            // SAFETY: the avx512 tier is only chosen on a CPU that has AVX-512 F, BW, DQ, VL.
            unsafe { avx512::prepare(r32, o32) };
            return;
        }
    }
    for (o, r) in out.iter_mut().zip(rays) {
        *o = PreparedRay::new(*r);
    }
}

/// The prepared eye rays through the centres of the `w × h` pixels at `(x0, y0)`, row by row,
/// into `out`; returns their number `w·h` (at most [`LANES`]). `out[i]` is bit for bit
/// `PreparedRay::new(camera.ray(x + ½, y + ½))`.
///
/// # Panics
/// When `w·h` exceeds [`LANES`] or `out`'s length.
#[inline]
pub fn eye_block<R: Real>(
    camera: &Camera<R>,
    x0: u32,
    y0: u32,
    w: u32,
    h: u32,
    out: &mut [PreparedRay<R>],
) -> usize {
    let n = (w * h) as usize;
    assert!(n <= LANES && out.len() >= n);
    #[cfg(target_arch = "x86_64")]
    if n > 1 && available() {
        let cam = (camera as &dyn Any).downcast_ref::<Camera<f32>>();
        if let (Some(cam), Some(o32)) = (cam, as_f32::<R, PreparedRay<R>, PreparedRay<f32>>(out))
        {
            // SAFETY: the avx512 tier is only chosen on a CPU that has AVX-512 F, BW, DQ, VL.
            unsafe { avx512::eye_block(cam, x0, y0, w, h, o32) };
            return n;
        }
    }
    let mut i = 0;
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            let ray = camera.ray(R::from_u32(x) + R::HALF, R::from_u32(y) + R::HALF);
            out[i] = PreparedRay::new(ray);
            i += 1;
        }
    }
    n
}

#[cfg(target_arch = "x86_64")]
pub(crate) mod avx512 {
    use super::LANES;
    use crate::camera::Camera;
    use crate::geometry::ray::{PreparedRay, Ray};
    use crate::vec3::V3;
    use std::arch::x86_64::*;

    /// A packet's rays by component, one register per component.
    struct Soa {
        o: [__m512; 3],
        d: [__m512; 3],
        t_min: __m512,
        t_max: __m512,
    }

    #[target_feature(enable = "avx512f")]
    #[inline]
    fn store(v: __m512) -> [f32; LANES] {
        let mut a = [0.0f32; LANES];
        // SAFETY: sixteen `f32` into a `[f32; 16]` (unaligned store).
        unsafe { _mm512_storeu_ps(a.as_mut_ptr(), v) };
        a
    }

    /// The component of `v` on the axis each lane's masks name: axis 0 where `m0`, axis 1
    /// where `m1`, axis 2 elsewhere.
    #[target_feature(enable = "avx512f")]
    #[inline]
    fn pick(m0: __mmask16, m1: __mmask16, v: &[__m512; 3]) -> __m512 {
        _mm512_mask_blend_ps(m0, _mm512_mask_blend_ps(m1, v[2], v[1]), v[0])
    }

    /// Prepares `rays` into `out`.
    ///
    /// # Safety
    /// The CPU must support AVX-512 F.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn prepare(rays: &[Ray<f32>], out: &mut [PreparedRay<f32>]) {
        let n = rays.len();
        let Some(first) = rays.first() else {
            return;
        };
        let mut c = [[0.0f32; LANES]; 8];
        for i in 0..LANES {
            let r = rays.get(i).unwrap_or(first);
            let v = [r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, r.t_min, r.t_max];
            for (k, x) in v.into_iter().enumerate() {
                c[k][i] = x;
            }
        }
        let load = |a: &[f32; LANES]| _mm512_loadu_ps(a.as_ptr());
        let soa = Soa {
            o: [load(&c[0]), load(&c[1]), load(&c[2])],
            d: [load(&c[3]), load(&c[4]), load(&c[5])],
            t_min: load(&c[6]),
            t_max: load(&c[7]),
        };
        finish(&soa, &mut out[..n]);
    }

    /// The prepared eye rays of the block (see [`super::eye_block`]).
    ///
    /// # Safety
    /// The CPU must support AVX-512 F.
    #[target_feature(enable = "avx512f")]
    pub unsafe fn eye_block(
        cam: &Camera<f32>,
        x0: u32,
        y0: u32,
        w: u32,
        h: u32,
        out: &mut [PreparedRay<f32>],
    ) {
        let n = (w * h) as usize;
        // Lane i is pixel (x0 + i mod w, y0 + i div w); lanes past the block repeat lane 0.
        let (mut px, mut py) = ([x0; LANES], [y0; LANES]);
        for i in 0..n {
            px[i] = x0 + i as u32 % w;
            py[i] = y0 + i as u32 / w;
        }
        let half = _mm512_set1_ps(0.5);
        let load = |a: &[u32; LANES]| _mm512_loadu_si512(a.as_ptr().cast());
        // camera.ray(x + ½, y + ½): `from_u32` rounds to nearest like `vcvtudq2ps`.
        let sx = _mm512_add_ps(_mm512_cvtepu32_ps(load(&px)), half);
        let sy = _mm512_add_ps(_mm512_cvtepu32_ps(load(&py)), half);
        let cx = _mm512_sub_ps(sx, _mm512_set1_ps(cam.width as f32 * 0.5));
        let cy = _mm512_sub_ps(_mm512_set1_ps(cam.height as f32 * 0.5), sy);
        let pixel = _mm512_set1_ps(cam.pixel);
        let (a, b) = (_mm512_mul_ps(cx, pixel), _mm512_mul_ps(cy, pixel));
        let (f, r, u) = (cam.forward, cam.right, cam.up);
        // forward + right·a + up·b, left to right.
        let axis = |f: f32, r: f32, u: f32| {
            _mm512_add_ps(
                _mm512_add_ps(_mm512_set1_ps(f), _mm512_mul_ps(_mm512_set1_ps(r), a)),
                _mm512_mul_ps(_mm512_set1_ps(u), b),
            )
        };
        let d = [axis(f.x, r.x, u.x), axis(f.y, r.y, u.y), axis(f.z, r.z, u.z)];
        // normalize: d · (1 / sqrt(x·x + y·y + z·z)).
        let len2 = _mm512_add_ps(
            _mm512_add_ps(_mm512_mul_ps(d[0], d[0]), _mm512_mul_ps(d[1], d[1])),
            _mm512_mul_ps(d[2], d[2]),
        );
        let inv_len = _mm512_div_ps(_mm512_set1_ps(1.0), _mm512_sqrt_ps(len2));
        let soa = Soa {
            o: [
                _mm512_set1_ps(cam.eye.x),
                _mm512_set1_ps(cam.eye.y),
                _mm512_set1_ps(cam.eye.z),
            ],
            d: [
                _mm512_mul_ps(d[0], inv_len),
                _mm512_mul_ps(d[1], inv_len),
                _mm512_mul_ps(d[2], inv_len),
            ],
            t_min: _mm512_set1_ps(cam.hither),
            t_max: _mm512_set1_ps(f32::INFINITY),
        };
        finish(&soa, &mut out[..n]);
    }

    /// [`PreparedRay::new`] for the lanes of `r`, into `out` (lane `i` into `out[i]`).
    #[target_feature(enable = "avx512f")]
    #[inline]
    fn finish(r: &Soa, out: &mut [PreparedRay<f32>]) {
        let one = _mm512_set1_ps(1.0);
        let d = &r.d;
        let inv = [
            _mm512_div_ps(one, d[0]),
            _mm512_div_ps(one, d[1]),
            _mm512_div_ps(one, d[2]),
        ];
        // max_abs_axis: x if |x| > |y| and |x| > |z|; else y if not |x| > |y| and |y| > |z|;
        // else z (ordered comparisons: false on NaN, like `>`).
        let ad = [_mm512_abs_ps(d[0]), _mm512_abs_ps(d[1]), _mm512_abs_ps(d[2])];
        let xy = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(ad[0], ad[1]);
        let xz = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(ad[0], ad[2]);
        let yz = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(ad[1], ad[2]);
        let z0 = xy & xz;
        let z1 = !xy & yz;
        let z2 = !(z0 | z1);
        // kx follows kz, ky follows kx (0 → 1 → 2 → 0), swapped where d[kz] < 0.
        let dz = pick(z0, z1, d);
        let swap = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(dz, _mm512_setzero_ps());
        let (x0, x1, y0, y1) = (z2, z0, z1, z2);
        let (x0, x1, y0, y1) = (
            (x0 & !swap) | (y0 & swap),
            (x1 & !swap) | (y1 & swap),
            (y0 & !swap) | (x0 & swap),
            (y1 & !swap) | (x1 & swap),
        );
        let shear = [
            store(_mm512_div_ps(pick(x0, x1, d), dz)),
            store(_mm512_div_ps(pick(y0, y1, d), dz)),
            store(pick(z0, z1, &inv)),
        ];
        let zero = _mm512_setzero_ps();
        let neg = inv.map(|v| _mm512_cmp_ps_mask::<_CMP_LT_OQ>(v, zero));
        let (o, dd) = (r.o.map(|v| store(v)), r.d.map(|v| store(v)));
        let inv = inv.map(|v| store(v));
        let (t_min, t_max) = (store(r.t_min), store(r.t_max));
        let axis = |m0: u16, m1: u16, i: usize| {
            if m0 >> i & 1 != 0 {
                0
            } else if m1 >> i & 1 != 0 {
                1
            } else {
                2
            }
        };
        for (i, p) in out.iter_mut().enumerate().take(LANES) {
            *p = PreparedRay {
                ray: Ray {
                    o: V3::new(o[0][i], o[1][i], o[2][i]),
                    d: V3::new(dd[0][i], dd[1][i], dd[2][i]),
                    t_min: t_min[i],
                    t_max: t_max[i],
                },
                inv_d: V3::new(inv[0][i], inv[1][i], inv[2][i]),
                neg: neg.map(|m| m >> i & 1 != 0),
                kz: axis(z0, z1, i),
                kx: axis(x0, x1, i),
                ky: axis(y0, y1, i),
                shear: V3::new(shear[0][i], shear[1][i], shear[2][i]),
            };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::description::View;
    use crate::vec3::V3;
    use proptest::prelude::*;

    /// Asserts two prepared rays are the same bits.
    fn same(a: &PreparedRay<f32>, b: &PreparedRay<f32>) {
        let bits = |p: &PreparedRay<f32>| {
            let v = [p.ray.o, p.ray.d, p.inv_d, p.shear];
            let mut out: Vec<u32> = v
                .iter()
                .flat_map(|v| [v.x, v.y, v.z])
                .map(f32::to_bits)
                .collect();
            out.extend([p.ray.t_min.to_bits(), p.ray.t_max.to_bits()]);
            out.extend(p.neg.map(u32::from));
            out.extend([p.kx, p.ky, p.kz].map(|k| k as u32));
            out
        };
        assert_eq!(bits(a), bits(b), "{a:?} against {b:?}");
    }

    fn comp() -> impl Strategy<Value = f32> {
        prop_oneof![
            4 => -2.0f32..2.0,
            1 => Just(0.0f32),
            1 => Just(-0.0f32),
            1 => Just(1.0f32),
            1 => Just(-1.0f32),
            1 => Just(f32::NAN),
            1 => -1.0e-30f32..1.0e-30,
            1 => -3.0e30f32..3.0e30,
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        /// The AVX-512 set-up gives every ray the bits `PreparedRay::new` gives it alone: zero
        /// and −0 components (infinite reciprocals), ties between components' magnitudes (the
        /// axis permutation's order), NaN, tiny and huge components, 1 to 16 rays.
        #[test]
        fn prepare_is_prepared_ray_new(
            rays in proptest::collection::vec(
                (proptest::array::uniform3(comp()), proptest::array::uniform3(comp()),
                 0.0f32..1.0, prop_oneof![Just(f32::INFINITY), 0.0f32..30.0]),
                1..=LANES),
        ) {
            let rays: Vec<Ray<f32>> = rays
                .iter()
                .map(|(o, d, t_min, t_max)| Ray {
                    o: V3::from_array(*o),
                    d: V3::from_array(*d),
                    t_min: *t_min,
                    t_max: *t_max,
                })
                .collect();
            let want: Vec<_> = rays.iter().map(|r| PreparedRay::new(*r)).collect();
            let mut got = want.clone();
            let blank = PreparedRay::new(Ray { o: V3::zero(), d: V3::new(0.0, 0.0, 1.0), t_min: 0.0, t_max: 1.0 });
            got.fill(blank);
            prepare(&rays, &mut got);
            for (g, w) in got.iter().zip(&want) {
                same(g, w);
            }
            #[cfg(target_arch = "x86_64")]
            if crate::isa::Isa::Avx512.supported() {
                got.fill(blank);
                // SAFETY: this CPU has AVX-512 F.
                unsafe { avx512::prepare(&rays, &mut got) };
                for (g, w) in got.iter().zip(&want) {
                    same(g, w);
                }
            }
        }

        /// The eye rays of a block are `camera.ray` of each pixel centre, prepared, bit for bit,
        /// for cameras looking every way and blocks anywhere in images of any size.
        #[test]
        fn eye_block_is_camera_ray(
            from in proptest::array::uniform3(-100.0f64..100.0),
            at in proptest::array::uniform3(-100.0f64..100.0),
            up in proptest::array::uniform3(-1.0f64..1.0),
            angle in 1.0f64..170.0,
            hither in prop_oneof![Just(0.0f64), 0.0f64..1.0],
            size in (1u32..3000, 1u32..3000),
            corner in (0.0f64..1.0, 0.0f64..1.0),
            block in (1u32..=4, 1u32..=4),
        ) {
            let view = View {
                from: V3::from_array(from),
                at: V3::from_array(at),
                up: V3::from_array(up),
                angle,
                hither,
                width: size.0,
                height: size.1,
            };
            let cam: Camera<f32> = Camera::new(&view, size.0, size.1);
            let x0 = (corner.0 * f64::from(size.0)) as u32;
            let y0 = (corner.1 * f64::from(size.1)) as u32;
            let (w, h) = block;
            let blank = PreparedRay::new(cam.ray(0.5, 0.5));
            let mut want = Vec::new();
            for y in y0..y0 + h {
                for x in x0..x0 + w {
                    want.push(PreparedRay::new(cam.ray(x as f32 + 0.5, y as f32 + 0.5)));
                }
            }
            let mut got = [blank; LANES];
            prop_assert_eq!(eye_block(&cam, x0, y0, w, h, &mut got), want.len());
            for (g, w) in got.iter().zip(&want) {
                same(g, w);
            }
            #[cfg(target_arch = "x86_64")]
            if crate::isa::Isa::Avx512.supported() {
                let mut got = [blank; LANES];
                // SAFETY: this CPU has AVX-512 F.
                unsafe { avx512::eye_block(&cam, x0, y0, w, h, &mut got) };
                for (g, w) in got.iter().zip(&want) {
                    same(g, w);
                }
            }
        }
    }
}
