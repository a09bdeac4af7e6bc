//! Acceleration structures. Each knows only boxes and primitive indices; the primitive test comes
//! in as a closure, so one traversal serves closest hit, any hit and the tests. All of them
//! return the same hit for the same ray: nearest `t`, ties broken by the smaller primitive index.

pub mod brute;
pub mod bvh;
pub mod grid;
pub mod prim_test;

use crate::accel::bvh::packet::LanesPrimTest;
use crate::geometry::ray_packet::RayPacket;
use crate::geometry::{Aabb, PreparedRay, PrimHit};
use crate::real::Real;
use crate::settings::AccelKind;
use crate::stats::RayStats;

pub use brute::Brute;
pub use bvh::Bvh;
pub use grid::Grid;
pub use prim_test::{OneRay, PrimTest, RayPrimTest};

/// The margin every accelerator widens primitive boxes by, relative to the scene's largest
/// coordinate magnitude: 2⁻¹⁴, about a thousand `f32` ulps. A primitive's hit then lies strictly
/// inside every box that holds it, so a box's (rounded) entry distance can never pass the hit's
/// (rounded) `t`: the BVH never prunes the nearest hit, and a grid step decided a few ulps early
/// or late at a cell face still lands in a cell holding the primitive. It covers rays that start
/// within a few hundred scene magnitudes of the origin.
pub const MARGIN_REL: f64 = 1.0 / 16384.0;

/// The absolute margin of a scene whose primitives span `world`.
pub fn margin(world: &Aabb) -> f64 {
    let mag = world
        .min
        .iter()
        .chain(world.max.iter())
        .filter(|v| v.is_finite())
        .fold(0.0f64, |m, &v| m.max((v as f64).abs()));
    (mag * MARGIN_REL).max(f64::from(f32::MIN_POSITIVE))
}

/// Statistics of a built accelerator, for logs and `--stats`.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct AccelStats {
    /// Which structure.
    pub kind: String,
    /// Nodes (BVH) or cells (grid).
    pub nodes: u64,
    /// Leaves (BVH) or non-empty cells (grid).
    pub leaves: u64,
    /// Primitive references stored.
    pub references: u64,
    /// SAH cost of the tree (BVH), relative to one primitive test.
    pub sah_cost: f64,
    /// Deepest leaf (BVH).
    pub max_depth: u32,
    /// Bytes of the structure's arrays.
    pub bytes: u64,
    /// Seconds the build took (from the primitive bounds on; set by the renderer).
    #[serde(default)]
    pub build_s: f64,
}

/// One of the acceleration structures.
#[derive(Debug)]
pub enum Accel {
    /// Bounding volume hierarchy.
    Bvh(Bvh),
    /// Uniform voxel grid.
    Grid(Grid),
    /// Linear scan.
    Brute(Brute),
}

impl Accel {
    /// Builds the structure of `kind` over primitive bounds.
    pub fn build(kind: AccelKind, bounds: &[Aabb], grid_density: f64) -> Accel {
        match kind {
            AccelKind::Bvh => Accel::Bvh(Bvh::build(bounds)),
            AccelKind::Brute => Accel::Brute(Brute::build(bounds)),
            AccelKind::Grid => Accel::Grid(Grid::build(bounds, grid_density)),
            AccelKind::BvhGoldsmithSalmon => Accel::Bvh(Bvh::build_goldsmith_salmon(bounds)),
        }
    }

    /// Like [`Accel::build`], but takes the bounds and frees them as early as the structure
    /// allows (the BVH: once its build records are made), for a lower peak memory.
    pub fn build_owned(kind: AccelKind, bounds: Vec<Aabb>, grid_density: f64) -> Accel {
        match kind {
            AccelKind::Bvh => Accel::Bvh(Bvh::build_owned(bounds)),
            _ => Accel::build(kind, &bounds, grid_density),
        }
    }

    /// Build statistics.
    pub fn stats(&self) -> AccelStats {
        match self {
            Accel::Bvh(b) => b.stats(),
            Accel::Grid(g) => g.stats(),
            Accel::Brute(b) => b.stats(),
        }
    }

