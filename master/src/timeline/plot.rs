//! The timeline plot: a row per render thread (SMP) or per worker thread (distributed), a bar
//! per tile from its start to its end, so idle gaps and the tail of a render show; requeued,
//! backup and ignored duplicate copies in their own colours, faults as red marks, and in a
//! sequence a line where each frame was complete, labelled with the frame. SVG and PNG with
//! plotters, titled with the scene, size and machine.

use super::{Attempt, Timeline};
use anyhow::Context;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

const FIRST: RGBColor = RGBColor(60, 110, 180);
const REQUEUED: RGBColor = RGBColor(235, 140, 20);
const BACKUP: RGBColor = RGBColor(140, 70, 170);
const DUPLICATE: RGBColor = RGBColor(160, 160, 160);
const FAULT: RGBColor = RGBColor(210, 20, 20);

fn colour(a: Attempt) -> RGBColor {
    match a {
        Attempt::First => FIRST,
        Attempt::Requeued => REQUEUED,
        Attempt::Backup => BACKUP,
        Attempt::DuplicateIgnored => DUPLICATE,
    }
}

/// Where each tile is drawn: its lane, and each row's label and first lane.
pub struct Layout {
    /// Lane of each entry of `timeline.tiles`.
    pub lane_of: Vec<usize>,
    /// (label, first lane, lanes) per row.
    pub rows: Vec<(String, usize, usize)>,
    /// Lanes in all.
    pub lanes: usize,
}

/// Lays the tiles out: an SMP thread is one lane; a worker gets one lane per thread and its
/// tiles are packed into them in order of start (a worker does not say which thread rendered
/// a tile, so lanes are the threads it must have used, not their names).
pub fn layout(t: &Timeline) -> Layout {
    let mut rows: Vec<(String, usize, usize)> = Vec::new();
    let mut lanes = 0;
    let mut row_of = std::collections::HashMap::new();
    let mut add = |name: &str, n: usize, rows: &mut Vec<(String, usize, usize)>| {
        rows.push((name.to_string(), lanes, n.max(1)));
        lanes += n.max(1);
        rows.len() - 1
    };
    for r in &t.rows {
        let i = add(&r.worker, r.threads as usize, &mut rows);
        row_of.insert(r.worker.clone(), i);
    }
    for tile in &t.tiles {
        if !row_of.contains_key(&tile.worker) {
            let i = add(&tile.worker, 1, &mut rows);
            row_of.insert(tile.worker.clone(), i);
        }
    }
    // Pack each row's tiles by start time.
    let mut order: Vec<usize> = (0..t.tiles.len()).collect();
    order.sort_by(|&a, &b| t.tiles[a].start_s.total_cmp(&t.tiles[b].start_s));
    let mut lane_end = vec![f64::MIN; lanes];
    let mut lane_of = vec![0; t.tiles.len()];
    for i in order {
        let tile = &t.tiles[i];
        let (_, first, n) = rows[row_of[&tile.worker]];
        let lane = match tile.thread {
            Some(th) if t.mode == "smp" => first + (th as usize).min(n - 1),
            _ => {
                // The first free lane, else the one that frees first.
                let eps = 1e-6;
                (first..first + n)
                    .find(|&l| lane_end[l] <= tile.start_s + eps)
                    .unwrap_or_else(|| {
                        (first..first + n)
                            .min_by(|&a, &b| lane_end[a].total_cmp(&lane_end[b]))
                            .unwrap_or(first)
                    })
            }
        };
        lane_end[lane] = lane_end[lane].max(tile.end_s);
        lane_of[i] = lane;
    }
    Layout {
        lane_of,
        rows,
        lanes,
    }
}

fn err<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow::anyhow!("plotting failed: {e:?}")
}

/// The default title: scene, size, mode and machine.
pub fn title(t: &Timeline) -> String {
    format!(
        "Timeline: {} {}×{} ({}, tile {}) on {}",
        t.scene, t.width, t.height, t.mode, t.tile_size, t.machine
    )
}

