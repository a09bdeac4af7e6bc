//! One run of `parrt bench cluster`: `workers` real worker processes of `threads` threads
//! replaying the recording behind emulated links, measured, predicted by the schedule model
//! three ways, bounded by the hardware, and checked against the recorded image.

use super::{limit, Row};
use crate::studies::cluster::emulate::{self, EmulatedRun};
use crate::studies::cluster::link::LinkParams;
use crate::studies::simulate::{simulate, SimParams};
use anyhow::Context;
use parrt_render::description::SceneDescription;
use parrt_render::film::Film;
use parrt_render::settings::RenderSettings;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

/// What every run of the study shares: the scene, the recording and its scale, the links.
pub(super) struct Setup<'a> {
    pub args: &'a super::ClusterArgs,
    pub desc: SceneDescription,
    pub settings: RenderSettings,
    /// The recording's file and the image it holds.
    pub path: PathBuf,
    pub reference: Film,
    /// The factor on every recorded tile cost, and the one-thread work it makes (seconds).
    pub scale: f64,
    pub work: f64,
    /// Scaled tile costs (seconds) and pixel counts, in tile order, and the image's pixels.
    pub costs: Vec<f64>,
    pub px: Vec<u64>,
    pub pixels: u64,
    pub link: LinkParams,
    /// The worker executable and the arguments before the worker's own.
    pub worker_exe: PathBuf,
    pub prefix: Vec<String>,
}

/// A run's timeline: workers, threads, what was recorded and the trace seconds.
pub(super) type RunTimeline = (usize, usize, Arc<crate::timeline::Recorder>, f64);

impl Setup<'_> {
    /// Runs `workers` × `threads` and makes its row of the report.
    pub(super) fn measure(
        &self,
        workers: usize,
        threads: usize,
    ) -> anyhow::Result<(Row, RunTimeline)> {
        let args = self.args;
        crate::errln!("{workers} workers × {threads} threads ...");
        let recorder = std::sync::Arc::new(crate::timeline::Recorder::new());
        let m = emulate::run(
            &self.desc,
            &self.settings,
            &EmulatedRun {
                workers,
                threads,
                tile: args.tile,
                window: args.window,
                max_batch: args.max_batch,
                pixel_format: if args.exact_pixels {
                    parrt_protocol::PixelFormat::F32
                } else {
                    parrt_protocol::PixelFormat::Rgb8
                },
                link: self.link,
                replay: self.path.clone(),
                cost_scale: self.scale,
                worker_exe: self.worker_exe.clone(),
                worker_prefix: self.prefix.clone(),
                timeout: Duration::from_secs_f64(args.run_timeout),
                observers: parrt_runtime::observer::Observers(vec![recorder.clone()]),
            },
        )
        .with_context(|| format!("{workers} workers × {threads} threads"))?;
        let cores = workers * threads;
        let machine_cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        let master_per_tile = m.master_cpu_s / m.tiles.max(1) as f64;
        let p = self.model_params(&m, workers, threads, machine_cores);
        let sim = simulate(&self.costs, &self.px, &p);
        let as_run = simulate(&m.tile_seconds, &self.px, &p);
        let cluster = simulate(
            &self.costs,
            &self.px,
            &SimParams {
                host_per_tile_s: 0.0,
                ..p.clone()
            },
        );
        let ran: f64 = m.tile_seconds.iter().sum();
        let (bound, binding) = limit(
            self.work,
            cores,
            m.bytes_received as f64,
            self.link.master_bps,
            args.latency_ms / 1e3,
            m.own_cpu_s,
        );
        let busy = |cpu: f64| cpu / (machine_cores as f64 * m.trace_s.max(1e-12));
        let row = Row {
            workers,
            threads,
            tile: args.tile,
            efficiency: self.work / (cores as f64 * m.trace_s.max(1e-12)),
            predicted: sim.efficiency,
            predicted_cluster: cluster.efficiency,
            limit: (self.work / cores as f64) / bound.max(1e-12),
            binding,
            identical: if args.exact_pixels {
                m.film == self.reference
            } else {
                m.film.to_rgb8() == self.reference.to_rgb8()
            },
            delivered_once: m.delivered == m.tiles as u64,
            tiles: m.tiles,
            duplicates: m.duplicates,
            trace_s: m.trace_s,
            master_us_per_tile: master_per_tile * 1e6,
            worker_overrun: ran / self.work - 1.0,
            emulation_cpu: busy(m.own_cpu_s),
            machine_busy: busy(m.machine_busy_s),
            cpu_split: {
                let total = m.own_cpu_s.max(1e-12);
                let relay = (m.bench_process_cpu_s - m.master_cpu_s).max(0.0);
                let workers = (m.own_cpu_s - m.bench_process_cpu_s).max(0.0);
                [m.master_cpu_s / total, relay / total, workers / total]
            },
            predicted_as_run: as_run.efficiency * self.work / ran.max(1e-12),
            bytes_received: m.bytes_received,
        };
        crate::errln!(
            "  e = {:.3}, predicted {:.3} ({:.3} from the tile times as run, workers overran {:.1}%), limit {:.3} ({}), emulation CPU {:.0}% (master {:.0}%, relay {:.0}%, workers {:.0}% of it), machine busy {:.0}%, identical {}",
            row.efficiency,
            row.predicted,
            row.predicted_as_run,
            100.0 * row.worker_overrun,
            row.limit,
            row.binding,
            100.0 * row.emulation_cpu,
            100.0 * row.cpu_split[0],
            100.0 * row.cpu_split[1],
            100.0 * row.cpu_split[2],
            100.0 * row.machine_busy,
            row.identical
        );
        Ok((row, (workers, threads, recorder, m.trace_s)))
    }

    /// The schedule model's parameters for a run as measured: the master's window rule fed
    /// the round trip this link and master gave a result, the links, and the CPU the master
    /// and the emulation spent per result on this machine's cores.
    fn model_params(
        &self,
        m: &emulate::Measured,
        workers: usize,
        threads: usize,
        machine_cores: usize,
    ) -> SimParams {
        let args = self.args;
        let master_per_tile = m.master_cpu_s / m.tiles.max(1) as f64;
        SimParams {
            workers,
            threads,
            // The master's rule, fed the round trip this link and master give a result.
            window: args.window.assignments(
                threads,
                Some(
                    2.0 * args.latency_ms / 1e3
                        + master_per_tile
                        + (m.own_cpu_s - m.master_cpu_s).max(0.0) / m.tiles.max(1) as f64,
                ),
                self.work / self.costs.len().max(1) as f64,
            ),
            max_batch: args.max_batch,
            batch_seconds: parrt_runtime::batch::BATCH_SECONDS,
            latency_s: args.latency_ms / 1e3,
            bandwidth_bps: self.link.worker_bps,
            master_link_bps: self.link.master_bps,
            master_per_tile_s: master_per_tile,
            // Everything else the emulation spent per result, on this machine's cores.
            host_per_tile_s: (m.own_cpu_s - m.master_cpu_s).max(0.0) / m.tiles.max(1) as f64,
            host_cores: machine_cores,
            // Every worker is ready before the first tile: the trace has no start-up.
            // Raster order: the master fills each window in turn.
            rounds: false,
            scene_bytes: 0.0,
            build_s: 0.0,
            result_bytes_per_pixel: m.bytes_received as f64 / self.pixels.max(1) as f64,
            message_bytes: 0.0,
            // The master's default: idle workers take copies of tiles out once the queue is empty.
            backups: true,
            // One frame.
            frames: None,
        }
    }
}
