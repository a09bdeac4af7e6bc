//! One seed's simulated world: the real master runtime ([`parrt_runtime::Master`]) on host
//! `master`, real worker sessions ([`parrt_worker::session::run_with`] with an inline executor
//! that traces real pixels and spends each tile's cost in virtual time) on hosts `w0`…, and
//! hostile peers, all over turmoil's simulated TCP in one thread. The driver steps the
//! simulation, plays the seed's faults at their virtual times, and checks the invariants when
//! the master ends (or when it should have).

use super::frames::{self, MasterEnd};
use super::net::{SimDial, SimListener};
use super::plan::{Fault, Hostile, Plan};
use super::trace::Trace;
use crate::dist::{test_scene, token};
use parrt_protocol::{
    Connection, Message, Packing, PixelFormat, TilePixels, Token, PROTOCOL_VERSION,
};
use parrt_render::description::SceneDescription;
use parrt_render::film::Film;
use parrt_render::settings::RenderSettings;
use parrt_runtime::checkpoint::{self, JobKey};
use parrt_runtime::mutation::Mutation;
use parrt_runtime::{DistError, DistResult, Master, MasterConfig, Writer};
use parrt_worker::exec::InlineExec;
use parrt_worker::session::SessionEnd;
use parrt_worker::WorkerOptions;
use std::cell::Cell;
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, UNIX_EPOCH};
use tokio_util::sync::CancellationToken;

/// The master's port on its simulated host.
pub const PORT: u16 = 7878;
/// The image: small enough to trace thousands of seeds, tiled into 24 tiles.
pub const WIDTH: u32 = 48;
/// See [`WIDTH`].
pub const HEIGHT: u32 = 32;
/// Tile edge.
pub const TILE: u32 = 8;
/// Virtual time allowed after the last fault has played out: far beyond every deadline and
/// the master's wait for workers, so a run still going then has hung.
pub const SLACK: Duration = Duration::from_secs(90);

/// What one seed gave.
#[derive(Debug)]
pub struct Outcome {
    /// The seed.
    pub seed: u64,
    /// Invariants broken (empty: the seed passed).
    pub failures: Vec<String>,
    /// The trace hash.
    pub trace: String,
    /// Events traced.
    pub events: u64,
    /// Virtual seconds simulated.
    pub virtual_s: f64,
    /// How the render ended.
    pub ended: String,
}

/// The scene, settings and SMP image every seed renders.
struct Reference {
    desc: SceneDescription,
    settings: RenderSettings,
    film: Film,
}

fn reference() -> &'static Reference {
    static R: OnceLock<Reference> = OnceLock::new();
    R.get_or_init(|| {
        let desc = test_scene(WIDTH, HEIGHT);
        let settings = RenderSettings::new(WIDTH, HEIGHT);
        let (film, _) = crate::dist::smp_reference(&desc, &settings, TILE);
        Reference {
            desc,
            settings,
            film,
        }
    })
}

thread_local! {
    /// Panics on this thread since the current seed began (tasks' panics are caught by
    /// tokio and would pass unseen otherwise).
    static PANICS: Cell<usize> = const { Cell::new(0) };
}

fn count_panics() {
    static HOOK: OnceLock<()> = OnceLock::new();
    HOOK.get_or_init(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            PANICS.with(|p| p.set(p.get() + 1));
            previous(info);
        }));
    });
}

/// How many bytes of the checkpoint the running master has synced (set when it opens it).
pub type Durable = Arc<Mutex<Option<Arc<std::sync::atomic::AtomicU64>>>>;

/// How the master host's last life ended, once it did.
type Ended = Arc<Mutex<Option<MasterEnd>>>;

/// The master host's software: started anew on every (re)start, resuming its checkpoint.
#[derive(Clone)]
struct MasterHost {
    config: MasterConfig,
    checkpoint: Option<PathBuf>,
    /// What the checkpoint has on the disk: a crash tears only what came after.
    durable: Durable,
    trace: Trace,
    result: Ended,
    /// Frames of the job (above 1: a sequence, its frames written to `dir`).
    frames: usize,
    dir: PathBuf,
    /// The frames written over every life of the master.
    written: frames::Written,
}

