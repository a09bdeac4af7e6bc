//! Running the same work on each tier this CPU has, one tier at a time.

use parrt_render::film::Film;
use parrt_render::isa::{self, Isa};
use parrt_render::stats::RayStats;
use std::sync::Mutex;

/// Held by every test of this binary while it switches tiers: the tier is process-wide.
pub static LOCK: Mutex<()> = Mutex::new(());

/// The tiers this CPU runs, narrowest (`scalar`) first; on x86-64 at least `scalar` and `sse2`,
/// so no comparison is vacuous.
pub fn tiers() -> Vec<Isa> {
    let tiers = Isa::supported_tiers();
    assert_eq!(tiers[0], Isa::Scalar);
    #[cfg(target_arch = "x86_64")]
    assert!(tiers.len() >= 2, "x86-64 runs scalar and sse2 at least");
    tiers
}

/// `f` run once on each tier (with the tier forced for the whole process), under [`LOCK`].
pub fn on_each_tier<T>(mut f: impl FnMut(Isa) -> T) -> Vec<(Isa, T)> {
    let _held = LOCK.lock().unwrap_or_else(|e| e.into_inner());
    let before = isa::current();
    let out = tiers()
        .into_iter()
        .map(|t| {
            isa::force(t).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(isa::current(), t);
            (t, f(t))
        })
        .collect();
    isa::force(before).expect("the tier chosen at start runs here");
    out
}

/// What one tier rendered: the film, its ray statistics and its 8-bit bytes.
pub type Rendered = (Film, RayStats, Vec<u8>);

/// Asserts every tier's film and statistics equal the `scalar` tier's, bit for bit, and that
/// the 8-bit conversion of each film gives the same bytes.
pub fn assert_same_on_every_tier(what: &str, runs: &[(Isa, Rendered)]) {
    let (_, (want, want_stats, want_bytes)) = &runs[0];
    for (tier, (film, stats, bytes)) in &runs[1..] {
        crate::support::film::assert_same_bits(film, want, &format!("{what} on {tier}"));
        assert_eq!(stats, want_stats, "{what}: ray statistics on {tier}");
        assert!(bytes == want_bytes, "{what}: 8-bit bytes on {tier}");
    }
}

/// The 8-bit bytes of `film` by [`parrt_render::film::to_u8_into`] on the current tier.
pub fn bytes(film: &Film) -> Vec<u8> {
    let values: Vec<f32> = film.pixels.iter().flatten().copied().collect();
    let mut out = vec![0; values.len()];
    parrt_render::film::to_u8_into(&mut out, &values);
    out
}
