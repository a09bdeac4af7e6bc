//! Scale in virtual time: the real master and N real worker sessions on simulated hosts,
//! replaying a recorded render (each tile's recorded one-thread cost, scaled to the frame's
//! work, and its recorded pixels) with no faults, so a 512-core cluster runs on one core of
//! this machine. What a network and a master cost is charged in virtual time where the bytes
//! arrive at the master ([`Paced`]): each worker's link and the master's link at their
//! bandwidth, then the master's CPU per result received (charged by the byte, one byte after
//! another as a single-threaded master handles them). The bytes are the workers' own: 8-bit
//! pixels packed as the protocol packs them. Beside each run, the analytic simulator
//! (`parrt_master::studies::simulate`) predicts the same configuration.
//!
//! tokio's timers run in whole milliseconds, so a frame whose tiles last microseconds (a
//! 0.2 s frame cut into 16 384 tiles) is run *dilated*: every duration the world sets — tile
//! costs, latency, the time a byte takes on a link and in the master, the batch rule's work
//! cap, heartbeats — is stretched by one factor, so that the mean tile lasts at least
//! [`MIN_DILATED_TILE_S`]. Efficiency is a ratio of times, so it does not change; the row
//! reports times undilated and says the factor.

use super::net::SimDial;
use super::sequence::{scenes, FrameSeen, Orbit, SeqExec, SimFrames};
use super::tail::{Tail, TailTrace};
use parrt_master::studies::simulate::{
    simulate, simulate_sequence, FrameWindow, Predicted, SimParams,
};
use parrt_protocol::{PixelFormat, TilePixels, Token};
use parrt_render::description::SceneDescription;
use parrt_render::film::Film;
use parrt_render::render::Renderer;
use parrt_render::settings::RenderSettings;
use parrt_render::smp::{render_smp, Executor, SmpOptions};
use parrt_runtime::{DistResult, Master, MasterConfig};
use parrt_worker::replay::{self, Replay};
use parrt_worker::WorkerOptions;
use serde::Serialize;
use std::future::Future;
use std::io;
use std::net::SocketAddr;
use std::path::Path;
use std::pin::Pin;
use std::sync::{Arc, Mutex};
use std::task::{ready, Context, Poll};
use std::time::{Duration, UNIX_EPOCH};
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::time::{sleep_until, Instant, Sleep};
use tokio_util::sync::CancellationToken;

/// The shortest mean tile, in virtual seconds, that the simulation runs undilated: tokio's
/// millisecond timers then add at most 1 % to it (half a millisecond on average).
pub const MIN_DILATED_TILE_S: f64 = 0.05;

/// The most simulated worker hosts: turmoil links every host with every other and visits
/// every link for every host on every step, so a step costs the cube of the host count (513
/// hosts: no 20-minute frame finished in 35 CPU minutes). Past this many workers, sessions
/// share hosts; each still has its own connection, and its own link in [`Paced`], so sharing
/// changes no duration.
pub const MAX_HOSTS: usize = 64;

/// One configuration to run.
#[derive(Clone, Debug)]
pub struct Config {
    /// Worker hosts.
    pub workers: usize,
    /// Threads of each.
    pub threads: usize,
    /// One-core seconds of the whole frame (the recording's costs are scaled to it).
    pub work_s: f64,
    /// Bandwidth of each worker's link and of the master's, bits per second.
    pub link_bps: f64,
    /// One-way latency.
    pub latency: Duration,
    /// The master's CPU per result received, seconds (charged by the byte: this over the
    /// mean bytes of a packed result).
    pub master_s_per_tile: f64,
    /// Most tiles in one assignment.
    pub max_batch: usize,
    /// Stretch every duration by this factor (`None`: only as much as the frame needs,
    /// [`MIN_DILATED_TILE_S`]). A test sets it to show a factor changes nothing.
    pub dilation: Option<f64>,
    /// Hand the tiles out costliest first (by the recording's costs, as a previous frame's
    /// would give them) instead of in raster order.
    pub costly_first: bool,
    /// The most simulated hosts the workers are spread over (`None`: [`MAX_HOSTS`]). A test
    /// sets it to show that sharing hosts changes nothing.
    pub hosts: Option<usize>,
    /// Frames rendered as one sequence (1: one frame), each the recording panned
    /// ([`super::sequence`]).
    pub frames: usize,
    /// Degrees the sequence turns over its frames.
    pub orbit_deg: f64,
    /// Frames the master keeps open at once (a sequence's window).
    pub frames_window: usize,
}