impl MasterHost {
    async fn run(self) -> turmoil::Result {
        let r = reference();
        self.trace.master_started();
        self.trace.note("master up");
        let listener = turmoil::net::TcpListener::bind(("0.0.0.0", PORT)).await?;
        let mut master = Master::with_listener(SimListener(listener), &self.config, token())?;
        if self.frames > 1 {
            let path = self.checkpoint.as_deref();
            let (dir, written) = (&self.dir, &self.written);
            let end = frames::render(master, self.frames, path, dir, written, &self.durable).await;
            self.end(end);
            return Ok(());
        }
        if let Some(path) = &self.checkpoint {
            let key = JobKey::new(&r.desc, &r.settings, TILE, PixelFormat::F32)?;
            let list = parrt_render::tile::tiles(WIDTH, HEIGHT, TILE);
            let opened = checkpoint::open(path, &key, &list, true)?;
            *self.durable.lock().unwrap_or_else(|p| p.into_inner()) =
                Some(opened.checkpoint.durable());
            self.trace
                .note(&format!("resumed {} tiles", opened.scan.tiles.len()));
            master.set_checkpoint(opened, Writer::Inline);
        }
        let out = master
            .render(&r.desc, &r.settings, CancellationToken::new())
            .await;
        self.end(MasterEnd::Ran(Box::new(out)));
        Ok(())
    }

    /// Traces and keeps how this life ended.
    fn end(&self, end: MasterEnd) {
        let ended = match &end {
            MasterEnd::Ran(r) => match r.as_ref() {
                Ok(_) => "ok".to_string(),
                Err(e) => e.to_string(),
            },
            MasterEnd::NothingLeft => "nothing left".to_string(),
            MasterEnd::Broken(why) => why.clone(),
        };
        // The checkpoint's directory is a fresh temporary one each run: kept out of the trace.
        let ended = ended.replace(&self.dir.display().to_string(), "$CHECKPOINT_DIR");
        self.trace.note(&format!("master ended {ended}"));
        *self.result.lock().unwrap_or_else(|p| p.into_inner()) = Some(end);
    }
}

/// Options of simulated worker `i`.
fn worker_options(plan: &Plan, i: usize, tok: Token) -> WorkerOptions {
    let mut o = WorkerOptions::new(format!("master:{PORT}"), tok);
    o.name = format!("w{i}");
    o.threads = plan.threads.get(i).copied().unwrap_or(1);
    o.dial_timeout = Duration::from_secs(30);
    o.handshake_timeout = Duration::from_secs(2);
    o.heartbeat = Duration::from_secs(1);
    o.master_timeout = Duration::from_secs(4);
    o.tile_delay = None;
    o.nonce_seed = Some(plan.seed.wrapping_mul(31).wrapping_add(i as u64));
    o
}

/// A worker host's software: sessions one after another (as a supervisor restarts a worker
/// process), until the master says Shutdown.
async fn worker_host(
    plan: Plan,
    i: usize,
    starts: Arc<AtomicUsize>,
    trace: Trace,
) -> turmoil::Result {
    if starts.fetch_add(1, Ordering::Relaxed) == 0 {
        tokio::time::sleep(plan.late[i]).await;
    }
    let cost = plan.tile_cost[i];
    loop {
        let o = worker_options(&plan, i, token());
        let r = parrt_worker::session::run_with(
            &o,
            CancellationToken::new(),
            &SimDial,
            InlineExec::constant(cost),
        )
        .await;
        trace.note(&format!(
            "w{i} session {}",
            match &r {
                Ok(s) => format!("{:?} {} tiles", s.end, s.tiles_rendered),
                Err(e) => e.to_string(),
            }
        ));
        if matches!(&r, Ok(s) if s.end == SessionEnd::Shutdown) {
            return Ok(());
        }
        tokio::time::sleep(Duration::from_millis(250)).await;
    }
}

/// A hostile peer's software, connecting at `at`. Whatever befalls it (the master down,
/// a refusal) ends only itself.
async fn hostile_host(kind: Hostile, at: Duration, seed: u64, trace: Trace) -> turmoil::Result {
    tokio::time::sleep(at).await;
    if let Err(e) = hostile(kind, seed, &trace).await {
        trace.note(&format!("hostile {kind:?}: {e}"));
    }
    Ok(())
}

