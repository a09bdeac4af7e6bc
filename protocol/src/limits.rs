//! Named limits of the protocol layer: how big a frame may be in each phase, how many peers may
//! handshake at once, how many threads a worker may claim, how slowly a frame may arrive, how
//! long a duration flag may be, and how much of a peer's text (names, reasons) is ever logged
//! or kept. Everything a peer or a flag controls is checked against one of these.

use std::time::Duration;

/// The largest frame accepted before a peer has authenticated: Hello and Auth are tiny, so an
/// unauthenticated peer can never make us reserve much memory.
pub const HANDSHAKE_MAX_FRAME: usize = 64 * 1024;

/// The default largest frame accepted from an authenticated peer: 256 MiB (a large scene). Only
/// a Job needs this much (a sequence sends one a frame); see [`worker_frame_limit`] and
/// [`MASTER_FRAME_AFTER_JOB`].
pub const DEFAULT_MAX_FRAME: usize = 256 * 1024 * 1024;

/// The largest frame a master sends besides a Job: Assign, Heartbeat, Cancel, Shutdown and
/// Error are all small. (A worker still accepts its whole frame limit after the first Job: a
/// sequence sends the next frame's Job on the same connection.)
pub const MASTER_FRAME_AFTER_JOB: usize = 64 * 1024;

/// The most jobs (frames of a sequence) a worker keeps built at once: a master opens at most
/// its window of frames and cancels each as it closes; beyond this the worker drops the job it
/// received first (its tiles unanswered, which the master's deadline requeues).
pub const MAX_JOBS_HELD: usize = 16;

/// The most tiles in one AssignBatch: with ~25 bytes a tile, a batch stays far inside
/// [`MASTER_FRAME_AFTER_JOB`] whatever a master is told.
pub const MAX_BATCH: usize = 256;

/// The most bytes of pixels a worker holds for one assignment's results (sent together): 256
/// MiB, more than a full batch of the largest tiles an honest master sends (256 tiles of
/// 256² f32 pixels are 192 MiB), far less than a hostile one could ask for in one batch (32
/// tiles of 2048² f32 are 1.5 GiB).
pub const MAX_BATCH_RESULT_BYTES: usize = 256 * 1024 * 1024;

/// Bytes of a TileResult beside its pixels (ids, attempt, ray statistics, seconds, varint
/// lengths), rounded up generously.
pub const RESULT_OVERHEAD: usize = 256;

/// Longest reason (in bytes) a peer's Error or Refused carries; longer ones are cut.
pub const MAX_REASON_BYTES: usize = 1024;

/// The largest frame a worker may send once authenticated, for a job with tiles of `tile`
/// pixels a side: a TileResult of the biggest tile (12 bytes a pixel) plus its headers, or an
/// Error with a capped reason, whichever is larger.
pub fn worker_frame_limit(tile: u32) -> usize {
    let t = tile as usize;
    let result = t
        .saturating_mul(t)
        .saturating_mul(12)
        .saturating_add(RESULT_OVERHEAD);
    result.max(MAX_REASON_BYTES + RESULT_OVERHEAD)
}

/// The most render threads a worker may use (its `--threads`) or claim in its Hello; the
/// master refuses a Hello claiming more, so no peer can take every tile by lying.
pub const MAX_THREADS: u32 = 4096;

/// The most peers handshaking at once (unauthenticated), whatever the connection table's size:
/// peers that stall their handshake can hold only these slots, never an authenticated worker's.
pub const MAX_HANDSHAKING: usize = 64;

/// The most peers handshaking at once from one address.
pub const MAX_HANDSHAKING_PER_PEER: usize = 16;

/// The slowest a frame may arrive: a frame of `n` bytes must be complete within the peer
/// timeout plus `n / MIN_FRAME_RATE` seconds from its length prefix, however steadily bytes
/// trickle.
pub const MIN_FRAME_RATE: u64 = 64 * 1024;

/// Time allowed for a frame of `len` bytes beyond the peer timeout (see [`MIN_FRAME_RATE`]).
pub fn frame_allowance(len: usize) -> Duration {
    Duration::from_secs_f64(len as f64 / MIN_FRAME_RATE as f64)
}

/// The longest duration a flag may ask for: 7 days. Longer ones would overflow clocks
/// (`Instant + d`) or never end, which is never what was meant.
pub const MAX_FLAG_SECONDS: f64 = 7.0 * 86_400.0;

/// Characters of a peer's name (or other peer text) shown in a log or kept in a record.
pub const MAX_SHOWN_CHARS: usize = 64;