/// The chart's coordinates: seconds across, lanes up.
type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Seconds spanned by the tiles, the trace and the faults (never an empty range).
fn time_range(t: &Timeline) -> (f64, f64) {
    let mut x0 = 0.0f64;
    let mut x1 = t.trace_s;
    for tile in &t.tiles {
        x1 = x1.max(tile.end_s);
        x0 = x0.min(tile.start_s);
    }
    for e in t.events.iter().filter(|e| e.kind.is_fault()) {
        x1 = x1.max(e.t_s);
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    (x0, x1)
}

/// The lanes' geometry: lane `l` is drawn from `top(l + 1)` to `top(l + 1) + 1`, the first
/// row at the top.
struct Lanes<'a> {
    lay: &'a Layout,
    lanes: usize,
}

impl Lanes<'_> {
    fn top(&self, l: usize) -> f64 {
        (self.lanes - l.min(self.lanes)) as f64
    }

    /// The label of the row whose middle is at `y`; rows, not lanes, get labels.
    fn row_label(&self, t: &Timeline, y: f64) -> String {
        self.lay
            .rows
            .iter()
            .find(|(_, first, n)| (self.top(*first + *n) + *n as f64 / 2.0 - y).abs() < 0.25)
            .map(|(name, _, n)| {
                if t.mode == "smp" {
                    name.clone()
                } else {
                    format!("{name} ({n} thr)")
                }
            })
            .unwrap_or_default()
    }

    /// From the bottom to the top of `worker`'s row, or the whole height for a fault of no
    /// worker.
    fn row_span(&self, w: &Option<String>) -> (f64, f64) {
        w.as_ref()
            .and_then(|w| self.lay.rows.iter().find(|r| &r.0 == w))
            .map_or((0.0, self.lanes as f64), |(_, f, n)| {
                (self.top(*f + *n), self.top(*f))
            })
    }
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    t: &Timeline,
    title: &str,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let text = crate::plot::font_ready();
    root.fill(&WHITE).map_err(err)?;
    let lay = layout(t);
    let lanes = Lanes {
        lanes: lay.lanes.max(1),
        lay: &lay,
    };
    let (x0, x1) = time_range(t);
    // Room on the right for the legend, clear of the bars.
    let x_end = x1 + (x1 - x0) * 0.28;
    let mut b = ChartBuilder::on(&root);
    b.margin(12)
        .x_label_area_size(if text { 40 } else { 0 })
        .y_label_area_size(if text { 150 } else { 0 });
    if text {
        b.caption(title, ("sans-serif", 16));
    }
    let mut ctx = b
        .build_cartesian_2d(x0..x_end, 0f64..lanes.lanes as f64)
        .map_err(err)?;
    if text {
        // Label positions: the middle of every row (plotters picks from y_labels points; ask
        // for one per half lane so every middle is among them when rows are few).
        let points = (2 * lanes.lanes).min(200);
        let row_label = |y: &f64| lanes.row_label(t, *y);
        ctx.configure_mesh()
            .disable_y_mesh()
            .y_labels(points + 1)
            .y_label_formatter(&row_label)
            .x_desc("seconds since the trace began")
            .y_desc(if t.mode == "smp" {
                "render thread"
            } else {
                "worker"
            })
            .draw()
            .map_err(err)?;
    } else {
        ctx.configure_mesh()
            .disable_x_mesh()
            .disable_y_mesh()
            .x_labels(0)
            .y_labels(0)
            .draw()
            .map_err(err)?;
    }
    // Row separators.
    ctx.draw_series(lay.rows.iter().skip(1).map(|(_, first, _)| {
        PathElement::new(
            vec![(x0, lanes.top(*first)), (x_end, lanes.top(*first))],
            BLACK.mix(0.3),
        )
    }))
    .map_err(err)?;
    draw_tiles(&mut ctx, t, &lanes, text)?;
    draw_faults(&mut ctx, t, &lanes, text)?;
    draw_frames(&mut ctx, t, &lanes, text)?;
    if text {
        ctx.configure_series_labels()
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(err)?;
    }
    root.present().map_err(err)?;
    Ok(())
}

