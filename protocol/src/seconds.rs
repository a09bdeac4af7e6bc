//! Durations written for people: `120 s`, `2.5 s`, `0.3 s` — never `120.002006428s` (a
//! `Duration`'s `Debug`). Every message that names a wait, a deadline or a time spent uses
//! [`seconds`], on the master, the worker and the command line alike.

use std::time::Duration;

/// A duration for people: seconds with at most one decimal (`120 s`, `2.5 s`, `0.3 s`); under
/// 0.05 s, milliseconds (`20 ms`), so a short limit does not read as `0 s`.
pub fn seconds(d: Duration) -> String {
    let s = d.as_secs_f64();
    if s > 0.0 && s < 0.05 {
        let ms = (s * 1e4).round() / 10.0;
        return if ms == ms.trunc() {
            format!("{ms:.0} ms")
        } else {
            format!("{ms:.1} ms")
        };
    }
    let r = (s * 10.0).round() / 10.0;
    if r == r.trunc() {
        format!("{r:.0} s")
    } else {
        format!("{r:.1} s")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_seconds_tenths_and_milliseconds() {
        assert_eq!(seconds(Duration::from_nanos(120_002_006_428)), "120 s");
        assert_eq!(seconds(Duration::from_millis(2_460)), "2.5 s");
        assert_eq!(seconds(Duration::from_millis(300)), "0.3 s");
        assert_eq!(seconds(Duration::from_millis(20)), "20 ms");
        assert_eq!(seconds(Duration::from_micros(1_250)), "1.3 ms");
        assert_eq!(seconds(Duration::ZERO), "0 s");
    }
}