/// Characters of a peer's reason (a refusal, an error) shown to a user: enough for every
/// reason a parrt master gives, far under a screenful.
pub const MAX_SHOWN_REASON_CHARS: usize = 300;

/// `text` made safe to log or keep: control and non-ASCII characters escaped (as `{:?}` does,
/// without the quotes) and cut to [`MAX_SHOWN_CHARS`] characters, with `…` and the original
/// length when cut.
pub fn shown(text: &str) -> String {
    shown_within(text, MAX_SHOWN_CHARS)
}

/// A reason a peer sent (its `Refused` or `Error`), made safe to print on a user's terminal:
/// control characters escaped (so no escape sequence, link or forged log line gets through)
/// and cut to [`MAX_SHOWN_REASON_CHARS`] characters, as [`shown`] does.
pub fn shown_reason(text: &str) -> String {
    shown_within(text, MAX_SHOWN_REASON_CHARS)
}

fn shown_within(text: &str, max: usize) -> String {
    let escaped: String = text
        .chars()
        .flat_map(char::escape_debug)
        .take(max + 1)
        .collect();
    if escaped.chars().count() > max {
        let cut: String = escaped.chars().take(max).collect();
        format!("{cut}… ({} bytes)", text.len())
    } else {
        escaped
    }
}

/// `reason` cut to at most [`MAX_REASON_BYTES`] bytes (on a character boundary, `…` appended
/// when cut), for Error and Refused messages and for records of them.
pub fn capped_reason(mut reason: String) -> String {
    if reason.len() > MAX_REASON_BYTES {
        let mut end = MAX_REASON_BYTES - '…'.len_utf8();
        while !reason.is_char_boundary(end) {
            end -= 1;
        }
        reason.truncate(end);
        reason.push('…');
    }
    reason
}

/// A duration flag (`--dial-timeout`, `--heartbeat-timeout`, ...) given in seconds.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{flag} must be a number of seconds from {min} to {max}, got {value}")]
pub struct DurationError {
    /// The flag, e.g. `--dial-timeout`.
    pub flag: String,
    /// What was given.
    pub value: f64,
    /// The least allowed, in seconds.
    pub min: f64,
    /// The most allowed, in seconds ([`MAX_FLAG_SECONDS`]).
    pub max: f64,
}

/// `secs` as a duration when it is finite and within `min ..= MAX_FLAG_SECONDS` seconds.
/// `positive` additionally refuses zero (a timeout of 0 would drop every peer at once).
pub fn duration_from_secs(
    flag: &str,
    secs: f64,
    positive: bool,
) -> Result<Duration, DurationError> {
    let ok = (0.0..=MAX_FLAG_SECONDS).contains(&secs) && !(positive && secs == 0.0);
    if !ok {
        return Err(DurationError {
            flag: flag.to_string(),
            value: secs,
            min: 0.0,
            max: MAX_FLAG_SECONDS,
        });
    }
    Ok(Duration::from_secs_f64(secs))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shown_escapes_and_cuts() {
        assert_eq!(shown("host-1"), "host-1");
        assert_eq!(shown("a\nb"), "a\\nb");
        let long = "\u{1}".repeat(65_530);
        let s = shown(&long);
        assert!(s.len() < 200, "{}", s.len());
        assert!(s.ends_with("(65530 bytes)"), "{s}");
    }

    #[test]
    fn reasons_are_capped_on_a_char_boundary() {
        assert_eq!(capped_reason("short".into()), "short");
        let r = capped_reason("é".repeat(5000));
        assert!(r.len() <= MAX_REASON_BYTES && r.ends_with('…'));
    }

    #[test]
    fn durations_are_checked() {
        assert_eq!(
            duration_from_secs("--x", 1.5, true).unwrap(),
            Duration::from_millis(1500)
        );
        assert!(duration_from_secs("--x", 0.0, false).is_ok());
        for bad in [0.0, -1.0, 1e30, f64::NAN, f64::INFINITY, 1e19] {
            let e = duration_from_secs("--x", bad, true).unwrap_err();
            assert!(e.to_string().contains("--x must be"), "{e}");
        }
    }

    #[test]
    fn worker_frames_fit_the_biggest_result() {
        assert_eq!(worker_frame_limit(8), MAX_REASON_BYTES + RESULT_OVERHEAD);
        assert_eq!(worker_frame_limit(512), 512 * 512 * 12 + RESULT_OVERHEAD);
        assert!(worker_frame_limit(u32::MAX) > 0);
    }
}
