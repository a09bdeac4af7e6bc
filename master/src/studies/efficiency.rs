//! The paper's measures (docs/design-measures.md, *Efficiency*): cost c = n·tₙ and efficiency e =
//! t₁/c, tables of efficiency against threads (rows) and tile sizes (columns) as Markdown and CSV,
//! and per-tile cost files. CSV is read and written with the `csv` crate.

use parrt_render::tile::Tile;
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
    /// Frames each measured run rendered (1, or a sequence's frames as one job).
    pub frames: usize,
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
            frames: 1,
        }
    }

    /// This table with each run rendering `frames` frames as one job.
    pub fn with_frames(mut self, frames: usize) -> Self {
        self.frames = frames;
        self
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

    /// Writes one CSV record per measured cell, in the columns of [`CSV_HEADER`] (which the
    /// caller writes once, before the first table).
    pub fn write_csv<W: std::io::Write>(&self, out: &mut csv::Writer<W>) -> csv::Result<()> {
        for (r, n) in self.threads.iter().enumerate() {
            for (c, tile) in self.tiles.iter().enumerate() {
                if let Some(cell) = self.cells[r][c] {
                    out.write_record([
                        self.title.clone(),
                        n.to_string(),
                        tile.to_string(),
                        format!("{:.6}", cell.tn),
                        format!("{:.6}", cell.cost),
                        format!("{:.6}", cell.efficiency),
                        (*n > self.cores).to_string(),
                        self.frames.to_string(),
                    ])?;
                }
            }
        }
        Ok(())
    }
}

/// The columns of an efficiency table's CSV ([`EfficiencyTable::write_csv`]).
pub const CSV_HEADER: [&str; 8] = [
    "table",
    "threads",
    "tile",
    "tn_s",
    "cost_s",
    "efficiency",
    "oversubscribed",
    "frames",
];

/// The columns of a per-tile cost file.
const TILE_COSTS_HEADER: [&str; 6] = ["tile", "x", "y", "w", "h", "seconds"];

/// Writes per-tile costs as CSV: `tile,x,y,w,h,seconds`.
pub fn write_tile_costs(path: &Path, tiles: &[Tile], seconds: &[f64]) -> std::io::Result<()> {
    let mut out = csv::Writer::from_path(path)?;
    out.write_record(TILE_COSTS_HEADER)?;
    for (t, secs) in tiles.iter().zip(seconds) {
        out.write_record([
            t.id.to_string(),
            t.x.to_string(),
            t.y.to_string(),
            t.w.to_string(),
            t.h.to_string(),
            format!("{secs:.9}"),
        ])?;
    }
    out.flush()
}

/// Reads a per-tile cost file written by [`write_tile_costs`] (the header line may be left
/// out; blank lines are skipped). Errors name the line.
pub fn read_tile_costs(text: &str) -> Result<Vec<(Tile, f64)>, String> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let mut out = Vec::new();
    for (i, record) in reader.records().enumerate() {
        let line = |e: &csv::Error| e.position().map_or(0, |p| p.line());
        let f = record.map_err(|e| format!("line {}: {e}", line(&e)))?;
        let n = f.position().map_or(0, |p| p.line());
        if i == 0 && f.get(0) == Some(TILE_COSTS_HEADER[0]) || f.iter().all(str::is_empty) {
            continue;
        }
        if f.len() != 6 {
            return Err(format!("line {n}: expected 6 fields, found {}", f.len()));
        }
        let num = |k: usize| -> Result<u32, String> {
            f[k].parse().map_err(|_| {
                format!(
                    "line {n}: field {} '{}' is not a whole number",
                    k + 1,
                    &f[k]
                )
            })
        };
        let secs: f64 = f[5]
            .parse()
            .map_err(|_| format!("line {n}: seconds '{}' is not a number", &f[5]))?;
        if !secs.is_finite() || secs < 0.0 {
            return Err(format!("line {n}: seconds must be finite and non-negative"));
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
    use parrt_render::tile::tiles;

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
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(CSV_HEADER).expect("in memory");
        t.write_csv(&mut w).expect("in memory");
        let csv = String::from_utf8(w.into_inner().expect("in memory")).expect("UTF-8");
        assert_eq!(csv.lines().count(), 4); // header + 3 cells
        assert!(
            csv.starts_with("table,threads,tile,tn_s,cost_s,efficiency,oversubscribed,frames\n")
        );
        assert!(csv.contains("\nmount bvh smp,4,64,5.000000,20.000000,0.500000,true,1\n"));
        // A title with a comma or a quote is quoted, and reads back as one field.
        let mut q = EfficiencyTable::new("a, \"b\"", vec![1], vec![8], 2).with_frames(24);
        q.set(1, 8, 1.0, 1.0);
        let mut w = csv::Writer::from_writer(Vec::new());
        q.write_csv(&mut w).expect("in memory");
        let text = w.into_inner().expect("in memory");
        assert_eq!(
            text,
            b"\"a, \"\"b\"\"\",1,8,1.000000,1.000000,1.000000,false,24\n"
        );
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
        assert_eq!(
            read_tile_costs("tile,x,y,w,h,seconds\n1,2,3\n"),
            Err("line 2: expected 6 fields, found 3".into())
        );
        assert!(read_tile_costs("1,0,0,8,8,-1\n").is_err());
        assert_eq!(
            read_tile_costs("0,0,0,8,8,1\n\n 1 , 8,0,8,8, 2\n2,x,0,8,8,1\n"),
            Err("line 4: field 2 'x' is not a whole number".into())
        );
        assert_eq!(
            read_tile_costs("0,0,0,8,8,\"1,5\"\n"),
            Err("line 1: seconds '1,5' is not a number".into())
        );
    }
}
