//! A packet's interval bounds ([`Frustum`]): the least and greatest origin and reciprocal
//! direction of its rays per axis, and the node test those bounds make — conservative in
//! floating point, so a node one ray would enter is entered.

use super::{COHERENCE, PACKET};
use crate::accel::bvh::wide::WIDTH;
use crate::geometry::ray_packet::RayPacket;
use crate::geometry::slab::Box8;
use crate::geometry::PreparedRay;
#[cfg(target_arch = "x86_64")]
use crate::packet::leaf::f32_rays;
use crate::real::Real;
#[cfg(target_arch = "x86_64")]
use std::any::Any;

/// Interval bounds of a packet's rays, per axis.
#[derive(Clone, Copy, Debug)]
pub(super) struct Frustum<R> {
    pub(super) o_lo: [R; 3],
    pub(super) o_hi: [R; 3],
    pub(super) inv_lo: [R; 3],
    pub(super) inv_hi: [R; 3],
    pub(super) neg: [bool; 3],
    pub(super) t_min: R,
}

impl Frustum<f32> {
    /// Bounds of a packet in lanes whose direction signs are `neg`, to be filled in: every
    /// bound 0, the start `t_min`.
    #[inline(always)]
    fn unfilled(neg: [bool; 3], t_min: f32) -> Self {
        Frustum {
            o_lo: [0.0; 3],
            o_hi: [0.0; 3],
            inv_lo: [0.0; 3],
            inv_hi: [0.0; 3],
            neg,
            t_min,
        }
    }
}

impl<R: Real> Frustum<R> {
    /// The bounds of `rays`, or `None` when they cannot be bounded this way: mixed direction
    /// signs on an axis, a zero (infinite reciprocal) direction component, or a non-finite
    /// origin or start.
    pub(super) fn new(rays: &[PreparedRay<R>]) -> Option<Self> {
        #[cfg(target_arch = "x86_64")]
        if let (Some(rays), true) = (f32_rays(rays), crate::isa::current().sse2()) {
            let f: &dyn Any = &frustum_sse2(rays)?;
            return f.downcast_ref::<Frustum<R>>().copied();
        }
        let first = rays.first()?;
        let o = |r: &PreparedRay<R>| [r.ray.o.x, r.ray.o.y, r.ray.o.z];
        let inv = |r: &PreparedRay<R>| [r.inv_d.x, r.inv_d.y, r.inv_d.z];
        let mut f = Frustum {
            o_lo: o(first),
            o_hi: o(first),
            inv_lo: inv(first),
            inv_hi: inv(first),
            neg: first.neg,
            t_min: first.ray.t_min,
        };
        // One pass without early exits (a packet is rejected rarely): the bounds, whether
        // every ray can be bounded, and the shortest ray. The bounds are compare-and-select
        // (one `minps`/`maxps` each, where `f32::min` adds a NaN test and a blend): a NaN
        // bound value comes with `ok` false, and a NaN end leaves the shortest as it was, as
        // `f32::min` does.
        let mut ok = true;
        let mut shortest = R::INFINITY;
        for r in rays {
            ok &= (r.neg == f.neg) & r.ray.t_min.is_finite();
            let (ro, ri) = (o(r), inv(r));
            for a in 0..3 {
                ok &= ro[a].is_finite() & ri[a].is_finite();
                f.o_lo[a] = lower(f.o_lo[a], ro[a]);
                f.o_hi[a] = upper(f.o_hi[a], ro[a]);
                f.inv_lo[a] = lower(f.inv_lo[a], ri[a]);
                f.inv_hi[a] = upper(f.inv_hi[a], ri[a]);
            }
            f.t_min = lower(f.t_min, r.ray.t_min);
            shortest = lower(shortest, r.ray.t_max);
        }
        if !ok {
            return None;
        }
        f.coherent(shortest)
    }

    /// `self` when its origins are close enough for its shortest ray, `shortest`. Rays whose
    /// origins spread widely compared with their length (shadow rays from both sides of a
    /// silhouette) make loose bounds that let the packet into far more nodes than any of its
    /// rays: those go one by one.
    #[inline(always)]
    fn coherent(self, shortest: R) -> Option<Self> {
        let mut spread = R::ZERO;
        for a in 0..3 {
            spread = spread.max(self.o_hi[a] - self.o_lo[a]);
        }
        if spread > R::from_f64(COHERENCE) * shortest {
            return None;
        }
        Some(self)
    }

