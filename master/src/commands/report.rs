//! What the rendering commands print and write when a render is done: the ray statistics and
//! timings of `parrt render` (`--stats`, `--stats-json`), and the summary and JSON report of a
//! distributed render (`parrt master`, rank 0 of `parrt cluster`). Formatting only: nothing
//! here renders or decides an exit code.

use parrt_render::stats::RayStats;
use parrt_runtime::DistResult;
use serde_json::json;

/// Everything a finished render reports.
pub struct RenderReport {
    /// Ray statistics.
    pub stats: RayStats,
    /// Seconds parsing or generating the scene.
    pub parse_s: f64,
    /// Seconds building the render-ready scene and accelerator.
    pub build_s: f64,
    /// Seconds tracing.
    pub trace_s: f64,
}

impl RenderReport {
    /// The `--stats-json` object (the stable keys of docs/design.md, *Command line contract*, plus
    /// extras).
    pub fn to_json(&self, extra: serde_json::Value) -> serde_json::Value {
        let s = &self.stats;
        // The counters as one value (their serde names are the stable keys).
        let mut v = serde_json::to_value(s).unwrap_or_else(|_| json!({}));
        let timing = json!({
            "total_rays": s.total_rays(),
            "parse_s": self.parse_s,
            "build_s": self.build_s,
            "trace_s": self.trace_s,
            "mrays_per_s": self.mrays_per_s(),
            "isa": parrt_render::isa::current(),
        });
        if let Some(obj) = v.as_object_mut() {
            for more in [timing, extra] {
                if let serde_json::Value::Object(e) = more {
                    obj.extend(e);
                }
            }
        }
        v
    }

    /// Millions of rays per second of tracing time.
    pub fn mrays_per_s(&self) -> f64 {
        if self.trace_s > 0.0 {
            self.stats.total_rays() as f64 / self.trace_s / 1e6
        } else {
            0.0
        }
    }

    /// Human-readable statistics.
    pub fn print(&self) {
        let s = &self.stats;
        let per = |n: u64, rays: u64| {
            if rays > 0 {
                n as f64 / rays as f64
            } else {
                0.0
            }
        };
        let rays = s.total_rays();
        crate::outln!(
            "rays              {:>14}  ({:.2} Mrays/s)",
            rays,
            self.mrays_per_s()
        );
        crate::outln!("  eye             {:>14}  hits {}", s.eye_rays, s.eye_hits);
        crate::outln!(
            "  shadow          {:>14}  blocked {}",
            s.shadow_rays,
            s.shadow_hits
        );
        crate::outln!(
            "  reflection      {:>14}  hits {}",
            s.reflection_rays,
            s.reflection_hits
        );
        crate::outln!(
            "  refraction      {:>14}  hits {}",
            s.refraction_rays,
            s.refraction_hits
        );
        crate::outln!(
            "box tests         {:>14}  ({:.1} per ray)",
            s.box_tests,
            per(s.box_tests, rays)
        );
        crate::outln!(
            "primitive tests   {:>14}  ({:.1} per ray)",
            s.primitive_tests,
            per(s.primitive_tests, rays)
        );
        if s.cell_steps > 0 {
            crate::outln!(
                "cell steps        {:>14}  ({:.1} per ray)",
                s.cell_steps,
                per(s.cell_steps, rays)
            );
        }
        crate::outln!("parse             {:>13.3}s", self.parse_s);
        crate::outln!("build             {:>13.3}s", self.build_s);
        crate::outln!("preprocessing     {:>13.3}s", self.parse_s + self.build_s);
        crate::outln!("trace             {:>13.3}s", self.trace_s);
        crate::outln!(
            "isa               {:>14}",
            parrt_render::isa::current().name()
        );
    }
}

/// Prints what a distributed render did (also `parrt cluster`'s rank 0).
pub fn print_summary(r: &DistResult, out: &std::path::Path) {
    crate::errln!(
        "parrt master: wrote {} ({} tiles in {:.3} s; {} rays; {} bytes out, {} in, {:.0} bytes/tile; scene transfer {:.4} s)",
        out.display(),
        r.tiles,
        r.trace_s,
        r.stats.total_rays(),
        r.bytes_sent,
        r.bytes_received,
        (r.bytes_sent + r.bytes_received) as f64 / r.tiles.max(1) as f64,
        r.scene_transfer_s,
    );
    if r.restored_tiles > 0 || r.checkpoint_bad_records > 0 {
        crate::errln!(
            "  checkpoint: {} tiles restored, {} bad records dropped",
            r.restored_tiles,
            r.checkpoint_bad_records
        );
    }
    for w in &r.per_worker {
        crate::errln!(
            "  {:<20} {:>2} threads {:<6} {:>6} tiles {:>8.3} s render{}",
            w.name,
            w.threads,
            w.isa.name(),
            w.tiles,
            w.render_s,
            w.left
                .as_deref()
                .map(|l| format!("  (left: {l})"))
                .unwrap_or_default()
        );
    }
    let f = &r.faults;
    if !f.refused.is_empty() || f.rejected_results + f.requeued + f.dropped > 0 {
        crate::errln!(
            "  faults: {} refused, {} results rejected, {} duplicates ignored, {} tiles requeued, {} backups, {} workers dropped",
            f.refused.len(),
            f.rejected_results,
            f.duplicate_results,
            f.requeued,
            f.backups,
            f.dropped
        );
    }
}

/// The figures of a run as JSON (for benchmarks and scripts).
pub fn report_json(r: &DistResult) -> serde_json::Value {
    serde_json::json!({
        "tiles": r.tiles,
        "restored_tiles": r.restored_tiles,
        "checkpoint_bad_records": r.checkpoint_bad_records,
        "trace_s": r.trace_s,
        "bytes_sent": r.bytes_sent,
        "bytes_received": r.bytes_received,
        "bytes_per_tile": (r.bytes_sent + r.bytes_received) as f64 / r.tiles.max(1) as f64,
        "scene_transfer_s": r.scene_transfer_s,
        "master_cpu_s": r.master_cpu_s,
        "master_cpu_per_tile_us": r.master_cpu_per_tile_us(),
        "master_cpu_per_mb_ms": r.master_cpu_per_mb_ms(),
        "eye_rays": r.stats.eye_rays,
        "refused": r.faults.refused.count,
        "refused_reasons": r.faults.refused.reasons,
        "rejected_results": r.faults.rejected_results,
        "duplicate_results": r.faults.duplicate_results,
        "requeued": r.faults.requeued,
        "backups": r.faults.backups,
        "dropped": r.faults.dropped,
        "workers": r.per_worker.iter().map(|w| serde_json::json!({
            "name": w.name,
            "threads": w.threads,
            "isa": w.isa,
            "tiles": w.tiles,
            "render_s": w.render_s,
            "build_s": w.build_s,
            "scene_transfer_s": w.scene_transfer_s,
            "bytes_sent": w.bytes_sent,
            "bytes_received": w.bytes_received,
            "left": w.left,
        })).collect::<Vec<_>>(),
    })
}
