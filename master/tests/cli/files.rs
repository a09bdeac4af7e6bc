//! Files, flags and limits through the real `parrt` binary: outputs that are one file with each
//! other or with the scene, the cap on local workers, images past `--max-pixels` in every
//! bench, a closed stdout and stderr, and a master told to stop while it starts its workers. Runs
//! are capped in memory and time by `careless`'s runner, so a regression fails instead of hanging.

use crate::careless::parrt as capped;
use crate::stderr;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn path(p: &Path) -> &str {
    p.to_str().expect("UTF-8 temp path")
}

/// A small scene file.
fn scene(dir: &Path) -> std::path::PathBuf {
    let f = dir.join("scene.nff");
    std::fs::write(
        &f,
        "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0.01 resolution 16 16\n\
         l 5 5 5\nf 1 0 0 1 0 0 0 0\ns 0 0 0 1\n",
    )
    .unwrap();
    f
}

/// Exit 2, no panic, a message naming both flags.
fn same_file(args: &[&str], first: &str, second: &str) {
    let o = capped(args);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "parrt {args:?}: {err}");
    assert!(
        err.contains(first) && err.contains(second) && err.contains("are the same file"),
        "parrt {args:?}: {err}"
    );
}

#[test]
fn outputs_that_are_one_file_with_each_other_or_the_scene_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let nff = scene(dir.path());
    let before = std::fs::read(&nff).unwrap();
    let out = dir.path().join("out.png");
    let o = path(&out);
    // The scene overwritten by an output, named otherwise.
    let dotted = format!("{}/./scene.nff", path(dir.path()));
    for flag in ["--timeline", "--stats-json", "--tile-costs"] {
        same_file(
            &["render", path(&nff), "-o", o, flag, &dotted],
            "the scene",
            flag,
        );
    }
    same_file(
        &[
            "master",
            path(&nff),
            "--token",
            "t",
            "--listen",
            "127.0.0.1:0",
            "--report-json",
            &dotted,
        ],
        "the scene",
        "--report-json",
    );
    assert_eq!(
        std::fs::read(&nff).unwrap(),
        before,
        "the scene was written"
    );
    // Two outputs on one file, and JSON into the image.
    let json = dir.path().join("a.json");
    let json_dotted = format!("{}/./a.json", path(dir.path()));
    same_file(
        &[
            "render",
            path(&nff),
            "-o",
            o,
            "--stats-json",
            path(&json),
            "--timeline",
            &json_dotted,
        ],
        "--stats-json",
        "--timeline",
    );
    same_file(
        &[
            "render",
            path(&nff),
            "-o",
            o,
            "--stats-json",
            &format!("{}/./out.png", path(dir.path())),
        ],
        "-o",
        "--stats-json",
    );
    // An existing image reached through a link is the same file.
    std::fs::write(&out, b"an earlier image").unwrap();
    let link = dir.path().join("link.png");
    std::os::unix::fs::symlink(&out, &link).unwrap();
    same_file(
        &["render", path(&nff), "-o", o, "--tile-costs", path(&link)],
        "-o",
        "--tile-costs",
    );
    assert!(!dir.path().join("out.png.tmp").exists());
    // `--checkpoint ./out.png -o out.png`, in the working directory.
    let o = Command::new(env!("CARGO_BIN_EXE_parrt"))
        .current_dir(dir.path())
        .args([
            "render",
            "scene.nff",
            "--workers",
            "1",
            "--checkpoint",
            "./out.png",
        ])
        .args(["-o", "out.png"])
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--checkpoint ./out.png") && err.contains("-o out.png"),
        "{err}"
    );
    assert_eq!(std::fs::read(&out).unwrap(), b"an earlier image");
}