/// A bar per tile in its lane, coloured by attempt, each kind with its legend entry.
fn draw_tiles<DB: DrawingBackend>(
    ctx: &mut Chart<'_, DB>,
    t: &Timeline,
    lanes: &Lanes,
    text: bool,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    for a in [
        Attempt::First,
        Attempt::Requeued,
        Attempt::Backup,
        Attempt::DuplicateIgnored,
    ] {
        let c = colour(a);
        let bars = t.tiles.iter().enumerate().filter(|(_, r)| r.attempt == a);
        let corners = |(i, r): (usize, &super::TileRecord)| {
            let lane = lanes.top(lanes.lay.lane_of[i] + 1);
            [
                (r.start_s, lane + 0.12),
                (r.end_s.max(r.start_s), lane + 0.88),
            ]
        };
        let anno = ctx
            .draw_series(bars.clone().map(|b| Rectangle::new(corners(b), c.filled())))
            .map_err(err)?;
        if text {
            anno.label(format!("tile, {}", a.name()))
                .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 14, y + 5)], c.filled()));
        }
        // A thin outline so that back-to-back tiles stay apart.
        ctx.draw_series(bars.map(|b| Rectangle::new(corners(b), WHITE.mix(0.6).stroke_width(1))))
            .map_err(err)?;
    }
    Ok(())
}

/// Faults: a red line over the worker's row (or the whole height), a triangle on top.
fn draw_faults<DB: DrawingBackend>(
    ctx: &mut Chart<'_, DB>,
    t: &Timeline,
    lanes: &Lanes,
    text: bool,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let faults: Vec<_> = t.events.iter().filter(|e| e.kind.is_fault()).collect();
    let anno = ctx
        .draw_series(faults.iter().map(|e| {
            let (lo, hi) = lanes.row_span(&e.worker);
            PathElement::new(vec![(e.t_s, lo), (e.t_s, hi)], FAULT.stroke_width(2))
        }))
        .map_err(err)?;
    if text && !faults.is_empty() {
        anno.label("fault (worker lost / tile requeued)")
            .legend(|(x, y)| {
                PathElement::new(vec![(x + 7, y - 6), (x + 7, y + 6)], FAULT.stroke_width(2))
            });
    }
    ctx.draw_series(faults.iter().map(|e| {
        let (_, hi) = lanes.row_span(&e.worker);
        TriangleMarker::new(
            (e.t_s, hi.min(lanes.lanes as f64) - 0.05),
            5,
            FAULT.filled(),
        )
    }))
    .map_err(err)?;
    Ok(())
}

/// When each frame of a sequence was complete: its last tile in the image, by frame.
pub fn frame_ends(t: &Timeline) -> Vec<(u32, f64)> {
    let mut ends = std::collections::BTreeMap::new();
    for r in t
        .tiles
        .iter()
        .filter(|r| r.attempt != Attempt::DuplicateIgnored)
    {
        if let Some(f) = r.frame {
            let e = ends.entry(f).or_insert(r.end_s);
            *e = r.end_s.max(*e);
        }
    }
    ends.into_iter().collect()
}

/// A sequence's frames: a dark line over every lane where each frame was complete, labelled
/// with the frame (tiles of frame k+1 to the left of frame k's line filled its tail).
fn draw_frames<DB: DrawingBackend>(
    ctx: &mut Chart<'_, DB>,
    t: &Timeline,
    lanes: &Lanes,
    text: bool,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let ends = frame_ends(t);
    let top = lanes.lanes as f64;
    let anno = ctx
        .draw_series(ends.iter().map(|&(_, x)| {
            PathElement::new(vec![(x, 0.0), (x, top)], BLACK.mix(0.7).stroke_width(2))
        }))
        .map_err(err)?;
    if text && !ends.is_empty() {
        anno.label("frame complete").legend(|(x, y)| {
            PathElement::new(vec![(x + 7, y - 6), (x + 7, y + 6)], BLACK.stroke_width(2))
        });
        ctx.draw_series(
            ends.iter()
                .map(|&(f, x)| Text::new(format!(" {f}"), (x, top - 0.02), ("sans-serif", 12))),
        )
        .map_err(err)?;
    }
    Ok(())
}

