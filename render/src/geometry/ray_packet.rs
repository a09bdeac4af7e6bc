//! A packet of up to sixteen `f32` rays that lives in lanes (structure of arrays) from the moment
//! its rays are made: the eye rays of a 4 × 4 block straight from the camera, or shadow rays
//! written lane by lane. Everything [`PreparedRay::new`] computes — reciprocals, direction
//! signs, the watertight triangle test's axis permutation and shear — is computed here for the
//! sixteen lanes at once, in the same IEEE operations and order (no FMA, exact divisions and
//! square roots), into the forms the packet walk's box test ([`LeafRays`]) and the leaf kernels
//! ([`ShearedRays`]) read. A [`PreparedRay`] is made only for a ray that leaves the packet
//! ([`RayPacket::prepared`]), and it is the same bits as the lanes.
//!
//! The lane loops are portable; on the `avx2` and `avx512` tiers ([`crate::isa`]) the same
//! loops are compiled with those instruction sets enabled, so the compiler runs them eight or
//! sixteen lanes per instruction.

use super::packet_prims::ShearedRays;
use super::ray::{PreparedRay, Ray};
use super::slab::LeafRays;
use crate::camera::Camera;
use crate::isa::Isa;
use crate::vec3::V3;

/// Rays per packet.
pub const LANES: usize = 16;

/// Sixteen rays in lanes. Lanes past [`RayPacket::len`] repeat lane 0 once prepared.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct RayPacket {
    /// Origins, reciprocal directions and starts, for the box test.
    pub slab: LeafRays<f32>,
    /// Origins, directions, permutation and shear, for the triangle and sphere kernels.
    pub tri: ShearedRays,
    /// Ends of the rays' intervals.
    pub t_max: [f32; LANES],
    n: usize,
}

impl Default for RayPacket {
    fn default() -> Self {
        Self::new()
    }
}

impl RayPacket {
    /// An empty packet.
    pub fn new() -> Self {
        RayPacket {
            slab: LeafRays {
                o: [[0.0; LANES]; 3],
                inv: [[0.0; LANES]; 3],
                t_min: [0.0; LANES],
                neg: [false; 3],
            },
            tri: ShearedRays::empty(),
            t_max: [0.0; LANES],
            n: 0,
        }
    }

    /// Rays in the packet.
    #[inline(always)]
    pub fn len(&self) -> usize {
        self.n
    }

    /// Whether the packet has no rays.
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Empties the packet (before [`RayPacket::push`]).
    #[inline(always)]
    pub fn clear(&mut self) {
        self.n = 0;
    }

    /// Appends `ray` as the next lane; [`RayPacket::prepare`] must follow before the packet is
    /// traced.
    ///
    /// # Panics
    /// When the packet already holds [`LANES`] rays.
    #[inline(always)]
    pub fn push(&mut self, ray: &Ray<f32>) {
        let i = self.n;
        assert!(i < LANES, "a packet holds at most {LANES} rays");
        for (a, (o, d)) in ray
            .o
            .to_array()
            .into_iter()
            .zip(ray.d.to_array())
            .enumerate()
        {
            self.tri.o[a][i] = o;
            self.tri.d[a][i] = d;
        }
        self.tri.t_min[i] = ray.t_min;
        self.t_max[i] = ray.t_max;
        self.n = i + 1;
    }

    /// Ray `i` (`i < len`).
    #[inline(always)]
    pub fn ray(&self, i: usize) -> Ray<f32> {
        let l = &self.tri;
        Ray {
            o: V3::new(l.o[0][i], l.o[1][i], l.o[2][i]),
            d: V3::new(l.d[0][i], l.d[1][i], l.d[2][i]),
            t_min: l.t_min[i],
            t_max: self.t_max[i],
        }
    }

    /// Ray `i` prepared for one-by-one traversal: the same values as its lanes.
    #[inline(always)]
    pub fn prepared(&self, i: usize) -> PreparedRay<f32> {
        PreparedRay::new(self.ray(i))
    }

    /// The eye rays of the pixels `bx..bx + bw` × `by..by + bh` (at most [`LANES`]) through their
    /// centres, row by row, prepared: ray `i` is `camera.ray(x + 0.5, y + 0.5)` bit for bit.
    ///
    /// # Panics
    /// When the block has more than [`LANES`] pixels.
    pub fn eye(&mut self, camera: &Camera<f32>, bx: u32, by: u32, bw: u32, bh: u32) {
        let n = (bw * bh) as usize;
        assert!(n <= LANES, "a packet holds at most {LANES} rays");
        let (mut px, mut py) = ([0u32; LANES], [0u32; LANES]);
        let mut i = 0;
        for y in by..by + bh {
            for x in bx..bx + bw {
                (px[i], py[i]) = (x, y);
                i += 1;
            }
        }
        self.n = n;
        self.eye_on(crate::isa::current(), camera, &px, &py);
    }

