//! Render timelines (`--timeline FILE`): per tile, who rendered it and when, with the faults
//! met on the way, written as JSON or CSV (by the file's extension; the records with the `csv`
//! crate) and drawn by [`plot`].
//!
//! Times are seconds since the trace phase began (the first tile handed out); events before it
//! (a worker joining or building the scene) have negative times. The columns are documented in
//! `docs/timeline.md`.

pub mod plot;
pub mod recorder;

pub use recorder::Recorder;

use anyhow::Context;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Why [`Timeline::read`] failed.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The file could not be read.
    #[error("cannot read {}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The file is not a timeline [`Timeline::write`] wrote (the reader's fault, not parrt's).
    #[error("{} is not a parrt timeline", path.display())]
    NotATimeline {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        source: anyhow::Error,
    },
}

/// How a tile's result came to be in the timeline.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Attempt {
    /// The tile's first assignment, and its result is in the image.
    First,
    /// A later assignment after the tile was requeued (worker lost, deadline missed, result
    /// rejected), and its result is in the image.
    Requeued,
    /// A backup copy handed to an idle worker near the end, and its result is in the image.
    Backup,
    /// A result that came after another copy's had been taken: ignored (the work was wasted).
    DuplicateIgnored,
}

impl Attempt {
    /// The name written in files.
    pub fn name(self) -> &'static str {
        match self {
            Attempt::First => "first",
            Attempt::Requeued => "requeued",
            Attempt::Backup => "backup",
            Attempt::DuplicateIgnored => "duplicate-ignored",
        }
    }

    fn parse(s: &str) -> Option<Attempt> {
        [
            Attempt::First,
            Attempt::Requeued,
            Attempt::Backup,
            Attempt::DuplicateIgnored,
        ]
        .into_iter()
        .find(|a| a.name() == s)
    }
}

/// One rendered tile.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TileRecord {
    /// The tile's id (row-major).
    pub tile: u32,
    /// Who rendered it: `thread N` in an SMP render, the worker's name in a distributed one.
    pub worker: String,
    /// The render thread, when known (SMP renders; workers do not say).
    pub thread: Option<u32>,
    /// When the master handed it out (distributed renders only).
    pub assigned_s: Option<f64>,
    /// When rendering began. Distributed: the result's arrival less the worker's own render
    /// seconds, never before the assignment.
    pub start_s: f64,
    /// When rendering ended (SMP: pixels in the film; distributed: the result arrived).
    pub end_s: f64,
    /// How this copy came about.
    pub attempt: Attempt,
    /// The tile's frame in a sequence (none for a render of one frame).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame: Option<u32>,
}

/// What happened besides tiles.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum EventKind {
    /// A worker authenticated and was sent the job.
    WorkerJoined,
    /// A worker built the job and can take tiles.
    WorkerReady,
    /// A worker left, was dropped or fell silent; its tiles were requeued.
    WorkerLost,
    /// A tile went back to the queue.
    TileRequeued,
}

impl EventKind {
    /// The name written in files.
    pub fn name(self) -> &'static str {
        match self {
            EventKind::WorkerJoined => "worker-joined",
            EventKind::WorkerReady => "worker-ready",
            EventKind::WorkerLost => "worker-lost",
            EventKind::TileRequeued => "tile-requeued",
        }
    }

    fn parse(s: &str) -> Option<EventKind> {
        [
            EventKind::WorkerJoined,
            EventKind::WorkerReady,
            EventKind::WorkerLost,
            EventKind::TileRequeued,
        ]
        .into_iter()
        .find(|k| k.name() == s)
    }

    /// Whether it is a fault (drawn as a mark on the plot).
    pub fn is_fault(self) -> bool {
        matches!(self, EventKind::WorkerLost | EventKind::TileRequeued)
    }
}

/// One event.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimelineEvent {
    /// When.
    pub t_s: f64,
    /// What.
    pub kind: EventKind,
    /// The worker concerned, if one.
    pub worker: Option<String>,
    /// The tile concerned, if one.
    pub tile: Option<u32>,
    /// Why (a worker's reason for leaving, say).
    pub detail: String,
}

