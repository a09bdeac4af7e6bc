//! The clock seam. Wall time is tokio's clock everywhere in the runtime (`tokio::time`), which
//! tests pause and the deterministic simulation runs virtually; what tokio cannot fake is the
//! CPU a master spends, so that comes from a [`Clock`]: the process's CPU clock for real runs,
//! a charged, virtual one under simulation.

use std::sync::Arc;

/// Where the master reads the CPU seconds it has used.
pub trait Clock: Send + Sync {
    /// CPU seconds used so far (NaN where unknown).
    fn cpu_s(&self) -> f64;
}

/// The operating system's clock: this process's CPU time, all threads.
#[derive(Clone, Copy, Debug, Default)]
pub struct SystemClock;

impl Clock for SystemClock {
    fn cpu_s(&self) -> f64 {
        crate::cpu_time::process_cpu_s()
    }
}

/// A shared clock.
pub type SharedClock = Arc<dyn Clock>;

/// The clock of real runs.
pub fn system() -> SharedClock {
    Arc::new(SystemClock)
}
