//! One emulated-cluster render: a real [`Master`] on 127.0.0.1, the emulated LAN
//! ([`super::link::Relay`]) in front of it, and N real worker processes replaying a recorded
//! render through it. Bounded in time (the run is cancelled, and the workers told to shut down,
//! when it overruns) and the worker processes are killed and reaped on every path.

use super::cpu::{CpuSampler, MASTER_THREAD};
use super::link::{LinkParams, Relay};
use crate::distributed::{generate_token, DistOptions, Master};
use anyhow::Context;
use parrt::description::SceneDescription;
use parrt::film::Film;
use parrt::settings::RenderSettings;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
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
    pub window: parrt::window::Window,
    /// Most tiles in one assignment.
    pub max_batch: usize,
    /// How pixels travel.
    pub pixel_format: parrt::protocol::PixelFormat,
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
    pub observers: crate::distributed::observer::Observers,
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

/// Worker processes, killed and reaped on drop.
struct Children(Vec<Child>);

impl Drop for Children {
    fn drop(&mut self) {
        for c in &mut self.0 {
            let _ = c.kill();
        }
        for c in &mut self.0 {
            let _ = c.wait();
        }
    }
}

/// Runs one emulated-cluster render of `desc` (which the replay must have been recorded from).
pub fn run(
    desc: &SceneDescription,
    settings: &RenderSettings,
    run: &EmulatedRun,
) -> anyhow::Result<Measured> {
    let token = generate_token();
    let opts = DistOptions {
        workers_to_spawn: 0,
        threads_per_worker: run.threads,
        tile: run.tile,
        listen: "127.0.0.1:0".into(),
        token: Some(token.clone()),
        min_workers: run.workers,
        wait_workers: run.timeout,
        window: run.window,
        max_batch: run.max_batch,
        pixel_format: run.pixel_format,
        // Many processes share few cores here: no tile is late, no worker silent, before the
        // run's own timeout says so.
        tile_deadline: run.timeout,
        heartbeat_timeout: run.timeout.min(Duration::from_secs(120)),
        handshake_timeout: Duration::from_secs(60),
        progress: false,
        observers: run.observers.clone(),
        ..DistOptions::default()
    };
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .thread_name(MASTER_THREAD)
        .enable_all()
        .build()
        .context("cannot start the async runtime")?;
    let master = rt
        .block_on(Master::bind(&opts, token.clone()))
        .context("cannot start the master")?;
    let relay = Relay::start(master.local_addr(), run.link).context("cannot start the relay")?;
    let token_text = String::from_utf8_lossy(token.as_bytes()).into_owned();
    let mut children = Children(Vec::with_capacity(run.workers));
    for i in 0..run.workers {
        let mut cmd = Command::new(&run.worker_exe);
        cmd.args(&run.worker_prefix)
            .arg("--connect")
            .arg(relay.addr().to_string())
            .arg("--threads")
            .arg(run.threads.to_string())
            .arg("--name")
            .arg(format!("cluster-{i}"))
            .arg("--dial-timeout")
            .arg("60")
            .arg("--replay")
            .arg(&run.replay)
            .arg("--cost-scale")
            .arg(run.cost_scale.to_string())
            .env(parrt_worker::cli::TOKEN_ENV, &token_text)
            .env(parrt_worker::cli::LOG_ENV, "error")
            .stdin(Stdio::null())
            .stdout(Stdio::null());
        let child = cmd
            .spawn()
            .with_context(|| format!("cannot start worker {}", run.worker_exe.display()))?;
        children.0.push(child);
    }
    let sampler = CpuSampler::start(children.0.iter().map(|c| c.id()).collect());
    let cancel = CancellationToken::new();
    let timed_out = Arc::new(AtomicBool::new(false));
    let result = rt.block_on(async {
        // Overrunning the time limit, or Ctrl-C, cancels the render: the workers are told
        // to shut down, and dropping `children` kills whatever is left.
        let (stop, late) = (cancel.clone(), timed_out.clone());
        let limit = run.timeout;
        let timer = tokio::spawn(async move {
            tokio::select! {
                _ = tokio::time::sleep(limit) => late.store(true, Ordering::Relaxed),
                r = tokio::signal::ctrl_c() => if r.is_err() { return },
            }
            stop.cancel();
        });
        let r = master.render(desc, settings, cancel.clone()).await;
        timer.abort();
        r
    });
    let ended = Instant::now();
    let r = result.map_err(|e| {
        if timed_out.load(Ordering::Relaxed) {
            anyhow::anyhow!("the run did not finish within {:?}", run.timeout)
        } else {
            anyhow::Error::new(e)
        }
    })?;
    let started = ended
        .checked_sub(Duration::from_secs_f64(r.trace_s))
        .unwrap_or(ended);
    let cpu = sampler.between(started, ended);
    drop(sampler);
    drop(relay);
    drop(children);
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