/// A render's timeline.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Timeline {
    /// `smp` or `distributed`.
    pub mode: String,
    /// The scene's label.
    pub scene: String,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Tile edge.
    pub tile_size: u32,
    /// The machine (CPU model and cores) the render ran on.
    pub machine: String,
    /// Seconds of the trace phase.
    pub trace_s: f64,
    /// Rows of the plot, in order: `thread N` or worker names (with their thread count).
    pub rows: Vec<Row>,
    /// Every tile result, accepted or not, in the order they landed.
    pub tiles: Vec<TileRecord>,
    /// Events in the order they happened.
    pub events: Vec<TimelineEvent>,
}

/// A thread or a worker.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// `thread N` or the worker's name.
    pub worker: String,
    /// Its render threads (1 for an SMP thread).
    pub threads: u32,
}

/// The header of the CSV form.
pub const CSV_HEADER: &str = "record,tile,worker,thread,assigned_s,start_s,end_s,attempt,detail";
/// The header of the CSV form of a sequence: a tile's frame in one more column.
pub const CSV_HEADER_FRAMES: &str =
    "record,tile,worker,thread,assigned_s,start_s,end_s,attempt,detail,frame";

/// Where the render ran: what the titles of plots name.
pub struct Job<'a> {
    /// Scene label.
    pub scene: &'a str,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Tile edge.
    pub tile_size: u32,
}

impl TileRecord {
    /// Tile `tile` (of frame `frame` of a sequence) rendered by an SMP thread over `span`.
    fn on_thread(tile: u32, frame: Option<u32>, span: &parrt_render::smp::TileSpan) -> Self {
        TileRecord {
            tile,
            worker: format!("thread {}", span.thread),
            thread: Some(span.thread),
            assigned_s: None,
            start_s: span.start_s,
            end_s: span.end_s,
            attempt: Attempt::First,
            frame,
        }
    }
}

impl Timeline {
    /// The timeline of an SMP render from its per-tile spans.
    pub fn from_smp(
        job: &Job<'_>,
        threads: usize,
        spans: &[parrt_render::smp::TileSpan],
        trace_s: f64,
    ) -> Self {
        let mut tiles: Vec<TileRecord> = spans
            .iter()
            .enumerate()
            .map(|(id, s)| TileRecord::on_thread(id as u32, None, s))
            .collect();
        tiles.sort_by(|a, b| a.end_s.total_cmp(&b.end_s));
        Timeline {
            mode: "smp".into(),
            rows: (0..threads)
                .map(|t| Row {
                    worker: format!("thread {t}"),
                    threads: 1,
                })
                .collect(),
            tiles,
            events: Vec::new(),
            trace_s,
            ..Timeline::header(job)
        }
    }

    /// The timeline of an SMP sequence from its tiles (frame, tile id, span), in any order;
    /// `job` is frame 0's.
    pub fn from_smp_sequence(
        job: &Job<'_>,
        threads: usize,
        spans: &[(usize, u32, parrt_render::smp::TileSpan)],
        trace_s: f64,
    ) -> Self {
        let mut t = Timeline::from_smp(job, threads, &[], trace_s);
        t.tiles = spans
            .iter()
            .map(|(frame, tile, s)| TileRecord::on_thread(*tile, u32::try_from(*frame).ok(), s))
            .collect();
        t.tiles.sort_by(|a, b| a.end_s.total_cmp(&b.end_s));
        t
    }

    /// An empty timeline of `job` on this machine.
    pub fn header(job: &Job<'_>) -> Self {
        Timeline {
            mode: String::new(),
            scene: job.scene.to_string(),
            width: job.width,
            height: job.height,
            tile_size: job.tile_size,
            machine: crate::machine::machine(),
            trace_s: 0.0,
            rows: Vec::new(),
            tiles: Vec::new(),
            events: Vec::new(),
        }
    }

