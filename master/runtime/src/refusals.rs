//! The bounded record of refused handshakes: a count, the first few reasons (each already cut
//! to a bounded length by the connection task), and a WARN log line at most once a second
//! (the rest at DEBUG), so a flood of bad peers costs neither memory nor disk.

use parrt_protocol::limits;
use std::time::Duration;
use tokio::time::Instant;
use tracing::{debug, warn};

/// Reasons kept as a sample.
pub const SAMPLE_REASONS: usize = 16;

/// How often a refusal may be logged at WARN.
pub const WARN_EVERY: Duration = Duration::from_secs(1);

/// Handshakes refused during one job.
#[derive(Clone, Debug, Default)]
pub struct Refusals {
    /// How many.
    pub count: u64,
    /// The first [`SAMPLE_REASONS`] reasons.
    pub reasons: Vec<String>,
    last_warn: Option<Instant>,
    unlogged: u64,
}

impl Refusals {
    /// Records one refusal of `peer` at `now`.
    pub fn record(&mut self, peer: &str, reason: String, now: Instant) {
        self.count += 1;
        let reason = limits::capped_reason(reason);
        if self
            .last_warn
            .is_none_or(|t| now.duration_since(t) >= WARN_EVERY)
        {
            warn!(%peer, %reason, not_logged_since = self.unlogged, "refused a peer");
            self.last_warn = Some(now);
            self.unlogged = 0;
        } else {
            self.unlogged += 1;
            debug!(%peer, %reason, "refused a peer");
        }
        if self.reasons.len() < SAMPLE_REASONS {
            self.reasons.push(reason);
        }
    }

    /// How many handshakes were refused.
    pub fn len(&self) -> u64 {
        self.count
    }

    /// Whether none was.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test(start_paused = true)]
    async fn the_record_stays_bounded() {
        let mut r = Refusals::default();
        let huge = "x".repeat(1 << 20);
        for _ in 0..10_000 {
            r.record("127.0.0.1:1", huge.clone(), Instant::now());
        }
        assert_eq!(r.len(), 10_000);
        assert_eq!(r.reasons.len(), SAMPLE_REASONS);
        assert!(r
            .reasons
            .iter()
            .all(|s| s.len() <= limits::MAX_REASON_BYTES));
        assert_eq!(r.unlogged, 9_999);
        tokio::time::advance(WARN_EVERY).await;
        r.record("127.0.0.1:1", "again".into(), Instant::now());
        assert_eq!(r.unlogged, 0);
    }
}
