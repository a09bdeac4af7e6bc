//! What `parrt bench cluster` writes: the Markdown report, `cluster.csv`, the efficiency plot
//! and the timelines of the runs, and the warnings that say when the table measures this machine
//! more than a cluster.

use super::{ClusterArgs, Row};
use crate::plot::{save_chart, Chart, Reference, Series};
use std::fmt::Write as _;
use std::path::Path;

/// A mean tile cost below this (seconds) measures wake-ups, timer slack and the emulation's own
/// CPU per message more than a cluster's schedule.
pub const SHORT_TILE_S: f64 = 0.002;

/// Machine busy above this share during a run: the emulation competes with itself.
pub const BUSY_MACHINE: f64 = 0.8;

/// What makes the table measure this machine rather than a cluster, in words (empty: nothing).
pub(super) fn binding_warnings(mean_tile_s: f64, rows: &[Row]) -> Vec<String> {
    let mut w = Vec::new();
    if mean_tile_s < SHORT_TILE_S {
        w.push(format!(
            "tiles average {:.2} ms of work: at this size the per-message costs of the \
             emulation (process wake-ups, timer slack, the relay) weigh as much as the work, and \
             the efficiencies say more about this machine than about a cluster; give the frame \
             a cluster's work with --work-seconds (e.g. --work-seconds 60)",
            mean_tile_s * 1e3
        ));
    }
    let busy: Vec<String> = rows
        .iter()
        .filter(|r| r.machine_busy > BUSY_MACHINE)
        .map(|r| {
            format!(
                "{}×{} ({:.0}%)",
                r.workers,
                r.threads,
                100.0 * r.machine_busy
            )
        })
        .collect();
    if !busy.is_empty() {
        w.push(format!(
            "this machine was busy above {:.0}% during {}: the emulation competes with itself \
             for its cores, so those rows bound this host, not the schedule",
            100.0 * BUSY_MACHINE,
            busy.join(", ")
        ));
    }
    w
}

pub(super) fn report(
    args: &ClusterArgs,
    title: &str,
    replay: &Path,
    costs: &[f64],
    scale: f64,
    rows: &[Row],
) -> String {
    let t1: f64 = costs.iter().sum();
    let largest = costs.iter().cloned().fold(0.0, f64::max);
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# {title}\n\nCommand: `parrt {}`. Replay {} (t₁ = {t1:.3} s recorded at one thread, × {scale:.3} \
         = {:.1} s of work; {} tiles, the largest {:.1}× the mean). Link: {} ms one way, master {} Mbit/s shared, workers {} Mbit/s each; \
         window {} (assignments per thread, or auto: one per thread plus the round trip's prefetch). e = t₁·scale/(N·T·t_N), t_N from the first tile handed out (every \
         worker ready) to the last result in. Predicted: `crate::studies::simulate` with the measured master \
         CPU per tile and bytes per pixel, and the rest of the emulation's measured CPU per tile \
         queued on this machine's cores; cluster predicted: the same without that shared host (every \
         node its own CPU, as in a real cluster). Limit: compute/cores ÷ max(compute/cores, bytes/master \
         link, 2 × latency, this machine's CPU used by the emulation / its cores). Emulation CPU: \
         share of this machine's cores the master, relay and workers used while tracing; machine busy: \
         every process's (others' too). Near 100%, the run measures this machine, not the cluster.\n",
        std::env::args().skip(1).collect::<Vec<_>>().join(" "),
        replay.display(),
        t1 * scale,
        costs.len(),
        largest * costs.len() as f64 / t1.max(1e-12),
        args.latency_ms,
        args.bandwidth_mbps,
        args.worker_bandwidth_mbps.unwrap_or(args.bandwidth_mbps),
        args.window
    );
    md.push_str(
        "| workers | threads | cores | t_N s | efficiency | predicted | Δ points | cluster predicted | limit | binds | \
         master µs/tile | emulation CPU | machine busy | MB in | identical | once | dup |\n\
         |---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|---|---|---:|\n",
    );
    for r in rows {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.3} | {:.3} | {:.3} | {:+.1} | {:.3} | {:.3} | {} | {:.0} | {:.0}% | {:.0}% | {:.1} | {} | {} | {} |",
            r.workers,
            r.threads,
            r.workers * r.threads,
            r.trace_s,
            r.efficiency,
            r.predicted,
            100.0 * (r.predicted - r.efficiency),
            r.predicted_cluster,
            r.limit,
            r.binding,
            r.master_us_per_tile,
            100.0 * r.emulation_cpu,
            100.0 * r.machine_busy,
            r.bytes_received as f64 / 1e6,
            if r.identical { "yes" } else { "**no**" },
            if r.delivered_once { "yes" } else { "**no**" },
            r.duplicates
        );
    }
    let _ = writeln!(md, "\n![cluster](cluster.png)");
    md
}