    /// Writes the timeline to `path`: CSV for `.csv`, JSON otherwise.
    pub fn write(&self, path: &Path) -> anyhow::Result<()> {
        let text = if is_csv(path) {
            self.to_csv()?
        } else {
            serde_json::to_string_pretty(self)? + "\n"
        };
        std::fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))
    }

    /// Reads a timeline written by [`Self::write`].
    pub fn read(path: &Path) -> Result<Self, ReadError> {
        let bytes = std::fs::read(path).map_err(|source| ReadError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let bad = |source: anyhow::Error| ReadError::NotATimeline {
            path: path.to_path_buf(),
            source,
        };
        let text = String::from_utf8(bytes).map_err(|_| bad(anyhow::anyhow!("not UTF-8 text")))?;
        if is_csv(path) {
            Self::from_csv(&text)
        } else {
            serde_json::from_str(&text).map_err(anyhow::Error::from)
        }
        .map_err(bad)
    }

    /// The CSV form: one `tile` record per tile result, one record per event (its kind in
    /// `record`, its time in `start_s` and `end_s`); `#` comment lines with the job and the
    /// rows first. Line breaks in names and details become spaces (a row's name must read the
    /// same in its `# row=` line and in its records).
    pub fn to_csv(&self) -> anyhow::Result<String> {
        let mut out = format!(
            "# mode={} scene={} width={} height={} tile_size={} trace_s={} machine={}\n",
            self.mode,
            one_line(&self.scene),
            self.width,
            self.height,
            self.tile_size,
            self.trace_s,
            one_line(&self.machine)
        );
        for r in &self.rows {
            out += &format!("# row={} threads={}\n", one_line(&r.worker), r.threads);
        }
        let mut w = csv::Writer::from_writer(Vec::new());
        // A sequence's timeline has one more column, a tile's frame; one frame's keeps the
        // columns it always had.
        let frames = self.tiles.iter().any(|t| t.frame.is_some());
        let header = if frames {
            CSV_HEADER_FRAMES
        } else {
            CSV_HEADER
        };
        w.write_record(header.split(','))?;
        let opt = |v: Option<f64>| v.map(|v| format!("{v:.6}")).unwrap_or_default();
        let id = |v: Option<u32>| v.map(|v| v.to_string()).unwrap_or_default();
        for t in &self.tiles {
            let fields = [
                "tile",
                &t.tile.to_string(),
                &one_line(&t.worker),
                &id(t.thread),
                &opt(t.assigned_s),
                &format!("{:.6}", t.start_s),
                &format!("{:.6}", t.end_s),
                t.attempt.name(),
                "",
                &id(t.frame),
            ];
            w.write_record(&fields[..if frames { 10 } else { 9 }])?;
        }
        for e in &self.events {
            let t = format!("{:.6}", e.t_s);
            let fields = [
                e.kind.name(),
                &id(e.tile),
                &one_line(e.worker.as_deref().unwrap_or("")),
                "",
                "",
                &t,
                &t,
                "",
                &one_line(&e.detail),
                "",
            ];
            w.write_record(&fields[..if frames { 10 } else { 9 }])?;
        }
        out += &String::from_utf8(w.into_inner()?)?;
        Ok(out)
    }

    /// Parses [`Self::to_csv`]'s output: the `#` lines first, then the records after the
    /// header. Errors name the line.
    pub fn from_csv(text: &str) -> anyhow::Result<Self> {
        let mut tl = Timeline::default();
        // The `#` lines (and blank ones) before the header: `key=value` text, not CSV.
        let mut body = 0;
        let mut skipped: u64 = 0;
        for (n, line) in text.split_inclusive('\n').enumerate() {
            let bare = line.trim_end_matches(['\n', '\r']);
            if bare.starts_with('#') {
                tl.comment(bare)
                    .map_err(|e| anyhow::anyhow!("line {}: {e}", n + 1))?;
            } else if !bare.is_empty() {
                break;
            }
            body += line.len();
            skipped += 1;
        }
        let mut reader = csv::ReaderBuilder::new()
            .flexible(true)
            .from_reader(&text.as_bytes()[body..]);
        let line_of = |p: Option<&csv::Position>| skipped + p.map_or(1, csv::Position::line);
        let header = reader
            .headers()
            .map_err(|e| anyhow::anyhow!("line {}: {e}", line_of(e.position())))?;
        let frames = header.iter().eq(CSV_HEADER_FRAMES.split(','));
        if header.iter().ne(CSV_HEADER.split(',')) && !frames {
            anyhow::bail!("line {}: not the `{CSV_HEADER}` line", skipped + 1);
        }
        let fields = if frames { 10 } else { 9 };
        for record in reader.records() {
            let f = record.map_err(|e| anyhow::anyhow!("line {}: {e}", line_of(e.position())))?;
            let n = line_of(f.position());
            let bad = |what: &str| anyhow::anyhow!("line {n}: {what}");
            if f.len() != fields {
                return Err(bad(&format!("expected {fields} fields")));
            }
            let num = |s: &str| -> anyhow::Result<Option<f64>> {
                if s.is_empty() {
                    Ok(None)
                } else {
                    s.parse::<f64>().map(Some).map_err(|_| bad("bad number"))
                }
            };
            let tile = if f[1].is_empty() {
                None
            } else {
                Some(f[1].parse::<u32>().map_err(|_| bad("bad tile id"))?)
            };
            let start = num(&f[5])?.ok_or_else(|| bad("missing start_s"))?;
            if &f[0] == "tile" {
                tl.tiles.push(TileRecord {
                    tile: tile.ok_or_else(|| bad("missing tile id"))?,
                    worker: f[2].to_string(),
                    thread: if f[3].is_empty() {
                        None
                    } else {
                        Some(f[3].parse().map_err(|_| bad("bad thread"))?)
                    },
                    assigned_s: num(&f[4])?,
                    start_s: start,
                    end_s: num(&f[6])?.ok_or_else(|| bad("missing end_s"))?,
                    attempt: Attempt::parse(&f[7]).ok_or_else(|| bad("unknown attempt"))?,
                    frame: match f.get(9) {
                        Some(v) if !v.is_empty() => Some(v.parse().map_err(|_| bad("bad frame"))?),
                        _ => None,
                    },
                });
            } else {
                tl.events.push(TimelineEvent {
                    t_s: start,
                    kind: EventKind::parse(&f[0]).ok_or_else(|| bad("unknown record"))?,
                    worker: (!f[2].is_empty()).then(|| f[2].to_string()),
                    tile,
                    detail: f[8].to_string(),
                });
            }
        }
        Ok(tl)
    }

    /// Takes in one `#` line of the CSV form: `# row=NAME threads=N`, or the job's
    /// `# mode=… scene=… width=… height=… tile_size=… trace_s=… machine=…`.
    fn comment(&mut self, line: &str) -> Result<(), &'static str> {
        if let Some(c) = line.strip_prefix("# row=") {
            let (w, t) = c.rsplit_once(" threads=").ok_or("bad row line")?;
            self.rows.push(Row {
                worker: w.to_string(),
                threads: t.parse().map_err(|_| "bad thread count")?,
            });
            return Ok(());
        }
        let c = line.strip_prefix("# ").ok_or("bad comment line")?;
        let keys = [
            "mode=",
            " scene=",
            " width=",
            " height=",
            " tile_size=",
            " trace_s=",
            " machine=",
        ];
        let mut rest = c;
        let mut vals = Vec::new();
        for (i, k) in keys.iter().enumerate() {
            rest = rest.strip_prefix(k).ok_or("bad header comment")?;
            let end = keys
                .get(i + 1)
                .and_then(|next| rest.find(next))
                .unwrap_or(rest.len());
            vals.push(&rest[..end]);
            rest = &rest[end..];
        }
        self.mode = vals[0].to_string();
        self.scene = vals[1].to_string();
        self.width = vals[2].parse().map_err(|_| "bad width")?;
        self.height = vals[3].parse().map_err(|_| "bad height")?;
        self.tile_size = vals[4].parse().map_err(|_| "bad tile size")?;
        self.trace_s = vals[5].parse().map_err(|_| "bad trace_s")?;
        self.machine = vals[6].to_string();
        Ok(())
    }
}