    /// [`RayPacket::eye`]'s lanes with the code of `tier`, which must be a tier this CPU runs.
    #[inline(always)]
    fn eye_on(&mut self, tier: Isa, camera: &Camera<f32>, px: &[u32; LANES], py: &[u32; LANES]) {
        #[cfg(target_arch = "x86_64")]
        {
            if tier.avx512() {
                // SAFETY: the avx512 tier is only chosen on a CPU with AVX-512 F, BW, DQ, VL.
                return unsafe { eye_avx512(self, camera, px, py) };
            }
            if tier.avx() {
                // SAFETY: the avx2 and avx512 tiers are only chosen on a CPU with AVX and AVX2.
                return unsafe { eye_avx2(self, camera, px, py) };
            }
        }
        let _ = tier;
        eye_lanes(self, camera, px, py);
    }

    /// Computes every lane's per-ray constants from its origin, direction and interval (and
    /// repeats lane 0 past the packet's rays).
    pub fn prepare(&mut self) {
        self.prepare_on(crate::isa::current());
    }

    /// [`RayPacket::prepare`] with the code of `tier`, which must be a tier this CPU runs.
    #[inline(always)]
    fn prepare_on(&mut self, tier: Isa) {
        #[cfg(target_arch = "x86_64")]
        {
            if tier.avx512() {
                // SAFETY: the avx512 tier is only chosen on a CPU with AVX-512 F, BW, DQ, VL.
                return unsafe { prepare_avx512(self) };
            }
            if tier.avx() {
                // SAFETY: the avx2 and avx512 tiers are only chosen on a CPU with AVX and AVX2.
                return unsafe { prepare_avx2(self) };
            }
        }
        let _ = tier;
        prepare_lanes(self);
    }
}

/// [`RayPacket::eye`] compiled for the `avx512` tier.
///
/// # Safety
/// The CPU must support AVX-512 F, BW, DQ and VL.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,avx2,avx512f,avx512bw,avx512dq,avx512vl")]
unsafe fn eye_avx512(l: &mut RayPacket, c: &Camera<f32>, px: &[u32; LANES], py: &[u32; LANES]) {
    eye_lanes(l, c, px, py)
}

/// [`RayPacket::eye`] compiled for the `avx2` tier.
///
/// # Safety
/// The CPU must support AVX and AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,avx2")]
unsafe fn eye_avx2(l: &mut RayPacket, c: &Camera<f32>, px: &[u32; LANES], py: &[u32; LANES]) {
    eye_lanes(l, c, px, py)
}

/// [`RayPacket::prepare`] compiled for the `avx512` tier.
///
/// # Safety
/// The CPU must support AVX-512 F, BW, DQ and VL.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,avx2,avx512f,avx512bw,avx512dq,avx512vl")]
unsafe fn prepare_avx512(l: &mut RayPacket) {
    prepare_lanes(l)
}

/// [`RayPacket::prepare`] compiled for the `avx2` tier.
///
/// # Safety
/// The CPU must support AVX and AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,avx2")]
unsafe fn prepare_avx2(l: &mut RayPacket) {
    prepare_lanes(l)
}

/// The eye rays of pixels `(px[i], py[i])` for the packet's lanes (lanes past it take lane 0's
/// pixel): [`Camera::ray`]'s operations lane by lane, then [`prepare_lanes`].
// Lane loops index several arrays by lane: the form the compiler vectorises.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn eye_lanes(l: &mut RayPacket, c: &Camera<f32>, px: &[u32; LANES], py: &[u32; LANES]) {
    let n = l.n;
    let half_w = c.width as f32 * 0.5;
    let half_h = c.height as f32 * 0.5;
    let (f, r, u) = (c.forward.to_array(), c.right.to_array(), c.up.to_array());
    let eye = c.eye.to_array();
    let mut d = [[0.0f32; LANES]; 3];
    for i in 0..LANES {
        let k = if i < n { i } else { 0 };
        let sx = px[k] as f32 + 0.5;
        let sy = py[k] as f32 + 0.5;
        let cx = (sx - half_w) * c.pixel;
        let cy = (half_h - sy) * c.pixel;
        let v = [0, 1, 2].map(|a| f[a] + r[a] * cx + u[a] * cy);
        let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let s = 1.0 / len;
        for a in 0..3 {
            d[a][i] = v[a] * s;
        }
    }
    l.tri.d = d;
    for a in 0..3 {
        l.tri.o[a] = [eye[a]; LANES];
    }
    l.tri.t_min = [c.hither; LANES];
    l.t_max = [f32::INFINITY; LANES];
    prepare_lanes(l);
}

