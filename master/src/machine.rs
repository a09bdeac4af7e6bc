//! What machine a measurement ran on (CPU model and cores available), for the titles and
//! headers of timelines, plots and study reports. Reads `/proc/cpuinfo` where there is one;
//! never fails.

/// A short description of this machine: `CPU model, N cores available`.
pub fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    format!("{cpu}, {cores} cores available")
}
