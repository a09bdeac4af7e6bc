//! Files named on `parrt-worker`'s command line, through the real binary: a token file that is a
//! device, a FIFO or too large to be a token, and a replay file whose header claims more than its
//! bytes hold, are refused at once with exit 2, naming the file, within a bounded address space and
//! before any dial.

use std::os::unix::process::CommandExt;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Address space each run may take: far below what an unchecked header makes it allocate.
const MEMORY_CAP: u64 = 1 << 30;

/// Runs `parrt-worker` with `args`, under [`MEMORY_CAP`], killed if it outlives a hang guard.
fn worker(args: &[&std::ffi::OsStr]) -> (Option<i32>, String) {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_parrt-worker"));
    cmd.args(["--connect", "127.0.0.1:9", "--dial-timeout", "1"])
        .args(args)
        .env("RUST_BACKTRACE", "0")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
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
    let mut child = cmd.spawn().expect("parrt-worker runs");
    let t0 = Instant::now();
    while child.try_wait().expect("wait").is_none() {
        if t0.elapsed() > Duration::from_secs(30) {
            let _ = child.kill();
            panic!("parrt-worker {args:?} hung");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let o = child.wait_with_output().expect("output");
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn worker_with(token_file: &std::path::Path) -> (Option<i32>, String) {
    worker(&["--token-file".as_ref(), token_file.as_os_str()])
}

#[test]
fn devices_fifos_and_huge_token_files_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("fifo");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let big = dir.path().join("big");
    std::fs::write(&big, vec![b'a'; 3 << 20]).unwrap();
    for (p, want) in [
        (std::path::PathBuf::from("/dev/zero"), "character device"),
        (fifo, "a FIFO"),
        (big, "larger than 4096 bytes"),
    ] {
        let (code, err) = worker_with(&p);
        assert_eq!(code, Some(2), "{}: {err}", p.display());
        assert!(err.contains("token file") && err.contains(want), "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

/// A 24-byte replay file claiming 16384² pixels in tiles of 1 (268 M tiles): refused from its
/// length before the tile list is made (it took 5 GiB, or aborted under a limit).
#[test]
fn a_replay_header_claiming_more_than_its_bytes_is_refused_in_bounded_memory() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("lying.replay");
    let mut bytes = b"PARRTRP1".to_vec();
    for v in [16384u32, 16384, 1, 16384 * 16384] {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    assert_eq!(bytes.len(), 24);
    std::fs::write(&f, &bytes).unwrap();
    let tok = dir.path().join("tok");
    std::fs::write(&tok, "t").unwrap();
    let (code, err) = worker(&[
        "--token-file".as_ref(),
        tok.as_os_str(),
        "--replay".as_ref(),
        f.as_os_str(),
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("lying.replay"), "{err}");
    assert!(!err.contains("memory allocation"), "{err}");
}

/// With stderr closed (`parrt-worker … 2>&1 | true`), bad input still ends in exit 2, not in a
/// panic's 101: an unknown `PARRT_ISA` (refused before anything else) and a missing token file.
#[test]
fn a_closed_stderr_keeps_the_exit_status() {
    use std::os::fd::FromRawFd;
    for (isa, token_file) in [
        ("no-such-tier", "/nonexistent/tok"),
        ("", "/nonexistent/tok"),
    ] {
        let mut fds = [0; 2];
        // SAFETY: pipe fills two descriptors; the reading end is closed at once and the
        // writing end owned once, by the OwnedFd.
        let write_end = unsafe {
            assert_eq!(libc::pipe(fds.as_mut_ptr()), 0);
            libc::close(fds[0]);
            std::os::fd::OwnedFd::from_raw_fd(fds[1])
        };
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_parrt-worker"));
        cmd.args(["--connect", "127.0.0.1:9", "--token-file", token_file])
            .env("RUST_BACKTRACE", "0")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::from(write_end));
        if isa.is_empty() {
            cmd.env_remove("PARRT_ISA");
        } else {
            cmd.env("PARRT_ISA", isa);
        }
        let status = cmd.status().expect("parrt-worker runs");
        assert_eq!(status.code(), Some(2), "PARRT_ISA={isa:?}");
    }
}
