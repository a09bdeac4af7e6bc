//! What a Rust CLI user expects of `parrt`: `--help` and the README list every
//! command, `--version` names the build, completions and a man page come from the clap
//! definitions, and every command that writes a file says so.

use super::{parrt, stderr};

/// The subcommands as the binary's `--help` lists them (the lines under "Commands:").
fn listed_commands() -> Vec<String> {
    let o = parrt(&["--help"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let help = String::from_utf8_lossy(&o.stdout).into_owned();
    let after = help.split("Commands:").nth(1).expect("a Commands: section");
    let section = after.split("Options:").next().unwrap_or(after);
    section
        .lines()
        .filter(|l| l.starts_with("  ") && !l.starts_with("   "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|&c| c != "help")
        .map(str::to_string)
        .collect()
}

#[test]
fn help_and_readme_list_every_command() {
    let commands = listed_commands();
    for c in ["render", "cluster", "plot-timeline", "completions", "man"] {
        assert!(
            commands.iter().any(|x| x == c),
            "--help lacks {c}: {commands:?}"
        );
    }
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../README.md"))
        .expect("README.md beside the workspace");
    let map_row = readme
        .lines()
        .find(|l| l.starts_with("| `master/`"))
        .expect("the crate map's master row");
    for c in &commands {
        assert!(
            map_row.contains(&format!("`{c}`")),
            "the README's crate map lacks `{c}`"
        );
    }
    let o = parrt(&["--help"]);
    let about = String::from_utf8_lossy(&o.stdout);
    assert!(
        !about.contains("(render, info, scene, master, worker, bench)"),
        "{about}"
    );
}

#[test]
fn version_names_the_build() {
    let o = parrt(&["--version"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v = String::from_utf8_lossy(&o.stdout).into_owned();
    // The text parrt-worker prints too (worker/tests/version.rs), from this package's build.
    assert_eq!(v, format!("parrt {}\n", parrt::version_text!()));
    assert!(
        v.starts_with(&format!("parrt {} (", env!("CARGO_PKG_VERSION"))),
        "{v}"
    );
    assert!(v.contains("commit "), "{v}");
    assert!(v.contains(" build, "), "{v}");
    assert!(v.contains(std::env::consts::ARCH), "{v}");
    assert!(v.contains(", tier "), "{v}");
}

#[test]
fn completions_for_each_shell_and_a_refusal_for_others() {
    for shell in ["bash", "zsh", "fish", "elvish", "powershell"] {
        let o = parrt(&["completions", shell]);
        assert!(o.status.success(), "{shell}: {}", stderr(&o));
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(text.contains("plot-timeline"), "{shell}: {text}");
        assert!(
            text.contains("http-linger"),
            "{shell} completes render's flags"
        );
    }
    let o = parrt(&["completions", "tcsh"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("tcsh"), "{}", stderr(&o));
}

#[test]
fn man_page_to_stdout_and_a_page_per_command() {
    let o = parrt(&["man"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let page = String::from_utf8_lossy(&o.stdout);
    assert!(page.contains(".TH parrt 1"), "{page}");
    assert!(page.contains("plot\\-timeline"), "{page}");
    let dir = tempfile::tempdir().expect("temp dir");
    let o = parrt(&["man", "--dir", &dir.path().display().to_string()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.path().join("parrt-render.1").is_file());
    assert!(stderr(&o).starts_with("parrt: wrote "), "{}", stderr(&o));
}

#[test]
fn scene_says_what_it_wrote() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("mount-3.nff");
    let o = parrt(&[
        "scene",
        "mount",
        "--size",
        "3",
        "-o",
        &out.display().to_string(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.starts_with(&format!("parrt: wrote {}", out.display())),
        "a success line like render's: {err}"
    );
    assert!(err.contains("primitives"), "{err}");
    // To stdout, the NFF alone: no line mixed into it.
    let o = parrt(&["scene", "mount", "--size", "1"]);
    assert!(o.status.success());
    assert!(stderr(&o).is_empty(), "{}", stderr(&o));
}