fn is_csv(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("csv"))
}

/// `s` on one line: line breaks become spaces.
fn one_line(s: &str) -> String {
    s.replace(['\n', '\r'], " ")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Timeline {
        Timeline {
            mode: "distributed".into(),
            scene: "balls:2".into(),
            width: 64,
            height: 32,
            tile_size: 16,
            machine: "test cpu, 2 cores".into(),
            trace_s: 1.5,
            rows: vec![Row {
                worker: "w,1".into(),
                threads: 2,
            }],
            tiles: vec![TileRecord {
                tile: 3,
                worker: "w,1".into(),
                thread: None,
                assigned_s: Some(0.25),
                start_s: 0.5,
                end_s: 0.75,
                attempt: Attempt::Backup,
                frame: None,
            }],
            events: vec![TimelineEvent {
                t_s: -0.5,
                kind: EventKind::WorkerLost,
                worker: Some("w,1".into()),
                tile: None,
                detail: "said \"bye\", left".into(),
            }],
        }
    }

    #[test]
    fn csv_round_trips() {
        let t = sample();
        let text = t.to_csv().expect("writes");
        let back = Timeline::from_csv(&text).expect("parses");
        assert_eq!(back, t);
        assert!(text.contains(CSV_HEADER));
        // The bytes the scripts and docs/timeline.md know: quoted only where needed.
        assert!(
            text.ends_with(
                "\ntile,3,\"w,1\",,0.250000,0.500000,0.750000,backup,\n\
                 worker-lost,,\"w,1\",,,-0.500000,-0.500000,,\"said \"\"bye\"\", left\"\n"
            ),
            "{text}"
        );
    }

    /// A sequence's timeline: one more column, the tile's frame, in CSV and in JSON.
    #[test]
    fn a_sequences_frames_round_trip_in_csv_and_json() {
        let mut t = sample();
        t.tiles[0].frame = Some(2);
        let text = t.to_csv().expect("writes");
        assert!(text.contains(CSV_HEADER_FRAMES), "{text}");
        assert!(
            text.contains("\ntile,3,\"w,1\",,0.250000,0.500000,0.750000,backup,,2\n"),
            "{text}"
        );
        assert_eq!(Timeline::from_csv(&text).expect("parses"), t);
        let json = serde_json::to_string(&t).unwrap();
        assert!(json.contains("\"frame\":2"), "{json}");
        assert_eq!(serde_json::from_str::<Timeline>(&json).unwrap(), t);
        // One frame's JSON has no frame at all.
        assert!(!serde_json::to_string(&sample()).unwrap().contains("frame"));
    }

    #[test]
    fn line_breaks_in_names_become_spaces_everywhere() {
        let mut t = sample();
        t.rows[0].worker = "w\n1".into();
        t.tiles[0].worker = "w\n1".into();
        t.events[0].detail = "a\r\nb".into();
        let back = Timeline::from_csv(&t.to_csv().expect("writes")).expect("parses");
        assert_eq!(back.rows[0].worker, "w 1");
        assert_eq!(back.tiles[0].worker, "w 1");
        assert_eq!(back.events[0].detail, "a  b");
    }

    #[test]
    fn json_round_trips_with_kebab_names() {
        let t = sample();
        let text = serde_json::to_string(&t).expect("serialises");
        assert!(
            text.contains("\"backup\"") && text.contains("\"worker-lost\""),
            "{text}"
        );
        let back: Timeline = serde_json::from_str(&text).expect("parses");
        assert_eq!(back, t);
    }

    #[test]
    fn bad_csv_is_an_error_not_a_panic() {
        let err = |text: &str| match Timeline::from_csv(text) {
            Ok(t) => panic!("{text:?} parsed: {t:?}"),
            Err(e) => e.to_string(),
        };
        assert_eq!(err(""), format!("line 1: not the `{CSV_HEADER}` line"));
        assert_eq!(
            err(&format!("{CSV_HEADER}\ntile,x,a,,,1,2,first,\n")),
            "line 2: bad tile id"
        );
        assert_eq!(err("# mode=\n"), "line 1: bad header comment");
        assert_eq!(
            err(&format!(
                "# row=a threads=1\n\n{CSV_HEADER}\ntile,1,a,,,1,2,first,\ntile,2\n"
            )),
            "line 5: expected 9 fields"
        );
        assert_eq!(
            err(&format!(
                "{CSV_HEADER}\ntile,1,\"a\nb\",,,1,2,first,\nodd,,,,,1,1,,\n"
            )),
            "line 4: unknown record"
        );
        assert_eq!(
            err("record,tile\n"),
            format!("line 1: not the `{CSV_HEADER}` line")
        );
        assert_eq!(
            err(&format!("{CSV_HEADER}\n# late comment\n")),
            "line 2: expected 9 fields"
        );
    }
}
