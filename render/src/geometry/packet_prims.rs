//! One triangle, sphere or cone against up to sixteen rays at once, a ray per SIMD lane: the
//! transposed form of [`super::leaf_triangles`], [`super::leaf_spheres`] and
//! [`super::cone::lanes`], for a packet's rays that enter a BVH leaf. Every lane does the scalar
//! test's IEEE operations in the same order (no FMA, no reassociation, `f32::max`'s NaN rule,
//! edge functions that come out exactly zero redone in `f64` lane by lane), so each lane's
//! answer is bit for bit what [`super::triangle::intersect_triangle`],
//! [`super::sphere::Sphere::intersect`] or [`super::cone::Cone::intersect`] gives that ray. The
//! rays' axis permutations may differ: each lane picks its vertex components with masks. The
//! arithmetic is the one triangle test (`watertight`), the one sphere test (`nearest_root`) and
//! the one cone test (`lateral_hits`): the `avx512` tier ([`crate::isa`]) runs them on the
//! sixteen rays in one AVX-512 register, the `avx2` tier in two halves of eight AVX lanes.
//! [`ShearedRays::new`] is `None` unless the process's tier runs AVX; the portable kernel
//! ([`portable16`], the scalar test ray by ray) defines the answers and serves the tests.
//! [`packet16`] takes any of the three ([`PacketShape`]).

use super::cone::{lateral_hits, Cone, ConeLanes, ConeRays};
use super::ray::PreparedRay;
use super::sphere::{nearest_root, Sphere};
use super::triangle::{intersect_triangle, watertight};
use crate::isa::{Isa, Kernel, Tier};
use crate::lanes::{Lanes, Mask};
use crate::vec3::V3;

/// Rays per call.
pub const LANES: usize = 16;

/// A packet's rays in lanes (lane `i` is ray `i`; lanes past the packet repeat ray 0).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct ShearedRays {
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
/// `b2` are valid for set bits (`b1`, `b2` are zero for spheres and cones).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub struct PacketHits {
    /// Rays hit.
    pub mask: u32,
    /// Distances.
    pub t: [f32; LANES],
    /// Barycentrics of vertex 1.
    pub b1: [f32; LANES],
    /// Barycentrics of vertex 2.
    pub b2: [f32; LANES],
}

#[cfg(test)]
impl crate::geometry::four_lanes::HitBits for PacketHits {
    fn hit_bits(&self) -> Vec<(usize, Vec<u32>)> {
        crate::geometry::four_lanes::lanes_bits(self.mask, &[&self.t, &self.b1, &self.b2])
    }
}

impl PacketHits {
    fn none() -> Self {
        PacketHits {
            mask: 0,
            t: [0.0; LANES],
            b1: [0.0; LANES],
            b2: [0.0; LANES],
        }
    }
}

impl ShearedRays {
    /// The lanes of `rays` (1..=16), or `None` when there are too many or the process's tier
    /// runs no AVX.
    #[inline]
    pub fn new(rays: &[PreparedRay<f32>]) -> Option<Self> {
        if rays.is_empty() || rays.len() > LANES || !available() {
            return None;
        }
        Some(Self::lanes(rays))
    }

