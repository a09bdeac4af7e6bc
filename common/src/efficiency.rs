//! The paper's measures (DESIGN §9): cost c = n·tₙ and efficiency e = t₁/c, tables of efficiency
//! against threads (rows) and tile sizes (columns) as Markdown and CSV, and per-tile cost files.

use crate::tile::Tile;
use std::fmt::Write as _;
use std::path::Path;

/// Cost of a run on `n` threads taking `tn` seconds: `n·tₙ`.
pub fn cost(n: usize, tn: f64) -> f64 {
    n as f64 * tn
}

/// Efficiency of a run on `n` threads taking `tn` seconds, against a one-thread time `t1`:
/// `t₁ / (n·tₙ)`.
pub fn efficiency(t1: f64, n: usize, tn: f64) -> f64 {
    t1 / cost(n, tn)
}

/// The median of some timings (the upper median for an even count); NaN when empty. The one
/// median of the workspace: every study that repeats a measurement reports this.
pub fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[s.len() / 2]
}

/// One measured cell of an efficiency table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cell {
    /// Wall time tₙ in seconds (median).
    pub tn: f64,
    /// Cost n·tₙ.
    pub cost: f64,
    /// Efficiency t₁/(n·tₙ).
    pub efficiency: f64,
}

/// A table like the paper's Tables 1 and 2: rows are thread counts, columns tile sizes.
#[derive(Clone, Debug, PartialEq)]
pub struct EfficiencyTable {
    /// Caption (scene, accelerator, mode, executor).
    pub title: String,
    /// Thread counts (n), one per row.
    pub threads: Vec<usize>,
    /// Tile sizes, one per column.
    pub tiles: Vec<u32>,
    /// `cells[row][col]`; `None` where not measured.
    pub cells: Vec<Vec<Option<Cell>>>,
    /// Rows whose thread count exceeds the cores (marked as oversubscribed).
    pub cores: usize,
}

impl EfficiencyTable {
    /// An empty table of the given shape.
    pub fn new(
        title: impl Into<String>,
        threads: Vec<usize>,
        tiles: Vec<u32>,
        cores: usize,
    ) -> Self {
        let cells = vec![vec![None; tiles.len()]; threads.len()];
        EfficiencyTable {
            title: title.into(),
            threads,
            tiles,
            cells,
            cores,
        }
    }

    /// Fills the cell for `n` threads and tile size `tile`, given the one-thread time `t1`.
    pub fn set(&mut self, n: usize, tile: u32, t1: f64, tn: f64) {
        if let (Some(r), Some(c)) = (
            self.threads.iter().position(|&x| x == n),
            self.tiles.iter().position(|&x| x == tile),
        ) {
            self.cells[r][c] = Some(Cell {
                tn,
                cost: cost(n, tn),
                efficiency: efficiency(t1, n, tn),
            });
        }
    }

    /// The cell for `n` threads and tile size `tile`.
    pub fn get(&self, n: usize, tile: u32) -> Option<Cell> {
        let r = self.threads.iter().position(|&x| x == n)?;
        let c = self.tiles.iter().position(|&x| x == tile)?;
        self.cells[r][c]
    }

    /// Markdown: efficiency per cell, with tₙ in parentheses; oversubscribed rows marked.
    pub fn to_markdown(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "**{}**\n", self.title);
        s.push_str("| threads |");
        for t in &self.tiles {
            let _ = write!(s, " tile {t} |");
        }
        s.push_str("\n|---|");
        for _ in &self.tiles {
            s.push_str("---:|");
        }
        s.push('\n');
        for (r, n) in self.threads.iter().enumerate() {
            let mark = if *n > self.cores {
                " (oversubscribed)"
            } else {
                ""
            };
            let _ = write!(s, "| {n}{mark} |");
            for c in &self.cells[r] {
                match c {
                    Some(c) => {
                        let _ = write!(s, " {:.3} ({:.3}s) |", c.efficiency, c.tn);
                    }
                    None => s.push_str(" – |"),
                }
            }
            s.push('\n');
        }
        s
    }

    /// CSV: one line per cell: `title,threads,tile,tn_s,cost_s,efficiency,oversubscribed`.
    pub fn to_csv(&self, header: bool) -> String {
        let mut s = String::new();
        if header {
            s.push_str("table,threads,tile,tn_s,cost_s,efficiency,oversubscribed\n");
        }
        for (r, n) in self.threads.iter().enumerate() {
            for (c, tile) in self.tiles.iter().enumerate() {
                if let Some(cell) = self.cells[r][c] {
                    let _ = writeln!(
                        s,
                        "\"{}\",{n},{tile},{:.6},{:.6},{:.6},{}",
                        self.title.replace('"', "'"),
                        cell.tn,
                        cell.cost,
                        cell.efficiency,
                        *n > self.cores
                    );
                }
            }
        }
        s
    }
}

