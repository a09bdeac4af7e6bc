//! Local worker processes: `parrt render --workers N` starts N copies of this executable as
//! `<exe> worker --connect ADDR --threads T`, the emulated cluster N replaying workers; both
//! through [`spawn_workers`] and a [`WorkerCommand`]. The token travels in their environment
//! (never on the command line, where `ps` would show it). Dropping the handle kills them.
//!
//! Workers that render for real on this machine may each get a region of memory shared with the
//! master for their pixels ([`Share`], [`parrt_protocol::shared_pixels`]): a `memfd` whose
//! descriptor only that worker inherits, its number in [`SHARED_PIXELS_ENV`]. A region that
//! cannot be made costs only speed: that worker's pixels go over its connection.
//!
//! No orphans: each worker asks the kernel to kill it when the thread that started it ends
//! (`PR_SET_PDEATHSIG`), so a master that dies any way at all, `SIGKILL` included, takes its
//! workers with it; and [`spawn_workers_until`] stops starting them as soon as the run is
//! cancelled (SIGINT, SIGTERM), handing back only those it started, to be killed and reaped.

use crate::options::WorkerCommand;
use crate::shared_regions::SharedRegions;
use parrt_protocol::{Token, LOG_ENV, SHARED_PIXELS_ENV, TOKEN_ENV};
use std::net::SocketAddr;
use std::os::fd::AsRawFd;
use std::os::unix::process::CommandExt;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use thiserror::Error;
use tokio_util::sync::CancellationToken;
use tracing::warn;

/// Memory to share with each worker started, for its pixels: a region of `slots` slots of
/// `slot_bytes` bytes each, made in `regions`.
#[derive(Clone, Copy, Debug)]
pub struct Share<'a> {
    /// Where the regions are kept (the master's, for its connections to find).
    pub regions: &'a SharedRegions,
    /// Slots of each region: as many tiles as a worker may have rendered and not yet sent.
    pub slots: u32,
    /// Bytes of each slot: a whole tile's pixels.
    pub slot_bytes: u32,
}

/// Errors starting local workers.
#[derive(Debug, Error)]
pub enum SpawnError {
    /// The path of this executable is unknown.
    #[error("cannot find this executable to start workers: {0}")]
    CurrentExe(std::io::Error),
    /// A worker process did not start.
    #[error("cannot start worker {index} ({exe})")]
    Start {
        /// Which worker.
        index: usize,
        /// The executable.
        exe: String,
        /// The cause.
        source: std::io::Error,
    },
}

/// Running local worker processes; killed on drop (and reaped on a thread of their own).
#[derive(Debug)]
pub struct LocalWorkers {
    children: Vec<Child>,
}

impl LocalWorkers {
    /// Process ids of the workers (for tests that stop or kill one).
    pub fn pids(&self) -> Vec<u32> {
        self.children.iter().map(|c| c.id()).collect()
    }
}

impl Drop for LocalWorkers {
    /// Kills every worker at once, then reaps them on a thread of its own: a process's exit
    /// takes ~0.5-1 ms to tear down its memory, and the caller (writing the image) need not
    /// wait for that. If no thread can be started they are reaped here.
    fn drop(&mut self) {
        for c in &mut self.children {
            let _ = c.kill();
        }
        let children = Arc::new(Mutex::new(std::mem::take(&mut self.children)));
        let theirs = Arc::clone(&children);
        let spawned = std::thread::Builder::new()
            .name("parrt-reap".into())
            .spawn(move || reap(&theirs));
        if spawned.is_err() {
            reap(&children);
        }
    }
}

/// Waits for every (killed) child to exit.
fn reap(children: &Mutex<Vec<Child>>) {
    if let Ok(mut children) = children.lock() {
        for c in children.iter_mut() {
            let _ = c.wait();
        }
    }
}

/// Starts `n` workers of `threads` threads each from `cmd`, dialling `addr`, each with a region
/// of `share` if given.
pub fn spawn_workers(
    cmd: &WorkerCommand,
    n: usize,
    threads: usize,
    addr: SocketAddr,
    token: &Token,
    share: Option<Share<'_>>,
) -> Result<LocalWorkers, SpawnError> {
    let mut workers = LocalWorkers {
        children: Vec::with_capacity(n),
    };
    let mut start = starter(cmd, threads, addr, token, share)?;
    for index in 0..n {
        workers.children.push(start(index)?);
    }
    Ok(workers)
}