#[test]
fn every_bench_refuses_an_image_past_max_pixels_and_render_caps_its_workers() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("b");
    let d = path(&out);
    let over = "65536x65536 is 4294967296 pixels, over the limit of 268435456 (raise it with --max-pixels)";
    for args in [
        vec!["bench", "cluster", "balls:1", "--size", "65536", "--out", d],
        vec![
            "bench",
            "efficiency",
            "balls:1",
            "--sizes",
            "65536",
            "--out",
            d,
        ],
        vec![
            "bench",
            "accuracy",
            "balls:1",
            "--size",
            "65536x65536",
            "--out",
            d,
        ],
        vec![
            "bench",
            "precision",
            "balls:1",
            "--size",
            "65536x65536",
            "--out",
            d,
        ],
        vec!["bench", "cast", "balls:1", "--size", "65536"],
    ] {
        let o = capped(&args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "parrt {args:?}: {err}");
        assert!(err.contains(over), "parrt {args:?}: {err}");
    }
    for args in [
        vec![
            "render",
            "--scene",
            "balls:1",
            "--workers",
            "100000",
            "-o",
            "x.png",
        ],
        vec![
            "bench",
            "cluster",
            "balls:1",
            "--workers",
            "100000",
            "--out",
            d,
        ],
    ] {
        let o = capped(&args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "parrt {args:?}: {err}");
        assert!(err.contains("1024"), "parrt {args:?}: {err}");
    }
}

/// A pipe whose reading end is closed: every write to it fails with EPIPE.
fn broken_pipe() -> std::os::fd::OwnedFd {
    use std::os::fd::FromRawFd;
    let mut fds = [0; 2];
    // SAFETY: pipe fills two descriptors, each then owned exactly once.
    unsafe {
        assert_eq!(libc::pipe(fds.as_mut_ptr()), 0);
        libc::close(fds[0]);
        std::os::fd::OwnedFd::from_raw_fd(fds[1])
    }
}

/// `parrt … 2>&1 | true`. Nothing can be shown, but the render is written and
/// the exit status is the render's (it was a panic, 101, and no image).
#[test]
fn a_closed_stdout_and_stderr_do_not_stop_the_render() {
    let dir = tempfile::tempdir().unwrap();
    let nff = scene(dir.path());
    for (name, extra) in [
        ("smp.png", vec!["--stats"]),
        ("dist.png", vec!["--stats", "--workers", "1"]),
        // The live view's last words ("stays up 1 s more") come after the image is written.
        (
            "live.png",
            vec!["--http", "127.0.0.1:0", "--http-linger", "1"],
        ),
    ] {
        let out = dir.path().join(name);
        let pipe = broken_pipe();
        let o = Command::new(env!("CARGO_BIN_EXE_parrt"))
            .args(["render", path(&nff), "-o", path(&out)])
            .args(&extra)
            .env("RUST_BACKTRACE", "0")
            .stdin(Stdio::null())
            .stdout(Stdio::from(pipe.try_clone().unwrap()))
            .stderr(Stdio::from(pipe))
            .status()
            .unwrap();
        assert_eq!(o.code(), Some(0), "{name}");
        assert!(out.exists(), "{name} not written");
    }
    let pipe = broken_pipe();
    let o = Command::new(env!("CARGO_BIN_EXE_parrt"))
        .args(["render", "/nonexistent.nff"])
        .stderr(Stdio::from(pipe))
        .status()
        .unwrap();
    assert_eq!(o.code(), Some(2), "bad input stays exit 2");
}

/// Processes alive (not zombies) whose environment holds `marker`.
fn alive_with(marker: &str) -> Vec<u32> {
    let needle = marker.as_bytes();
    let mut pids = Vec::new();
    for e in std::fs::read_dir("/proc").unwrap().flatten() {
        let Some(pid) = e.file_name().to_str().and_then(|s| s.parse::<u32>().ok()) else {
            continue;
        };
        let Ok(env) = std::fs::read(e.path().join("environ")) else {
            continue;
        };
        if !env.windows(needle.len()).any(|w| w == needle) {
            continue;
        }
        let stat = std::fs::read_to_string(e.path().join("stat")).unwrap_or_default();
        let state = stat
            .rsplit(')')
            .next()
            .unwrap_or("")
            .trim_start()
            .chars()
            .next();
        if state != Some('Z') && state.is_some() {
            pids.push(pid);
        }
    }
    pids
}