    /// Lanes of zeros, made from no slice (filled by [`super::ray_packet::RayPacket`]).
    pub(crate) fn empty() -> Self {
        ShearedRays {
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
    pub(crate) fn same_lane(&self, i: usize, other: &ShearedRays, j: usize) -> bool {
        let rows = |r: &ShearedRays, k: usize| {
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
        let mut l = Self::empty();
        l.fill(rays);
        l
    }

    /// Makes these lanes the lanes of `rays` (1..=16; lanes past them repeat ray 0), in place:
    /// a packet's test keeps one set of lanes and refills it for each packet. One pass over the
    /// rays writes every row of a lane; the permuted origin is a select on the axis masks
    /// (no indexing by a run-time axis), and the mask bits gather in registers.
    pub(crate) fn fill(&mut self, rays: &[PreparedRay<f32>]) {
        let first = &rays[0];
        self.src = rays.as_ptr() as usize;
        self.n = rays.len();
        let (mut k0_bits, mut k1_bits) = ([0u16; 3], [0u16; 3]);
        for i in 0..LANES {
            let pr = if i < rays.len() { &rays[i] } else { first };
            let (o, d) = (pr.ray.o.to_array(), pr.ray.d.to_array());
            let s = pr.shear.to_array();
            let k = [pr.kx, pr.ky, pr.kz];
            for a in 0..3 {
                let (is0, is1) = (k[a] == 0, k[a] == 1);
                self.o[a][i] = o[a];
                self.d[a][i] = d[a];
                self.ok[a][i] = if is0 {
                    o[0]
                } else if is1 {
                    o[1]
                } else {
                    o[2]
                };
                self.s[a][i] = s[a];
                self.k0[a][i] = ones(is0);
                self.k1[a][i] = ones(is1);
                k0_bits[a] |= u16::from(is0) << i;
                k1_bits[a] |= u16::from(is1) << i;
            }
            self.t_min[i] = pr.ray.t_min;
            self.a[i] = pr.ray.d.length_squared();
        }
        self.k0_bits = k0_bits;
        self.k1_bits = k1_bits;
    }

    /// Whether these lanes were made from `rays` (the same slice).
    #[inline(always)]
    pub fn made_from(&self, rays: &[PreparedRay<f32>]) -> bool {
        self.src == rays.as_ptr() as usize && self.n == rays.len()
    }
}

/// A lane mask's lane: all ones when `on`, else zero.
#[inline(always)]
fn ones(on: bool) -> f32 {
    f32::from_bits(0u32.wrapping_sub(u32::from(on)))
}

/// Whether the process's tier ([`crate::isa`]) runs the AVX kernels (`avx2`, `avx512`).
#[inline(always)]
pub fn available() -> bool {
    cfg!(target_arch = "x86_64") && crate::isa::current().avx()
}

/// A primitive the packet kernels test up to sixteen rays against at once: a triangle (its
/// three vertices), a sphere or a cone.
pub trait PacketShape {
    /// The lane kernel on one group of `L::N` lanes: their hits into `out`, at the group's
    /// lanes.
    fn group<L: Lanes<Elem = f32>>(&self, g: LaneGroup, out: &mut PacketHits);
    /// The scalar test of one ray within `t_max`: its hit's `(t, b1, b2)` (the barycentrics
    /// zero for a sphere or a cone).
    fn scalar(&self, pr: &PreparedRay<f32>, t_max: f32) -> Option<(f32, f32, f32)>;
}

/// Lanes `h..h + L::N` of a packet: the rays one call of a lane kernel tests at once.
#[derive(Clone, Copy)]
pub struct LaneGroup<'a> {
    r: &'a ShearedRays,
    /// The group's first lane.
    h: usize,
    /// The group's rays to test (bit `i` is lane `h + i`).
    live: u32,
    /// Every lane's bound (the group reads its own).
    t_max: &'a [f32; LANES],
}

/// `shape` against the rays of `active`, `L::N` lanes at a time (groups with no ray to test
/// are skipped).
#[inline(always)]
fn in_groups<L: Lanes<Elem = f32>, P: PacketShape>(
    shape: &P,
    r: &ShearedRays,
    active: u32,
    t_max: &[f32; LANES],
) -> PacketHits {
    let mut out = PacketHits::none();
    let all = u32::MAX >> (32 - L::N);
    for h in (0..LANES).step_by(L::N) {
        let live = (active >> h) & all;
        if live != 0 {
            shape.group::<L>(LaneGroup { r, h, live, t_max }, &mut out);
        }
    }
    out
}

impl PacketShape for [V3<f32>; 3] {
    /// The watertight test (`watertight`) with a ray per lane. The rays' axis permutations may
    /// differ: each lane picks its vertex components with masks.
    #[inline(always)]
    fn group<L: Lanes<Elem = f32>>(&self, g: LaneGroup, out: &mut PacketHits) {
        let LaneGroup { r, h, live, t_max } = g;
        let v = [rel(r, h, self[0]), rel(r, h, self[1]), rel(r, h, self[2])];
        let s = [
            L::load(&r.s[0][h..]),
            L::load(&r.s[1][h..]),
            L::load(&r.s[2][h..]),
        ];
        let (t_min, t_max) = (L::load(&r.t_min[h..]), L::load(&t_max[h..]));
        if let Some(hit) = watertight(v, s, t_min, t_max, live) {
            out.mask |= hit.mask << h;
            hit.t.store(&mut out.t[h..]);
            hit.b1.store(&mut out.b1[h..]);
            hit.b2.store(&mut out.b2[h..]);
        }
    }
    #[inline(always)]
    fn scalar(&self, pr: &PreparedRay<f32>, t_max: f32) -> Option<(f32, f32, f32)> {
        intersect_triangle(pr, self[0], self[1], self[2], t_max).map(|h| (h.t, h.b1, h.b2))
    }
}

impl PacketShape for Sphere<f32> {
    /// The sphere test (`nearest_root`) with a ray per lane.
    #[inline(always)]
    fn group<L: Lanes<Elem = f32>>(&self, g: LaneGroup, out: &mut PacketHits) {
        let LaneGroup { r, h, live, t_max } = g;
        let c = self.center.to_array();
        let f = [
            L::load(&r.o[0][h..]) - L::splat(c[0]),
            L::load(&r.o[1][h..]) - L::splat(c[1]),
            L::load(&r.o[2][h..]) - L::splat(c[2]),
        ];
        let d = [
            L::load(&r.d[0][h..]),
            L::load(&r.d[1][h..]),
            L::load(&r.d[2][h..]),
        ];
        let r2 = L::splat(self.radius * self.radius);
        let (a, t_min, t_max) = (
            L::load(&r.a[h..]),
            L::load(&r.t_min[h..]),
            L::load(&t_max[h..]),
        );
        if let Some(hit) = nearest_root(f, d, a, r2, t_min, t_max, live) {
            out.mask |= hit.mask << h;
            hit.t.store(&mut out.t[h..]);
        }
    }
    #[inline(always)]
    fn scalar(&self, pr: &PreparedRay<f32>, t_max: f32) -> Option<(f32, f32, f32)> {
        self.intersect(&pr.ray, t_max).map(|t| (t, 0.0, 0.0))
    }
}

impl PacketShape for Cone<f32> {
    /// The lateral surface test (`lateral_hits`) with a ray per lane: the cone in every lane.
    #[inline(always)]
    fn group<L: Lanes<Elem = f32>>(&self, g: LaneGroup, out: &mut PacketHits) {
        let LaneGroup { r, h, live, t_max } = g;
        let rays = ConeRays {
            o: [
                L::load(&r.o[0][h..]),
                L::load(&r.o[1][h..]),
                L::load(&r.o[2][h..]),
            ],
            d: [
                L::load(&r.d[0][h..]),
                L::load(&r.d[1][h..]),
                L::load(&r.d[2][h..]),
            ],
            t_min: L::load(&r.t_min[h..]),
            t_max: L::load(&t_max[h..]),
        };
        let (hit, t) = lateral_hits(&ConeLanes::splat(&self.lanes()), &rays);
        let hit = hit.bits() & live;
        if hit != 0 {
            out.mask |= hit << h;
            t.store(&mut out.t[h..]);
        }
    }
    #[inline(always)]
    fn scalar(&self, pr: &PreparedRay<f32>, t_max: f32) -> Option<(f32, f32, f32)> {
        self.intersect(&pr.ray, t_max).map(|t| (t, 0.0, 0.0))
    }
}

/// The primitive `shape` against the rays of `active` (bits of lanes), ray `i` within
/// `t_max[i]`; `rays` are the lanes of `src`.
#[inline]
pub fn packet16<P: PacketShape>(
    rays: &ShearedRays,
    src: &[PreparedRay<f32>],
    shape: &P,
    active: u32,
    t_max: &[f32; LANES],
) -> PacketHits {
    crate::isa::dispatch(ShapePacket {
        rays,
        src,
        shape,
        active,
        t_max,
    })
}

/// [`packet16`] with the code of `tier`, or `None` when this CPU does not run `tier` (for the
/// tests that compare the tiers).
pub fn packet16_on<P: PacketShape>(
    tier: Isa,
    rays: &ShearedRays,
    src: &[PreparedRay<f32>],
    shape: &P,
    active: u32,
    t_max: &[f32; LANES],
) -> Option<PacketHits> {
    crate::isa::dispatch_on(
        tier,
        ShapePacket {
            rays,
            src,
            shape,
            active,
            t_max,
        },
    )
}

/// A packet's rays against one primitive: the kernel [`crate::isa::dispatch`] runs.
struct ShapePacket<'a, P> {
    rays: &'a ShearedRays,
    src: &'a [PreparedRay<f32>],
    shape: &'a P,
    active: u32,
    t_max: &'a [f32; LANES],
}

impl<P: PacketShape> Kernel for ShapePacket<'_, P> {
    type Output = PacketHits;

