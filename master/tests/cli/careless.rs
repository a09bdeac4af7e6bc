//! Careless flags and files through the real `parrt` binary (huge grid densities, images and
//! tile counts, durations out of range, devices, directories and FIFOs as inputs, outputs that
//! cannot be written, bad listen addresses): each is refused with exit 2 and a message naming
//! the flag or file — before any render and before the master listens — and never panics, hangs
//! or allocates without bound. Every run is capped (address space, wall time) so a regression fails
//! instead of taking the machine with it.

use crate::stderr;
use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Address space each run may take: a regression that allocates gigabytes fails quickly.
const MEMORY_CAP: u64 = 4 << 30;
/// Wall time each run may take: every refusal here is immediate; a render or a wait is not.
const TIME_CAP: Duration = Duration::from_secs(30);

/// Runs `parrt args` under [`MEMORY_CAP`] and [`TIME_CAP`] (killed past it).
pub(crate) fn parrt(args: &[&str]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_parrt"));
    cmd.args(args)
        .env("RUST_BACKTRACE", "0")
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    // SAFETY: setrlimit is async-signal-safe and touches only the child being started.
    unsafe {
        cmd.pre_exec(|| {
            let lim = libc::rlimit {
                rlim_cur: MEMORY_CAP,
                rlim_max: MEMORY_CAP,
            };
            if libc::setrlimit(libc::RLIMIT_AS, &lim) != 0 {
                return Err(std::io::Error::last_os_error());
            }
            Ok(())
        });
    }
    let mut child = cmd.spawn().expect("the parrt binary runs");
    let t0 = Instant::now();
    while child.try_wait().expect("wait").is_none() {
        if t0.elapsed() > TIME_CAP {
            let _ = child.kill();
            let o = child.wait_with_output().expect("output");
            panic!(
                "parrt {args:?} still running after {TIME_CAP:?}; stderr:\n{}",
                String::from_utf8_lossy(&o.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().expect("output")
}

/// Asserts exit 2, no panic, nothing listened or rendered, and stderr equal to
/// `parrt: <message>`; returns stderr.
fn refused(args: &[&str], message: &str) -> String {
    let o = parrt(args);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "parrt {args:?}: {err}");
    assert!(!err.contains("panicked"), "parrt {args:?} panicked: {err}");
    assert!(
        !err.contains("listening"),
        "parrt {args:?} listened first: {err}"
    );
    assert_eq!(
        err.trim_end(),
        format!("parrt: {message}"),
        "parrt {args:?}"
    );
    err
}

/// `parrt master` flags that would otherwise listen: a loopback port of the system's choice,
/// a token, and a short wait.
const MASTER: [&str; 7] = [
    "master",
    "--listen",
    "127.0.0.1:0",
    "--token",
    "careless-test-token",
    "--wait-workers",
    "1",
];

fn master(extra: &[&str]) -> Vec<String> {
    MASTER.iter().chain(extra).map(|s| s.to_string()).collect()
}

fn refused_master(extra: &[&str], message: &str) -> String {
    let args = master(extra);
    refused(
        &args.iter().map(String::as_str).collect::<Vec<_>>(),
        message,
    )
}

fn path(p: &Path) -> &str {
    p.to_str().expect("UTF-8 temp path")
}

/// A one-sphere scene as parrt's JSON description.
fn sphere_json() -> serde_json::Value {
    let nff = "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0.01 resolution 8 8\n\
               l 5 5 5\nf 1 0 0 1 0 0 0 0\ns 0 0 0 1\n";
    let desc = parrt_render::nff::parse(nff, "ball.nff", &Default::default()).expect("valid NFF");
    serde_json::to_value(&desc).expect("serialisable")
}

// Item 4: a grid density past the named maximum is refused by the settings check that master
// and workers both run; it used to wrap the cell count and abort.
#[test]
fn a_huge_grid_density_is_refused_up_front() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("ball.json");
    std::fs::write(&json, sphere_json().to_string()).unwrap();
    let msg = "bad setting: grid density 1e30 is outside (0, 10000]";
    refused(
        &[
            "render",
            "--scene",
            "balls:1",
            "--accel",
            "grid",
            "--grid-density",
            "1e30",
            "-o",
            path(&dir.path().join("g.png")),
        ],
        msg,
    );
    refused_master(
        &[
            "--scene-json",
            path(&json),
            "--accel",
            "grid",
            "--grid-density",
            "1e30",
        ],
        msg,
    );
}

// Item 5: master applies render's --max-pixels check (the same function) and both cap the tile
// count; both used to allocate gigabytes (master after printing "listening").
#[test]
fn oversized_images_and_tile_counts_are_refused_before_listening() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("o.png");
    let big = "100000x100000 is 10000000000 pixels, over the limit of 268435456 (raise it with \
               --max-pixels)";
    refused_master(&["--width", "100000", "--height", "100000"], big);
    let tiles = "--tile 1 cuts 16384x16384 into 268435456 tiles, over the limit of 4194304; use \
                 --tile 8 or larger";
    let flags = ["--width", "16384", "--height", "16384", "--tile", "1"];
    refused_master(&flags, tiles);
    let mut render = vec!["render", "-o", path(&out)];
    render.extend(flags);
    refused(&render, tiles);
}

// Item 6: duration flags take a number of seconds in a range per flag; they used to panic
// converting to a Duration, overflow an Instant, or (0) drop every worker.
#[test]
fn duration_flags_out_of_range_are_refused() {
    for (flag, value, range) in [
        ("--tile-deadline", "1e30", "1..=604800"),
        ("--tile-deadline", "0", "1..=604800"),
        ("--wait-workers", "1e30", "0..=604800"),
        ("--wait-workers", "-1", "0..=604800"),
        ("--wait-workers", "NaN", "0..=604800"),
        ("--heartbeat-timeout", "1e30", "2..=604800"),
        ("--heartbeat-timeout", "1e19", "2..=604800"),
        ("--heartbeat-timeout", "0", "2..=604800"),
        ("--heartbeat-timeout", "1.5", "2..=604800"),
    ] {
        let shown = match value {
            "0" => "0.0",
            "-1" => "-1.0",
            v => v,
        };
        // --wait-workers is given once only: the one under test replaces MASTER's.
        let mut args: Vec<String> = master(&[]);
        args.truncate(MASTER.len() - 2);
        args.push(format!("{flag}={value}"));
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        refused(
            &args,
            &format!("{flag} {shown} is not a number of seconds in {range}"),
        );
    }
}

// Item 7: only regular files are read, and at most --max-file-bytes of them; /dev/zero used to
// be read until memory ran out.
#[test]
fn devices_directories_fifos_and_huge_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = path(dir.path());
    let out = dir.path().join("o.png");
    let o = path(&out);
    let dev = |p: &str| format!("{p}: is a character device, not a regular file");
    refused(&["render", "/dev/zero", "-o", o], &dev("/dev/zero"));
    refused(&["render", "/dev/urandom", "-o", o], &dev("/dev/urandom"));
    refused(&["info", "/dev/zero"], &dev("/dev/zero"));
    refused_master(&["--scene-json", "/dev/zero"], &dev("/dev/zero"));
    let isdir = format!("{d}: is a directory, not a regular file");
    refused(&["render", d, "-o", o], &isdir);
    refused_master(&["--scene-json", d], &isdir);
    // A FIFO with no writer: opening it would block forever.
    let fifo = dir.path().join("pipe.nff");
    let c = std::ffi::CString::new(path(&fifo)).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    refused(
        &["render", path(&fifo), "-o", o],
        &format!("{}: is a FIFO, not a regular file", path(&fifo)),
    );
    // Over the byte limit (raisable).
    let small = dir.path().join("s.nff");
    std::fs::write(&small, b"v from 0 0 5 at 0 0 0 up 0 1 0 angle 45\n").unwrap();
    refused(
        &["info", path(&small), "--max-file-bytes", "10"],
        &format!(
            "{}: is larger than the limit of 10 bytes (raise it with --max-file-bytes)",
            path(&small)
        ),
    );
}