/// Children of `pid`, from /proc.
fn children_of(pid: u32) -> usize {
    let mut n = 0;
    for e in std::fs::read_dir("/proc").unwrap().flatten() {
        let stat = std::fs::read_to_string(e.path().join("stat")).unwrap_or_default();
        let after = stat.rsplit(')').next().unwrap_or("");
        if after.split_whitespace().nth(1) == Some(&pid.to_string()) {
            n += 1;
        }
    }
    n
}

/// SIGTERM or SIGINT while `render --workers` is still starting its workers
/// stops it, and none of the workers started is left running.
#[test]
fn a_signal_while_spawning_leaves_no_worker_behind() {
    let dir = tempfile::tempdir().unwrap();
    let nff = scene(dir.path());
    for sig in [libc::SIGTERM, libc::SIGINT] {
        let marker = format!("PARRT_TEST_SPAWN_MARK={}-{sig}", std::process::id());
        let (k, v) = marker.split_once('=').unwrap();
        let mut master = Command::new(env!("CARGO_BIN_EXE_parrt"))
            .args(["render", path(&nff), "--workers", "300", "-o"])
            .arg(dir.path().join("never.png"))
            .env(k, v)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let t0 = Instant::now();
        while children_of(master.id()) < 3 {
            assert!(t0.elapsed() < Duration::from_secs(60), "no worker started");
            if master.try_wait().unwrap().is_some() {
                break;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        // SAFETY: kill with a signal to a child this test started and has not reaped.
        unsafe { libc::kill(master.id() as libc::pid_t, sig) };
        let status = loop {
            if let Some(status) = master.try_wait().unwrap() {
                break status;
            }
            if t0.elapsed() > Duration::from_secs(60) {
                let _ = master.kill();
                panic!("signal {sig} did not stop a spawning master");
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        // 128 + the signal, as an SMP render killed by it.
        assert_eq!(status.code(), Some(128 + sig), "signal {sig}");
        // The workers dial for 30 s on their own; give the killed ones a moment to go.
        let t1 = Instant::now();
        let mut left = alive_with(&marker);
        while !left.is_empty() && t1.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(50));
            left = alive_with(&marker);
        }
        assert!(
            left.is_empty(),
            "signal {sig}: workers left running: {left:?}"
        );
    }
}

/// The inputs a command reads (the handout order, the token file, the scene, the checkpoint)
/// are files its outputs must not overwrite either: exit 2 naming both flags, the input kept.
#[test]
fn an_output_onto_one_of_the_inputs_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let nff = scene(dir.path());
    let costs = dir.path().join("costs.csv");
    std::fs::write(&costs, "tile,x,y,w,h,seconds\n").unwrap();
    let token = dir.path().join("tok");
    std::fs::write(&token, "a-token-of-some-length\n").unwrap();
    let master = |extra: &[&str]| {
        let mut a = vec![
            "master",
            path(&nff),
            "--listen",
            "127.0.0.1:0",
            "--wait-workers",
            "0",
        ];
        a.extend_from_slice(extra);
        a.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let run = |args: Vec<String>| {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        same_file_named(&args)
    };
    for out in ["--timeline", "--report-json"] {
        let (code, err) = run(master(&[
            "--token",
            "t",
            "--costly-first",
            path(&costs),
            out,
            path(&costs),
        ]));
        assert_eq!(code, Some(2), "{err}");
        assert!(
            err.contains("--costly-first") && err.contains(out) && err.contains("same file"),
            "{err}"
        );
    }
    let (code, err) = run(master(&[
        "--token-file",
        path(&token),
        "--timeline",
        path(&token),
    ]));
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("--token-file") && err.contains("--timeline") && err.contains("same file"),
        "{err}"
    );
    // `cluster`'s master rank, as a launcher starts it.
    let o = Command::new(env!("CARGO_BIN_EXE_parrt"))
        .current_dir(dir.path())
        .env("SLURM_PROCID", "0")
        .env("SLURM_NTASKS", "2")
        .args(["cluster", path(&nff), "--costly-first", path(&costs)])
        .args(["--timeline", path(&costs), "--rendezvous-timeout", "0"])
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--costly-first") && err.contains("--timeline") && err.contains("same file"),
        "{err}"
    );
    assert_eq!(
        std::fs::read(&costs).unwrap(),
        b"tile,x,y,w,h,seconds\n",
        "an input was written"
    );
    assert_eq!(
        std::fs::read(&token).unwrap(),
        b"a-token-of-some-length\n",
        "the token file was written"
    );
}

