//! One emulated-cluster render: the master as `parrt master` runs it (the runtime's one entry
//! point, on 127.0.0.1), the emulated LAN ([`super::link::Relay`]) in front of it, and N real
//! worker processes, started by the runtime's spawn code, replaying a recorded render through
//! it. Bounded in time (the run is cancelled, and the workers told to shut down,
//! when it overruns) and the worker processes are killed and reaped on every path.

use super::cpu::{CpuSampler, MASTER_THREAD};
use super::link::{LinkParams, Relay};
use anyhow::Context;
use parrt_render::description::SceneDescription;
use parrt_render::film::Film;
use parrt_render::settings::RenderSettings;
use parrt_runtime::{generate_token, DistError, Job, MasterConfig, Spawn, WorkerCommand};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio_util::sync::CancellationToken;

/// What to run.
#[derive(Clone, Debug)]
pub struct EmulatedRun {
    /// Worker processes.
    pub workers: usize,
    /// Threads per worker.
    pub threads: usize,
    /// Tile edge (must be the recording's).
    pub tile: u32,
    /// Tiles in flight per worker thread.
    pub window: parrt_runtime::window::Window,
    /// Most tiles in one assignment.
    pub max_batch: usize,
    /// How pixels travel.
    pub pixel_format: parrt_protocol::PixelFormat,
    /// The network.
    pub link: LinkParams,
    /// The recorded render the workers replay.
    pub replay: PathBuf,
    /// Factor on every recorded tile cost.
    pub cost_scale: f64,
    /// The worker executable and the arguments before `--connect` (e.g. `parrt` and `worker`).
    pub worker_exe: PathBuf,
    /// Arguments before the worker's own flags.
    pub worker_prefix: Vec<String>,
    /// The whole run (start-up included) must end within this.
    pub timeout: Duration,
    /// Told what happens to workers and tiles (the timeline).
    pub observers: parrt_runtime::observer::Observers,
}

/// What a run measured.
#[derive(Debug)]
pub struct Measured {
    /// The assembled image.
    pub film: Film,
    /// Tracing wall time: first tile handed out to last result in (all workers ready before).
    pub trace_s: f64,
    /// Tiles in the image.
    pub tiles: usize,
    /// Tiles delivered first, summed over workers (equal to `tiles` when none is doubled).
    pub delivered: u64,
    /// Valid results that came second and were ignored (backups).
    pub duplicates: u64,
    /// Results rejected.
    pub rejected: u64,
    /// CPU seconds of the master's threads during the tracing phase.
    pub master_cpu_s: f64,
    /// CPU seconds of the whole emulation (this process and the workers) during tracing.
    pub own_cpu_s: f64,
    /// CPU seconds of this process (master and relay) during tracing.
    pub bench_process_cpu_s: f64,
    /// CPU seconds the whole machine (every process, other users' too) was busy during tracing.
    pub machine_busy_s: f64,
    /// Bytes the master received from workers.
    pub bytes_received: u64,
    /// Bytes the master sent to workers.
    pub bytes_sent: u64,
    /// Seconds each tile took on the worker that delivered it (its replayed cost plus any
    /// oversleep), by tile id.
    pub tile_seconds: Vec<f64>,
}

/// Runs one emulated-cluster render of `desc` (which the replay must have been recorded from)
/// through the runtime's one entry point, as `parrt master` runs: its current-thread runtime
/// on a thread of its own (named [`MASTER_THREAD`], so its CPU can be read apart from the
/// relay's), its spawn code starting the replaying workers, which dial the relay.
pub fn run(
    desc: &SceneDescription,
    settings: &RenderSettings,
    run: &EmulatedRun,
) -> anyhow::Result<Measured> {
    let mut config = MasterConfig {
        observers: run.observers.clone(),
        ..MasterConfig::default()
    };
    let s = &mut config.schedule;
    s.tile = run.tile;
    s.min_workers = run.workers;
    s.wait_workers = run.timeout;
    s.window = run.window;
    s.max_batch = run.max_batch;
    s.pixel_format = run.pixel_format;
    // Many processes share few cores here: no tile is late, no worker silent, before the
    // run's own timeout says so.
    s.tile_deadline = run.timeout;
    config.net.token = Some(generate_token());
    config.net.heartbeat_timeout = run.timeout.min(Duration::from_secs(120));
    config.net.handshake_timeout = Duration::from_secs(60);
    config.spawn = Spawn {
        count: run.workers,
        threads: run.threads,
        // The emulated network is what is measured: pixels cross it.
        share_pixels: false,
        command: WorkerCommand {
            exe: Some(run.worker_exe.clone()),
            prefix: run.worker_prefix.clone(),
            extra: vec![
                "--dial-timeout".into(),
                "60".into(),
                "--replay".into(),
                run.replay.display().to_string(),
                "--cost-scale".into(),
                run.cost_scale.to_string(),
            ],
            name_prefix: "cluster".into(),
            log: "error".into(),
        },
    };
    let link = run.link;
    let limit = run.timeout;
    let (desc, settings) = (desc.clone(), settings.clone());
    let sampler = CpuSampler::start();
    let cancel = CancellationToken::new();
    let timed_out = Arc::new(AtomicBool::new(false));
    // Overrunning the time limit cancels the render: the workers are told to shut down, and
    // the runtime kills whatever is left.
    let timer = {
        let (stop, late) = (cancel.clone(), timed_out.clone());
        let (tx, rx) = std::sync::mpsc::channel::<()>();
        let t = std::thread::spawn(move || {
            if rx.recv_timeout(limit).is_err() {
                late.store(true, Ordering::Relaxed);
                stop.cancel();
            }
        });
        (tx, t)
    };
    let master = std::thread::Builder::new()
        .name(MASTER_THREAD.into())
        .spawn(move || {
            let mut relay = None;
            let r = parrt_runtime::run(
                &config,
                Job::<DistError>::ready(desc, settings),
                &mut |bound| {
                    let r = Relay::start(bound, link).map_err(DistError::Runtime)?;
                    let at = r.addr();
                    relay = Some(r);
                    Ok(Some(at))
                },
                Some(cancel),
            );
            let ended = Instant::now();
            drop(relay);
            (r, ended)
        })
        .context("cannot start the master's thread")?;
    let joined = master.join();
    let _ = timer.0.send(());
    let _ = timer.1.join();
    let (result, ended) = joined.map_err(|_| anyhow::anyhow!("the master's thread panicked"))?;
    let r = result
        .map_err(|e| {
            if timed_out.load(Ordering::Relaxed) {
                anyhow::anyhow!(
                    "the run did not finish within {}",
                    parrt_protocol::seconds::seconds(run.timeout)
                )
            } else {
                anyhow::Error::new(e)
            }
        })?
        .result;
    let started = ended
        .checked_sub(Duration::from_secs_f64(r.trace_s))
        .unwrap_or(ended);
    let cpu = sampler.between(started, ended);
    drop(sampler);
    Ok(Measured {
        trace_s: r.trace_s,
        tiles: r.tiles,
        delivered: r.per_worker.iter().map(|w| w.tiles).sum(),
        duplicates: r.faults.duplicate_results,
        rejected: r.faults.rejected_results,
        master_cpu_s: cpu.master_s,
        own_cpu_s: cpu.own_s,
        bench_process_cpu_s: cpu.this_process_s,
        machine_busy_s: cpu.machine_s,
        bytes_received: r.bytes_received,
        bytes_sent: r.bytes_sent,
        tile_seconds: r.tile_seconds,
        film: r.film,
    })
}