// Item 8: outputs are checked before the render (a big one here, which would take minutes),
// for render, master and the bench studies; they used to fail with exit 1 after it.
#[test]
fn bad_outputs_are_refused_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let sub = dir.path().join("sub.png");
    std::fs::create_dir(&sub).unwrap();
    let slow = ["--width", "4096", "--height", "4096", "--spp", "64"];
    let with = |mut v: Vec<&'static str>, extra: &[&'static str]| {
        v.extend(extra);
        v
    };
    let gone = "cannot write /nonexistent/dir/out.png: directory /nonexistent/dir: No such file \
                or directory (os error 2)";
    let render = |o: &str| {
        let mut v = vec!["render".to_string(), "-o".to_string(), o.to_string()];
        v.extend(slow.iter().map(|s| s.to_string()));
        v
    };
    let run = |v: Vec<String>, msg: &str| {
        refused(&v.iter().map(String::as_str).collect::<Vec<_>>(), msg);
    };
    run(render("/nonexistent/dir/out.png"), gone);
    run(
        render(path(&sub)),
        &format!("cannot write {}: it is a directory", path(&sub)),
    );
    run(
        render("x.jpg"),
        "unknown image format for x.jpg: use .png, .ppm or .exr",
    );
    refused_master(
        &with(vec!["-o", "x.jpg"], &slow),
        "unknown image format for x.jpg: use .png, .ppm or .exr",
    );
    refused_master(&with(vec!["-o", "/nonexistent/dir/out.png"], &slow), gone);
    refused_master(
        &with(vec!["--report-json", "/nonexistent/dir/r.json"], &slow),
        "cannot write /nonexistent/dir/r.json: directory /nonexistent/dir: No such file or \
         directory (os error 2)",
    );
    let ok = dir.path().join("ok.png");
    let mut v = render(path(&ok));
    v.extend(["--stats-json".into(), path(&sub).into()]);
    run(
        v,
        &format!("cannot write {}: it is a directory", path(&sub)),
    );
    // A bench study's output directory under a file.
    let file = dir.path().join("file");
    std::fs::write(&file, b"x").unwrap();
    let under = file.join("out");
    refused(
        &["bench", "efficiency", "mount", "--out", path(&under)],
        &format!(
            "cannot create {}: Not a directory (os error 20)",
            path(&under)
        ),
    );
}

