//! The primitive test of one packet's rays ([`crate::accel::RayPrimTest`]): [`SceneLeaf`], except
//! that where the process's tier runs AVX ([`crate::isa`]) and the scene is in `f32`, a leaf of
//! triangles, of spheres or of cones that several of the packet's rays enter is tested one
//! primitive at a time against all of them at once, a ray per lane ([`crate::geometry::packet_prims`]). The packet's rays are put into lanes
//! once, when the first such leaf needs them; every ray gets exactly the one-ray test's answer.

use crate::bits::SetBits;
use std::any::{Any, TypeId};

use crate::accel::bvh::packet::LanesPrimTest;
use crate::accel::RayPrimTest;
use crate::geometry::packet_prims::{self, ShearedRays, LANES};
use crate::geometry::ray_packet::RayPacket;
use crate::geometry::{Nearest, PreparedRay, PrimHit};
use crate::packet::scene_leaf::SceneLeaf;
use crate::real::Real;
use crate::scene::{Prim, Scene};

/// Fewest entering rays for which a leaf goes to the ray-per-lane kernels (below, each ray
/// takes the leaf four primitives at a time through [`SceneLeaf`]).
pub const MIN_RAYS: u32 = 3;

/// The primitive test of one packet's rays: make one per packet (it keeps the rays' lanes
/// between leaves and is moved into the traversal, so it is neither `Clone` nor `Copy`). The
/// lanes, over a kilobyte, live in a slot of the caller's that several packets may share one
/// after the other: the test itself is a few pointers, so moving it into the traversal copies
/// no lanes, and each packet's lanes are written over the last ones in place.
#[derive(Debug)]
pub struct PacketLeaf<'a, R> {
    leaf: SceneLeaf<'a, R>,
    /// The scene when it is in `f32` and the CPU runs the ray-per-lane kernels.
    scene: Option<&'a Scene<f32>>,
    /// Where the packet's rays are put in lanes when a leaf first needs them.
    lanes: &'a mut Option<ShearedRays>,
    /// Whether `lanes` holds this packet's rays (a slot shared by packets holds another's).
    made: bool,
}

impl<'a, R: Real> PacketLeaf<'a, R> {
    /// The test of `scene`'s primitives, making the packet's lanes in `lanes` (a local `None`,
    /// or the slot an earlier packet used).
    #[inline]
    pub fn new(scene: &'a Scene<R>, lanes: &'a mut Option<ShearedRays>) -> Self {
        PacketLeaf {
            leaf: SceneLeaf::new(scene),
            scene: (scene as &dyn Any)
                .downcast_ref::<Scene<f32>>()
                .filter(|_| packet_prims::available()),
            lanes,
            made: false,
        }
    }

    /// The scene, the rays and their lanes when the ray-per-lane kernels take `rays` into
    /// `leaf`, a leaf of triangles, of spheres or of cones (the kind is checked first, so a
    /// leaf of mixed kinds costs no lanes; the lanes are made once per packet: again only when
    /// `rays` is another slice).
    #[inline(always)]
    fn lanes<'b>(&'b mut self, rays: &'b [PreparedRay<R>], leaf: &[u32]) -> Option<Lanes<'a, 'b>> {
        let scene = self.scene?;
        if kind(&scene.prims, leaf) == Kind::Other {
            return None;
        }
        let r = f32_rays(rays)?;
        if !(self.made && self.lanes.as_ref().is_some_and(|l| l.made_from(r))) {
            if r.is_empty() || r.len() > LANES {
                return None;
            }
            match self.lanes {
                Some(l) => l.fill(r),
                None => *self.lanes = Some(ShearedRays::lanes(r)),
            }
            self.made = true;
        }
        Some((scene, r, self.lanes.as_ref()?))
    }
}

