//! The `sim` binary as a careless user meets it: a seed range past the last seed, sizes that do
//! not fit in `u32`, absurd latencies and rates, unknown or misspelt flags. Each is exit 2 with
//! a message naming the flag, before anything runs; none panics or runs with an altered value.

use std::process::Command;

const SIM: &str = env!("CARGO_BIN_EXE_sim");

/// Runs `sim args`: exit code, stdout, stderr.
fn sim(args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(SIM)
        .args(args)
        .output()
        .expect("the sim binary runs");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn a_seed_range_past_the_last_seed_is_exit_2() {
    let (code, out, err) = sim(&["explore", "--seeds", "3", "--first", "18446744073709551615"]);
    assert_eq!(code, Some(2), "stdout {out:?} stderr {err:?}");
    assert_eq!(out, "");
    assert_eq!(
        err,
        "sim: --first 18446744073709551615 plus --seeds 3 passes the last seed \
         (18446744073709551615): at most 0 seeds start there\n"
    );
}

#[test]
fn out_of_range_numbers_are_exit_2_naming_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("rows.json");
    let json = json.to_str().unwrap();
    for (flag, value) in [
        ("--size", "4294967312"),
        ("--tile", "4294967312"),
        ("--latency-ms", "1e300"),
        ("--gbit", "1e-300"),
        ("--master-us-per-tile", "1e300"),
        ("--work-seconds", "inf"),
        ("--max-batch", "100000"),
    ] {
        let (code, out, err) = sim(&[
            "scale",
            "--json",
            json,
            "--replay-dir",
            dir.path().to_str().unwrap(),
            flag,
            value,
        ]);
        assert_eq!(
            code,
            Some(2),
            "{flag} {value}: stdout {out:?} stderr {err:?}"
        );
        assert!(
            err.contains(&format!("invalid value '{value}' for '{flag}")),
            "{flag} {value}: {err}"
        );
        assert!(!err.contains("panicked"), "{flag} {value}: {err}");
        assert!(!err.contains("recording"), "{flag} {value} ran: {err}");
    }
    assert!(!std::path::Path::new(json).exists());
}

#[test]
fn unknown_and_misspelt_flags_are_exit_2() {
    for args in [
        &["scale", "--json", "x.json", "--bogus-flag", "7"][..],
        &["scale", "--json", "x.json", "--frame", "24"],
        &["explore", "--seeds", "1", "--seed", "4"],
        &["replay", "4", "--fast"],
    ] {
        let (code, out, err) = sim(args);
        assert_eq!(code, Some(2), "{args:?}: stdout {out:?} stderr {err:?}");
        assert!(err.contains("unexpected argument '"), "{args:?}: {err}");
    }
}
