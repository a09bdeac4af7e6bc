//! The shadow rays of a packet's hits towards one light, made sixteen lanes at a time straight
//! into a [`RayPacket`] packet: the hit points, their error bounds and geometric normals in lanes
//! ([`SurfaceLanes`]), and per lane exactly what `cast::shadow_ray` computes for that
//! hit — the normal turned towards the eye, the cull test, the origin offset off the surface and
//! rounded away from it ([`crate::geometry::offset_ray_origin`]), the unit direction and the
//! distance — in the same IEEE operations and order. The rays that exist go into the packet in
//! lane order. The arithmetic is written once, `shadow_ray`, over the lane types of
//! [`crate::lanes`]: the `avx512` tier ([`crate::isa::dispatch`]) runs it on the sixteen lanes
//! in one register per component, the `avx2` tier on eight lanes at a time, the other tiers on
//! each lane hit, one by one.

use crate::geometry::ray_packet::{RayPacket, LANES};
use crate::geometry::Ray;
#[cfg(test)]
use crate::isa::Isa;
use crate::isa::{Kernel, Tier};
use crate::lanes::{dot3 as dot, splat3, Lanes, Mask};
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

/// The shadow rays from the hits of `s` to the light at `light`, into `out` (emptied first,
/// then prepared). With `cull`, the directions of the rays that made the hits, a lane is culled
/// where its surface faces away from the light; without, every hit off the light has a ray.
pub fn shadow_lanes(
    out: &mut RayPacket,
    cull: Option<&[[f32; LANES]; 3]>,
    s: &SurfaceLanes,
    light: V3<f32>,
) {
    let mut rays = Rays::default();
    crate::isa::dispatch(Shadow {
        r: &mut rays,
        cull,
        s,
        light,
    });
    pack(out, &rays, s);
}

/// [`shadow_lanes`] with the code of `tier` (for the tests that compare the tiers); `false`
/// when this CPU does not run `tier`.
#[cfg(test)]
fn shadow_lanes_on(
    tier: Isa,
    out: &mut RayPacket,
    cull: Option<&[[f32; LANES]; 3]>,
    s: &SurfaceLanes,
    light: V3<f32>,
) -> bool {
    let mut rays = Rays::default();
    let k = Shadow {
        r: &mut rays,
        cull,
        s,
        light,
    };
    let ran = crate::isa::dispatch_on(tier, k).is_some();
    pack(out, &rays, s);
    ran
}

/// The rays that exist, into `out` in lane order.
#[inline(always)]
fn pack(out: &mut RayPacket, rays: &Rays, s: &SurfaceLanes) {
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

/// The shadow rays of a packet: the kernel [`crate::isa::dispatch`] runs.
struct Shadow<'a> {
    r: &'a mut Rays,
    /// The hits' ray directions when culling.
    cull: Option<&'a [[f32; LANES]; 3]>,
    s: &'a SurfaceLanes,
    light: V3<f32>,
}

impl Kernel for Shadow<'_> {
    type Output = ();

    /// The sixteen lanes in one register per component on `avx512`, eight at a time on
    /// `avx2`; elsewhere the lanes hit, one by one (the compiler does not vectorise that loop).
    #[inline(always)]
    fn run<T: Tier>(self) {
        #[cfg(target_arch = "x86_64")]
        if T::ISA.avx512() {
            return rays_wide::<crate::lanes::X16>(self);
        }
        #[cfg(target_arch = "x86_64")]
        if T::ISA.avx() {
            return rays_wide::<crate::lanes::X8>(self);
        }
        rays_one_by_one(self)
    }
}

/// The shadow rays of the lanes, computed `L::N` at a time (a group of lanes without a hit is
/// skipped).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn rays_wide<L: Lanes<Elem = f32>>(k: Shadow<'_>) {
    let mut valid = 0;
    let group = (1u32 << L::N) - 1;
    for c in (0..LANES).step_by(L::N) {
        if (k.s.mask >> c) & group == 0 {
            continue;
        }
        let eye_d = match k.cull {
            Some(d) => load3::<L>(d, c),
            None => [L::zero(); 3],
        };
        let ray = shadow_ray(
            eye_d,
            load3::<L>(&k.s.p, c),
            load3::<L>(&k.s.p_err, c),
            load3::<L>(&k.s.ng, c),
            splat3(k.light.to_array()),
            k.cull.is_some(),
        );
        for a in 0..3 {
            ray.o[a].store(&mut k.r.o[a][c..]);
            ray.d[a].store(&mut k.r.d[a][c..]);
        }
        ray.len.store(&mut k.r.len[c..]);
        valid |= (ray.valid & group) << c;
    }
    k.r.valid = valid;
}

