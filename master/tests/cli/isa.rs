//! The instruction-set tier on the command line: `PARRT_ISA` forces it, an unknown
//! name is refused with exit 2 before any work, and `--stats`, `--stats-json` and `info --json`
//! say which tier ran.

use super::{spd, stderr};
use std::process::Command;

fn parrt_on(tier: &str, args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_parrt"))
        .args(args)
        .env(parrt_render::isa::ENV, tier)
        .output()
        .expect("the parrt binary runs")
}

#[test]
fn an_unknown_tier_is_refused_with_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.png");
    let o = parrt_on(
        "sse5",
        &["render", &spd("tetra-4.nff"), "-o", out.to_str().unwrap()],
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("PARRT_ISA") && err.contains("sse5"), "{err}");
    assert!(err.contains("avx512") && !err.contains("panicked"), "{err}");
    assert!(!out.exists(), "no image written");
}

#[test]
fn the_forced_tier_is_reported_by_stats_and_info() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.png");
    let json = dir.path().join("stats.json");
    for tier in ["scalar", "sse2"] {
        let o = parrt_on(
            tier,
            &[
                "render",
                &spd("tetra-4.nff"),
                "--width",
                "16",
                "--height",
                "16",
                "-o",
                out.to_str().unwrap(),
                "--stats",
                "--stats-json",
                json.to_str().unwrap(),
            ],
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(
            text.lines()
                .any(|l| l.starts_with("isa") && l.trim_end().ends_with(tier)),
            "{text}"
        );
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        assert_eq!(v["isa"], tier);
        let o = parrt_on(tier, &["info", &spd("tetra-4.nff"), "--json"]);
        assert!(o.status.success(), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(v["isa"], tier);
    }
}