/// Writes per-tile costs as CSV: `tile,x,y,w,h,seconds`.
pub fn write_tile_costs(path: &Path, tiles: &[Tile], seconds: &[f64]) -> std::io::Result<()> {
    let mut s = String::from("tile,x,y,w,h,seconds\n");
    for (t, secs) in tiles.iter().zip(seconds) {
        let _ = writeln!(s, "{},{},{},{},{},{:.9}", t.id, t.x, t.y, t.w, t.h, secs);
    }
    std::fs::write(path, s)
}

/// Reads a per-tile cost file written by [`write_tile_costs`]. Errors name the line.
pub fn read_tile_costs(text: &str) -> Result<Vec<(Tile, f64)>, String> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if i == 0 && line.starts_with("tile,") || line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 6 {
            return Err(format!(
                "line {}: expected 6 fields, found {}",
                i + 1,
                f.len()
            ));
        }
        let num = |k: usize| -> Result<u32, String> {
            f[k].trim().parse().map_err(|_| {
                format!(
                    "line {}: field {} '{}' is not a whole number",
                    i + 1,
                    k + 1,
                    f[k]
                )
            })
        };
        let secs: f64 = f[5]
            .trim()
            .parse()
            .map_err(|_| format!("line {}: seconds '{}' is not a number", i + 1, f[5]))?;
        if !secs.is_finite() || secs < 0.0 {
            return Err(format!(
                "line {}: seconds must be finite and non-negative",
                i + 1
            ));
        }
        out.push((
            Tile {
                id: num(0)?,
                x: num(1)?,
                y: num(2)?,
                w: num(3)?,
                h: num(4)?,
            },
            secs,
        ));
    }
    Ok(out)
}

/// Sums fine tile costs into the tiles of a coarser tiling: each fine tile's cost goes to the
/// coarse tile containing its top-left pixel. Exact when the coarse size is a multiple of the
/// fine one.
pub fn aggregate_costs(fine: &[(Tile, f64)], coarse: &[Tile], coarse_size: u32) -> Vec<f64> {
    let size = coarse_size.max(1);
    let cols = coarse.iter().map(|t| t.x / size + 1).max().unwrap_or(0) as usize;
    let mut out = vec![0.0; coarse.len()];
    for (t, c) in fine {
        let idx = (t.y / size) as usize * cols + (t.x / size) as usize;
        if let Some(slot) = out.get_mut(idx) {
            *slot += c;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tile::tiles;

    #[test]
    fn cost_and_efficiency_follow_the_paper() {
        assert_eq!(cost(4, 2.5), 10.0);
        assert_eq!(efficiency(8.0, 4, 2.5), 0.8);
        assert_eq!(efficiency(8.0, 1, 8.0), 1.0);
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 3.0);
        assert!(median(&[]).is_nan());
    }

    #[test]
    fn table_shape_markdown_and_csv() {
        let mut t = EfficiencyTable::new("mount bvh smp", vec![1, 2, 4], vec![8, 16, 32, 64], 2);
        t.set(1, 8, 10.0, 10.0);
        t.set(2, 8, 10.0, 5.5);
        t.set(4, 64, 10.0, 5.0);
        assert_eq!(t.get(2, 8).map(|c| c.cost), Some(11.0));
        assert!((t.get(2, 8).unwrap().efficiency - 10.0 / 11.0).abs() < 1e-12);
        let md = t.to_markdown();
        assert_eq!(md.lines().filter(|l| l.starts_with("| ")).count(), 4); // header + 3 rows
        assert!(md.contains("| 4 (oversubscribed) |"));
        assert!(md.contains("0.909 (5.500s)"));
        let csv = t.to_csv(true);
        assert_eq!(csv.lines().count(), 4); // header + 3 cells
        assert!(csv.contains(",4,64,5.000000,20.000000,0.500000,true"));
    }

    #[test]
    fn tile_costs_round_trip_and_aggregate() {
        let fine = tiles(64, 48, 8);
        let secs: Vec<f64> = (0..fine.len()).map(|i| i as f64 * 0.5).collect();
        let dir = std::env::temp_dir().join(format!("parrt-costs-{}.csv", std::process::id()));
        write_tile_costs(&dir, &fine, &secs).unwrap();
        let read = read_tile_costs(&std::fs::read_to_string(&dir).unwrap()).unwrap();
        let _ = std::fs::remove_file(&dir);
        assert_eq!(read.len(), fine.len());
        let coarse = tiles(64, 48, 16);
        let agg = aggregate_costs(&read, &coarse, 16);
        assert_eq!(agg.len(), coarse.len());
        assert!((agg.iter().sum::<f64>() - secs.iter().sum::<f64>()).abs() < 1e-9);
        // Coarse tile 0 holds fine tiles (0,0),(8,0),(0,8),(8,8): ids 0, 1, 8, 9, summing to 18.
        assert!((agg[0] - 0.5 * 18.0).abs() < 1e-9);
        assert!(read_tile_costs("tile,x,y,w,h,seconds\n1,2,3\n").is_err());
        assert!(read_tile_costs("1,0,0,8,8,-1\n").is_err());
    }
}