/// What one configuration gave.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// Worker hosts.
    pub workers: usize,
    /// Threads per worker.
    pub threads: usize,
    /// One-core seconds of the frame.
    pub work_s: f64,
    /// Link bandwidth, Gbit/s.
    pub link_gbit: f64,
    /// Frames in the sequence (1: one frame).
    pub frames: usize,
    /// Frames the master kept open at once (1 for one frame).
    pub frames_window: usize,
    /// Measured in virtual time: t₁ / (n · trace time), t₁ the tiles' costs as simulated
    /// (of every frame: a sequence's throughput).
    pub efficiency: f64,
    /// How much tokio's millisecond timers lengthened the frame's work (spent / asked − 1).
    pub rounding: f64,
    /// How much every duration was stretched to keep the timers' rounding small (1: not).
    pub dilation: f64,
    /// The analytic simulator's efficiency for the same configuration.
    pub predicted: f64,
    /// The model's share of thread time idle after the first thread ran out of work (the
    /// tail: tiles of unequal cost).
    pub model_tail: f64,
    /// The model's share of the master's time busy (near 1: the master or its link binds).
    pub model_master: f64,
    /// The assembled image equals the recorded one, bit for bit.
    pub identical: bool,
    /// Virtual seconds from the first tile handed out to the last result.
    pub trace_s: f64,
    /// Mean over the frames of the virtual seconds from a frame's first tile handed out to
    /// its last accepted (for one frame, the trace time).
    pub latency_mean_s: f64,
    /// The longest of those.
    pub latency_max_s: f64,
    /// The model's time for one frame alone on the same cluster (what a frame's latency
    /// compares with).
    pub single_frame_predicted_s: f64,
    /// A sequence's frames as they finished (empty for one frame).
    #[serde(skip)]
    pub seen: Vec<FrameSeen>,
    /// Real seconds the simulation took.
    pub wall_s: f64,
    /// What the run's event trace says binds it.
    pub trace: Tail,
}

/// Records (or reuses) a one-thread render (each tile's cost the least of three) of `desc` at `settings`, tile `tile`, in `path`.
pub fn record(
    desc: &SceneDescription,
    settings: &RenderSettings,
    tile: u32,
    path: &Path,
) -> anyhow::Result<()> {
    if path.exists() {
        return Ok(());
    }
    let renderer = Renderer::new(desc, settings)?;
    let opts = SmpOptions {
        threads: 1,
        tile,
        executor: Executor::Queue,
    };
    // Each tile's cost is the least of three renders, as `parrt bench cluster` records: a
    // tile preempted once on a shared machine, scaled to a 20-minute frame, would otherwise
    // become a tail no real render has.
    let r = render_smp(&renderer, &opts, &|_, _| {});
    let mut costs = r.tile_seconds.clone();
    for _ in 0..2 {
        let again = render_smp(&renderer, &opts, &|_, _| {});
        for (c, a) in costs.iter_mut().zip(&again.tile_seconds) {
            *c = c.min(*a);
        }
    }
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)?;
    }
    replay::write(path, tile, &costs, &r.film)?;
    Ok(())
}

