//! How many tiles go in one assignment message (see docs/design.md, *Distributed runtime*):
//! batches cut the master's per-tile cost on cheap tiles. The master's scheduler and the
//! schedule simulator both call [`batch_size`], so the model follows the rule the
//! master runs.

/// The most work, in seconds at the mean tile cost, that one batch of tiles may hold, by
/// default (a message costs the master 10–20 µs, so 2 ms keeps it near 1 %).
pub const BATCH_SECONDS: f64 = 0.002;

/// Tiles in the next assignment: guided, as the SMP `guided` schedule shrinks its runs — a
/// quarter of the queued tiles' share per ready render thread, between 1 and `max_batch` — and
/// no more than `batch_seconds` (by default [`BATCH_SECONDS`]) of work at `mean_cost`, the mean one-thread cost of the
/// tiles seen so far (single tiles until one has been seen, `None`). Large batches of cheap
/// tiles cut the messages (and the wake-ups of master and worker) per tile; costly tiles,
/// which amortise a message anyway, go alone so a batch never nears the tile deadline; single
/// tiles at the tail keep the workers' finish even.
pub fn batch_size(
    max_batch: usize,
    queued: usize,
    ready_threads: usize,
    mean_cost: Option<f64>,
    batch_seconds: f64,
) -> usize {
    let Some(mean) = mean_cost else {
        return 1;
    };
    if max_batch <= 1 {
        return 1;
    }
    let by_cost = if mean > 0.0 {
        (batch_seconds / mean).clamp(1.0, max_batch as f64) as usize
    } else {
        max_batch
    };
    (queued / (4 * ready_threads.max(1))).clamp(1, by_cost)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_tiles_until_a_cost_is_known_or_when_costly() {
        assert_eq!(batch_size(8, 10_000, 2, None, BATCH_SECONDS), 1);
        assert_eq!(batch_size(1, 10_000, 2, Some(1e-6), BATCH_SECONDS), 1);
        assert_eq!(batch_size(8, 10_000, 2, Some(1e-6), BATCH_SECONDS), 8);
        assert_eq!(
            batch_size(8, 10_000, 2, Some(BATCH_SECONDS), BATCH_SECONDS),
            1
        );
        assert_eq!(
            batch_size(8, 10_000, 2, Some(BATCH_SECONDS / 3.0), BATCH_SECONDS),
            3
        );
        // Guided: the queue's share per thread shrinks the batch toward the tail.
        assert_eq!(batch_size(8, 24, 2, Some(1e-6), BATCH_SECONDS), 3);
        assert_eq!(batch_size(8, 3, 2, Some(1e-6), BATCH_SECONDS), 1);
    }
}
