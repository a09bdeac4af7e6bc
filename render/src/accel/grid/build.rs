//! Grid construction: the resolution from the primitive count and the scene box, then the compact
//! cell lists in two passes (count, then fill) over a single allocation. Runs once per scene;
//! never called while tracing.

use super::Grid;
use crate::accel::margin;
use crate::geometry::aabb::{f32_down, f32_up};
use crate::geometry::Aabb;
use crate::settings::MAX_GRID_DENSITY;
use crate::vec3::V3;

/// Most cells a grid may have, whatever the density asks for (16 MiB of offsets).
pub const MAX_CELLS: u64 = 1 << 22;

/// Most primitive references a grid may store; past it the resolution is halved until it fits.
pub const MAX_REFERENCES: u64 = 1 << 26;

/// How far (in cells) the grid reaches past the scene's box on the high side of each axis. SPD
/// geometry sits on round (often dyadic) coordinates; cells of exactly `extent / res` then put
/// many cell planes exactly on primitive box faces, where the margin drags each box into the
/// neighbouring cells too (tetra: 25 references per primitive instead of 5). Stretching the
/// cells by this irrational-ish fraction (2 − φ) moves the planes off those coordinates.
pub const PLANE_SHIFT: f64 = 0.381_966;

/// Cells per axis for `count` primitives in a box of extents `ext` (all > 0): about
/// ∛(density·count) along the longest axis, the others in proportion, each at least 1, the
/// product at most [`MAX_CELLS`] and at most [`CELLS_PER_WANTED`]·`density`·`count` (the density
/// held to [`MAX_GRID_DENSITY`]). The product is taken in `f64`, so no density can wrap it.
pub fn resolution(ext: [f64; 3], count: usize, density: f64) -> [u32; 3] {
    let density = if density.is_finite() && density > 0.0 {
        density.min(MAX_GRID_DENSITY)
    } else {
        crate::settings::DEFAULT_GRID_DENSITY
    };
    let wanted = density * count.max(1) as f64;
    let cap = (CELLS_PER_WANTED * wanted)
        .ceil()
        .clamp(1.0, MAX_CELLS as f64);
    let longest = ext[0].max(ext[1]).max(ext[2]);
    let along = wanted.cbrt();
    let mut res = ext.map(|e| (e / longest * along).round().clamp(1.0, MAX_CELLS as f64) as u32);
    let total = |r: &[u32; 3]| r[0] as f64 * r[1] as f64 * r[2] as f64;
    while total(&res) > cap {
        let shrink = (cap / total(&res)).cbrt();
        for r in &mut res {
            *r = ((*r as f64 * shrink).floor() as u32).max(1);
        }
    }
    res
}

/// How far rounding each axis may take the cell count past `density`·`count`: (a + ½)³ ≤ 3.375·a³
/// for a ≥ 1 cells along the longest axis, so this cap never changes a grid that fits
/// [`MAX_CELLS`]; it only stops a density from asking for more cells than it means.
pub const CELLS_PER_WANTED: f64 = 4.0;

/// A cell range along one axis, both ends inclusive.
type Span = (u32, u32);

impl Grid {
    /// A grid with no cells: every ray misses.
    fn empty() -> Grid {
        Grid {
            res: [0; 3],
            min: [0.0; 3],
            cell: [1.0; 3],
            inv_cell: [1.0; 3],
            bounds: Aabb::EMPTY,
            lists: vec![0],
            empty_cells: 0,
            references: 0,
        }
    }