/// The mean bytes of a result's pixels as the workers send them: 8-bit, packed
/// ([`TilePixels::pack`]).
pub fn packed_result_bytes(replay: &Replay) -> anyhow::Result<f64> {
    let mut px = Vec::new();
    let mut total = 0usize;
    for t in &replay.tiles {
        replay.pixels(t, &mut px)?;
        total += TilePixels::encode(&px, PixelFormat::Rgb8)
            .pack()
            .bytes
            .len();
    }
    Ok(total as f64 / replay.tiles.len().max(1) as f64)
}

/// Runs `c` over the recording at `path` in virtual time.
pub fn run(path: &Path, c: &Config) -> anyhow::Result<Row> {
    let probe = Replay::open(path, 1.0)?;
    let t1: f64 = probe.costs.iter().sum();
    // Dilate a frame whose mean tile is shorter than the timers can follow (module docs).
    let mean_asked = c.work_s / probe.costs.len().max(1) as f64;
    let k = c
        .dilation
        .unwrap_or_else(|| (MIN_DILATED_TILE_S / mean_asked.max(1e-12)).max(1.0).ceil());
    anyhow::ensure!(
        k.is_finite() && k >= 1.0,
        "dilation {k} is not a factor ≥ 1"
    );
    let scale = c.work_s * k / t1.max(1e-12);
    let replay = Arc::new(Replay::open(path, scale)?);
    let want = replay.film()?;
    let (width, height, tile) = (replay.width, replay.height, replay.tile);
    // What each tile really lasts in the simulation: tokio's timers run in whole
    // milliseconds, so a replayed tile ends at the next millisecond. Both the measured
    // efficiency and the model take these costs (undilated), so they compare like with like;
    // the JSON says how much rounding added (`rounding`).
    let costs: Vec<f64> = replay
        .costs
        .iter()
        .map(|x| (x * scale * 1e3).ceil() / 1e3 / k)
        .collect();
    let spent: f64 = costs.iter().sum();
    let result_bytes = packed_result_bytes(&replay)?;
    let latency = c.latency.mul_f64(k);
    let pixels: Vec<u64> = replay
        .tiles
        .iter()
        .map(|t| t.pixel_count() as u64)
        .collect();
    // The job: any scene will do (workers replay, never trace); its size goes to each worker.
    let desc = crate::dist::test_scene(width, height);
    let settings = RenderSettings::new(width, height);
    let token = Token::new("scale")?;
    let tail = Arc::new(TailTrace::default());
    let mut config = MasterConfig {
        seed: Some(1),
        observers: parrt_runtime::observer::Observers(vec![tail.clone()]),
        ..MasterConfig::default()
    };
    config.schedule.tile = tile;
    config.schedule.min_workers = c.workers;
    config.schedule.max_batch = c.max_batch;
    config.schedule.batch_seconds = parrt_runtime::batch::BATCH_SECONDS * k;
    // The handout order, by tile id; the model is given the tiles in the same order.
    let mut order: Vec<u32> = (0..costs.len() as u32).collect();
    if c.costly_first {
        order.sort_by(|&a, &b| costs[b as usize].total_cmp(&costs[a as usize]));
        config.schedule.order = Some(order.clone());
    }
    config.schedule.pixel_format = PixelFormat::Rgb8;
    config.schedule.frames_window = c.frames_window;
    let config_backups = config.schedule.backups;
    config.schedule.wait_workers = Duration::from_secs(3_600);
    config.schedule.tile_deadline = Duration::from_secs(86_400);
    config.net.token = Some(token.clone());
    config.net.heartbeat = config.net.heartbeat.mul_f64(k);
    config.net.heartbeat_timeout = Duration::from_secs(3_600).mul_f64(k);
    config.net.handshake_timeout = Duration::from_secs(600);
    config.net.max_connections = c.workers + 16;
    let result: Arc<Mutex<Option<DistResult>>> = Arc::default();
    // A sequence: every frame is the recording panned by its angle ([`super::sequence`]).
    let frame_count = c.frames.max(1);
    let orbit = Orbit::new(frame_count, c.orbit_deg, width, tile);
    let frame_scenes = scenes(&desc, &orbit);
    let eyes = Arc::new(frame_scenes.iter().map(|d| d.view.from).collect::<Vec<_>>());
    let seen: Arc<Mutex<Vec<FrameSeen>>> = Arc::default();
    let frames = (frame_count > 1).then(|| SimFrames {
        scenes: frame_scenes.clone(),
        settings: settings.clone(),
        orbit: orbit.clone(),
        want: Arc::new(want.to_rgb8()),
        tiles: Arc::new(replay.tiles.clone()),
        seen: seen.clone(),
    });
    // Dilated: a byte takes k times as long on a link and in the master.
    let link_bytes_per_s = c.link_bps / 8.0;
    let sim_link_bytes_per_s = link_bytes_per_s / k;
    let master_gates = Arc::new(Mutex::new(MasterGates::default()));
    let mut sim = turmoil::Builder::new()
        .rng_seed(1)
        .epoch(UNIX_EPOCH + Duration::from_secs(1_700_000_000))
        .simulation_duration(Duration::from_secs(1_000_000).mul_f64(k))
        // Time moves in steps of half the latency (at least 10 µs): a coarser step would
        // round every message up to whole steps.
        .tick_duration((latency / 2).max(Duration::from_micros(10)))
        .min_message_latency(latency)
        .max_message_latency(latency)
        .tcp_capacity(1 << 16)
        .build();
    {
        let (result, desc, settings) = (result.clone(), desc.clone(), settings.clone());
        let (config, token, gate) = (config.clone(), token.clone(), master_gates.clone());
        let frames = frames.clone();
        let per_byte = PerByte {
            link: 1.0 / sim_link_bytes_per_s,
            cpu: c.master_s_per_tile / result_bytes * k,
        };
        sim.host("master", move || {
            let (result, desc, settings) = (result.clone(), desc.clone(), settings.clone());
            let (config, token, gate) = (config.clone(), token.clone(), gate.clone());
            let frames = frames.clone();
            async move {
                let l = turmoil::net::TcpListener::bind(("0.0.0.0", 7878)).await?;
                let listener = PacedListener {
                    inner: l,
                    master: gate,
                    per_byte,
                };
                let m = Master::with_listener(listener, &config, token)?;
                let r = match frames {
                    Some(mut f) => {
                        let r = m
                            .render_sequence(&desc, &settings, &mut f, CancellationToken::new())
                            .await?;
                        if let Some(span) = r.last_frame_span {
                            f.note(f.scenes.len() - 1, &r.film, span);
                        }
                        r
                    }
                    None => m.render(&desc, &settings, CancellationToken::new()).await?,
                };
                *result.lock().unwrap_or_else(|p| p.into_inner()) = Some(r);
                Ok(())
            }
        });
    }
    // Worker sessions share simulated hosts, at most MAX_HOSTS of them ([`MAX_HOSTS`]).
    let per_host = c
        .workers
        .div_ceil(c.hosts.unwrap_or(MAX_HOSTS).max(1))
        .max(1);
    let hosts = c.workers.div_ceil(per_host);
    for h in 0..hosts {
        let ids: Vec<usize> = (h * per_host..((h + 1) * per_host).min(c.workers)).collect();
        let (replay, token, threads) = (replay.clone(), token.clone(), c.threads);
        let (orbit, eyes) = (orbit.clone(), eyes.clone());
        sim.host(format!("h{h}"), move || {
            let (replay, token, ids) = (replay.clone(), token.clone(), ids.clone());
            let (orbit, eyes) = (orbit.clone(), eyes.clone());
            async move {
                let session = |i: usize| {
                    let mut o = WorkerOptions::new("master:7878", token.clone());
                    o.name = format!("w{i}");
                    o.threads = threads;
                    o.tile_delay = None;
                    o.nonce_seed = Some(i as u64);
                    o.dial_timeout = Duration::from_secs(3_600).mul_f64(k);
                    o.master_timeout = Duration::from_secs(3_600).mul_f64(k);
                    // A worker's heartbeats stretch with everything else: at 1 s in a frame
                    // dilated ×4 096, 4 096 workers' heartbeats alone would fill a 1 Gbit/s
                    // master link.
                    o.heartbeat = o.heartbeat.mul_f64(k);
                    let exec = SeqExec::new(replay.clone(), orbit.clone(), eyes.clone());
                    async move {
                        let _ = parrt_worker::session::run_with(
                            &o,
                            CancellationToken::new(),
                            &SimDial,
                            exec,
                        )
                        .await;
                    }
                };
                // One session runs as the host's software itself, as up to 64 workers always
                // did; more are tasks of it.
                if let [i] = ids[..] {
                    session(i).await;
                    return Ok(());
                }
                let mut sessions = tokio::task::JoinSet::new();
                for i in ids {
                    sessions.spawn_local(session(i));
                }
                while sessions.join_next().await.is_some() {}
                Ok(())
            }
        });
    }
    let t0 = std::time::Instant::now();
    loop {
        if result.lock().unwrap_or_else(|p| p.into_inner()).is_some() {
            break;
        }
        sim.step().map_err(|e| anyhow::anyhow!("simulation: {e}"))?;
    }
    let wall_s = t0.elapsed().as_secs_f64();
    let r = result
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .take()
        .ok_or_else(|| anyhow::anyhow!("no result"))?;
    let n = c.workers * c.threads;
    let trace_s = r.trace_s / k;
    let efficiency = spent * frame_count as f64 / (n as f64 * trace_s.max(1e-12));
    let mean = spent / costs.len().max(1) as f64;
    let window = parrt_runtime::window::Window::default().assignments(
        c.threads,
        Some(2.0 * c.latency.as_secs_f64()),
        mean,
    );
    let p = SimParams {
        window,
        max_batch: c.max_batch,
        batch_seconds: parrt_runtime::batch::BATCH_SECONDS,
        latency_s: c.latency.as_secs_f64(),
        bandwidth_bps: link_bytes_per_s,
        master_link_bps: link_bytes_per_s,
        master_per_tile_s: c.master_s_per_tile,
        result_bytes_per_pixel: result_bytes / (tile * tile) as f64,
        message_bytes: 64.0,
        // The master's default: idle workers take copies of tiles out once the queue is empty.
        backups: config_backups,
        // An order by cost is dealt in rounds (`Scheduler::fill`); so is every frame after
        // a sequence's first.
        rounds: c.costly_first || frame_count > 1,
        ..SimParams::ideal(c.workers, c.threads)
    };
    // The model of a sequence: its frames' tiles one after another, through the same window.
    let p_seq = SimParams {
        frames: Some(FrameWindow {
            tiles: costs.len(),
            window: c.frames_window,
        }),
        ..p.clone()
    };
    let in_order = |v: &[f64]| order.iter().map(|&i| v[i as usize]).collect::<Vec<_>>();
    let pixels_in_order: Vec<u64> = order.iter().map(|&i| pixels[i as usize]).collect();
    let single = simulate(&in_order(&costs), &pixels_in_order, &p);
    // Each frame's tile costs, by tile id: frame 0's as recorded, the others as the orbit
    // carries them.
    let each: Vec<Vec<f64>> = (0..frame_count).map(|f| orbit.costs(f, &costs)).collect();
    // A sequence as the model sees it: a stream of tiles, frame after frame, each later frame
    // costliest first by the previous frame's costs, which are its predicted costs; frame
    // k+1's tiles fill frame k's tail, up to the master's window of frames.
    let model = if frame_count > 1 {
        use parrt_runtime::prediction::{predict, Grid, Motion, Risk, Track, RADIUS};
        let (mut all_costs, mut all_pixels) = (in_order(&costs), pixels_in_order.clone());
        let mut longest = vec![0.0; all_costs.len()];
        let mut expected = longest.clone();
        let grid = |g: usize| Grid {
            costs: &each[g],
            cols: orbit.cols,
        };
        let mut guesses: Vec<Vec<f64>> = vec![Vec::new(); frame_count];
        let mut risk = Risk::default();
        let mut track = Track::default();
        for f in 1..frame_count {
            // What the master knows as frame f opens: frames up to f − 2 closed (frame f − 1
            // has its tail out), and before any has closed, frame 0's times as they came.
            let guess = match f.checked_sub(2) {
                Some(g) => {
                    if g >= 1 {
                        risk.learn(&each[g], &guesses[g]);
                        track.learn(Motion::between(grid(g - 1), grid(g)));
                    }
                    predict(grid(g), track.over(2), &risk, RADIUS)
                }
                None => predict(grid(0), Motion::default(), &risk, RADIUS),
            };
            let now = &each[f];
            let before = &each[f - 1];
            let mut next: Vec<usize> = (0..now.len()).collect();
            next.sort_by(|&a, &b| guess[b].total_cmp(&guess[a]));
            all_costs.extend(next.iter().map(|&i| now[i]));
            all_pixels.extend(next.iter().map(|&i| pixels[i]));
            longest.extend(next.iter().map(|&i| guess[i]));
            expected.extend(next.iter().map(|&i| before[i]));
            guesses[f] = guess;
        }
        let predicted = Predicted {
            longest: &longest,
            expected: &expected,
        };
        simulate_sequence(&all_costs, predicted, &all_pixels, &p_seq)
    } else {
        single.clone()
    };
    let predicted = model.efficiency;
    let seen = seen.lock().unwrap_or_else(|p| p.into_inner()).clone();
    let (identical, latency_mean_s, latency_max_s) = if frame_count > 1 {
        let mut once = vec![0usize; frame_count];
        for f in &seen {
            if let Some(n) = once.get_mut(f.index) {
                *n += 1;
            }
        }
        let lat: Vec<f64> = seen.iter().map(|f| f.latency_s / k).collect();
        (
            once.iter().all(|&n| n == 1) && seen.iter().all(|f| f.identical),
            lat.iter().sum::<f64>() / lat.len().max(1) as f64,
            lat.iter().copied().fold(0.0, f64::max),
        )
    } else {
        (same_bytes(&r.film, &want), trace_s, trace_s)
    };
    Ok(Row {
        workers: c.workers,
        threads: c.threads,
        work_s: c.work_s,
        link_gbit: c.link_bps / 1e9,
        frames: frame_count,
        frames_window: if frame_count > 1 { c.frames_window } else { 1 },
        efficiency,
        rounding: spent / c.work_s - 1.0,
        dilation: k,
        predicted,
        model_tail: model.tail_idle_s / (n as f64 * model.makespan.max(1e-12)),
        model_master: model.master_utilisation,
        identical,
        trace_s,
        latency_mean_s,
        latency_max_s,
        single_frame_predicted_s: single.makespan,
        seen,
        wall_s,
        // The trace's clock is dilated: so are the costs it is read with.
        trace: tail.tail(
            n,
            &each
                .iter()
                .map(|f| f.iter().map(|c| c * k).collect())
                .collect::<Vec<Vec<f64>>>(),
        ),
    })
}