async fn hostile(kind: Hostile, seed: u64, trace: &Trace) -> turmoil::Result {
    let addr = format!("master:{PORT}");
    match kind {
        Hostile::Junk => {
            let mut s = turmoil::net::TcpStream::connect(addr).await?;
            let junk: Vec<u8> = (0..96u64)
                .map(|i| {
                    (seed
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(i.wrapping_mul(1442695040888963407))
                        >> 33) as u8
                })
                .collect();
            use tokio::io::{AsyncReadExt, AsyncWriteExt};
            let _ = s.write_all(&junk).await;
            let mut buf = [0u8; 256];
            let _ = tokio::time::timeout(Duration::from_secs(5), async {
                while let Ok(n) = s.read(&mut buf).await {
                    if n == 0 {
                        break;
                    }
                }
            })
            .await;
        }
        Hostile::WrongToken => {
            let mut o = WorkerOptions::new(addr, Token::new("not-the-token").expect("non-empty"));
            o.name = "intruder".into();
            o.dial_timeout = Duration::from_secs(2);
            o.nonce_seed = Some(seed);
            let r = parrt_worker::session::run_with(
                &o,
                CancellationToken::new(),
                &SimDial,
                InlineExec::constant(Duration::ZERO),
            )
            .await;
            trace.note(&format!(
                "intruder: {}",
                r.err().map(|e| e.to_string()).unwrap_or_default()
            ));
        }
        Hostile::ImpossibleResults => impossible_results(addr, seed).await?,
    }
    Ok(())
}

/// Authenticates with the right token, takes the job, then answers with a result for a
/// tile it was never given, with too few pixels, and keeps reading until dropped.
async fn impossible_results(addr: String, seed: u64) -> turmoil::Result {
    let stream = turmoil::net::TcpStream::connect(addr).await?;
    let key = parrt_protocol::LinkKey::from_token(&token());
    let eph = parrt_protocol::channel::seeded_ephemeral(seed);
    let stream = parrt_protocol::channel::connect(stream, &key, Some(eph)).await?;
    let mut c = Connection::new(stream, parrt_protocol::HANDSHAKE_MAX_FRAME);
    let ours = [seed as u8; parrt_protocol::message::NONCE_LEN];
    c.write(&Message::Hello {
        version: PROTOCOL_VERSION,
        name: "liar".into(),
        threads: 1,
        nonce: ours,
        isa: parrt_render::isa::Isa::Scalar,
    })
    .await?;
    let Some(Message::Challenge { nonce, .. }) = c.read().await? else {
        return Ok(());
    };
    c.write(&Message::Auth {
        mac: token().worker_proof(&nonce, &ours),
    })
    .await?;
    c.set_max_frame(parrt_protocol::DEFAULT_MAX_FRAME);
    let mut job_id = 0;
    let _ = tokio::time::timeout(Duration::from_secs(10), async {
        while let Ok(Some(m)) = c.read().await {
            if let Message::Job(spec) = m {
                job_id = spec.job_id;
                let bogus = Message::TileResult {
                    job_id,
                    tile_id: 3,
                    attempt: 999,
                    pixels: TilePixels {
                        format: PixelFormat::F32,
                        packing: Packing::Raw,
                        bytes: vec![0xff; 12],
                    },
                    stats: Default::default(),
                    seconds: 0.0,
                };
                if c.write(&bogus).await.is_err() {
                    break;
                }
            }
        }
    })
    .await;
    Ok(())
}

/// Runs seed `seed` and checks its invariants.
pub fn run_seed(seed: u64) -> Outcome {
    run_seed_with(seed, None)
}

/// Runs seed `seed` with `mutation` planted in the runtime (a bug the invariants must catch).
pub fn run_seed_with(seed: u64, mutation: Option<Mutation>) -> Outcome {
    count_panics();
    PANICS.with(|p| p.set(0));
    parrt_runtime::mutation::plant(mutation);
    let o = run_planted(seed);
    parrt_runtime::mutation::plant(None);
    o
}