    /// [`Frustum::new`] of a packet in lanes (its lanes past the packet repeat lane 0, so
    /// the bounds over all sixteen are the bounds of its rays).
    #[inline(always)]
    pub(super) fn from_lanes(l: &RayPacket) -> Option<Frustum<f32>> {
        let s = &l.slab;
        let mut f = Frustum::unfilled(s.neg, s.t_min[0]);
        let mut ok = true;
        for a in 0..3 {
            let (o, inv) = (&s.o[a], &s.inv[a]);
            let (mut o_lo, mut o_hi, mut i_lo, mut i_hi) = (o[0], o[0], inv[0], inv[0]);
            for i in 0..PACKET {
                ok &= o[i].is_finite() & inv[i].is_finite() & ((inv[i] < 0.0) == s.neg[a]);
                o_lo = o_lo.min(o[i]);
                o_hi = o_hi.max(o[i]);
                i_lo = i_lo.min(inv[i]);
                i_hi = i_hi.max(inv[i]);
            }
            (f.o_lo[a], f.o_hi[a], f.inv_lo[a], f.inv_hi[a]) = (o_lo, o_hi, i_lo, i_hi);
        }
        let mut shortest = f32::INFINITY;
        for i in 0..PACKET {
            ok &= s.t_min[i].is_finite();
            f.t_min = f.t_min.min(s.t_min[i]);
            shortest = shortest.min(l.t_max[i]);
        }
        if !ok {
            return None;
        }
        let mut spread = 0.0f32;
        for a in 0..3 {
            spread = spread.max(f.o_hi[a] - f.o_lo[a]);
        }
        if spread > COHERENCE as f32 * shortest {
            return None;
        }
        Some(f)
    }

    /// The children of a node against the packet: bit `i` is set when some ray of the packet
    /// may enter lane `i` before `t_max`; the distances are lower bounds of every ray's entry
    /// distance into the lane.
    #[inline(always)]
    pub(super) fn test8(&self, b: &Box8, t_max: R) -> (u32, [R; WIDTH]) {
        let widen = R::ONE + R::TWO * R::gamma(3);
        let mut t0 = [self.t_min; WIDTH];
        let mut t1 = [t_max; WIDTH];
        for a in 0..3 {
            let (near, far) = if self.neg[a] {
                (&b.hi[a], &b.lo[a])
            } else {
                (&b.lo[a], &b.hi[a])
            };
            let (il, ih) = (self.inv_lo[a], self.inv_hi[a]);
            for i in 0..WIDTH {
                let n = R::from_f32(near[i]);
                let (xl, xh) = (n - self.o_hi[a], n - self.o_lo[a]);
                let lo = (xl * il).min(xl * ih).min((xh * il).min(xh * ih));
                let f = R::from_f32(far[i]);
                let (yl, yh) = (f - self.o_hi[a], f - self.o_lo[a]);
                let hi = (yl * il).max(yl * ih).max((yh * il).max(yh * ih)) * widen;
                t0[i] = t0[i].max(lo);
                t1[i] = t1[i].min(hi);
            }
        }
        let mut mask = 0;
        for i in 0..WIDTH {
            if t0[i] <= t1[i] {
                mask |= 1 << i;
            }
        }
        (mask, t0)
    }
}

/// `x` when it is below `acc`, else `acc` (`minps`'s rule, with `x` first: a NaN `x` keeps
/// `acc`). Where `acc` is not NaN, the value `acc.min(x)` gives (and the bits, as `f32::min`
/// is compiled for x86-64: `minps` and a NaN blend).
#[inline(always)]
fn lower<R: Real>(acc: R, x: R) -> R {
    if x < acc {
        x
    } else {
        acc
    }
}

/// `x` when it is above `acc`, else `acc`: [`lower`]'s mirror image (`maxps`).
#[inline(always)]
fn upper<R: Real>(acc: R, x: R) -> R {
    if x > acc {
        x
    } else {
        acc
    }
}

