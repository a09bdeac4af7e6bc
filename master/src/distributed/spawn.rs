//! Local worker processes for `parrt render --workers N`: N copies of this executable started
//! as `<exe> worker --connect ADDR --threads T`, with the token in their environment (never on
//! the command line, where `ps` would show it). Dropping the handle kills them.

use parrt::protocol::Token;
use std::net::SocketAddr;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use thiserror::Error;

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

/// Running local worker processes; killed (and reaped) on drop.
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
    fn drop(&mut self) {
        for c in &mut self.children {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// Starts `n` workers of `threads` threads each from this executable, dialling `addr`.
pub fn spawn_local_workers(
    n: usize,
    threads: usize,
    addr: SocketAddr,
    token: &Token,
) -> Result<LocalWorkers, SpawnError> {
    let exe = std::env::current_exe().map_err(SpawnError::CurrentExe)?;
    spawn_workers_from(&exe, n, threads, addr, token)
}

/// Starts `n` workers from executable `exe` (which must accept `worker --connect ...`).
pub fn spawn_workers_from(
    exe: &Path,
    n: usize,
    threads: usize,
    addr: SocketAddr,
    token: &Token,
) -> Result<LocalWorkers, SpawnError> {
    let mut workers = LocalWorkers {
        children: Vec::with_capacity(n),
    };
    let token = String::from_utf8_lossy(token.as_bytes()).into_owned();
    for index in 0..n {
        let mut cmd = Command::new(exe);
        cmd.arg("worker")
            .arg("--connect")
            .arg(addr.to_string())
            .arg("--threads")
            .arg(threads.max(1).to_string())
            .arg("--name")
            .arg(format!("local-{index}"))
            .env(parrt_worker::cli::TOKEN_ENV, &token)
            .stdin(Stdio::null())
            .stdout(Stdio::null());
        if std::env::var_os(parrt_worker::cli::LOG_ENV).is_none() {
            cmd.env(parrt_worker::cli::LOG_ENV, "warn");
        }
        let child = cmd.spawn().map_err(|source| SpawnError::Start {
            index,
            exe: exe.display().to_string(),
            source,
        })?;
        workers.children.push(child);
    }
    Ok(workers)
}