fn same_bytes(a: &Film, b: &Film) -> bool {
    a.width == b.width && a.height == b.height && a.to_rgb8() == b.to_rgb8()
}

/// When one resource (a link, the master's CPU) is next free: it serves one byte after
/// another.
#[derive(Default)]
struct Gate {
    free: Option<Instant>,
}

impl Gate {
    /// Reserves `secs` after `from` (or after the last reservation, if later); returns the end.
    fn reserve(&mut self, from: Instant, secs: f64) -> Instant {
        let start = self.free.map_or(from, |f| f.max(from));
        let end = start + Duration::from_secs_f64(secs.max(0.0));
        self.free = Some(end);
        end
    }
}

/// The master's two resources every worker's results queue for, one after the other: its
/// link (the network card receives the next message while the CPU handles the last one, as
/// a real host's does) and its CPU.
#[derive(Default)]
struct MasterGates {
    link: Gate,
    cpu: Gate,
}

/// Seconds a byte takes on a link (each worker's and the master's are alike) and in the
/// master's CPU.
#[derive(Clone, Copy)]
struct PerByte {
    link: f64,
    cpu: f64,
}

/// The master's listener whose streams deliver bytes as the links and the master's CPU allow.
struct PacedListener {
    inner: turmoil::net::TcpListener,
    master: Arc<Mutex<MasterGates>>,
    per_byte: PerByte,
}

