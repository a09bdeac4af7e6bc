//! A seed replays to the same trace in a new process: `sim replay` run twice, as two separate
//! processes, on seeds whose master crashes and whose checkpoint is torn (the seeds where
//! something outside the seed once entered the trace: a temporary path, the process's
//! randomness), must print the same trace hash, event count and virtual time.

use parrt_tests::sim::plan::{Fault, Plan};
use std::process::Command;

const SIM: &str = env!("CARGO_BIN_EXE_sim");

/// `sim replay seed`'s summary: its `ended:` line and its `trace` line.
fn replay(seed: u64) -> (String, String) {
    let out = Command::new(SIM)
        .args(["replay", &seed.to_string()])
        .env_remove("PARRT_SIM_LOG")
        .output()
        .expect("the sim binary runs");
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    let line = |prefix: &str| {
        text.lines()
            .find(|l| l.starts_with(prefix))
            .unwrap_or_else(|| panic!("seed {seed}: no {prefix:?} line in {text:?}"))
            .to_string()
    };
    (line("ended: "), line("trace "))
}

#[test]
fn seeds_with_a_torn_checkpoint_replay_alike_in_separate_processes() {
    let torn = |s: &u64| {
        Plan::draw(*s)
            .faults
            .iter()
            .any(|(_, f)| matches!(f, Fault::MasterCrash { torn, .. } if *torn > 0))
    };
    // The seeds the hostile round found, and the next few of their kind.
    let mut seeds = vec![1005, 1007, 307_855_734];
    seeds.extend((1030..2000).filter(torn).take(3));
    for &s in &seeds {
        assert!(torn(&s), "seed {s} tears no checkpoint");
    }
    for seed in seeds {
        let (a, b) = (replay(seed), replay(seed));
        assert_eq!(a, b, "seed {seed}: two processes, two traces");
    }
}
