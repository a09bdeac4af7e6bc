//! The `parrt` command line end to end through the real binary, one test binary with a file per
//! subject: `parrt info` (`info`), `parrt render` (`render`), `parrt scene --format pov`
//! (`pov`), the instruction-set tier (`isa`), the bench studies (`studies`), what a Rust CLI
//! user expects (`conventions`), sequences of frames (`sequence`), and careless flags and files
//! refused before any work (`careless`).

use parrt_test_support as support;

mod careless;
mod conventions;
mod files;
mod info;
mod isa;
mod pov;
mod render;
mod sequence;
mod studies;

use std::process::{Command, Output};

/// Runs the `parrt` binary with `args` to the end. (`careless` has its own, capped runner.)
fn parrt(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_parrt"))
        .args(args)
        .env_remove("PARRT_LOG")
        .output()
        .expect("the parrt binary runs")
}

/// The SPD scene file `name` (e.g. `"mount-4.nff"`), as a command-line argument.
fn spd(name: &str) -> String {
    support::spd_dir().join(name).display().to_string()
}

/// A run's stderr as text.
fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}
