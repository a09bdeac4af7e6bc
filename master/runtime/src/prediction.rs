//! A frame's tile costs predicted from the frames measured before it. Between frames of a
//! sequence the image moves: a camera turning shifts every feature by several tiles a frame
//! and brings new ones into view at an edge. A tile's own cost in an earlier frame predicts it
//! poorly where cost is concentrated, so the prediction follows the motion ([`Motion`]):
//! the shift, in whole tiles, that carries the costliest tiles of one frame onto those of the
//! next, averaged over the frames ([`Track`]: a camera turning 5.3 tiles a frame reads 5, 5,
//! 6, …) and applied once per frame between the last frame measured and the one predicted. Each
//! tile is then predicted as long as the costliest tile within [`RADIUS`] tiles of where it
//! came from (the shift is rounded; features straddle tiles), a tile whose origin is out of
//! view as long as the costliest measured (nothing says it is cheap), and, where predictions
//! fell short before, by how far they did ([`Risk`]). A costly tile predicted cheap is dealt
//! among the last, and the whole sequence then waits for it.

/// Tiles each way (across and down) whose measured costs predict a tile.
pub const RADIUS: usize = 1;

/// How much of a shortfall is still feared one frame later.
pub const DECAY: f64 = 0.75;

/// The largest shift looked for between two frames, as a share of the tile columns (rows).
pub const MOST_MOTION: f64 = 0.25;

/// A frame's tiles: costs in raster order, `cols` tiles a row.
#[derive(Clone, Copy, Debug)]
pub struct Grid<'a> {
    /// Tile costs, raster order.
    pub costs: &'a [f64],
    /// Tiles a row.
    pub cols: usize,
}

impl Grid<'_> {
    fn rows(&self) -> usize {
        self.costs.len().div_ceil(self.cols.max(1))
    }

    /// The cost at column `c`, row `r`, if both are in the image.
    fn at(&self, c: i64, r: i64) -> Option<f64> {
        let cols = self.cols.max(1) as i64;
        if c < 0 || r < 0 || c >= cols {
            return None;
        }
        self.costs.get((r * cols + c) as usize).copied()
    }
}

/// The motion between frames, in whole tiles: frame k + 1's tile at (c, r) shows what frame
/// k's tile at (c + dx, r + dy) showed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Motion {
    /// Tile columns.
    pub dx: i64,
    /// Tile rows.
    pub dy: i64,
}

impl Motion {
    /// The shift that best carries `before`'s costs onto `after`'s (two frames of the same
    /// grid, one frame apart): the one under which the costliest 1 % of `after`'s tiles
    /// (at least 16, at most 256: the search is shifts × those tiles, once a frame, on the
    /// master's loop) find the most of their cost at their origin in `before`; the smallest
    /// shift of equals, so a still camera reads as no motion.
    pub fn between(before: Grid<'_>, after: Grid<'_>) -> Motion {
        let n = after.costs.len();
        if n == 0 || before.costs.len() != n || before.cols != after.cols {
            return Motion::default();
        }
        let cols = after.cols.max(1);
        let mut top: Vec<usize> = (0..n).collect();
        let k = (n / 100).clamp(16, 256).min(n);
        top.select_nth_unstable_by(k - 1, |&a, &b| after.costs[b].total_cmp(&after.costs[a]));
        top.truncate(k);
        let (mx, my) = (
            (cols as f64 * MOST_MOTION) as i64,
            (after.rows() as f64 * MOST_MOTION) as i64,
        );
        let mut best = (f64::NEG_INFINITY, 0, Motion::default());
        for dy in -my..=my {
            for dx in -mx..=mx {
                let score: f64 = top
                    .iter()
                    .map(|&t| {
                        let (c, r) = ((t % cols) as i64, (t / cols) as i64);
                        before
                            .at(c + dx, r + dy)
                            .map_or(0.0, |b| b.min(after.costs[t]))
                    })
                    .sum();
                let size = dx.abs() + dy.abs();
                if score > best.0 || (score == best.0 && size < best.1) {
                    best = (score, size, Motion { dx, dy });
                }
            }
        }
        best.2
    }
}

/// The motion of the frames so far, each frame's measured shift averaged with those before
/// (the last [`Track::SPAN`] weighing most), in tiles.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Track {
    dx: f64,
    dy: f64,
    seen: u32,
}

impl Track {
    /// How many frames' shifts the average mostly spans.
    pub const SPAN: u32 = 4;

    /// Adds one frame's measured shift.
    pub fn learn(&mut self, m: Motion) {
        self.seen = (self.seen + 1).min(Self::SPAN);
        let w = 1.0 / self.seen as f64;
        self.dx += w * (m.dx as f64 - self.dx);
        self.dy += w * (m.dy as f64 - self.dy);
    }

    /// The shift over `frames` frames, rounded to whole tiles.
    pub fn over(&self, frames: usize) -> Motion {
        Motion {
            dx: (self.dx * frames as f64).round() as i64,
            dy: (self.dy * frames as f64).round() as i64,
        }
    }
}

/// Each tile's predicted cost, as long as it may take: `measured` (a frame's costs) carried on
/// by `shift`, each tile as long as the costliest within `radius` tiles across and down of its
/// origin, the costliest measured where its origin is out of view, or its `risk` if larger.
pub fn predict(measured: Grid<'_>, shift: Motion, risk: &Risk, radius: usize) -> Vec<f64> {
    let cols = measured.cols.max(1);
    let highest = measured.costs.iter().copied().fold(0.0, f64::max);
    let r = radius as i64;
    (0..measured.costs.len())
        .map(|t| {
            let (c, row) = ((t % cols) as i64 + shift.dx, (t / cols) as i64 + shift.dy);
            let near = match measured.at(c, row) {
                None => highest,
                Some(_) => (row - r..=row + r)
                    .flat_map(|rr| (c - r..=c + r).map(move |cc| (cc, rr)))
                    .filter_map(|(cc, rr)| measured.at(cc, rr))
                    .fold(0.0, f64::max),
            };
            near.max(risk.0.get(t).copied().unwrap_or(0.0))
        })
        .collect()
}