    /// Builds the grid over primitive bounds with the given density (cells along the longest
    /// axis ≈ ∛(density·N)). Boxes that are empty or not finite are put into every cell, so
    /// their primitives are still tested.
    pub fn build(bounds: &[Aabb], density: f64) -> Grid {
        let finite =
            |b: &Aabb| !b.is_empty() && b.min.iter().chain(b.max.iter()).all(|v| v.is_finite());
        let mut world = Aabb::EMPTY;
        for b in bounds.iter().filter(|b| finite(b)) {
            world = world.union(b);
        }
        if bounds.is_empty() {
            return Grid::empty();
        }
        if world.is_empty() {
            // Nothing has usable bounds: one cell holding everything.
            world = Aabb {
                min: [0.0; 3],
                max: [0.0; 3],
            };
        }
        let m = margin(&world);
        let lo = V3::new(
            world.min[0] as f64,
            world.min[1] as f64,
            world.min[2] as f64,
        );
        let hi = V3::new(
            world.max[0] as f64,
            world.max[1] as f64,
            world.max[2] as f64,
        );
        let lo = lo - V3::splat(m);
        let hi = hi + V3::splat(m);
        debug_assert!((hi - lo).to_array().iter().all(|&e| e > 0.0));
        let min = lo.to_array();
        let ext = (hi - lo).to_array();
        let mut res = resolution(ext, bounds.len(), density);
        let mut grid = loop {
            // The grid reaches PLANE_SHIFT of a cell past the scene's top on each axis.
            let cell = [0, 1, 2].map(|a| ext[a] / (res[a] as f64 - PLANE_SHIFT));
            let top = [0, 1, 2].map(|a| min[a] + res[a] as f64 * cell[a]);
            let g = Grid {
                res,
                min,
                cell,
                inv_cell: cell.map(|c| 1.0 / c),
                bounds: Aabb {
                    min: min.map(f32_down),
                    max: top.map(f32_up),
                },
                lists: Vec::new(),
                empty_cells: 0,
                references: 0,
            };
            let refs: u64 = bounds
                .iter()
                .map(|b| {
                    let s = g.spans(b, m);
                    (0..3)
                        .map(|a| (s[a].1 - s[a].0 + 1) as u64)
                        .product::<u64>()
                })
                .sum();
            if refs <= MAX_REFERENCES || res == [1, 1, 1] {
                break Grid {
                    references: refs,
                    ..g
                };
            }
            res = res.map(|r| (r / 2).max(1));
        };
        grid.fill(bounds, m);
        tracing::debug!(
            res = ?grid.res,
            cells = grid.cells(),
            empty = grid.empty_cells,
            references = grid.references,
            "grid built"
        );
        grid
    }

    /// The cells the box `b` widened by `m` overlaps, per axis.
    fn spans(&self, b: &Aabb, m: f64) -> [Span; 3] {
        let mut s = [(0u32, 0u32); 3];
        for (a, span) in s.iter_mut().enumerate() {
            let last = self.res[a] - 1;
            let lo = (b.min[a] as f64 - m - self.min[a]) * self.inv_cell[a];
            let hi = (b.max[a] as f64 + m - self.min[a]) * self.inv_cell[a];
            *span = if lo.is_finite() && hi.is_finite() && lo <= hi {
                let i0 = lo.floor().clamp(0.0, last as f64) as u32;
                let i1 = hi.floor().clamp(0.0, last as f64) as u32;
                (i0, i1)
            } else {
                (0, last)
            };
        }
        s
    }

    /// Fills `lists` (offsets, then indices) for boxes already counted in `references`.
    fn fill(&mut self, bounds: &[Aabb], m: f64) {
        let cells = self.cells();
        let base = cells + 1;
        let mut lists = vec![0u32; base + self.references as usize];
        // Pass 1: count into lists[c + 1].
        for b in bounds {
            self.for_each_cell(b, m, |c| lists[c + 1] += 1);
        }
        // Prefix sums: lists[c] = where cell c's list starts (absolute position).
        lists[0] = base as u32;
        for c in 0..cells {
            lists[c + 1] += lists[c];
        }
        self.empty_cells = (0..cells).filter(|&c| lists[c] == lists[c + 1]).count() as u64;
        // Pass 2: fill, using lists[c] as the cursor of cell c; afterwards lists[c] is the end of
        // cell c, i.e. the start of cell c + 1, so shift the offsets back by one.
        for (i, b) in bounds.iter().enumerate() {
            self.for_each_cell(b, m, |c| {
                let at = lists[c] as usize;
                lists[at] = i as u32;
                lists[c] += 1;
            });
        }
        for c in (1..=cells).rev() {
            lists[c] = lists[c - 1];
        }
        lists[0] = base as u32;
        self.lists = lists;
    }

