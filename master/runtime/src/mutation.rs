//! Planted bugs, for the deterministic simulation's proof that its invariants can fail: each
//! [`Mutation`] breaks one rule of the runtime on purpose, and the simulation's explorer must
//! catch it. Compiled in only with the `mutations` feature, which the test crate turns on for
//! its test builds alone (a dev-dependency, or its own `planted` feature for `sim mutants`), so
//! no `parrt` or `parrt-worker` carries it; without it [`is`] is a constant `false` and every
//! planted branch vanishes. Planted per
//! thread: the simulation runs a whole world on one thread, so parallel tests do not meet each
//! other's bugs.

/// One planted bug.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mutation {
    /// The scheduler writes a second result for a tile already done (first result no longer
    /// wins).
    AcceptDuplicates,
    /// A departed worker's tiles are forgotten instead of requeued.
    ForgetDeadWorkersTiles,
    /// A connection never judges its worker silent (the heartbeat check is skipped).
    NoHeartbeatCheck,
    /// The master gives up at once when its last worker goes, without waiting for one to
    /// come back.
    GiveUpAtOnce,
    /// Accepting a tile also marks the next tile done, unwritten.
    MarkNeighbourDone,
    /// Resuming a checkpoint takes a torn last record (cut short by a crash) as it is,
    /// without its checksum.
    TrustTornRecord,
}

impl Mutation {
    /// Every planted bug.
    pub const ALL: [Mutation; 6] = [
        Mutation::AcceptDuplicates,
        Mutation::ForgetDeadWorkersTiles,
        Mutation::NoHeartbeatCheck,
        Mutation::GiveUpAtOnce,
        Mutation::MarkNeighbourDone,
        Mutation::TrustTornRecord,
    ];
}

/// Whether this build has the planted bugs (the `mutations` feature): without them
/// [`plant`] does nothing, so a search for them can only report every one missed.
pub const COMPILED_IN: bool = cfg!(feature = "mutations");

#[cfg(feature = "mutations")]
thread_local! {
    static PLANTED: std::cell::Cell<Option<Mutation>> = const { std::cell::Cell::new(None) };
}

/// Plants `m` on this thread (`None` removes it). Does nothing without the `mutations` feature.
pub fn plant(m: Option<Mutation>) {
    #[cfg(feature = "mutations")]
    PLANTED.with(|p| p.set(m));
    #[cfg(not(feature = "mutations"))]
    let _ = m;
}

/// Whether `m` is planted on this thread.
#[inline]
pub fn is(m: Mutation) -> bool {
    #[cfg(feature = "mutations")]
    return PLANTED.with(|p| p.get()) == Some(m);
    #[cfg(not(feature = "mutations"))]
    {
        let _ = m;
        false
    }
}