    /// Sixteen lanes on `avx512`, two halves of eight on `avx2`, the portable loop otherwise.
    #[inline(always)]
    fn run<T: Tier>(self) -> PacketHits {
        let ShapePacket {
            rays,
            src,
            shape,
            active,
            t_max,
        } = self;
        #[cfg(target_arch = "x86_64")]
        {
            use crate::lanes::{X16, X8};
            if T::ISA.avx512() {
                return in_groups::<X16, P>(shape, rays, active, t_max);
            }
            if T::ISA.avx() {
                return in_groups::<X8, P>(shape, rays, active, t_max);
            }
        }
        let _ = rays;
        portable16(src, shape, active, t_max)
    }
}

/// `p`'s components along each lane's permuted axes `kx`, `ky`, `kz` minus the ray origin's,
/// in lanes `h..h + L::N` (no closures: they would be compiled without the tier's instructions).
#[inline(always)]
fn rel<L: Lanes<Elem = f32>>(r: &ShearedRays, h: usize, p: V3<f32>) -> [L; 3] {
    [
        pick::<L>(r, 0, h, p) - L::load(&r.ok[0][h..]),
        pick::<L>(r, 1, h, p) - L::load(&r.ok[1][h..]),
        pick::<L>(r, 2, h, p) - L::load(&r.ok[2][h..]),
    ]
}

