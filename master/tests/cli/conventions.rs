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
    assert_eq!(v, format!("parrt {}\n", parrt_render::version_text!()));
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
        "--factor",
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
    let o = parrt(&["scene", "mount", "--factor", "1"]);
    assert!(o.status.success());
    assert!(stderr(&o).is_empty(), "{}", stderr(&o));
}

/// `parrt scene mount | head -1`: the reader goes after one line; parrt ends quietly, exit 0,
/// as Unix filters do, not "Broken pipe" and exit 1.
#[test]
fn a_closed_pipe_ends_the_output_quietly() {
    use std::io::{BufRead, BufReader};
    use std::process::{Command, Stdio};
    for args in [&["scene", "mount"][..], &["man"]] {
        let mut child = Command::new(env!("CARGO_BIN_EXE_parrt"))
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("parrt starts");
        let mut line = String::new();
        BufReader::new(child.stdout.take().expect("stdout"))
            .read_line(&mut line)
            .expect("a first line");
        // The reader is dropped here, as `head -1` exits.
        let o = child.wait_with_output().expect("parrt ends");
        assert!(!line.is_empty(), "{args:?}");
        assert_eq!(o.status.code(), Some(0), "{args:?}: {}", stderr(&o));
        assert_eq!(stderr(&o), "", "{args:?}");
    }
}

/// A timeline that is not there is bad input, as a missing scene is: exit 2, naming it.
#[test]
fn plot_timeline_of_a_missing_file_exits_2() {
    let dir = tempfile::tempdir().expect("temp dir");
    let missing = dir.path().join("nosuch.csv");
    let out = dir.path().join("t.svg");
    let o = parrt(&[
        "plot-timeline",
        &missing.display().to_string(),
        "-o",
        &out.display().to_string(),
    ]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(
        err,
        format!(
            "parrt: cannot read {}: No such file or directory (os error 2)\n",
            missing.display()
        )
    );
    assert!(!out.exists());
}

/// From the workspace root, `cargo run --release -- render` runs `parrt` (the one package with
/// a `default-run`), and a plain `cargo build` builds what users run, not the test crate.
#[test]
fn cargo_run_from_the_root_runs_parrt_and_build_skips_the_test_crate() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
    let manifest = |p: &str| std::fs::read_to_string(format!("{root}/{p}")).expect(p);
    let master = manifest("master/Cargo.toml");
    assert!(
        master
            .lines()
            .any(|l| l.trim() == r#"default-run = "parrt""#),
        "master/Cargo.toml has no default-run"
    );
    let workspace = manifest("Cargo.toml");
    let line = workspace
        .lines()
        .find(|l| l.starts_with("default-members"))
        .expect("the workspace names its default members");
    for m in [
        "\"render\"",
        "\"protocol\"",
        "\"master\"",
        "\"worker\"",
        "\"scenes\"",
    ] {
        assert!(line.contains(m), "{line}");
    }
    assert!(!line.contains("\"tests\""), "{line}");
}

/// `--size` is an image's size in pixels wherever it is taken: `render --size WxH` is
/// `--width W --height H` (here written as a binary PPM, `P6`, which every PPM reader takes);
/// `scene`, whose size is a factor, refuses it and says what to give instead.
#[test]
fn size_means_pixels_everywhere_and_scene_says_to_use_factor() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("x.ppm");
    let o = parrt(&[
        "render",
        "--scene",
        "balls:1",
        "--size",
        "16x8",
        "-o",
        &out.display().to_string(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let ppm = std::fs::read(&out).expect("the image");
    assert!(ppm.starts_with(b"P6\n16 8 255\n"), "{:?}", &ppm[..16]);
    assert_eq!(ppm.len(), b"P6\n16 8 255\n".len() + 16 * 8 * 3);
    let o = parrt(&["render", "--size", "16x8", "--width", "4"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(!stderr(&o).contains("-- --size"), "{}", stderr(&o));
    let o = parrt(&["render", "--scene", "balls:1", "--size", "16y8"]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(
        stderr(&o),
        "parrt: --size 16y8: expected WxH or N (pixels), e.g. 256x256\n"
    );
    let o = parrt(&["scene", "mount", "--size", "1"]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(
        stderr(&o),
        "parrt: parrt scene takes no --size (an image's size in pixels elsewhere): give the \
         generator's size factor as --factor 1 (or -s 1)\n"
    );
    assert!(o.stdout.is_empty());
}

/// `parrt man --dir` never writes through a symbolic link at a page's name (its target is left
/// alone) nor opens a FIFO there (which would block for ever): exit 2 naming the path. An
/// earlier page, a regular file, is replaced. parrt(1) has the sections a reader looks for.
#[test]
fn man_dir_refuses_a_link_or_a_fifo_at_a_pages_name() {
    let dir = tempfile::tempdir().expect("temp dir");
    let pages = dir.path().join("man1");
    std::fs::create_dir(&pages).unwrap();
    let target = dir.path().join("precious");
    std::fs::write(&target, b"keep me").unwrap();
    let link = pages.join("parrt-render.1");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let o = parrt(&["man", "--dir", &pages.display().to_string()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(
        stderr(&o),
        format!(
            "parrt: {}: is a symbolic link, not a regular file (links are not followed)\n",
            link.display()
        )
    );
    assert_eq!(std::fs::read(&target).unwrap(), b"keep me");
    std::fs::remove_file(&link).unwrap();
    let fifo = pages.join("parrt-man.1");
    let c = std::ffi::CString::new(fifo.display().to_string()).unwrap();
    // SAFETY: mkfifo on a NUL-terminated path this test owns.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    let o = parrt(&["man", "--dir", &pages.display().to_string()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert_eq!(
        stderr(&o),
        format!("parrt: {}: is a FIFO, not a regular file\n", fifo.display())
    );
    std::fs::remove_file(&fifo).unwrap();
    std::fs::write(pages.join("parrt.1"), b"an old page").unwrap();
    let o = parrt(&["man", "--dir", &pages.display().to_string()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let top = std::fs::read_to_string(pages.join("parrt.1")).unwrap();
    for section in [".SH EXAMPLES", ".SH EXIT STATUS", ".SH ENVIRONMENT"] {
        assert!(top.contains(section), "parrt.1 lacks {section}");
    }
    for var in ["PARRT_ISA", "PARRT_LOG", "PARRT_TOKEN", "XDG_RUNTIME_DIR"] {
        assert!(top.contains(var), "parrt.1 lacks {var}");
    }
    assert!(top.contains("\\fB130\\fR"), "exit status 130 is listed");
}
