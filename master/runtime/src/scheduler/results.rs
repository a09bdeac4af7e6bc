//! A worker's result for a tile: the checks it must pass (a frame open, a tile the worker holds,
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
        pixels: TilePixels,
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
        if !self.workers.contains_key(&id) {
            return; // Already removed: nothing it says counts any more.
        }
        let Some(p) = self.frame_of_job(job_id) else {
            self.faults.rejected_results += 1;
            let current = self.open.first().map_or(0, |f| f.job_id);
            self.fail(id, format!("result for job {job_id}, not {current}"));
            return;
        };
        let key = (self.open[p].index, tile_id);
        let Some(w) = self.workers.get_mut(&id) else {
            return;
        };
        let Some(&a) = w.inflight.get(&key).filter(|a| a.attempt == attempt) else {
            self.faults.rejected_results += 1;
            self.fail(
                id,
                format!("result for tile {tile_id} attempt {attempt}, which it does not hold"),
            );
            return;
        };
        w.inflight.remove(&key);
        if !a.expired {
            self.open[p].holders[tile_id as usize] -= 1;
        }
        if a.single && !a.backup && seconds.is_finite() {
            let turnaround = now.saturating_duration_since(a.since).as_secs_f64();
            let rt = (turnaround - seconds).max(0.0);
            w.round_trip = Some(w.round_trip.map_or(rt, |old| old.min(rt)));
        }
        // Held tiles come from our own list, so the id indexes it.
        let t = tile_id as usize;
        let f = &self.open[p];
        let tile = f.tiles[t];
        let mut decoded = std::mem::take(&mut self.scratch);
        // Unpacked first, into the tile's byte count and no more; then 8-bit pixels go into an
        // 8-bit film as they came, decoded only for observers.
        let (format, count) = (self.opts.pixel_format, tile.pixel_count());
        let unpacked = pixels.unpack(count);
        let checked = match &unpacked {
            Err(e) => Err(e.clone()),
            Ok(pixels) if f.film.is_rgb8() && self.observers.is_empty() => {
                decoded.clear();
                pixels.rgb8(format, count).map(Checked::Rgb8)
            }
            Ok(pixels) => pixels
                .decode_into(format, count, &mut decoded)
                .map(|()| Checked::Linear(&decoded)),
        };
        let checked = checked.map_err(|e| e.to_string()).and_then(|px| {
            let valid = stats.check_tile(&tile, &f.settings, f.lights);
            valid.map(|()| px).map_err(|e| e.to_string())
        });
        match checked.map_err(|e| format!("tile {tile_id}: {e}")) {
            Err(reason) => {
                self.faults.rejected_results += 1;
                self.requeue(p, tile_id);
                self.fail(id, reason);
            }
            Ok(px) => {
                let accepted = self.accept(id, p, t, px, stats, seconds);
                let shown: &[Rgb] = if accepted { &decoded } else { &[] };
                let frame = self.open[p].index;
                self.observers
                    .each(|o| o.result_in(frame, id, &tile, shown, &stats, seconds, accepted));
                if accepted {
                    if let (Some(sink), Ok(pixels)) = (&mut self.accepted, unpacked) {
                        sink.push(AcceptedTile {
                            frame,
                            tile_id,
                            pixels,
                            stats,
                            seconds,
                        });
                    }
                    self.close_if_complete(p, now);
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
        p: usize,
        t: usize,
        pixels: Checked,
        stats: RayStats,
        seconds: f64,
    ) -> bool {
        let f = &mut self.open[p];
        let tile = f.tiles[t];
        if f.state[t] == TileState::Done && !mutation::is(Mutation::AcceptDuplicates) {
            self.faults.duplicate_results += 1;
            debug!(worker = id, tile_id = t, "duplicate result ignored");
            return false;
        }
        let written = match pixels {
            Checked::Linear(px) => f.film.write_tile(&tile, px),
            Checked::Rgb8(bytes) => f.film.write_tile_rgb8(&tile, bytes),
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
        f.set_state(t, TileState::Done);
        // A worker's clock is its own word: only a plausible figure enters the mean.
        if seconds.is_finite() && (0.0..=86_400.0).contains(&seconds) {
            self.cost = (self.cost.0 + seconds, self.cost.1.saturating_add(1));
        }
        f.stats += stats;
        f.tile_seconds[t] = seconds;
        f.done += 1;
        if mutation::is(Mutation::MarkNeighbourDone)
            && f.state.get(t + 1) == Some(&TileState::Queued)
        {
            f.set_state(t + 1, TileState::Done);
            f.queue.retain(|&q| q as usize != t + 1);
            f.done += 1;
        }
        self.measured(p, t, seconds);
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