// Item 8, the other half: a successful write leaves only the image (it goes to a temporary file
// beside it, renamed when complete).
#[test]
fn a_written_image_leaves_no_temporary_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("small.png");
    let o = parrt(&[
        "render",
        "--scene",
        "balls:1",
        "--width",
        "16",
        "--height",
        "8",
        "-o",
        path(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert_eq!(names, ["small.png"]);
}

// Item 9: the master builds the scene once, as a worker would, before it listens; a bad
// material index used to make every worker fail and the master blame absent workers.
#[test]
fn master_refuses_a_scene_no_worker_could_build_before_listening() {
    let dir = tempfile::tempdir().unwrap();
    let mut v = sphere_json();
    v["primitives"][0]["material"] = serde_json::json!(9);
    let json = dir.path().join("bad.json");
    std::fs::write(&json, v.to_string()).unwrap();
    refused_master(
        &["--scene-json", path(&json)],
        &format!(
            "no worker could render {}: primitive 0 uses material 9 but the scene has 1",
            path(&json)
        ),
    );
}

// "Also": an address that cannot be resolved is bad input (2); a port in use is not (1). Either
// way the cause is printed once.
#[test]
fn listen_addresses_typos_are_bad_input_and_a_busy_port_is_not() {
    refused(
        &[
            "master",
            "--token",
            "careless-test-token",
            "--listen",
            "nothost:abc",
        ],
        "--listen nothost:abc: not an address to listen on (invalid port value); use HOST:PORT, \
         e.g. 127.0.0.1:7878",
    );
    let busy = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = busy.local_addr().unwrap().to_string();
    let o = parrt(&[
        "master",
        "--token",
        "careless-test-token",
        "--listen",
        &addr,
        "--scene",
        "balls:1",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert_eq!(
        stderr(&o).trim_end(),
        format!(
            "parrt: distributed render failed: cannot listen on {addr}: Address already in use \
             (os error 98)"
        )
    );
}

/// `parrt master --frames-window`: at least 1, and a sequence's flag only; both refused before
/// listening (exit 2).
#[test]
fn a_window_of_frames_is_refused_below_one_or_for_one_frame() {
    refused_master(
        &[
            "--scene",
            "balls:1",
            "--orbit",
            "90",
            "--frames",
            "3",
            "--frames-window",
            "0",
        ],
        "--frames-window must be at least 1",
    );
    refused_master(
        &["--scene", "balls:1", "--frames-window", "3"],
        "--frames-window is a sequence's flag (several scene files, --frames-from or --orbit); \
         a render of one frame has no frames to overlap",
    );
}
