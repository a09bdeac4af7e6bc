//! Duration flags (`--wait-workers`, `--tile-deadline`, `--heartbeat-timeout`, ...): one parser
//! that turns a number of seconds from the command line into a [`Duration`] within a sane range
//! per flag, or a bad-input error (exit 2) naming the flag — never a panic or an `Instant`
//! overflow. The ceiling is the protocol's ([`parrt_protocol::limits::MAX_FLAG_SECONDS`]), the
//! one the worker's `--dial-timeout` is held to; this adds a floor per flag.

use super::ArgError;
use parrt_runtime::options::DEFAULT_HEARTBEAT;
use std::time::Duration;

/// The longest any duration flag may be: one week. Far beyond any sensible wait, and small
/// enough that `Instant::now() + d` can never overflow.
pub const MAX_FLAG_DURATION: Duration =
    Duration::from_secs(parrt_protocol::limits::MAX_FLAG_SECONDS as u64);

/// The shortest `--heartbeat-timeout`: two heartbeats ([`DEFAULT_HEARTBEAT`]), so one late
/// heartbeat drops no worker.
pub const MIN_HEARTBEAT_TIMEOUT: Duration = Duration::from_secs(2 * DEFAULT_HEARTBEAT.as_secs());

/// The shortest `--tile-deadline`: below it every tile would be overdue before it is rendered.
pub const MIN_TILE_DEADLINE: Duration = Duration::from_secs(1);

/// Parses `v` seconds for `flag`: finite, within `min..=max`, else a bad-input error that names
/// the flag, the value and the allowed range.
pub fn seconds_flag(flag: &str, v: f64, min: Duration, max: Duration) -> anyhow::Result<Duration> {
    let (lo, hi) = (min.as_secs_f64(), max.as_secs_f64());
    if v.is_finite() && v >= lo && v <= hi {
        // In range, so the conversion cannot panic.
        Ok(Duration::from_secs_f64(v).clamp(min, max))
    } else {
        Err(ArgError::Value(format!(
            "{flag} {v:?} is not a number of seconds in {lo}..={hi}"
        ))
        .into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn accepts_the_range_and_refuses_the_rest() {
        let max = MAX_FLAG_DURATION;
        assert_eq!(
            seconds_flag("--x", 2.5, Duration::ZERO, max).unwrap(),
            Duration::from_millis(2500)
        );
        assert_eq!(
            seconds_flag("--x", 604800.0, Duration::ZERO, max).unwrap(),
            max
        );
        for bad in [f64::NAN, f64::INFINITY, -1.0, 1e30, 1e19, 604800.5] {
            let e = seconds_flag("--x", bad, Duration::ZERO, max).unwrap_err();
            assert!(e.to_string().contains("--x"), "{e}");
            assert!(super::ArgError::is_in(&e), "{e}");
        }
        assert!(seconds_flag("--x", 1.0, MIN_HEARTBEAT_TIMEOUT, max).is_err());
    }
}