/// [`Frustum::new`] of `f32` rays where the tier runs SSE2 (every tier but `scalar`): a ray's
/// origin with its start, and its reciprocal direction, are one four-lane register each, so a
/// ray costs one `minps` and one `maxps` per register and one compare per register for
/// finiteness, where the scalar pass does each axis alone. The same decision, and the same
/// bounds in the same bits: [`lower`] and [`upper`] are `minps` and `maxps` lane by lane.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn frustum_sse2(rays: &[PreparedRay<f32>]) -> Option<Frustum<f32>> {
    use crate::lanes::{Lanes, Mask, X4};
    let first = rays.first()?;
    let (mut lo, mut hi) = (origin_start(first), origin_start(first));
    let (mut inv_lo, mut inv_hi) = (inverse(first), inverse(first));
    let inf = X4::splat(f32::INFINITY);
    let mut finite = 0b1111;
    let mut signs = true;
    let mut shortest = f32::INFINITY;
    for r in rays {
        let (o, inv) = (origin_start(r), inverse(r));
        finite &= o.abs().lt(inf).bits() & inv.abs().lt(inf).bits();
        signs &= r.neg == first.neg;
        lo = o.min_or(lo);
        hi = o.max_or(hi);
        inv_lo = inv.min_or(inv_lo);
        inv_hi = inv.max_or(inv_hi);
        shortest = lower(shortest, r.ray.t_max);
    }
    if finite != 0b1111 || !signs {
        return None;
    }
    let mut b = [[0.0; 4]; 4];
    for (v, out) in [lo, hi, inv_lo, inv_hi].into_iter().zip(&mut b) {
        v.store(out);
    }
    let xyz = |v: [f32; 4]| [v[0], v[1], v[2]];
    let f = Frustum {
        o_lo: xyz(b[0]),
        o_hi: xyz(b[1]),
        inv_lo: xyz(b[2]),
        inv_hi: xyz(b[3]),
        neg: first.neg,
        t_min: b[0][3],
    };
    f.coherent(shortest)
}

/// A ray's origin and, in the fourth lane, its start.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn origin_start(r: &PreparedRay<f32>) -> crate::lanes::X4 {
    let o = r.ray.o;
    crate::lanes::Lanes::load(&[o.x, o.y, o.z, r.ray.t_min])
}

/// A ray's reciprocal direction, its last component again in the fourth lane.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn inverse(r: &PreparedRay<f32>) -> crate::lanes::X4 {
    let i = r.inv_d;
    crate::lanes::Lanes::load(&[i.x, i.y, i.z, i.z])
}

/// [`Frustum::from_lanes`] for the `avx2` tier: the sixteen lanes of a row as two eight-lane
/// registers, their `vminps`/`vmaxps`, and that register reduced by shuffles (the bounds of
/// finite lanes, where the order of the reduction changes at most the sign of a zero bound,
/// which no comparison of the walk sees); each check a compare and a `movemask` per register.
/// An end that is NaN counts as +∞ for the shortest ray, as `f32::min` takes it.
///
/// # Safety
/// The CPU must support AVX and AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,avx2")]
pub(super) unsafe fn frustum_avx2(l: &RayPacket) -> Option<Frustum<f32>> {
    use std::arch::x86_64::*;
    let s = &l.slab;
    let inf = _mm256_set1_ps(f32::INFINITY);
    let zero = _mm256_setzero_ps();
    let mut ok = true;
    let mut f = Frustum::unfilled(s.neg, 0.0);
    for a in 0..3 {
        let (o, inv) = (halves(&s.o[a]), halves(&s.inv[a]));
        let neg = if s.neg[a] { 0xff } else { 0 };
        for h in 0..2 {
            let below = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(inv[h], zero));
            ok &= ((finite(o[h]) & finite(inv[h])) == 0xff) & (below == neg);
        }
        f.o_lo[a] = reduce::<LEAST>(_mm256_min_ps(o[0], o[1]));
        f.o_hi[a] = reduce::<GREATEST>(_mm256_max_ps(o[0], o[1]));
        f.inv_lo[a] = reduce::<LEAST>(_mm256_min_ps(inv[0], inv[1]));
        f.inv_hi[a] = reduce::<GREATEST>(_mm256_max_ps(inv[0], inv[1]));
    }
    let t_min = halves(&s.t_min);
    ok &= (finite(t_min[0]) & finite(t_min[1])) == 0xff;
    if !ok {
        return None;
    }
    f.t_min = reduce::<LEAST>(_mm256_min_ps(t_min[0], t_min[1]));
    // `vminps` answers its second operand where the first is NaN.
    let t_max = halves(&l.t_max);
    let shortest = reduce::<LEAST>(_mm256_min_ps(t_max[1], _mm256_min_ps(t_max[0], inf)));
    f.coherent(shortest)
}

