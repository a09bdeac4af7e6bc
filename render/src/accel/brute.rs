//! The brute-force "accelerator": every primitive for every ray. The oracle the other structures
//! are tested against.

use super::AccelStats;
use crate::geometry::{Aabb, Nearest, PreparedRay, PrimHit};
use crate::real::Real;
use crate::stats::RayStats;

/// A linear scan over `count` primitives.
#[derive(Debug)]
pub struct Brute {
    count: u32,
}

impl Brute {
    /// "Builds" over the primitives' bounds (only their number matters).
    pub fn build(bounds: &[Aabb]) -> Self {
        Brute {
            count: bounds.len() as u32,
        }
    }

    /// Build statistics.
    pub fn stats(&self) -> AccelStats {
        AccelStats {
            kind: "brute".into(),
            references: self.count as u64,
            ..Default::default()
        }
    }

    /// Closest hit.
    pub fn intersect<R: Real, F>(
        &self,
        pr: &PreparedRay<R>,
        stats: &mut RayStats,
        mut test: F,
    ) -> Option<PrimHit<R>>
    where
        F: FnMut(u32, R) -> Option<PrimHit<R>>,
    {
        let mut best = Nearest::new(pr.ray.t_max);
        for i in 0..self.count {
            stats.primitive_tests += 1;
            best.offer(test(i, best.t));
        }
        best.hit
    }

    /// Any hit.
    pub fn occluded<R: Real, F>(
        &self,
        pr: &PreparedRay<R>,
        stats: &mut RayStats,
        mut test: F,
    ) -> bool
    where
        F: FnMut(u32, R) -> Option<PrimHit<R>>,
    {
        for i in 0..self.count {
            stats.primitive_tests += 1;
            if test(i, pr.ray.t_max).is_some() {
                return true;
            }
        }
        false
    }
}