/// The `f32` scene, a packet's rays and their lanes.
type Lanes<'a, 'b> = (&'a Scene<f32>, &'b [PreparedRay<f32>], &'b ShearedRays);

/// `rays` as `f32` rays when `R` is `f32`.
#[inline(always)]
pub(crate) fn f32_rays<R: Real>(rays: &[PreparedRay<R>]) -> Option<&[PreparedRay<f32>]> {
    if TypeId::of::<R>() == TypeId::of::<f32>() {
        // SAFETY: `R` is `f32`, so both slices have the same type.
        Some(unsafe { &*(rays as *const [PreparedRay<R>] as *const [PreparedRay<f32>]) })
    } else {
        None
    }
}

/// What a leaf holds, for the ray-per-lane kernels.
#[derive(Clone, Copy, PartialEq)]
enum Kind {
    Triangles,
    Spheres,
    Cones,
    Other,
}

#[inline(always)]
fn kind(prims: &[Prim<f32>], leaf: &[u32]) -> Kind {
    let of = |p: u32| match prims.get(p as usize) {
        Some(Prim::Triangle(_)) => Kind::Triangles,
        Some(Prim::Sphere(_)) => Kind::Spheres,
        Some(Prim::Cone(_)) => Kind::Cones,
        None => Kind::Other,
    };
    let Some(&first) = leaf.first() else {
        return Kind::Other;
    };
    let k = of(first);
    if leaf[1..].iter().all(|&p| of(p) == k) {
        k
    } else {
        Kind::Other
    }
}

/// Primitive `p` (of a leaf whose kind was checked) against the rays of `active`.
#[inline(always)]
fn run(
    scene: &Scene<f32>,
    rays: &[PreparedRay<f32>],
    lanes: &ShearedRays,
    p: u32,
    active: u32,
    t_max: &[f32; LANES],
) -> packet_prims::PacketHits {
    match &scene.prims[p as usize] {
        Prim::Triangle(v) => packet_prims::packet16(lanes, rays, v, active, t_max),
        Prim::Sphere(s) => packet_prims::packet16(lanes, rays, s, active, t_max),
        Prim::Cone(c) => packet_prims::packet16(lanes, rays, c, active, t_max),
    }
}

/// The leaf `leaf` (of a kind checked) against the rays of `mask` in `lanes`, into `best`.
/// Every primitive with the bound each ray entered the leaf with: a hit beyond the best so far
/// never beats it, so offering each ray its hits in leaf order picks what the one-at-a-time
/// loop picks.
#[inline(always)]
fn closest16<R: Real>(
    scene: &Scene<f32>,
    rays: &[PreparedRay<f32>],
    lanes: &ShearedRays,
    mask: u32,
    leaf: &[u32],
    best: &mut [Nearest<R>],
) {
    let mut t_max = [0.0f32; LANES];
    for i in SetBits(mask) {
        t_max[i] = best[i].t.to_f32();
    }
    for &p in leaf {
        let h = run(scene, rays, lanes, p, mask, &t_max);
        for i in SetBits(h.mask) {
            best[i].offer(Some(PrimHit {
                t: R::from_f32(h.t[i]),
                prim: p,
                u: R::from_f32(h.b1[i]),
                v: R::from_f32(h.b2[i]),
            }));
        }
    }
}

/// The leaf `leaf` (of a kind checked) against the rays of `mask` in `lanes`, ray `i` within
/// `t_max[i]`: the rays blocked, and the position of each one's first blocker in `first`.
#[inline(always)]
fn any16(
    scene: &Scene<f32>,
    rays: &[PreparedRay<f32>],
    lanes: &ShearedRays,
    mask: u32,
    leaf: &[u32],
    t_max: &[f32; LANES],
    first: &mut [usize],
) -> u32 {
    let (mut open, mut blocked) = (mask, 0);
    for (j, &p) in leaf.iter().enumerate() {
        let new = run(scene, rays, lanes, p, open, t_max).mask & open;
        for i in SetBits(new) {
            first[i] = j;
        }
        blocked |= new;
        open &= !new;
        if open == 0 {
            break;
        }
    }
    blocked
}

/// Whether the rays of `mask` take `leaf` together.
#[inline(always)]
fn takes(mask: u32, leaf: &[u32]) -> bool {
    mask.count_ones() >= MIN_RAYS.max(RAYS_PER_PRIM * leaf.len() as u32)
}

/// Fewest entering rays per primitive of the leaf for the ray-per-lane kernels.
pub const RAYS_PER_PRIM: u32 = 0;

impl<R: Real> RayPrimTest<R> for PacketLeaf<'_, R> {
    #[inline(always)]
    fn test(&mut self, pr: &PreparedRay<R>, prim: u32, t_max: R) -> Option<PrimHit<R>> {
        self.leaf.test(pr, prim, t_max)
    }

    #[inline(always)]
    fn closest(&mut self, pr: &PreparedRay<R>, leaf: &[u32], best: &mut Nearest<R>) {
        self.leaf.closest(pr, leaf, best)
    }

    #[inline(always)]
    fn any(&mut self, pr: &PreparedRay<R>, leaf: &[u32], t_max: R) -> Option<usize> {
        self.leaf.any(pr, leaf, t_max)
    }

    #[inline(always)]
    fn closest_many(
        &mut self,
        rays: &[PreparedRay<R>],
        mask: u32,
        leaf: &[u32],
        best: &mut [Nearest<R>],
    ) {
        if takes(mask, leaf) {
            if let Some((scene, r32, lanes)) = self.lanes(rays, leaf) {
                return closest16(scene, r32, lanes, mask, leaf, best);
            }
        }
        self.leaf.closest_many(rays, mask, leaf, best)
    }

    #[inline(always)]
    fn any_many(
        &mut self,
        rays: &[PreparedRay<R>],
        mask: u32,
        leaf: &[u32],
        first: &mut [usize],
    ) -> u32 {
        if takes(mask, leaf) {
            if let Some((scene, r32, lanes)) = self.lanes(rays, leaf) {
                let mut t_max = [0.0f32; LANES];
                for (t, r) in t_max.iter_mut().zip(r32) {
                    *t = r.ray.t_max;
                }
                return any16(scene, r32, lanes, mask, leaf, &t_max, first);
            }
        }
        self.leaf.any_many(rays, mask, leaf, first)
    }
}

