//! The deterministic simulation in the test suite: a few hundred seeded fault schedules run
//! against the real master runtime and worker sessions (turmoil, virtual time), every
//! invariant held; a seed replays to the same trace; and the invariants can fail.

use parrt_tests::sim::plan::{Fault, Plan};
use parrt_tests::sim::run_seed;

#[test]
fn three_hundred_seeds_keep_every_invariant() {
    let mut failed = Vec::new();
    let mut faults = 0;
    for seed in 0..300 {
        faults += Plan::draw(seed).faults.len();
        let o = run_seed(seed);
        if !o.failures.is_empty() {
            failed.push(format!("seed {seed}: {:?}", o.failures));
        }
    }
    assert!(faults > 300, "the seeds drew faults: {faults}");
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

#[test]
fn a_seed_replays_to_the_same_trace() {
    // Seeds with a master crash, a hostile peer and a held link among them.
    let seeds: Vec<u64> = (0..400)
        .filter(|&s| {
            Plan::draw(s).faults.iter().any(|(_, f)| {
                matches!(
                    f,
                    Fault::MasterCrash { .. } | Fault::Hold { .. } | Fault::Hostile(_)
                )
            })
        })
        .take(5)
        .collect();
    assert_eq!(seeds.len(), 5);
    for seed in seeds {
        let (a, b) = (run_seed(seed), run_seed(seed));
        assert_eq!(a.trace, b.trace, "seed {seed}");
        assert_eq!(a.events, b.events, "seed {seed}");
        assert!(a.events > 20, "seed {seed} traced {} events", a.events);
    }
    assert_ne!(run_seed(1).trace, run_seed(2).trace);
}

#[test]
fn a_master_killed_mid_render_resumes_from_its_checkpoint() {
    let seed = (0..2_000)
        .find(|&s| {
            let p = Plan::draw(s);
            p.faults.len() == 1
                && matches!(p.faults[0], (at, Fault::MasterCrash { .. }) if at.as_millis() < 300)
        })
        .expect("a seed whose only fault kills the master early");
    let o = run_seed(seed);
    assert!(o.failures.is_empty(), "seed {seed}: {:?}", o.failures);
    assert_eq!(o.ended, "complete");
}

#[test]
fn every_planted_bug_is_caught() {
    use parrt_runtime::mutation::Mutation;
    use parrt_tests::sim::run_seed_with;
    for m in Mutation::ALL {
        let caught = (0..400).find(|&seed| !run_seed_with(seed, Some(m)).failures.is_empty());
        assert!(caught.is_some(), "{m:?} was not caught in 400 seeds");
    }
    // And nothing stays planted: the same seeds pass without it.
    assert!(run_seed(0).failures.is_empty());
}