fn run_planted(seed: u64) -> Outcome {
    let plan = Plan::draw(seed);
    let trace = Trace::default();
    let mut failures = Vec::new();
    let dir = tempfile::tempdir().expect("a temporary directory");
    let result = Ended::default();
    let written = frames::Written::default();
    let mut config = MasterConfig {
        observers: parrt_runtime::observer::Observers(vec![Arc::new(trace.clone())]),
        seed: Some(seed),
        ..MasterConfig::default()
    };
    config.schedule.tile = TILE;
    config.schedule.order = plan.order.clone();
    config.schedule.min_workers = plan.min_workers;
    config.schedule.wait_workers = Duration::from_secs(20);
    config.schedule.tile_deadline = Duration::from_secs(5);
    config.net.token = Some(token());
    config.net.heartbeat_timeout = Duration::from_secs(3);
    config.net.handshake_timeout = Duration::from_secs(2);
    let host_checkpoint = plan.checkpoint.then(|| dir.path().join("render.ck"));
    let durable = Durable::default();
    let host = MasterHost {
        config,
        checkpoint: host_checkpoint.clone(),
        durable: durable.clone(),
        trace: trace.clone(),
        result: result.clone(),
        frames: plan.frames,
        dir: dir.path().to_path_buf(),
        written: written.clone(),
    };
    let bound = plan.faults_end() + SLACK;
    let mut sim = turmoil::Builder::new()
        .rng_seed(seed)
        .epoch(UNIX_EPOCH + Duration::from_secs(1_700_000_000))
        .simulation_duration(bound + Duration::from_secs(60))
        .min_message_latency(Duration::from_micros(100))
        .max_message_latency(Duration::from_millis(2))
        // Segments a connection buffers: as a real socket holds hours of heartbeats, so a
        // stuck peer is found by the heartbeat check, not by a full buffer first.
        .tcp_capacity(1 << 16)
        .build();
    sim.host("master", move || host.clone().run());
    for i in 0..plan.workers {
        let (p, t, starts) = (plan.clone(), trace.clone(), Arc::new(AtomicUsize::new(0)));
        sim.host(format!("w{i}"), move || {
            worker_host(p.clone(), i, starts.clone(), t.clone())
        });
    }
    for (k, (at, f)) in plan.faults.iter().enumerate() {
        if let Fault::Hostile(kind) = f {
            let (kind, at, t) = (*kind, *at, trace.clone());
            sim.host(format!("h{k}"), move || {
                hostile_host(kind, at, seed ^ k as u64, t.clone())
            });
        }
    }
    // Pending actions of the faults: (when, what), run in order of time.
    let mut actions: Vec<(Duration, Action)> = Vec::new();
    for (at, f) in &plan.faults {
        let w = |i: usize| format!("w{i}");
        match f {
            Fault::Crash { w: i, back } => {
                actions.push((*at, Action::Crash(w(*i))));
                if let Some(b) = back {
                    actions.push((*at + *b, Action::Bounce(w(*i))));
                }
            }
            Fault::Hold { w: i, d } => {
                actions.push((*at, Action::Hold(w(*i))));
                if let Some(d) = d {
                    actions.push((*at + *d, Action::Release(w(*i))));
                }
            }
            Fault::Partition { w: i, heal } => {
                actions.push((*at, Action::Partition(w(*i))));
                if let Some(h) = heal {
                    actions.push((*at + *h, Action::Repair(w(*i))));
                }
            }
            Fault::Latency { w: i, latency, d } => {
                actions.push((*at, Action::Latency(w(*i), *latency)));
                actions.push((*at + *d, Action::Latency(w(*i), Duration::from_millis(1))));
            }
            Fault::MasterCrash { back, torn } => {
                actions.push((*at, Action::Crash("master".into())));
                if let (Some(path), true) = (&host_checkpoint, *torn > 0) {
                    actions.push((*at, Action::Tear(path.clone(), *torn, durable.clone())));
                }
                actions.push((*at + *back, Action::Bounce("master".into())));
            }
            Fault::Hostile(_) => {}
        }
    }
    actions.sort_by_key(|(t, _)| *t);
    let mut next = 0;
    let stepped =
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| -> Result<(), String> {
            loop {
                let now = sim.elapsed();
                while next < actions.len() && actions[next].0 <= now {
                    let a = &actions[next].1;
                    trace.note(&format!("fault {a:?}"));
                    a.apply(&mut sim);
                    next += 1;
                }
                if result.lock().unwrap_or_else(|p| p.into_inner()).is_some() {
                    return Ok(());
                }
                if now > bound {
                    return Err(format!(
                        "hang: no outcome after {:.1} virtual s",
                        now.as_secs_f64()
                    ));
                }
                sim.step().map_err(|e| format!("simulation error: {e}"))?;
            }
        }));
    match stepped {
        Ok(Ok(())) => {}
        Ok(Err(e)) => failures.push(e),
        Err(_) => failures.push("panic in the simulation".into()),
    }
    let panics = PANICS.with(|p| p.get());
    if panics > 0 {
        failures.push(format!("panic: {panics} task(s) panicked"));
    }
    let outcome = result.lock().unwrap_or_else(|p| p.into_inner()).take();
    let outcome = outcome.map(|end| match end {
        MasterEnd::Ran(r) => Ok(*r),
        other => Err(other),
    });
    let ended = match &outcome {
        None => "no outcome".to_string(),
        Some(Ok(Err(e))) => e.to_string(),
        Some(Err(MasterEnd::Broken(why))) => why.clone(),
        // A render that ran to its end, or a resume that found every frame done.
        Some(Ok(Ok(_)) | Err(_)) => "complete".to_string(),
    };
    match outcome {
        Some(Err(MasterEnd::NothingLeft)) => {
            frames::check(plan.frames, dir.path(), &written, &mut failures);
        }
        Some(Err(MasterEnd::Broken(why))) => failures.push(format!("failed: {why}")),
        Some(Err(MasterEnd::Ran(_))) => {}
        Some(Ok(Ok(r))) if plan.frames > 1 => {
            frames::check(plan.frames, dir.path(), &written, &mut failures);
            check_queues(&plan, &r, &mut failures);
            check_accepted_once(&trace, &mut failures);
        }
        Some(Ok(Ok(r))) => {
            check_image(&r, &mut failures);
            check_queues(&plan, &r, &mut failures);
            let accepted = check_accepted_once(&trace, &mut failures);
            if accepted + r.restored_tiles != r.tiles {
                failures.push(format!(
                    "accepted-once: {} accepted + {} restored of {} tiles",
                    accepted, r.restored_tiles, r.tiles
                ));
            }
        }
        Some(Ok(Err(e))) => {
            // The documented failures, and only when the faults left too few workers.
            let survivors = plan.survivors();
            let documented = match e {
                DistError::NoWorkers { .. } => survivors < plan.min_workers,
                DistError::AllWorkersLost { .. } => survivors == 0,
                _ => false,
            };
            if !documented {
                failures.push(format!("failed: {e}"));
            }
        }
        None => {}
    }
    Outcome {
        seed,
        failures,
        trace: trace.hex(),
        events: trace.events(),
        virtual_s: sim.elapsed().as_secs_f64(),
        ended,
    }
}