    fn for_each_cell(&self, b: &Aabb, m: f64, mut f: impl FnMut(usize)) {
        let s = self.spans(b, m);
        for z in s[2].0..=s[2].1 {
            for y in s[1].0..=s[1].1 {
                for x in s[0].0..=s[0].1 {
                    f(self.cell_index(x, y, z));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube(lo: f32, hi: f32) -> Aabb {
        Aabb {
            min: [lo; 3],
            max: [hi; 3],
        }
    }

    #[test]
    fn resolution_follows_density_and_shape() {
        assert_eq!(resolution([1.0, 1.0, 1.0], 1000, 27.0), [30, 30, 30]);
        assert_eq!(resolution([2.0, 1.0, 0.0001], 1000, 8.0), [20, 10, 1]);
        let r = resolution([1.0; 3], 1 << 30, 1000.0);
        assert!(r[0] as u64 * r[1] as u64 * r[2] as u64 <= MAX_CELLS);
    }

    #[test]
    fn huge_densities_cannot_wrap_the_cell_count() {
        // 2^22 cells per axis would be 2^66 in all: it wrapped to 0 in u64 and passed the cap.
        for density in [1e30, f64::MAX, 1e4, 1e7] {
            for (ext, count) in [([1.0; 3], 1), ([3.0, 2.0, 1.0], 1000), ([1.0; 3], 1 << 26)] {
                let r = resolution(ext, count, density);
                let cells = r[0] as u64 * r[1] as u64 * r[2] as u64;
                assert!(cells <= MAX_CELLS, "{density} {count}: {r:?}");
                let most = (CELLS_PER_WANTED * MAX_GRID_DENSITY * count as f64).ceil() as u64;
                assert!(cells <= most, "{density} {count}: {r:?}");
            }
        }
        let g = Grid::build(&[cube(1.0, 2.0)], 1e30);
        assert!(g.cells() as u64 <= (CELLS_PER_WANTED * MAX_GRID_DENSITY) as u64);
        assert_eq!(g.references, g.cells() as u64);
    }

    #[test]
    fn lists_are_compact_and_complete() {
        let boxes: Vec<Aabb> = (0..50)
            .map(|i| cube(i as f32 * 0.1, i as f32 * 0.1 + 0.35))
            .collect();
        let g = Grid::build(&boxes, 8.0);
        assert_eq!(g.lists.len(), g.cells() + 1 + g.references as usize);
        let mut seen = vec![0u32; boxes.len()];
        let mut total = 0;
        for c in 0..g.cells() {
            let l = g.cell_prims(c);
            assert!(l.windows(2).all(|w| w[0] < w[1]), "ascending within a cell");
            for &p in l {
                seen[p as usize] += 1;
            }
            total += l.len();
        }
        assert_eq!(total as u64, g.references);
        assert!(seen.iter().all(|&n| n >= 1), "every primitive in some cell");
        assert_eq!(
            g.empty_cells,
            (0..g.cells())
                .filter(|&c| g.cell_prims(c).is_empty())
                .count() as u64
        );
    }

    #[test]
    fn degenerate_scenes() {
        let g = Grid::build(&[], 8.0);
        assert!(g.is_empty());
        assert_eq!(g.stats().nodes, 0);
        let g = Grid::build(&[cube(1.0, 2.0)], 8.0);
        assert_eq!(g.references, g.cells() as u64);
        // All primitives in the plane z = 0: one layer of cells, nonzero thickness.
        let flat: Vec<Aabb> = (0..100)
            .map(|i| Aabb {
                min: [i as f32, 0.0, 0.0],
                max: [i as f32 + 1.0, 1.0, 0.0],
            })
            .collect();
        let g = Grid::build(&flat, 8.0);
        assert_eq!(g.res[2], 1);
        assert!(g.cell[2] > 0.0);
    }
}