/// The shadow rays of the lanes hit, one lane at a time.
#[inline(always)]
fn rays_one_by_one(k: Shadow<'_>) {
    let mut valid = 0;
    for i in crate::bits::SetBits(k.s.mask) {
        let lane = |v: &[[f32; LANES]; 3]| [v[0][i], v[1][i], v[2][i]];
        let (p, p_err, ng) = (lane(&k.s.p), lane(&k.s.p_err), lane(&k.s.ng));
        let eye_d = k.cull.map_or([0.0; 3], lane);
        let ray = shadow_ray::<f32>(eye_d, p, p_err, ng, k.light.to_array(), k.cull.is_some());
        for a in 0..3 {
            k.r.o[a][i] = ray.o[a];
            k.r.d[a][i] = ray.d[a];
        }
        k.r.len[i] = ray.len;
        valid |= (ray.valid & 1) << i;
    }
    k.r.valid = valid;
}

/// Three rows of lanes, from lane `c` on.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn load3<L: Lanes<Elem = f32>>(v: &[[f32; LANES]; 3], c: usize) -> [L; 3] {
    [
        L::load(&v[0][c..]),
        L::load(&v[1][c..]),
        L::load(&v[2][c..]),
    ]
}

/// `v` negated in the lanes of `m`.
#[inline(always)]
fn flip<L: Lanes>(v: [L; 3], m: L::Mask) -> [L; 3] {
    [
        L::select(m, v[0].neg(), v[0]),
        L::select(m, v[1].neg(), v[1]),
        L::select(m, v[2].neg(), v[2]),
    ]
}

/// `u − v` by axis.
#[inline(always)]
fn sub3<L: Lanes>(u: [L; 3], v: [L; 3]) -> [L; 3] {
    [u[0] - v[0], u[1] - v[1], u[2] - v[2]]
}

/// The shadow rays of some lanes, and which lanes have one (bit `i` lane `i`).
struct ShadowRays<L> {
    o: [L; 3],
    d: [L; 3],
    len: L,
    valid: u32,
}

/// `cast::shadow_ray` written once for every lane type ([`crate::lanes`]): from the hit `p`
/// (error bound `p_err`, geometric normal `ng`) of an eye ray of direction `eye_d` to the light
/// at `pos`, the normal turned towards the eye, the cull test, the origin offset off the
/// surface and rounded away from it ([`crate::geometry::offset_ray_origin`]), the unit direction
/// and the distance, in the same IEEE operations and order. A lane has a ray when it is not
/// culled and the light is off the surface.
#[inline(always)]
fn shadow_ray<L: Lanes<Elem = f32>>(
    eye_d: [L; 3],
    p: [L; 3],
    p_err: [L; 3],
    ng: [L; 3],
    pos: [L; 3],
    cull: bool,
) -> ShadowRays<L> {
    // No closures over lane operations here: a closure is compiled apart from the tier's entry,
    // without its instruction sets, and its lane operations would become calls.
    let zero = L::zero();
    // `face_forward(-ray.d)`.
    let back = [eye_d[0].neg(), eye_d[1].neg(), eye_d[2].neg()];
    let n = flip(ng, dot(ng, back).lt(zero));
    let to = sub3(pos, p);
    let culled = if cull { dot(n, to).le(zero).bits() } else { 0 };
    let dist = dot(to, to).sqrt();
    let valid = !culled & dist.gt(zero).bits();
    let w = [to[0] / dist, to[1] / dist, to[2] / dist];
    // `offset_ray_origin(p, p_err, ng, w)`, with the normal as the surface gives it.
    let off_len = dot([ng[0].abs(), ng[1].abs(), ng[2].abs()], p_err);
    let off = [ng[0] * off_len, ng[1] * off_len, ng[2] * off_len];
    let off = flip(off, dot(w, ng).lt(zero));
    let mut o = [zero; 3];
    for a in 0..3 {
        let v = p[a] + off[a];
        let away = L::select(off[a].lt(zero), v.next_down(), v);
        o[a] = L::select(off[a].gt(zero), v.next_up(), away);
    }
    let d = sub3(pos, o);
    let len = dot(d, d).sqrt();
    ShadowRays {
        o,
        d: [d[0] / len, d[1] / len, d[2] / len],
        len,
        valid,
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
            let mut eye = RayPacket::new();
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
                let mut out = RayPacket::new();
                let d = cull.then_some(&eye.tri.d);
                prop_assert!(shadow_lanes_on(tier, &mut out, d, &s, light));
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
