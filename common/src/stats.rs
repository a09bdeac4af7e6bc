//! Ray statistics (DESIGN §9): counted per tile without atomics, merged by addition, so the
//! totals do not depend on how the work was split — with one exception: eye rays are traced in
//! packets of the image's 4 × 4 pixel blocks ([`crate::tile::Tile::blocks`]), and a tile size
//! that is not a multiple of 4 cuts blocks into other packets, which changes the box and
//! primitive test counts (never the rays, the hits or the pixels).

use serde::{Deserialize, Serialize};
use std::ops::AddAssign;

/// Counts of rays and tests. Every field is a plain sum over pixels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RayStats {
    /// Eye (primary) rays cast.
    pub eye_rays: u64,
    /// Eye rays that hit something.
    pub eye_hits: u64,
    /// Shadow rays cast.
    pub shadow_rays: u64,
    /// Shadow rays that found a blocker.
    pub shadow_hits: u64,
    /// Reflection rays cast.
    pub reflection_rays: u64,
    /// Reflection rays that hit something.
    pub reflection_hits: u64,
    /// Refraction rays cast.
    pub refraction_rays: u64,
    /// Refraction rays that hit something.
    pub refraction_hits: u64,
    /// Ray/box tests (BVH nodes, grid bounds).
    pub box_tests: u64,
    /// Ray/primitive tests.
    pub primitive_tests: u64,
    /// Grid cells stepped through.
    pub cell_steps: u64,
}

impl RayStats {
    /// All rays cast.
    pub fn total_rays(&self) -> u64 {
        self.eye_rays + self.shadow_rays + self.reflection_rays + self.refraction_rays
    }
}

impl AddAssign for RayStats {
    fn add_assign(&mut self, o: Self) {
        self.eye_rays += o.eye_rays;
        self.eye_hits += o.eye_hits;
        self.shadow_rays += o.shadow_rays;
        self.shadow_hits += o.shadow_hits;
        self.reflection_rays += o.reflection_rays;
        self.reflection_hits += o.reflection_hits;
        self.refraction_rays += o.refraction_rays;
        self.refraction_hits += o.refraction_hits;
        self.box_tests += o.box_tests;
        self.primitive_tests += o.primitive_tests;
        self.cell_steps += o.cell_steps;
    }
}