/// The plot's size: wide, and tall enough for its lanes.
fn size(t: &Timeline) -> (u32, u32) {
    let lanes = layout(t).lanes as u32;
    (1100, (160 + 22 * lanes).clamp(320, 1600))
}

/// A plot asked for in a format other than SVG or PNG.
#[derive(Debug, thiserror::Error)]
#[error("{}: a timeline plot is written as .svg or .png", .0.display())]
pub struct UnknownFormat(pub std::path::PathBuf);

/// Draws the timeline to `out` (`.svg` or `.png`, by extension) under `title`.
pub fn save(t: &Timeline, out: &Path, title: &str) -> anyhow::Result<()> {
    let dims = size(t);
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    match ext.as_deref() {
        Some("svg") => draw(SVGBackend::new(out, dims).into_drawing_area(), t, title),
        Some("png") => crate::plot::save_png(out, dims, |root| draw(root, t, title)),
        _ => Err(UnknownFormat(out.to_path_buf()).into()),
    }
    .with_context(|| format!("cannot draw {}", out.display()))
}

/// Draws the timeline as `stem.svg` and `stem.png`.
pub fn save_both(t: &Timeline, stem: &Path, title: &str) -> anyhow::Result<()> {
    save(t, &stem.with_extension("svg"), title)?;
    save(t, &stem.with_extension("png"), title)
}

/// Draws `t` as `stem.svg` and `stem.png` in `out` for a study's report, titled `what` (the
/// run it shows); returns the Markdown that shows it.
pub fn save_figure(t: &Timeline, out: &Path, stem: &str, what: &str) -> anyhow::Result<String> {
    let title = format!(
        "{} {}×{}, tile {}, {what}: timeline on {}",
        t.scene, t.width, t.height, t.tile_size, t.machine
    );
    save_both(t, &out.join(stem), &title)?;
    Ok(format!(
        "Timeline of one run ({what}, tile {}; a row per thread, a bar per tile, gaps are idle \
         time; trace {:.3} s):\n\n![{stem}]({stem}.png)\n\n",
        t.tile_size, t.trace_s
    ))
}

#[cfg(test)]
mod tests {
    use super::super::{Row, TileRecord};
    use super::*;

    fn tile(worker: &str, start: f64, end: f64) -> TileRecord {
        TileRecord {
            tile: 0,
            worker: worker.into(),
            thread: None,
            assigned_s: None,
            start_s: start,
            end_s: end,
            attempt: Attempt::First,
            frame: None,
        }
    }

    #[test]
    fn overlapping_tiles_of_a_worker_get_their_own_lanes() {
        let t = Timeline {
            mode: "distributed".into(),
            rows: vec![
                Row {
                    worker: "a".into(),
                    threads: 2,
                },
                Row {
                    worker: "b".into(),
                    threads: 1,
                },
            ],
            tiles: vec![
                tile("a", 0.0, 1.0),
                tile("a", 0.5, 1.5),
                tile("a", 1.0, 2.0),
                tile("b", 0.0, 1.0),
            ],
            ..Timeline::default()
        };
        let l = layout(&t);
        assert_eq!(l.lanes, 3);
        assert_eq!(l.lane_of, vec![0, 1, 0, 2]);
    }

    #[test]
    fn draws_svg_and_png_and_refuses_other_extensions() {
        let dir = tempfile::tempdir().expect("temp dir");
        let t = Timeline {
            mode: "smp".into(),
            rows: vec![Row {
                worker: "thread 0".into(),
                threads: 1,
            }],
            tiles: vec![tile("thread 0", 0.0, 1.0)],
            trace_s: 1.0,
            ..Timeline::default()
        };
        save_both(&t, &dir.path().join("t"), "test").expect("draws");
        assert!(dir.path().join("t.svg").exists() && dir.path().join("t.png").exists());
        assert!(save(&t, &dir.path().join("t.jpg"), "x").is_err());
    }
}
