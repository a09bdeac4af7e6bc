//! A worker's result for a tile: the checks it must pass (this job, a tile the worker holds,
//! the right pixel count, finite pixels, plausible ray statistics) and how a checked result
//! lands in the film, first result wins.

use super::*;

impl Scheduler {
    #[allow(clippy::too_many_arguments)]
    pub(super) fn result(
        &mut self,
        id: WorkerId,
        job_id: u64,
        tile_id: u32,
        attempt: u32,
        pixels: &TilePixels,
        stats: RayStats,
        seconds: f64,
        now: Instant,
    ) {
        if self.is_past(job_id) {
            // A backup (or a result sent before the worker read the next frame) of a frame
            // already complete: it came second.
            if self.workers.contains_key(&id) {
                self.faults.duplicate_results += 1;
            }
            return;
        }
        let Some(w) = self.workers.get_mut(&id) else {
            return; // Already removed: nothing it says counts any more.
        };
        if job_id != self.job_id {
            self.faults.rejected_results += 1;
            self.fail(id, format!("result for job {job_id}, not {}", self.job_id));
            return;
        }
        let Some(&a) = w.inflight.get(&tile_id).filter(|a| a.attempt == attempt) else {
            self.faults.rejected_results += 1;
            self.fail(
                id,
                format!("result for tile {tile_id} attempt {attempt}, which it does not hold"),
            );
            return;
        };
        w.inflight.remove(&tile_id);
        if !a.expired {
            self.holders[tile_id as usize] -= 1;
        }
        if a.single && !a.backup && seconds.is_finite() {
            let turnaround = now.saturating_duration_since(a.since).as_secs_f64();
            let rt = (turnaround - seconds).max(0.0);
            w.round_trip = Some(w.round_trip.map_or(rt, |old| old.min(rt)));
        }
        // Held tiles come from our own list, so the id indexes it.
        let t = tile_id as usize;
        let tile = self.tiles[t];
        let mut decoded = std::mem::take(&mut self.scratch);
        // 8-bit pixels go into an 8-bit film as they came, decoded only for observers.
        let (format, count) = (self.opts.pixel_format, tile.pixel_count());
        let checked = if self.film.is_rgb8() && self.observers.is_empty() {
            decoded.clear();
            pixels.rgb8(format, count).map(Checked::Rgb8)
        } else {
            pixels
                .decode_into(format, count, &mut decoded)
                .map(|()| Checked::Linear(&decoded))
        };
        let checked = checked.map_err(|e| e.to_string()).and_then(|px| {
            let valid = stats.check_tile(&tile, &self.settings, self.lights);
            valid.map(|()| px).map_err(|e| e.to_string())
        });
        match checked.map_err(|e| format!("tile {tile_id}: {e}")) {
            Err(reason) => {
                self.faults.rejected_results += 1;
                self.requeue(tile_id);
                self.fail(id, reason);
            }
            Ok(px) => {
                let accepted = self.accept(id, t, px, stats, seconds);
                let shown: &[Rgb] = if accepted { &decoded } else { &[] };
                self.observers
                    .each(|o| o.result(id, &tile, shown, &stats, seconds, accepted));
                if accepted {
                    if let Some(sink) = &mut self.accepted {
                        sink.push(AcceptedTile {
                            tile_id,
                            pixels: pixels.clone(),
                            stats,
                            seconds,
                        });
                    }
                }
            }
        }
        self.scratch = decoded;
    }

    /// Writes a checked result into the film unless the tile is already done; says whether it
    /// did.
    pub(super) fn accept(
        &mut self,
        id: WorkerId,
        t: usize,
        pixels: Checked,
        stats: RayStats,
        seconds: f64,
    ) -> bool {
        let tile = self.tiles[t];
        if self.state[t] == TileState::Done && !mutation::is(Mutation::AcceptDuplicates) {
            self.faults.duplicate_results += 1;
            debug!(worker = id, tile_id = t, "duplicate result ignored");
            return false;
        }
        let written = match pixels {
            Checked::Linear(px) => self.film.write_tile(&tile, px),
            Checked::Rgb8(bytes) => self.film.write_tile_rgb8(&tile, bytes),
        };
        if let Err(e) = written {
            // Cannot happen: the tile is ours and the count was checked.
            warn!(error = %e, "tile does not fit the film");
            return false;
        }
        if let Some(w) = self.workers.get_mut(&id) {
            w.tiles += 1;
            w.render_s += seconds;
            w.failures = 0;
        }
        self.state[t] = TileState::Done;
        // A worker's clock is its own word: only a plausible figure enters the mean.
        if seconds.is_finite() && (0.0..=86_400.0).contains(&seconds) {
            self.cost = (self.cost.0 + seconds, self.cost.1.saturating_add(1));
        }
        self.stats += stats;
        self.tile_seconds[t] = seconds;
        self.done += 1;
        if mutation::is(Mutation::MarkNeighbourDone)
            && self.state.get(t + 1) == Some(&TileState::Queued)
        {
            self.state[t + 1] = TileState::Done;
            self.queue.retain(|&q| q as usize != t + 1);
            self.done += 1;
        }
        true
    }
}

/// A checked result's pixels, as the film takes them.
#[derive(Clone, Copy)]
pub(super) enum Checked<'a> {
    /// Decoded linear values.
    Linear(&'a [Rgb]),
    /// 8-bit RGB bytes, for an 8-bit film.
    Rgb8(&'a [u8]),
}