/// No tile of a frame accepted twice by the master's current life; returns how many it
/// accepted.
fn check_accepted_once(trace: &Trace, failures: &mut Vec<String>) -> usize {
    let accepted = trace.accepted();
    let mut unique = accepted.clone();
    unique.sort_unstable();
    unique.dedup();
    if unique.len() != accepted.len() {
        failures.push(format!(
            "accepted-once: {} tiles accepted more than once",
            accepted.len() - unique.len()
        ));
    }
    accepted.len()
}

/// The master's queues stay bounded whatever the faults: an outbox holds at most the
/// worker's window of assignments and a Shutdown (and for a sequence a Job and a Cancel a
/// frame of its window); the events waiting for the scheduler are at
/// most what the connections may have in flight (each worker's window of results, its join
/// and its departure) plus what hostile peers send before they are refused or dropped.
fn check_queues(plan: &Plan, r: &DistResult, failures: &mut Vec<String>) {
    if std::env::var_os("PARRT_SIM_PEAKS").is_some() {
        eprintln!("seed {} peaks {:?}", plan.seed, r.queue_peaks);
    }
    let most_threads = plan.threads.iter().copied().max().unwrap_or(1);
    // A sequence's outbox also carries, for each frame of the window, its Job (or the
    // frame's camera) and the Cancel that ends it on the worker.
    let frames_window = match plan.frames {
        1 => 0,
        _ => MasterConfig::default().schedule.frames_window,
    };
    let outbox_bound = 2 * most_threads + 1 + 2 * frames_window;
    if r.queue_peaks.outbox > outbox_bound {
        failures.push(format!(
            "queues: an outbox held {} messages (bound {outbox_bound})",
            r.queue_peaks.outbox
        ));
    }
    let hostile = plan
        .faults
        .iter()
        .filter(|(_, f)| matches!(f, Fault::Hostile(_)))
        .count();
    let windows: usize = plan.threads.iter().map(|t| 2 * t + 2).sum();
    let events_bound = windows + 64 * (hostile + 1);
    if r.queue_peaks.events > events_bound {
        failures.push(format!(
            "queues: {} events waited for the scheduler (bound {events_bound})",
            r.queue_peaks.events
        ));
    }
}

