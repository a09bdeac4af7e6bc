//! Build script of both binaries' packages (`parrt-master`, and `parrt-worker` through its
//! manifest's `build = "../master/build.rs"`): records what build this is for `--version` — the
//! git commit (when the source is a git checkout and `git` runs; never an error outside one),
//! the cargo profile and the target triple — as compile-time environment variables that
//! `parrt_render::build_info!` reads in the package being built.

use std::path::PathBuf;
use std::process::Command;

/// `git ARGS` in this package's directory, trimmed; `None` when git is missing or fails.
fn git(args: &[&str]) -> Option<String> {
    let out = Command::new("git")
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    let s = String::from_utf8(out.stdout).ok()?.trim().to_string();
    (!s.is_empty()).then_some(s)
}

fn main() {
    let commit = git(&["rev-parse", "--short=10", "HEAD"]).unwrap_or_default();
    println!("cargo:rustc-env=PARRT_BUILD_COMMIT={commit}");
    // Rebuild when the checked-out commit moves: HEAD, the branch it names, and packed refs.
    // Only files that exist: cargo reruns a build script on every build while a path it
    // watches is missing (a repository without packed-refs has none).
    let mut watched = vec!["HEAD".to_string(), "packed-refs".to_string()];
    watched.extend(git(&["symbolic-ref", "-q", "HEAD"]));
    for name in watched {
        if let Some(p) = git(&["rev-parse", "--git-path", &name]).map(abs) {
            if p.exists() {
                println!("cargo:rerun-if-changed={}", p.display());
            }
        }
    }
    // This file, by a path that exists from both packages: a bare "build.rs" is missing in
    // worker/, and a missing watched path reruns the script (and rebuilds the worker) every time.
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../master/build.rs");
    println!("cargo:rerun-if-changed={}", script.display());
    let profile = std::env::var("PROFILE").unwrap_or_default();
    println!("cargo:rustc-env=PARRT_BUILD_PROFILE={profile}");
    let target = std::env::var("TARGET").unwrap_or_default();
    println!("cargo:rustc-env=PARRT_BUILD_TARGET={target}");
}

/// git prints paths relative to the directory it ran in.
fn abs(p: String) -> PathBuf {
    let p = PathBuf::from(p);
    if p.is_absolute() {
        p
    } else {
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(p)
    }
}