/// The primitive test of one packet in lanes ([`LanesPrimTest`]), for an `f32` scene: a leaf of
/// triangles, of spheres or of cones that several rays enter goes to the ray-per-lane kernels
/// straight from the packet's lanes (where the tier runs them, as [`PacketLeaf`] decides); any other
/// leaf goes through [`SceneLeaf`] with the rays prepared one by one from their lanes, each the
/// first time it needs it. Make one per packet, with a buffer that outlives the packets.
#[derive(Debug)]
pub struct LanesLeaf<'a, 'b> {
    leaf: SceneLeaf<'a, f32>,
    scene: &'a Scene<f32>,
    /// Whether the ray-per-lane kernels run on this tier.
    simd: bool,
    /// The packet's rays prepared so far (bits of `made`).
    prepared: &'b mut [PreparedRay<f32>; LANES],
    made: u32,
}

impl<'a, 'b> LanesLeaf<'a, 'b> {
    /// The test of `scene`'s primitives for one packet, preparing rays into `buffer`.
    #[inline]
    pub fn new(scene: &'a Scene<f32>, buffer: &'b mut [PreparedRay<f32>; LANES]) -> Self {
        LanesLeaf {
            leaf: SceneLeaf::new(scene),
            scene,
            simd: packet_prims::available(),
            prepared: buffer,
            made: 0,
        }
    }
}

/// The rays of `mask` prepared into `prepared` (each made once per packet: `made` holds the
/// bits of those made), as the packet's slice.
#[inline(always)]
fn prepare<'p>(
    prepared: &'p mut [PreparedRay<f32>; LANES],
    made: &mut u32,
    rays: &RayPacket,
    mask: u32,
) -> &'p [PreparedRay<f32>] {
    for i in SetBits(mask & !*made) {
        prepared[i] = rays.prepared(i);
    }
    *made |= mask;
    &prepared[..rays.len()]
}

impl RayPrimTest<f32> for LanesLeaf<'_, '_> {
    #[inline(always)]
    fn test(&mut self, pr: &PreparedRay<f32>, prim: u32, t_max: f32) -> Option<PrimHit<f32>> {
        self.leaf.test(pr, prim, t_max)
    }

    #[inline(always)]
    fn closest(&mut self, pr: &PreparedRay<f32>, leaf: &[u32], best: &mut Nearest<f32>) {
        self.leaf.closest(pr, leaf, best)
    }

    #[inline(always)]
    fn any(&mut self, pr: &PreparedRay<f32>, leaf: &[u32], t_max: f32) -> Option<usize> {
        self.leaf.any(pr, leaf, t_max)
    }
}

impl LanesPrimTest for LanesLeaf<'_, '_> {
    #[inline(always)]
    fn closest_lanes(
        &mut self,
        rays: &RayPacket,
        mask: u32,
        leaf: &[u32],
        best: &mut [Nearest<f32>],
    ) {
        if self.simd && takes(mask, leaf) && kind(&self.scene.prims, leaf) != Kind::Other {
            // The kernels read the lanes only (the rays' slice serves the portable kernels,
            // which this tier does not run).
            return closest16(self.scene, &[], &rays.tri, mask, leaf, best);
        }
        let prs = prepare(self.prepared, &mut self.made, rays, mask);
        self.leaf.closest_many(prs, mask, leaf, best)
    }

    #[inline(always)]
    fn any_lanes(&mut self, rays: &RayPacket, mask: u32, leaf: &[u32], first: &mut [usize]) -> u32 {
        if self.simd && takes(mask, leaf) && kind(&self.scene.prims, leaf) != Kind::Other {
            return any16(self.scene, &[], &rays.tri, mask, leaf, &rays.t_max, first);
        }
        let prs = prepare(self.prepared, &mut self.made, rays, mask);
        self.leaf.any_many(prs, mask, leaf, first)
    }
}