/// `cluster.csv`: a record per run.
pub(super) fn csv(rows: &[Row]) -> anyhow::Result<String> {
    let mut w = csv::Writer::from_writer(Vec::new());
    w.write_record([
        "workers",
        "threads",
        "tile",
        "trace_s",
        "efficiency",
        "predicted",
        "predicted_cluster",
        "limit",
        "binding",
        "master_us_per_tile",
        "emulation_cpu",
        "machine_busy",
        "bytes_received",
        "identical",
        "delivered_once",
        "duplicates",
    ])?;
    for r in rows {
        w.write_record([
            r.workers.to_string(),
            r.threads.to_string(),
            r.tile.to_string(),
            format!("{:.6}", r.trace_s),
            format!("{:.6}", r.efficiency),
            format!("{:.6}", r.predicted),
            format!("{:.6}", r.predicted_cluster),
            format!("{:.6}", r.limit),
            r.binding.clone(),
            format!("{:.2}", r.master_us_per_tile),
            format!("{:.3}", r.emulation_cpu),
            format!("{:.3}", r.machine_busy),
            r.bytes_received.to_string(),
            r.identical.to_string(),
            r.delivered_once.to_string(),
            r.duplicates.to_string(),
        ])?;
    }
    Ok(String::from_utf8(w.into_inner()?)?)
}

/// Draws the timeline of the run with the most workers at each thread count (and of one
/// worker, for contrast, when it differs); returns the Markdown that shows them.
pub(super) fn draw_timelines(
    args: &ClusterArgs,
    scene: &str,
    (width, height): (u32, u32),
    runs: &[(usize, usize, std::sync::Arc<crate::timeline::Recorder>, f64)],
) -> anyhow::Result<String> {
    let mut md = String::new();
    for &threads in &args.threads {
        let of: Vec<_> = runs.iter().filter(|r| r.1 == threads).collect();
        let (Some(most), Some(fewest)) =
            (of.iter().max_by_key(|r| r.0), of.iter().min_by_key(|r| r.0))
        else {
            continue;
        };
        // A timeline has a row per worker thread: draw it while it stays readable.
        let mut pick = vec![most];
        if fewest.0 != most.0 {
            pick.insert(0, fewest);
        }
        for (workers, threads, rec, trace_s) in pick.into_iter().map(|r| (r.0, r.1, &r.2, r.3)) {
            if workers * threads > 128 {
                continue;
            }
            let job = crate::timeline::Job {
                scene,
                width,
                height,
                tile_size: args.tile,
            };
            let tl = rec.timeline(&job, trace_s);
            let stem = format!("timeline-{workers}x{threads}");
            // The data behind the plot, for whoever wants to look closer.
            tl.write(&args.out.join(format!("{stem}.json")))?;
            md += &crate::timeline::plot::save_figure(
                &tl,
                &args.out,
                &stem,
                &format!("{workers} emulated workers × {threads} threads, replayed"),
            )?;
        }
    }
    Ok(md)
}

pub(super) fn plot(args: &ClusterArgs, title: &str, rows: &[Row]) -> anyhow::Result<()> {
    let mut series = Vec::new();
    for &t in &args.threads {
        let pick = |f: &dyn Fn(&Row) -> f64| -> Vec<(f64, f64)> {
            rows.iter()
                .filter(|r| r.threads == t)
                .map(|r| ((r.workers * r.threads) as f64, f(r)))
                .collect()
        };
        series.push(Series {
            label: format!("measured, {t} thread(s)/worker"),
            points: pick(&|r| r.efficiency),
            line: true,
        });
        series.push(Series {
            label: format!("simulated emulation, {t} thread(s)/worker"),
            points: pick(&|r| r.predicted),
            line: true,
        });
        series.push(Series {
            label: format!("simulated real cluster, {t} thread(s)/worker"),
            points: pick(&|r| r.predicted_cluster),
            line: true,
        });
        series.push(Series {
            label: format!("hardware limit, {t} thread(s)/worker"),
            points: pick(&|r| r.limit),
            line: true,
        });
    }
    let chart = Chart {
        title: title.to_string(),
        x_label: "render threads n (workers × threads per worker)".into(),
        y_label: "efficiency t₁/(n·tₙ) (1 = ideal)".into(),
        series,
        log_x: true,
        y_range: Some((0.0, 1.05)),
        reference: Some(Reference::ideal_efficiency()),
    };
    save_chart(
        &chart,
        &args.out.join("cluster.svg"),
        &args.out.join("cluster.png"),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_tiles_and_a_busy_machine_are_said() {
        assert!(binding_warnings(0.05, &[]).is_empty());
        let w = binding_warnings(0.0007, &[]);
        assert_eq!(w.len(), 1);
        assert!(
            w[0].contains("0.70 ms") && w[0].contains("--work-seconds"),
            "{}",
            w[0]
        );
    }

    #[test]
    fn csv_keeps_its_columns_and_number_formats() {
        let row = Row {
            workers: 1,
            threads: 1,
            tile: 16,
            efficiency: 0.998003,
            predicted: 0.999993,
            predicted_cluster: 0.999996,
            limit: 1.0,
            binding: "compute".into(),
            identical: true,
            delivered_once: true,
            tiles: 256,
            duplicates: 0,
            trace_s: 128.256123,
            master_us_per_tile: 116.28,
            worker_overrun: 0.0,
            predicted_as_run: 0.99,
            emulation_cpu: 0.008,
            machine_busy: 0.306,
            cpu_split: [0.2, 0.3, 0.5],
            bytes_received: 3314291,
        };
        assert_eq!(
            csv(&[row]).expect("writes"),
            "workers,threads,tile,trace_s,efficiency,predicted,predicted_cluster,limit,binding,\
             master_us_per_tile,emulation_cpu,machine_busy,bytes_received,identical,\
             delivered_once,duplicates\n\
             1,1,16,128.256123,0.998003,0.999993,0.999996,1.000000,compute,116.28,0.008,0.306,\
             3314291,true,true,0\n"
        );
    }
}