    /// Closest hit: `test` is the primitive test (inclusive of `t_max`); the BVH calls it leaf
    /// by leaf, the others one primitive at a time.
    #[inline]
    pub fn intersect<R: Real, T: PrimTest<R>>(
        &self,
        pr: &PreparedRay<R>,
        stats: &mut RayStats,
        mut test: T,
    ) -> Option<PrimHit<R>> {
        match self {
            Accel::Bvh(b) => b.intersect(pr, stats, test),
            Accel::Grid(g) => g.intersect(pr, stats, |p, t| test.test(p, t)),
            Accel::Brute(b) => b.intersect(pr, stats, |p, t| test.test(p, t)),
        }
    }

    /// Any hit within the ray's range.
    #[inline]
    pub fn occluded<R: Real, T: PrimTest<R>>(
        &self,
        pr: &PreparedRay<R>,
        stats: &mut RayStats,
        mut test: T,
    ) -> bool {
        match self {
            Accel::Bvh(b) => b.occluded(pr, stats, test),
            Accel::Grid(g) => g.occluded(pr, stats, |p, t| test.test(p, t)),
            Accel::Brute(b) => b.occluded(pr, stats, |p, t| test.test(p, t)),
        }
    }

    /// Closest hits of a packet of at most [`bvh::packet::PACKET`] rays into `out`:
    /// `test` is the primitive test. The BVH traces the packet together; the
    /// other accelerators trace its rays one by one. Either way each ray gets the hit it gets
    /// alone.
    pub fn intersect_packet<R: Real, T: RayPrimTest<R>>(
        &self,
        rays: &[PreparedRay<R>],
        out: &mut [Option<PrimHit<R>>],
        stats: &mut RayStats,
        mut test: T,
    ) {
        match self {
            Accel::Bvh(b) => b.intersect_packet(rays, out, stats, test),
            _ => {
                for (pr, o) in rays.iter().zip(out.iter_mut()) {
                    *o = self.intersect(pr, stats, |p, t| test.test(pr, p, t));
                }
            }
        }
    }

    /// [`Accel::intersect_packet`] for a packet in lanes ([`RayPacket`]): the BVH traces it
    /// together from its lanes; the other accelerators prepare its rays one by one.
    pub fn intersect_lanes<T: LanesPrimTest>(
        &self,
        rays: &RayPacket,
        out: &mut [Option<PrimHit<f32>>],
        stats: &mut RayStats,
        mut test: T,
    ) {
        match self {
            Accel::Bvh(b) => b.intersect_lanes(rays, out, stats, test),
            _ => {
                for (i, o) in out[..rays.len()].iter_mut().enumerate() {
                    let pr = &rays.prepared(i);
                    *o = self.intersect(pr, stats, |p, t| test.test(pr, p, t));
                }
            }
        }
    }

    /// [`Accel::occluded_packet`] for a packet in lanes ([`RayPacket`]).
    pub fn occluded_lanes<T: LanesPrimTest>(
        &self,
        rays: &RayPacket,
        out: &mut [bool],
        stats: &mut RayStats,
        mut test: T,
    ) {
        match self {
            Accel::Bvh(b) => b.occluded_lanes(rays, out, stats, test),
            _ => {
                for (i, o) in out[..rays.len()].iter_mut().enumerate() {
                    let pr = &rays.prepared(i);
                    *o = self.occluded(pr, stats, |p, t| test.test(pr, p, t));
                }
            }
        }
    }

    /// Occlusion of each ray of a packet of at most [`bvh::packet::PACKET`] rays into `out`.
    pub fn occluded_packet<R: Real, T: RayPrimTest<R>>(
        &self,
        rays: &[PreparedRay<R>],
        out: &mut [bool],
        stats: &mut RayStats,
        mut test: T,
    ) {
        match self {
            Accel::Bvh(b) => b.occluded_packet(rays, out, stats, test),
            _ => {
                for (pr, o) in rays.iter().zip(out.iter_mut()) {
                    *o = self.occluded(pr, stats, |p, t| test.test(pr, p, t));
                }
            }
        }
    }
}