/// One of three values by axis `k`.
#[inline(always)]
fn pick(k: u32, v: [f32; 3]) -> f32 {
    if k == 0 {
        v[0]
    } else if k == 1 {
        v[1]
    } else {
        v[2]
    }
}

/// Bit `i` set where byte `i` of `b` (each 0 or 1) is 1. Eight bytes at a time as one
/// little-endian word: the product with `0x0102040810204080` (bits `8k + 7 − k`, `k` = 0..7)
/// copies byte `j`'s bit to bits `8(j + k) + 7 − k`; only `k = 7 − j` lands in the top byte,
/// at bit `56 + j`, and the copies below it are distinct bits, so nothing carries.
#[inline(always)]
fn lane_bits(b: &[u8; LANES]) -> u16 {
    let gather = |h: usize| {
        let mut w = [0u8; 8];
        w.copy_from_slice(&b[8 * h..8 * h + 8]);
        (u64::from_le_bytes(w).wrapping_mul(0x0102_0408_1020_4080) >> 56) as u16
    };
    gather(0) | gather(1) << 8
}

/// [`PreparedRay::new`] lane by lane, into the box test's and the kernels' lanes.
// Lane loops index several arrays by lane: the form the compiler vectorises.
#[allow(clippy::needless_range_loop)]
#[inline(always)]
fn prepare_lanes(l: &mut RayPacket) {
    let n = l.n.max(1);
    for i in n..LANES {
        for a in 0..3 {
            l.tri.o[a][i] = l.tri.o[a][0];
            l.tri.d[a][i] = l.tri.d[a][0];
        }
        l.tri.t_min[i] = l.tri.t_min[0];
        l.t_max[i] = l.t_max[0];
    }
    let t = &mut l.tri;
    let s = &mut l.slab;
    // Per axis and lane, 1 where the permuted axis is x (`is0`) or y (`is1`), else 0: bytes
    // the lane loop writes side by side, gathered into the mask bits after it.
    let (mut is0, mut is1) = ([[0u8; LANES]; 3], [[0u8; LANES]; 3]);
    for i in 0..LANES {
        let d = [t.d[0][i], t.d[1][i], t.d[2][i]];
        let o = [t.o[0][i], t.o[1][i], t.o[2][i]];
        let inv = [1.0 / d[0], 1.0 / d[1], 1.0 / d[2]];
        let (ax, ay, az) = (d[0].abs(), d[1].abs(), d[2].abs());
        // `V3::max_abs_axis`, then the permutation of `PreparedRay::new`.
        let kz: u32 = if ax > ay {
            if ax > az {
                0
            } else {
                2
            }
        } else if ay > az {
            1
        } else {
            2
        };
        let kx0 = if kz == 2 { 0 } else { kz + 1 };
        let ky0 = if kx0 == 2 { 0 } else { kx0 + 1 };
        let dz = pick(kz, d);
        let (kx, ky) = if dz < 0.0 { (ky0, kx0) } else { (kx0, ky0) };
        let shear = [pick(kx, d) / dz, pick(ky, d) / dz, pick(kz, inv)];
        let ks = [kx, ky, kz];
        for a in 0..3 {
            s.o[a][i] = o[a];
            s.inv[a][i] = inv[a];
            t.ok[a][i] = pick(ks[a], o);
            t.s[a][i] = shear[a];
            is0[a][i] = u8::from(ks[a] == 0);
            is1[a][i] = u8::from(ks[a] == 1);
            let ones = |on: bool| f32::from_bits(if on { u32::MAX } else { 0 });
            t.k0[a][i] = ones(ks[a] == 0);
            t.k1[a][i] = ones(ks[a] == 1);
        }
        s.t_min[i] = t.t_min[i];
        t.a[i] = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    }
    for a in 0..3 {
        t.k0_bits[a] = lane_bits(&is0[a]);
        t.k1_bits[a] = lane_bits(&is1[a]);
        s.neg[a] = s.inv[a][0] < 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::description::View;
    use proptest::prelude::*;

    /// Asserts that lane `i` holds `pr`'s values bit for bit, in both lane forms.
    fn assert_lane(l: &RayPacket, i: usize, pr: &PreparedRay<f32>, what: &str) {
        let want = ShearedRays::lanes(std::slice::from_ref(pr));
        let bits = |x: f32| x.to_bits();
        let r = &pr.ray;
        assert_eq!(
            l.ray(i).o.to_array().map(bits),
            r.o.to_array().map(bits),
            "{what}"
        );
        assert_eq!(
            l.ray(i).d.to_array().map(bits),
            r.d.to_array().map(bits),
            "{what}"
        );
        assert_eq!(bits(l.tri.t_min[i]), bits(r.t_min), "{what}");
        assert_eq!(bits(l.t_max[i]), bits(r.t_max), "{what}");
        for a in 0..3 {
            assert_eq!(bits(l.slab.o[a][i]), bits(r.o.get(a)), "{what}");
            assert_eq!(bits(l.slab.inv[a][i]), bits(pr.inv_d.get(a)), "{what}");
            assert_eq!(l.slab.inv[a][i] < 0.0, pr.neg[a], "{what}");
        }
        assert_eq!(bits(l.slab.t_min[i]), bits(r.t_min), "{what}");
        assert!(
            l.tri.same_lane(i, &want, 0),
            "{what}: lane {i} {l:?} {pr:?}"
        );
    }

    /// Every tier this CPU runs (the process's tier is left alone: the lanes are made with each
    /// tier's code directly).
    fn on_each_tier(f: impl FnMut(Isa)) {
        Isa::supported_tiers().into_iter().for_each(f);
    }

    fn camera(from: [f64; 3], at: [f64; 3], angle: f64, w: u32, h: u32) -> Camera<f32> {
        let view = View {
            from: V3::from_array(from),
            at: V3::from_array(at),
            up: V3::new(0.0, 0.0, 1.0),
            angle,
            hither: 0.25,
            width: w,
            height: h,
        };
        Camera::new(&view, w, h)
    }

    #[test]
    fn eye_rays_are_the_cameras_prepared_rays_on_every_tier() {
        let cams = [
            camera([0.0, -5.0, 1.0], [0.1, 0.0, 0.2], 45.0, 512, 512),
            camera([3.0, 2.0, -1.0], [-2.0, 1.0, 7.0], 100.0, 37, 19),
            camera([1e5, 1e5, 1e5], [0.0, 0.0, 0.0], 20.0, 1000, 3),
        ];
        on_each_tier(|tier| {
            for c in &cams {
                for (bx, by, bw, bh) in [(0, 0, 4, 4), (8, 4, 3, 2), (c.width - 1, 0, 1, 3)] {
                    let bh = bh.min(c.height);
                    let mut l = RayPacket::new();
                    l.eye(c, bx, by, bw, bh);
                    assert_eq!(l.len(), (bw * bh) as usize);
                    let (mut px, mut py) = ([0; LANES], [0; LANES]);
                    for i in 0..l.len() {
                        (px[i], py[i]) = (bx + i as u32 % bw, by + i as u32 / bw);
                    }
                    l.eye_on(tier, c, &px, &py);
                    let mut i = 0;
                    for y in by..by + bh {
                        for x in bx..bx + bw {
                            let pr = PreparedRay::new(c.ray(x as f32 + 0.5, y as f32 + 0.5));
                            assert_lane(&l, i, &pr, &format!("{tier} ({x}, {y})"));
                            i += 1;
                        }
                    }
                    for pad in i..LANES {
                        assert!(l.tri.same_lane(pad, &l.tri, 0), "{tier}: pad {pad}");
                    }
                }
            }
        });
    }

    fn comp() -> impl Strategy<Value = f32> {
        prop_oneof![
            4 => -4.0f32..4.0,
            1 => Just(0.0f32),
            1 => Just(-0.0f32),
            1 => Just(1.0f32),
            1 => Just(-1.0f32),
            1 => -1.0e-30f32..1.0e-30,
            1 => -3.0e30f32..3.0e30,
            1 => Just(f32::NAN),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(500))]
        /// Pushed rays prepare to `PreparedRay::new`'s bits on every tier: −0, zero, tiny,
        /// huge and NaN components, ties of magnitudes (equal components are likely).
        #[test]
        fn pushed_rays_prepare_like_prepared_ray(
            rays in proptest::collection::vec(
                (proptest::array::uniform3(comp()), proptest::array::uniform3(comp()),
                 0.0f32..1.0, prop_oneof![Just(f32::INFINITY), 0.0f32..50.0]),
                1..=LANES),
        ) {
            let rays: Vec<Ray<f32>> = rays
                .iter()
                .map(|&(o, d, t_min, t_max)| Ray { o: V3::from_array(o), d: V3::from_array(d), t_min, t_max })
                .collect();
            on_each_tier(|tier| {
                let mut l = RayPacket::new();
                l.push(&rays[0]);
                l.clear();
                for r in &rays {
                    l.push(r);
                }
                l.prepare_on(tier);
                for (i, r) in rays.iter().enumerate() {
                    let pr = PreparedRay::new(*r);
                    assert_lane(&l, i, &pr, &format!("{tier}"));
                    let again = l.prepared(i);
                    assert_eq!(format!("{again:?}"), format!("{pr:?}"));
                }
            });
        }
    }
}