/// The two halves of a row of sixteen lanes.
///
/// # Safety
/// The CPU must support AVX.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn halves(a: &[f32; PACKET]) -> [std::arch::x86_64::__m256; 2] {
    use std::arch::x86_64::*;
    // SAFETY: each load reads eight `f32` of the sixteen of `a` (unaligned loads).
    unsafe {
        [
            _mm256_loadu_ps(a.as_ptr()),
            _mm256_loadu_ps(a[8..].as_ptr()),
        ]
    }
}

/// Bit `i` set where lane `i` of `v` is finite.
///
/// # Safety
/// The CPU must support AVX.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn finite(v: std::arch::x86_64::__m256) -> i32 {
    use std::arch::x86_64::*;
    // SAFETY: AVX instructions on registers.
    unsafe {
        let abs = _mm256_and_ps(v, _mm256_castsi256_ps(_mm256_set1_epi32(0x7fff_ffff)));
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(
            abs,
            _mm256_set1_ps(f32::INFINITY),
        ))
    }
}

/// Which of [`reduce`]'s answers: the least of the lanes.
const LEAST: bool = false;
/// Which of [`reduce`]'s answers: the greatest of the lanes.
const GREATEST: bool = true;

/// The least ([`LEAST`]) or the greatest ([`GREATEST`]) of eight lanes (none NaN where it is
/// used): each lane against its partner in the other half, then in the other pair, then next
/// door, so that every lane holds the answer.
///
/// # Safety
/// The CPU must support AVX.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn reduce<const MAX: bool>(v: std::arch::x86_64::__m256) -> f32 {
    use std::arch::x86_64::*;
    // SAFETY: AVX instructions on registers.
    unsafe {
        let pick = |a, b| {
            if MAX {
                _mm256_max_ps(a, b)
            } else {
                _mm256_min_ps(a, b)
            }
        };
        let v = pick(v, _mm256_permute2f128_ps::<0x01>(v, v));
        let v = pick(v, _mm256_permute_ps::<0b01_00_11_10>(v));
        _mm256_cvtss_f32(pick(v, _mm256_permute_ps::<0b10_11_00_01>(v)))
    }
}

