//! The uniform voxel grid (pbrt-v2's `GridAccel`; see docs/design-rendering.md, *Acceleration*):
//! the scene box cut into equal cells, each cell holding the primitives whose (slightly widened)
//! boxes overlap it, walked along a ray with the Amanatides–Woo 3D-DDA. It knows only boxes and
//! primitive indices, never geometry.
//!
//! Layout: [`build`] chooses the resolution and fills the compact cell lists; [`traverse`] walks
//! them for `intersect` and `occluded`; [`mailbox`] keeps one ray from testing a primitive twice.
//!
//! # Why it returns exactly the brute-force hit
//! The closest hit is the smallest `(t, primitive)` pair over all primitives (the tie rule of
//! [`PrimHit::beats`](crate::geometry::PrimHit::beats)). The traversal keeps the smallest pair
//! over every primitive it has tested so far, wherever along the ray that hit lies, and stops
//! only once the next cell starts beyond that hit (`t_next > best_t`; an equal `t` goes on, so a
//! tie with a smaller index in the next cell is still found). A primitive whose hit is nearer
//! than the stop is tested because its hit point lies in a cell the walk visited — provided the
//! walk's and the primitive test's rounding never move a point across a cell face by more than
//! the margin every box is widened by at insertion ([`crate::accel::margin`]). That margin is relative to
//! the scene's coordinates, so floating-point at cell faces, edges and corners cannot lose a hit;
//! testing a primitive too many times is only slower, never wrong.
//!
//! The margin (2⁻¹⁴ of the largest coordinate, ~1000 `f32` ulps) bounds what this covers: ray
//! origins within a few hundred scene magnitudes of the origin in `f32` (far more in `f64`).
//! It does not make the grid adaptive: a small dense object beside a huge polygon (pbrt's
//! "teapot in a stadium", SPD balls and tree) leaves most primitives in a few cells.

pub mod build;
pub mod mailbox;
pub mod traverse;

use super::AccelStats;
use crate::geometry::Aabb;

/// A built uniform grid.
///
/// Cell `(x, y, z)` has the linear index `(z·ny + y)·nx + x`. Its primitives are
/// `lists[lists[c] as usize..lists[c + 1] as usize]`: the first `cells + 1` entries of `lists` are
/// offsets into the same array (CSR in one allocation), the rest are primitive indices, ascending
/// within each cell.
#[derive(Debug)]
pub struct Grid {
    /// Cells per axis (each ≥ 1 unless the grid is empty).
    pub res: [u32; 3],
    /// Lower corner of the grid (the primitives' box widened by the margin).
    pub min: [f64; 3],
    /// Cell edge per axis.
    pub cell: [f64; 3],
    /// `1 / cell` per axis.
    pub inv_cell: [f64; 3],
    /// The grid's box in `f32`, rounded outward, for the entry slab test.
    pub bounds: Aabb,
    /// Offsets (`cells + 1` entries), then primitive indices.
    pub lists: Vec<u32>,
    /// Cells that hold no primitive.
    pub empty_cells: u64,
    /// Primitive references stored (sum of the list lengths).
    pub references: u64,
}

impl Grid {
    /// Number of cells (0 for an empty scene).
    #[inline]
    pub fn cells(&self) -> usize {
        self.res[0] as usize * self.res[1] as usize * self.res[2] as usize
    }

    /// True when the grid holds no cell (a scene without primitives).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.cells() == 0
    }

    /// Linear index of cell `(x, y, z)`.
    #[inline(always)]
    pub fn cell_index(&self, x: u32, y: u32, z: u32) -> usize {
        (z as usize * self.res[1] as usize + y as usize) * self.res[0] as usize + x as usize
    }

    /// The primitives of linear cell `c`.
    #[inline(always)]
    pub fn cell_prims(&self, c: usize) -> &[u32] {
        &self.lists[self.lists[c] as usize..self.lists[c + 1] as usize]
    }

    /// Build statistics: `nodes` = cells, `leaves` = non-empty cells, `references` = stored
    /// primitive indices.
    pub fn stats(&self) -> AccelStats {
        let cells = self.cells() as u64;
        AccelStats {
            kind: "grid".into(),
            nodes: cells,
            leaves: cells - self.empty_cells,
            references: self.references,
            sah_cost: 0.0,
            max_depth: 0,
            bytes: (self.lists.len() * std::mem::size_of::<u32>()) as u64,
            ..AccelStats::default()
        }
    }
}