impl parrt_runtime::net::Listener for PacedListener {
    type Stream = Paced;

    async fn accept(&mut self) -> io::Result<(Paced, SocketAddr)> {
        let (s, a) = self.inner.accept().await?;
        Ok((
            Paced {
                inner: s,
                link: Gate::default(),
                master: self.master.clone(),
                per_byte: self.per_byte,
                held: Vec::new(),
                pos: 0,
                wait: None,
            },
            a,
        ))
    }

    fn local_addr(&self) -> io::Result<SocketAddr> {
        self.inner.local_addr()
    }
}

/// A master-side stream: bytes read cross the worker's link, then the master's link, then
/// wait for the master's CPU.
pub struct Paced {
    inner: turmoil::net::TcpStream,
    link: Gate,
    master: Arc<Mutex<MasterGates>>,
    per_byte: PerByte,
    held: Vec<u8>,
    pos: usize,
    wait: Option<Pin<Box<Sleep>>>,
}

impl AsyncRead for Paced {
    fn poll_read(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        let me = self.get_mut();
        loop {
            if me.pos < me.held.len() {
                if let Some(w) = &mut me.wait {
                    ready!(w.as_mut().poll(cx));
                    me.wait = None;
                }
                let n = (me.held.len() - me.pos).min(buf.remaining());
                buf.put_slice(&me.held[me.pos..me.pos + n]);
                me.pos += n;
                return Poll::Ready(Ok(()));
            }
            // What has arrived, up to a window's worth. A stream queues at the master's gates
            // again only once this is through, so the streams with bytes waiting take turns.
            me.held.resize(64 * 1024, 0);
            let mut rb = ReadBuf::new(&mut me.held);
            match Pin::new(&mut me.inner).poll_read(cx, &mut rb) {
                Poll::Pending => {
                    me.held.clear();
                    me.pos = 0;
                    return Poll::Pending;
                }
                Poll::Ready(Err(e)) => {
                    me.held.clear();
                    return Poll::Ready(Err(e));
                }
                Poll::Ready(Ok(())) => {}
            }
            let n = rb.filled().len();
            me.held.truncate(n);
            me.pos = 0;
            if n == 0 {
                return Poll::Ready(Ok(()));
            }
            let now = Instant::now();
            let bytes = n as f64;
            let crossed = me.link.reserve(now, bytes * me.per_byte.link);
            let mut master = me.master.lock().unwrap_or_else(|p| p.into_inner());
            let received = master.link.reserve(crossed, bytes * me.per_byte.link);
            let handled = master.cpu.reserve(received, bytes * me.per_byte.cpu);
            drop(master);
            me.wait = Some(Box::pin(sleep_until(handled)));
        }
    }
}

impl AsyncWrite for Paced {
    fn poll_write(
        self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        Pin::new(&mut self.get_mut().inner).poll_write(cx, buf)
    }
    fn poll_flush(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.get_mut().inner).poll_flush(cx)
    }
    fn poll_shutdown(self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.get_mut().inner).poll_shutdown(cx)
    }
}
