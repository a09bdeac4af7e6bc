//! Ray statistics (docs/design-measures.md, *Ray statistics*): counted per tile without atomics,
//! merged by addition, so the totals do not depend on how the work was split — with one exception:
//! eye rays are traced in packets of the image's 4 × 4 pixel blocks
//! ([`crate::tile::Tile::blocks`]), and a tile size that is not a multiple of 4 cuts blocks into
//! other packets, which changes the box and primitive test counts (never the rays, the hits or the
//! pixels).

use crate::settings::RenderSettings;
use crate::tile::Tile;
use serde::{Deserialize, Serialize};
use std::ops::AddAssign;
use thiserror::Error;

/// Statistics that no render of the tile could have produced (a buggy or hostile worker).
#[derive(Debug, Error, PartialEq, Eq)]
#[error("implausible ray statistics: {0}")]
pub struct ImplausibleStats(pub String);

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
    /// Counters in a [`RayStats`].
    pub const FIELDS: usize = 11;

    /// The counters in declaration order: the one place their order is written down (the
    /// checkpoint's records keep it on disk, so it never changes).
    pub fn to_array(&self) -> [u64; Self::FIELDS] {
        [
            self.eye_rays,
            self.eye_hits,
            self.shadow_rays,
            self.shadow_hits,
            self.reflection_rays,
            self.reflection_hits,
            self.refraction_rays,
            self.refraction_hits,
            self.box_tests,
            self.primitive_tests,
            self.cell_steps,
        ]
    }

    /// The inverse of [`RayStats::to_array`].
    pub fn from_array(v: [u64; Self::FIELDS]) -> Self {
        let [eye_rays, eye_hits, shadow_rays, shadow_hits, reflection_rays, reflection_hits, refraction_rays, refraction_hits, box_tests, primitive_tests, cell_steps] =
            v;
        RayStats {
            eye_rays,
            eye_hits,
            shadow_rays,
            shadow_hits,
            reflection_rays,
            reflection_hits,
            refraction_rays,
            refraction_hits,
            box_tests,
            primitive_tests,
            cell_steps,
        }
    }

    /// All rays cast (saturating: a total never wraps).
    pub fn total_rays(&self) -> u64 {
        self.eye_rays
            .saturating_add(self.shadow_rays)
            .saturating_add(self.reflection_rays)
            .saturating_add(self.refraction_rays)
    }

    /// The eye rays a render of `tile` counts under `settings`: one per sample, or, in the SPD
    /// procedure, one per pixel corner the tile owns (its top-left corners, plus the image's
    /// last column and row of corners when the tile touches the right or bottom edge).
    pub fn expected_eye_rays(tile: &Tile, settings: &RenderSettings) -> u64 {
        if settings.spd_standard {
            let edge = |start: u32, len: u32, size: u32| {
                len as u64 + u64::from(start as u64 + len as u64 == size as u64)
            };
            edge(tile.x, tile.w, settings.width) * edge(tile.y, tile.h, settings.height)
        } else {
            tile.pixel_count() as u64 * settings.spp as u64
        }
    }

    /// Checks that these could be the statistics of rendering `tile` under `settings` in a
    /// scene with `lights` lights: the eye rays are exactly [`Self::expected_eye_rays`], no kind
    /// has more hits than rays, every hit spawns at most one reflection ray, one refraction ray
    /// and one shadow ray per light. A result that fails is not trusted (its pixels neither).
    pub fn check_tile(
        &self,
        tile: &Tile,
        settings: &RenderSettings,
        lights: usize,
    ) -> Result<(), ImplausibleStats> {
        let bad = |what: String| Err(ImplausibleStats(what));
        let eye = Self::expected_eye_rays(tile, settings);
        if self.eye_rays != eye {
            return bad(format!(
                "{} eye rays for a tile that casts {eye}",
                self.eye_rays
            ));
        }
        for (kind, rays, hits) in [
            ("eye", self.eye_rays, self.eye_hits),
            ("shadow", self.shadow_rays, self.shadow_hits),
            ("reflection", self.reflection_rays, self.reflection_hits),
            ("refraction", self.refraction_rays, self.refraction_hits),
        ] {
            if hits > rays {
                return bad(format!("{hits} {kind} hits from {rays} {kind} rays"));
            }
        }
        let hits = self
            .eye_hits
            .saturating_add(self.reflection_hits)
            .saturating_add(self.refraction_hits);
        if self.reflection_rays > hits || self.refraction_rays > hits {
            return bad(format!(
                "{} reflection and {} refraction rays from {hits} surface hits",
                self.reflection_rays, self.refraction_rays
            ));
        }
        if self.shadow_rays > hits.saturating_mul(lights as u64) {
            return bad(format!(
                "{} shadow rays from {hits} surface hits and {lights} lights",
                self.shadow_rays
            ));
        }
        Ok(())
    }
}

/// Sums saturate: statistics from many workers never wrap around (a total stuck at `u64::MAX`
/// is visibly wrong; a wrapped one looks plausible).
impl AddAssign for RayStats {
    fn add_assign(&mut self, o: Self) {
        self.eye_rays = self.eye_rays.saturating_add(o.eye_rays);
        self.eye_hits = self.eye_hits.saturating_add(o.eye_hits);
        self.shadow_rays = self.shadow_rays.saturating_add(o.shadow_rays);
        self.shadow_hits = self.shadow_hits.saturating_add(o.shadow_hits);
        self.reflection_rays = self.reflection_rays.saturating_add(o.reflection_rays);
        self.reflection_hits = self.reflection_hits.saturating_add(o.reflection_hits);
        self.refraction_rays = self.refraction_rays.saturating_add(o.refraction_rays);
        self.refraction_hits = self.refraction_hits.saturating_add(o.refraction_hits);
        self.box_tests = self.box_tests.saturating_add(o.box_tests);
        self.primitive_tests = self.primitive_tests.saturating_add(o.primitive_tests);
        self.cell_steps = self.cell_steps.saturating_add(o.cell_steps);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_array_keeps_declaration_order_and_round_trips() {
        let s = RayStats {
            eye_rays: 1,
            eye_hits: 2,
            shadow_rays: 3,
            shadow_hits: 4,
            reflection_rays: 5,
            reflection_hits: 6,
            refraction_rays: 7,
            refraction_hits: 8,
            box_tests: 9,
            primitive_tests: 10,
            cell_steps: 11,
        };
        assert_eq!(s.to_array(), [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11]);
        assert_eq!(RayStats::from_array(s.to_array()), s);
    }
}