fn check_image(r: &DistResult, failures: &mut Vec<String>) {
    let want = &reference().film;
    let same = r.film.width == want.width
        && r.film.height == want.height
        && r.film.pixels.len() == want.pixels.len()
        && r.film
            .pixels
            .iter()
            .zip(&want.pixels)
            .all(|(p, q)| p.iter().zip(q).all(|(x, y)| x.to_bits() == y.to_bits()));
    if !same {
        failures.push("image: differs from the SMP image".into());
    }
}

/// A fault's step, applied between simulation steps.
enum Action {
    Crash(String),
    Bounce(String),
    Hold(String),
    Release(String),
    Partition(String),
    Repair(String),
    Latency(String, Duration),
    /// Up to this many of the checkpoint's last bytes lost, as a power loss loses what was
    /// written but not yet synced (never what the checkpoint had synced).
    Tear(PathBuf, u64, Durable),
}

/// What the trace records of an action: only what the seed decides. A tear's file lives in a
/// temporary directory whose name is drawn afresh by each run, so its path is left out (with
/// it, every replay of a seed whose master crashes with a torn checkpoint hashed differently).
impl std::fmt::Debug for Action {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Action::Crash(h) => write!(f, "Crash({h:?})"),
            Action::Bounce(h) => write!(f, "Bounce({h:?})"),
            Action::Hold(w) => write!(f, "Hold({w:?})"),
            Action::Release(w) => write!(f, "Release({w:?})"),
            Action::Partition(w) => write!(f, "Partition({w:?})"),
            Action::Repair(w) => write!(f, "Repair({w:?})"),
            Action::Latency(w, d) => write!(f, "Latency({w:?}, {d:?})"),
            Action::Tear(_, bytes, durable) => {
                let synced = durable
                    .lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .as_ref()
                    .map(|d| d.load(std::sync::atomic::Ordering::Acquire));
                write!(f, "Tear(checkpoint, {bytes} bytes, synced {synced:?})")
            }
        }
    }
}

impl Action {
    fn apply(&self, sim: &mut turmoil::Sim<'_>) {
        match self {
            Action::Crash(h) => sim.crash(h.as_str()),
            Action::Bounce(h) => sim.bounce(h.as_str()),
            Action::Hold(w) => sim.hold("master", w.as_str()),
            Action::Release(w) => sim.release("master", w.as_str()),
            Action::Partition(w) => sim.partition("master", w.as_str()),
            Action::Repair(w) => sim.repair("master", w.as_str()),
            Action::Latency(w, d) => sim.set_link_latency("master", w.as_str(), *d),
            Action::Tear(path, bytes, durable) => {
                // The master is down: nothing writes the file now. A missing file (the
                // master had not opened it yet) has nothing to tear.
                let Some(synced) = durable.lock().unwrap_or_else(|p| p.into_inner()).clone() else {
                    return;
                };
                let synced = synced.load(std::sync::atomic::Ordering::Acquire);
                if let Ok(f) = std::fs::OpenOptions::new().write(true).open(path) {
                    let len = f.metadata().map(|m| m.len()).unwrap_or(0);
                    if len > synced {
                        let _ = f.set_len(len.saturating_sub(*bytes).max(synced));
                    }
                }
            }
        }
    }
}