/// Starts up to `n` workers as [`spawn_workers`] does, yielding to the runtime after each so
/// that a signal can cancel `stop`; stops starting them once it is cancelled. Returns the
/// workers started (all `n` unless cancelled); on an error, those started are killed.
pub async fn spawn_workers_until(
    cmd: &WorkerCommand,
    n: usize,
    threads: usize,
    addr: SocketAddr,
    token: &Token,
    share: Option<Share<'_>>,
    stop: &CancellationToken,
) -> Result<LocalWorkers, SpawnError> {
    let mut workers = LocalWorkers {
        children: Vec::with_capacity(n),
    };
    let mut start = starter(cmd, threads, addr, token, share)?;
    for index in 0..n {
        if stop.is_cancelled() {
            break;
        }
        workers.children.push(start(index)?);
        // Lets the signal listener run (its wake is handled when the driver is next polled).
        tokio::task::yield_now().await;
    }
    Ok(workers)
}

/// What starts worker `index`: the command line, the token in the environment, its region of
/// shared memory if any, and the parent-death signal.
fn starter<'a>(
    cmd: &'a WorkerCommand,
    threads: usize,
    addr: SocketAddr,
    token: &Token,
    share: Option<Share<'a>>,
) -> Result<impl FnMut(usize) -> Result<Child, SpawnError> + 'a, SpawnError> {
    let exe = match &cmd.exe {
        Some(e) => e.clone(),
        None => std::env::current_exe().map_err(SpawnError::CurrentExe)?,
    };
    let token = String::from_utf8_lossy(token.as_bytes()).into_owned();
    // SAFETY: getpid has no preconditions.
    let parent = unsafe { libc::getpid() };
    Ok(move |index: usize| {
        let mut c = Command::new(&exe);
        c.args(&cmd.prefix)
            .arg("--connect")
            .arg(addr.to_string())
            .arg("--threads")
            .arg(threads.max(1).to_string())
            .arg("--name")
            .arg(format!("{}-{index}", cmd.name_prefix))
            .args(&cmd.extra)
            .env(TOKEN_ENV, &token)
            .stdin(Stdio::null())
            .stdout(Stdio::null());
        if std::env::var_os(LOG_ENV).is_none() {
            c.env(LOG_ENV, &cmd.log);
        }
        // Kept open until the child has started, then closed here (the mappings stay).
        let region = share.and_then(|s| match s.regions.create(s.slots, s.slot_bytes) {
            Ok(fd) => Some(fd),
            Err(e) => {
                warn!(worker = index, error = %e, "no shared memory: its pixels go over its connection");
                None
            }
        });
        let inherit = region.as_ref().map(|fd| fd.as_raw_fd());
        match inherit {
            Some(fd) => c.env(SHARED_PIXELS_ENV, fd.to_string()),
            None => c.env_remove(SHARED_PIXELS_ENV),
        };
        // SAFETY: prctl, getppid, fcntl and _exit are async-signal-safe; the closure touches
        // nothing of the parent's but a copied pid and descriptor number.
        unsafe {
            c.pre_exec(move || {
                // This child alone keeps its region's descriptor across exec.
                if let Some(fd) = inherit {
                    if libc::fcntl(fd, libc::F_SETFD, 0) != 0 {
                        return Err(std::io::Error::last_os_error());
                    }
                }
                if libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGKILL as libc::c_ulong) != 0 {
                    return Err(std::io::Error::last_os_error());
                }
                // The master died before the request took hold: nothing to work for.
                if libc::getppid() != parent {
                    libc::_exit(1);
                }
                Ok(())
            });
        }
        c.spawn().map_err(|source| SpawnError::Start {
            index,
            exe: exe.display().to_string(),
            source,
        })
    })
}

/// Starts `n` workers from executable `exe` (which must accept `worker --connect ...`).
pub fn spawn_workers_from(
    exe: &Path,
    n: usize,
    threads: usize,
    addr: SocketAddr,
    token: &Token,
) -> Result<LocalWorkers, SpawnError> {
    let cmd = WorkerCommand {
        exe: Some(exe.to_path_buf()),
        ..WorkerCommand::default()
    };
    spawn_workers(&cmd, n, threads, addr, token, None)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::{Duration, Instant};

    /// Dropping the handle kills the workers without waiting for them, and they are reaped
    /// (no zombie left behind) soon after.
    #[test]
    fn dropping_kills_at_once_and_reaps_behind() {
        let children: Vec<Child> = (0..2)
            .map(|_| Command::new("sleep").arg("30").spawn().expect("sleep runs"))
            .collect();
        let pids: Vec<u32> = children.iter().map(|c| c.id()).collect();
        let t0 = Instant::now();
        drop(LocalWorkers { children });
        assert!(t0.elapsed() < Duration::from_secs(10), "drop waited");
        // A killed but unreaped child stays in /proc as a zombie until waited for.
        for pid in pids {
            let path = format!("/proc/{pid}");
            while std::path::Path::new(&path).exists() {
                assert!(
                    t0.elapsed() < Duration::from_secs(20),
                    "worker {pid} not reaped"
                );
                std::thread::sleep(Duration::from_millis(10));
            }
        }
    }
}