/// A capped run's exit code and stderr.
fn same_file_named(args: &[&str]) -> (Option<i32>, String) {
    let o = capped(args);
    (o.status.code(), stderr(&o))
}

/// Runs `parrt ARGS` with stderr piped and `$PARRT_LOG` unset, reads its first `lines` lines
/// of stderr, sends it `signal`, and returns those lines, the rest of stderr and its exit code.
fn signalled(args: &[&str], lines: usize, signal: i32) -> (Vec<String>, String, Option<i32>) {
    use std::io::{BufRead, BufReader, Read};
    let mut child = Command::new(env!("CARGO_BIN_EXE_parrt"))
        .args(args)
        .env_remove("PARRT_LOG")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = BufReader::new(child.stderr.take().unwrap());
    let mut first = Vec::new();
    for _ in 0..lines {
        let mut line = String::new();
        err.read_line(&mut line).unwrap();
        first.push(line);
    }
    // SAFETY: a signal to a child this test started and has not reaped.
    unsafe { libc::kill(child.id() as libc::pid_t, signal) };
    let mut rest = String::new();
    err.read_to_string(&mut rest).unwrap();
    let status = child.wait().unwrap();
    (first, rest, status.code())
}

/// A master waiting for its workers says so after "listening on", in lines for people (no
/// timestamped log lines unless asked for), and Ctrl-C stops it with exit status 130, as it
/// stops an SMP render.
#[test]
fn a_waiting_master_says_so_and_ctrl_c_exits_130() {
    let dir = tempfile::tempdir().unwrap();
    let nff = scene(dir.path());
    let out = dir.path().join("never.png");
    let args = [
        "master",
        path(&nff),
        "--token",
        "a-token",
        "--listen",
        "127.0.0.1:0",
        "--wait-workers",
        "60",
        "-o",
        path(&out),
    ];
    let (lines, rest, code) = signalled(&args, 2, libc::SIGINT);
    assert!(
        lines[0].starts_with("parrt master: listening on 127.0.0.1:"),
        "{lines:?}"
    );
    assert_eq!(
        lines[1],
        "parrt master: waiting for 1 worker (up to 60 s)…\n"
    );
    assert_eq!(code, Some(130), "{lines:?} {rest}");
    assert!(
        !rest.contains("INFO") && !rest.contains("parrt_runtime::"),
        "log lines by default: {rest}"
    );
}

/// A worker stopped by a signal while it dials exits as the signal would have it (130 for
/// Ctrl-C, 143 for SIGTERM), as `parrt render` and `parrt master` do, and says so in a line for
/// people, not a log line or an error.
#[test]
fn a_worker_stopped_by_a_signal_exits_128_plus_its_number() {
    // A port nothing listens on: the worker keeps dialling for its whole budget.
    let closed = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = closed.local_addr().unwrap().to_string();
    drop(closed);
    let args = [
        "worker",
        "--connect",
        &addr,
        "--token",
        "a-token",
        "--threads",
        "1",
        "--dial-timeout",
        "60",
    ];
    for (sig, code, name) in [
        (libc::SIGINT, 130, "Ctrl-C"),
        (libc::SIGTERM, 143, "SIGTERM"),
    ] {
        let (first, rest, status) = signalled(&args, 1, sig);
        assert!(
            first[0].starts_with("parrt worker: connecting to 127.0.0.1:"),
            "{first:?}"
        );
        assert_eq!(status, Some(code), "{name}: {rest}");
        assert!(
            rest.ends_with(&format!("parrt worker: interrupted by {name}\n")),
            "{name}: {rest}"
        );
    }
}