/// Component `k` (the permuted axis `kx`, `ky` or `kz`) of `p` in lanes `h..h + L::N`.
#[inline(always)]
fn pick<L: Lanes<Elem = f32>>(r: &ShearedRays, k: usize, h: usize, p: V3<f32>) -> L {
    let is0 = L::mask_from(&r.k0[k][h..], u32::from(r.k0_bits[k]) >> h);
    let is1 = L::mask_from(&r.k1[k][h..], u32::from(r.k1_bits[k]) >> h);
    let yz = L::select(is1, L::splat(p.y), L::splat(p.z));
    L::select(is0, L::splat(p.x), yz)
}

/// The portable kernel: the scalar test ray by ray.
pub fn portable16<P: PacketShape>(
    src: &[PreparedRay<f32>],
    shape: &P,
    active: u32,
    t_max: &[f32; LANES],
) -> PacketHits {
    let mut h = PacketHits::none();
    for (i, pr) in src.iter().enumerate().take(LANES) {
        if active & (1 << i) != 0 {
            if let Some((t, b1, b2)) = shape.scalar(pr, t_max[i]) {
                h.mask |= 1 << i;
                h.t[i] = t;
                h.b1[i] = b1;
                h.b2[i] = b2;
            }
        }
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::four_lanes::assert_agree;
    use crate::geometry::ray::Ray;
    use crate::geometry::test_coords::point;
    use proptest::prelude::*;

    /// Asserts that every kernel this CPU runs (the dispatched kernel and each tier's: the AVX
    /// halves, the AVX-512 kernel) gives the portable kernel's answers for `shape` bit for bit;
    /// returns the rays hit.
    fn agree<P: PacketShape + std::fmt::Debug>(
        lanes: &ShearedRays,
        rays: &[PreparedRay<f32>],
        shape: &P,
        active: u32,
        t_max: &[f32; LANES],
    ) -> u32 {
        let want = portable16(rays, shape, active, t_max);
        let mut got = vec![("dispatched", packet16(lanes, rays, shape, active, t_max))];
        for tier in Isa::ALL {
            if let Some(h) = packet16_on(tier, lanes, rays, shape, active, t_max) {
                got.push((tier.name(), h));
            }
        }
        for (kernel, got) in got {
            let case = format!("{kernel}: {rays:?} {shape:?} {active:#x} {t_max:?}");
            assert_agree(&want, &[got], &case);
        }
        want.mask
    }

    /// A cone (or cylinder, by `shape`) around the triangle's first edge, its radii from the
    /// other edges' lengths.
    fn cone_of(tri: &[V3<f32>; 3], shape: usize) -> Cone<f32> {
        let r = (tri[2] - tri[0]).length().max(1e-3);
        let r1 = [r, 0.0, 0.5 * r][shape % 3];
        Cone::new(tri[0], r, tri[1], r1)
            .unwrap_or_else(|| Cone::new(V3::zero(), 1.0, V3::new(0.0, 0.0, 1.0), 0.5).unwrap())
    }

    /// [`agree`] for the triangle, a sphere at its first vertex and cones along its first
    /// edge; returns the rays hit by any.
    fn check(
        rays: &[PreparedRay<f32>],
        tri: &[V3<f32>; 3],
        active: u32,
        t_max: &[f32; LANES],
    ) -> u32 {
        let lanes = ShearedRays::lanes(rays);
        let s = Sphere {
            center: tri[0],
            radius: (tri[1] - tri[0]).length().max(1e-3),
        };
        let mut hit = agree(&lanes, rays, tri, active, t_max);
        hit |= agree(&lanes, rays, &s, active, t_max);
        for shape in 0..3 {
            hit |= agree(&lanes, rays, &cone_of(tri, shape), active, t_max);
        }
        hit
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

    /// Rays at cylinders, a true cone and a widening cone from all sides: at the rims, through
    /// the sides and the middle, past the ends, along the axis and parallel to a generator
    /// line, sixteen to a packet (and one target's rays to a packet) with partial masks and
    /// bounds before, at and beyond the hits.
    #[test]
    fn cone_kernels_agree_on_rims_axes_and_generators() {
        let cones = [
            Cone::new(V3::new(0.0f32, 0.0, 5.0), 1.0, V3::new(0.0, 0.0, 7.0), 1.0),
            Cone::new(V3::new(0.0, 0.0, -1.0), 2.0, V3::new(0.0, 0.0, 1.0), 0.0),
            Cone::new(V3::new(0.0, -3.0, 0.0), 0.5, V3::new(0.0, 3.0, 0.0), 1.5),
            Cone::new(
                V3::new(0.93, 2.61, 0.0),
                0.074,
                V3::new(0.29, 1.73, 0.0),
                0.074,
            ),
        ]
        .map(|c| c.unwrap());
        let offsets = [
            [0.0f32, 0.0, 20.0],
            [0.0, 0.0, -20.0],
            [20.0, 1.0, 0.5],
            [-3.0, -20.0, 1.0],
            [1.0, 1.0, 1.0],
            [-0.5, 2.0, -4.0],
        ];
        let (mut hits, mut packets) = (0, 0);
        for c in &cones {
            let apex = c.base + c.axis * c.height;
            let side = c.axis.cross(V3::new(0.3, 0.5, 0.8)).normalize();
            let r1 = c.r0 + c.slope * c.height;
            let mid = c.base + c.axis * (0.5 * c.height);
            let targets = [
                c.base + side * c.r0,
                apex + side * r1,
                mid + side * (0.5 * (c.r0 + r1)),
                mid + side * (0.6 * (c.r0 + r1)),
                mid,
                c.base - c.axis * 0.1 + side * (0.5 * c.r0),
            ];
            let mut rays = Vec::new();
            let ray = |o: V3<f32>, d: V3<f32>| {
                PreparedRay::new(Ray {
                    o,
                    d: d.normalize(),
                    t_min: 0.0,
                    t_max: f32::INFINITY,
                })
            };
            for t in targets {
                for o in offsets {
                    let o = t + V3::from_array(o);
                    rays.push(ray(o, t - o));
                }
            }
            let generator = (apex + side * r1) - (c.base + side * c.r0);
            for k in [-0.5f32, 0.0, 0.5, 0.999, 1.0, 1.001, 2.0] {
                let on = c.base + side * (c.r0 * k);
                rays.push(ray(on - c.axis * 3.0, c.axis));
                rays.push(ray(on + c.axis * (c.height + 3.0), -c.axis));
                rays.push(ray(on - generator * 2.0, generator));
            }
            for packet in rays.chunks(LANES).chain(rays.chunks(offsets.len())) {
                let lanes = ShearedRays::lanes(packet);
                for active in [u32::MAX, 0x5555, 0xaaaa, 1, 0x8000] {
                    let active = active & ((1u32 << packet.len()) - 1);
                    for bound in [f32::INFINITY, 20.0, 19.0, 2.0, 0.5] {
                        let t_max = &[bound; LANES];
                        hits += agree(&lanes, packet, c, active, t_max).count_ones();
                        packets += 1;
                    }
                }
            }
        }
        assert!(hits > 1000, "{hits} hits in {packets} packets");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]
        /// Random triangles and spheres against sixteen random rays (each with its own origin,
        /// direction, axis permutation and bound; some aimed at a vertex).
        #[test]
        fn kernels_agree_on_random_rays(
            verts in proptest::array::uniform3(point()),
            origins in proptest::collection::vec(point(), LANES),
            dirs in proptest::collection::vec(point(), LANES),
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