/// Per tile, how far the predictions fell short of the measured costs in the frames before,
/// each frame's shortfall weighed [`DECAY`] less the next.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Risk(Vec<f64>);

impl Risk {
    /// Learns from a frame complete: its `measured` costs against the `predicted` (by tile;
    /// a frame of another tile count starts the risk again).
    pub fn learn(&mut self, measured: &[f64], predicted: &[f64]) {
        if measured.len() != predicted.len() {
            return;
        }
        if self.0.len() != measured.len() {
            self.0 = vec![0.0; measured.len()];
        }
        for ((r, &m), &p) in self.0.iter_mut().zip(measured).zip(predicted) {
            *r = (DECAY * *r).max(m - p);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(costs: &[f64], cols: usize) -> Grid<'_> {
        Grid { costs, cols }
    }

    #[test]
    fn a_tile_is_predicted_by_the_costliest_near_its_origin() {
        // 4 × 3 tiles, one costly tile at row 1, column 1.
        let mut m = vec![0.1; 12];
        m[5] = 2.0;
        let still = Motion::default();
        let p = predict(grid(&m, 4), still, &Risk::default(), 1);
        let costly: Vec<usize> = (0..12).filter(|&t| p[t] == 2.0).collect();
        assert_eq!(costly, [0, 1, 2, 4, 5, 6, 8, 9, 10]);
        assert_eq!(p[3], 0.1);
        let itself = predict(grid(&m, 4), still, &Risk::default(), 0);
        assert_eq!(itself, m, "radius 0, no motion: the tile itself");
        // Moving one column left (what was at column c + 1 is at c): column 3 comes into
        // view, so it is predicted as long as the costliest measured.
        let left = Motion { dx: 1, dy: 0 };
        let p = predict(grid(&m, 4), left, &Risk::default(), 0);
        assert_eq!(p[4], 2.0, "column 0 shows what column 1 did");
        assert_eq!(p[5], 0.1);
        assert_eq!(p[3], 2.0, "column 3 comes into view");
    }

    #[test]
    fn the_motion_is_the_shift_that_carries_the_costly_tiles_along() {
        // 40 × 20 tiles, cheap, with a costly blob; the next frame shows it 5 columns left
        // and 2 rows up (what was at (c + 5, r + 2) is at (c, r)).
        let (cols, rows) = (40usize, 20usize);
        let frame = |ox: usize, oy: usize| -> Vec<f64> {
            (0..cols * rows)
                .map(|t| {
                    let (c, r) = (t % cols, t / cols);
                    let inside = (ox..ox + 4).contains(&c) && (oy..oy + 3).contains(&r);
                    if inside {
                        1.0 + (c - ox + r - oy) as f64
                    } else {
                        0.01
                    }
                })
                .collect()
        };
        let (a, b) = (frame(20, 10), frame(15, 8));
        let m = Motion::between(grid(&a, cols), grid(&b, cols));
        assert_eq!(m, Motion { dx: 5, dy: 2 });
        // Carried one frame further, the prediction puts the blob where it goes next.
        let c = frame(10, 6);
        let p = predict(grid(&b, cols), m, &Risk::default(), 0);
        for t in 0..cols * rows {
            if c[t] > 0.5 {
                assert_eq!(p[t], c[t], "tile {t}");
            }
        }
        // The same frame twice is no motion.
        assert_eq!(
            Motion::between(grid(&a, cols), grid(&a, cols)),
            Motion::default()
        );
    }

    #[test]
    fn a_track_averages_the_shifts_of_whole_tiles() {
        // A camera turning 5⅓ tiles a frame measures 5, 5, 6, 5, 5, 6, …
        let mut track = Track::default();
        assert_eq!(track.over(3), Motion::default(), "nothing seen: no motion");
        for dx in [5, 5, 6, 5, 5, 6, 5, 5, 6] {
            track.learn(Motion { dx, dy: 0 });
        }
        // Over two frames 10.7 tiles: 11, where one frame's measure doubled says 10 or 12.
        assert_eq!(track.over(2), Motion { dx: 11, dy: 0 });
        assert_eq!(track.over(0), Motion::default());
    }

    #[test]
    fn where_a_prediction_fell_short_the_next_fears_it() {
        let mut risk = Risk::default();
        // Tile 3 came into view costly: predicted 0.1, measured 1.1.
        risk.learn(&[0.1, 0.1, 0.1, 1.1], &[0.1, 0.2, 0.1, 0.1]);
        let still = Motion::default();
        let p = predict(grid(&[0.1; 4], 4), still, &risk, 0);
        assert_eq!(p, [0.1, 0.1, 0.1, 1.0]);
        // A frame later, predicted well, the fear fades by DECAY.
        risk.learn(&[0.1; 4], &[0.1; 4]);
        assert_eq!(predict(grid(&[0.0; 4], 4), still, &risk, 0)[3], DECAY);
        // Another tile count starts again.
        risk.learn(&[0.1; 2], &[0.1; 2]);
        assert_eq!(risk, Risk(vec![0.0; 2]));
    }
}