/// [`Frustum::from_lanes`] for the `avx512` tier: each bound a reduction of one register
/// (`vminps`/`vmaxps`: the bounds of finite lanes, where the order of the reduction changes
/// at most the sign of a zero bound, which no comparison of the walk sees), each check one
/// mask. An end that is NaN counts as +∞ for the shortest ray, as `f32::min` takes it.
///
/// # Safety
/// The CPU must support AVX-512 F.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
pub(super) unsafe fn frustum_avx512(l: &RayPacket) -> Option<Frustum<f32>> {
    use std::arch::x86_64::*;
    let s = &l.slab;
    // SAFETY: every load reads sixteen `f32` of a `[f32; 16]` (unaligned loads).
    let load = |a: &[f32; PACKET]| unsafe { _mm512_loadu_ps(a.as_ptr()) };
    let inf = _mm512_set1_ps(f32::INFINITY);
    let finite = |v: __m512| _mm512_cmp_ps_mask::<_CMP_LT_OQ>(_mm512_abs_ps(v), inf);
    let zero = _mm512_setzero_ps();
    let mut ok = 0xffffu16;
    let mut f = Frustum::unfilled(s.neg, 0.0);
    for a in 0..3 {
        let (o, inv) = (load(&s.o[a]), load(&s.inv[a]));
        let neg = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(inv, zero);
        ok &= finite(o) & finite(inv) & if s.neg[a] { neg } else { !neg };
        f.o_lo[a] = _mm512_reduce_min_ps(o);
        f.o_hi[a] = _mm512_reduce_max_ps(o);
        f.inv_lo[a] = _mm512_reduce_min_ps(inv);
        f.inv_hi[a] = _mm512_reduce_max_ps(inv);
    }
    let t_min = load(&s.t_min);
    ok &= finite(t_min);
    if ok != 0xffff {
        return None;
    }
    f.t_min = _mm512_reduce_min_ps(t_min);
    let t_max = load(&l.t_max);
    let nan = _mm512_cmp_ps_mask::<_CMP_UNORD_Q>(t_max, t_max);
    let shortest = _mm512_reduce_min_ps(_mm512_mask_blend_ps(nan, t_max, inf));
    let mut spread = 0.0f32;
    for a in 0..3 {
        spread = spread.max(f.o_hi[a] - f.o_lo[a]);
    }
    if spread > COHERENCE as f32 * shortest {
        return None;
    }
    Some(f)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Ray;
    use crate::vec3::V3;
    use proptest::prelude::*;

    fn comp() -> impl Strategy<Value = f32> {
        prop_oneof![
            6 => 0.1f32..4.0,
            1 => Just(0.0f32),
            1 => Just(-0.0f32),
            1 => Just(f32::INFINITY),
            1 => Just(f32::NAN),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        /// The AVX-512 and AVX2 bounds of a packet in lanes are the portable ones: the same
        /// decision (signs, finiteness, coherence) and the same bound values.
        #[test]
        fn simd_bounds_are_the_portable_bounds(
            base in proptest::array::uniform3(-5.0f32..5.0),
            signs in proptest::array::uniform3(any::<bool>()),
            rays in proptest::collection::vec(
                (proptest::array::uniform3(prop_oneof![4 => 0.0f32..0.01, 1 => 0.0f32..2.0]),
                 proptest::array::uniform3(comp()), any::<bool>(),
                 prop_oneof![Just(f32::INFINITY), Just(f32::NAN), 0.0f32..50.0, 0.0f32..0.5],
                 prop_oneof![4 => Just(0.0f32), 1 => 0.0f32..1.0, 1 => Just(f32::NAN)]),
                1..=PACKET),
        ) {
            #[cfg(target_arch = "x86_64")]
            {
                let mut l = RayPacket::new();
                for &(jitter, d, flip, t_max, t_min) in &rays {
                    let o = V3::from_array([0, 1, 2].map(|a| base[a] + jitter[a]));
                    let mut d = [0, 1, 2].map(|a| if signs[a] { -d[a] } else { d[a] });
                    if flip {
                        d[0] = -d[0];
                    }
                    l.push(&Ray { o, d: V3::from_array(d), t_min, t_max });
                }
                l.prepare();
                let want = Frustum::<f32>::from_lanes(&l);
                let mut got = Vec::new();
                if crate::isa::Isa::Avx512.supported() {
                    // SAFETY: this CPU has AVX-512 F.
                    got.push(unsafe { frustum_avx512(&l) });
                }
                if crate::isa::Isa::Avx2.supported() {
                    // SAFETY: this CPU has AVX and AVX2.
                    got.push(unsafe { frustum_avx2(&l) });
                }
                for got in got {
                    prop_assert_eq!(want.is_some(), got.is_some(), "{:?} {:?}", want, got);
                    if let (Some(w), Some(g)) = (want, got) {
                        // Values, not bits: the sign of a zero bound may differ (see
                        // frustum_avx512).
                        prop_assert!(w.o_lo == g.o_lo && w.o_hi == g.o_hi, "{:?} {:?}", w, g);
                        prop_assert!(w.inv_lo == g.inv_lo && w.inv_hi == g.inv_hi, "{:?} {:?}", w, g);
                        prop_assert!(w.neg == g.neg && w.t_min == g.t_min, "{:?} {:?}", w, g);
                    }
                }
            }
        }
    }
}
