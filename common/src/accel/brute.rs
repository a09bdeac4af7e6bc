//! The brute-force "accelerator": every primitive for every ray. The oracle the other structures
//! are tested against.

use super::AccelStats;
use crate::geometry::{Aabb, PreparedRay, PrimHit};
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
        let mut best: Option<PrimHit<R>> = None;
        let mut best_t = pr.ray.t_max;
        let mut best_prim = u32::MAX;
        for i in 0..self.count {
            stats.primitive_tests += 1;
            if let Some(h) = test(i, best_t) {
                if h.beats(best_t, best_prim) {
                    best_t = h.t;
                    best_prim = h.prim;
                    best = Some(h);
                }
            }
        }
        best
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
