//! `parrt worker` and `parrt-worker`: the same arguments and the same entry point, so the master
//! can spawn workers from its own executable. Also the token flags shared with `parrt master`.

use crate::exec::ReplayExec;
use crate::net::TcpDial;
use crate::options::WorkerOptions;
use crate::session::{self, SessionEnd};
use anyhow::Context;
use clap::Args;
use parrt_protocol::limits::{duration_from_secs, MAX_THREADS};
use parrt_protocol::Token;
use std::net::ToSocketAddrs;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicI32, Ordering};
use std::sync::Arc;
use std::time::Duration;
use tokio_util::sync::CancellationToken;

/// The environment variable holding the shared token.
pub const TOKEN_ENV: &str = "PARRT_TOKEN";

/// The most bytes a `--token-file` may hold: a token is a line; anything larger is not one.
pub const MAX_TOKEN_FILE_BYTES: u64 = 4096;

pub use crate::logging::{human_lines, init_logging, log_level, LOG_ENV};

/// A usage error (exit status 2): bad flags, missing token.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);

/// A duration flag given in seconds, checked against [`parrt_protocol::limits`]: finite, not
/// negative, at most [`parrt_protocol::limits::MAX_FLAG_SECONDS`], and not zero when
/// `positive`. Out of range is a [`UsageError`] (exit 2) naming the flag. Shared with `parrt
/// master`'s duration flags.
pub fn seconds_flag(flag: &str, secs: f64, positive: bool) -> Result<Duration, UsageError> {
    duration_from_secs(flag, secs, positive).map_err(|e| UsageError(e.to_string()))
}

/// Checks that `addr` is HOST:PORT and resolves, so a typo fails at once (exit 2) instead of
/// being retried for the whole dial budget.
pub fn check_connect_address(addr: &str) -> Result<(), UsageError> {
    match addr.to_socket_addrs().map(|mut a| a.next()) {
        Ok(Some(_)) => Ok(()),
        Ok(None) => Err(UsageError(format!(
            "--connect {addr}: the name has no address"
        ))),
        Err(e) => Err(UsageError(format!(
            "--connect {addr}: not a HOST:PORT that resolves ({e})"
        ))),
    }
}

/// Where the shared token comes from: `--token`, `--token-file` or `$PARRT_TOKEN`, in that order.
#[derive(Debug, Clone, Default, Args)]
pub struct TokenArgs {
    /// Shared secret (visible in `ps`; prefer --token-file or PARRT_TOKEN).
    #[arg(long, value_name = "TOKEN", conflicts_with = "token_file")]
    pub token: Option<String>,
    /// File holding the shared secret (surrounding whitespace ignored).
    #[arg(long, value_name = "FILE")]
    pub token_file: Option<PathBuf>,
}

impl TokenArgs {
    /// The token from the flags or the environment; `Ok(None)` when none is given.
    pub fn resolve(&self) -> anyhow::Result<Option<Token>> {
        let text = if let Some(t) = &self.token {
            t.clone()
        } else if let Some(f) = &self.token_file {
            read_token_file(f)?
        } else {
            match std::env::var(TOKEN_ENV) {
                Ok(t) => t,
                Err(_) => return Ok(None),
            }
        };
        Token::new(&text)
            .map(Some)
            .map_err(|e| UsageError(format!("bad token: {e}")).into())
    }

    /// The token, or a usage error naming the three ways to give one.
    pub fn require(&self, who: &str) -> anyhow::Result<Token> {
        self.resolve()?.ok_or_else(|| {
            UsageError(format!(
                "{who} needs a shared token: --token, --token-file FILE or ${TOKEN_ENV}"
            ))
            .into()
        })
    }
}

/// Reads a `--token-file`: only a regular file (a FIFO or a device is refused without
/// opening it, so nothing blocks), at most [`MAX_TOKEN_FILE_BYTES`], UTF-8. Every refusal is
/// a [`UsageError`] naming the file.
pub fn read_token_file(f: &std::path::Path) -> Result<String, UsageError> {
    use parrt_render::nff::ReadError;
    let bad = |why: String| UsageError(format!("token file {}: {why}", f.display()));
    let bytes = parrt_render::nff::read_bounded(f, MAX_TOKEN_FILE_BYTES).map_err(|e| match e {
        ReadError::TooLarge { max } => bad(format!(
            "larger than {max} bytes; a token file holds one token"
        )),
        e => bad(e.to_string()),
    })?;
    String::from_utf8(bytes).map_err(|_| bad("not UTF-8 text".into()))
}

/// Arguments of `parrt worker` / `parrt-worker`.
#[derive(Debug, Clone, Args)]
pub struct WorkerArgs {
    /// The master's address, HOST:PORT.
    #[arg(long, value_name = "ADDR")]
    pub connect: String,
    /// Render threads (default: all cores; at most 4096).
    #[arg(long, value_name = "N")]
    pub threads: Option<usize>,
    /// Name reported to the master (default: host-pid).
    #[arg(long)]
    pub name: Option<String>,
    /// Seconds to keep retrying the connection.
    #[arg(long, value_name = "SECONDS", default_value_t = 30.0)]
    pub dial_timeout: f64,
    /// Token flags.
    #[command(flatten)]
    pub token: TokenArgs,
    /// Bench aid (`parrt bench cluster`): replay the recorded render in FILE instead of tracing:
    /// each tile sleeps its recorded one-thread cost, then returns the recorded pixels.
    #[arg(long, value_name = "FILE")]
    pub replay: Option<PathBuf>,
    /// With --replay: multiply every recorded tile cost by F.
    #[arg(long, value_name = "F", default_value_t = 1.0, requires = "replay")]
    pub cost_scale: f64,
    /// Log what happens (connections, jobs, departures) as timestamped lines on stderr, as
    /// PARRT_LOG=info does; without it, and without PARRT_LOG, a line when it connects and one
    /// when it is done.
    #[arg(short, long)]
    pub verbose: bool,
}

impl WorkerArgs {
    /// The worker options these arguments describe.
    pub fn options(&self) -> anyhow::Result<WorkerOptions> {
        let token = self.token.require("a worker")?;
        check_connect_address(&self.connect)?;
        let mut opts = WorkerOptions::new(self.connect.clone(), token);
        if let Some(t) = self.threads {
            if t == 0 || t > MAX_THREADS as usize {
                return Err(UsageError(format!(
                    "--threads must be from 1 to {MAX_THREADS}, got {t}"
                ))
                .into());
            }
            opts.threads = t;
        }
        if let Some(n) = &self.name {
            opts.name = n.clone();
        }
        opts.dial_timeout = seconds_flag("--dial-timeout", self.dial_timeout, false)?;
        // Set only by a master that starts its workers itself; a region that cannot be used
        // costs nothing but speed: the pixels go over the connection.
        opts.shared_pixels = match parrt_protocol::SharedPixels::from_env() {
            None => None,
            Some(Ok(region)) => Some(std::sync::Arc::new(region)),
            Some(Err(e)) => {
                tracing::warn!(error = %e, "pixels go over the connection");
                None
            }
        };
        Ok(opts)
    }
}

/// Runs a worker until the master says Shutdown or goes away (exit 0), or a signal stops it
/// (Ctrl-C exits 130, SIGTERM 143).
pub fn run(args: WorkerArgs) -> anyhow::Result<ExitCode> {
    init_logging(log_level(args.verbose));
    let human = human_lines(args.verbose);
    let opts = args.options()?;
    // A replaying worker (bench aid) plays the recording instead of tracing.
    let replay = match &args.replay {
        Some(path) => Some(Arc::new(
            crate::replay::Replay::open(path, args.cost_scale)
                .map_err(|e| UsageError(e.to_string()))?,
        )),
        None => None,
    };
    let signal = Arc::new(AtomicI32::new(0));
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context("cannot start the async runtime")?;
    let summary: session::SessionSummary = rt.block_on(async {
        let stop = CancellationToken::new();
        watch_signals(stop.clone(), Arc::clone(&signal))?;
        if human {
            say(&format!(
                "connecting to {} as {} ({} threads)…",
                opts.connect,
                opts.name,
                opts.render_threads()
            ));
        }
        match replay {
            Some(r) => session::run_with(&opts, stop, &TcpDial, ReplayExec::pool(r)).await,
            None => session::run(&opts, stop).await,
        }
        .with_context(|| format!("worker for {}", opts.connect))
    })?;
    tracing::info!(
        jobs = summary.jobs,
        tiles = summary.tiles_rendered,
        end = ?summary.end,
        "worker done"
    );
    if human {
        let plural = |n: u64, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
        say(&format!(
            "done: {} rendered in {}",
            plural(summary.tiles_rendered, "tile"),
            plural(u64::from(summary.jobs), "job")
        ));
    }
    if summary.end == SessionEnd::Stopped {
        // Stopped only by a signal: exit as a process the signal killed would (130 for
        // Ctrl-C, 143 for SIGTERM), the way `parrt render` and `parrt master` do.
        let sig = signal.load(Ordering::SeqCst);
        let name = if sig == libc::SIGTERM {
            "SIGTERM"
        } else {
            "Ctrl-C"
        };
        say(&format!("interrupted by {name}"));
        return Ok(ExitCode::from(u8::try_from(128 + sig).unwrap_or(130)));
    }
    Ok(ExitCode::SUCCESS)
}

/// Cancels `stop` on SIGINT (Ctrl-C) or SIGTERM (what a batch system sends to end a job), and
/// keeps which one came in `signal`. Both are watched before the worker dials, so a signal at
/// any moment ends the session cleanly.
fn watch_signals(stop: CancellationToken, signal: Arc<AtomicI32>) -> anyhow::Result<()> {
    use tokio::signal::unix::{signal as unix_signal, SignalKind};
    let mut int = unix_signal(SignalKind::interrupt()).context("cannot watch for Ctrl-C")?;
    let mut term = unix_signal(SignalKind::terminate()).context("cannot watch for SIGTERM")?;
    tokio::spawn(async move {
        let which = tokio::select! {
            _ = int.recv() => libc::SIGINT,
            _ = term.recv() => libc::SIGTERM,
        };
        signal.store(which, Ordering::SeqCst);
        stop.cancel();
    });
    Ok(())
}

/// A line for people on stderr, `parrt worker: …`; dropped if stderr is closed.
fn say(text: &str) {
    use std::io::Write as _;
    let _ = writeln!(std::io::stderr(), "parrt worker: {text}");
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn token_from_flag_or_file_trimmed_and_empty_refused() {
        let flag = TokenArgs {
            token: Some("abc".into()),
            token_file: None,
        };
        assert_eq!(flag.resolve().unwrap(), Some(Token::new("abc").unwrap()));
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("tok");
        std::fs::write(&f, "abc\n").unwrap();
        let file = TokenArgs {
            token: None,
            token_file: Some(f.clone()),
        };
        assert_eq!(file.resolve().unwrap(), Some(Token::new("abc").unwrap()));
        std::fs::write(&f, "\n").unwrap();
        assert!(file.resolve().unwrap_err().is::<UsageError>());
        let missing = TokenArgs {
            token: None,
            token_file: Some(dir.path().join("nope")),
        };
        assert!(missing.resolve().unwrap_err().is::<UsageError>());
    }

    /// /dev/zero, a FIFO and a huge file are refused at once (a usage error), without reading
    /// without bound or blocking.
    #[test]
    fn token_files_are_bounded_and_only_regular() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("fifo");
        let made = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap();
        assert!(made.success());
        let big = dir.path().join("big");
        std::fs::write(&big, vec![b'a'; MAX_TOKEN_FILE_BYTES as usize + 1]).unwrap();
        let (tx, rx) = std::sync::mpsc::channel();
        let paths = [PathBuf::from("/dev/zero"), fifo, big];
        std::thread::spawn(move || {
            for p in paths {
                let args = TokenArgs {
                    token: None,
                    token_file: Some(p),
                };
                let _ = tx.send(args.resolve().map(|_| ()).map_err(|e| e.to_string()));
            }
        });
        // A hang guard, not a timing: reading a FIFO without a writer never returns.
        let mut got = Vec::new();
        for _ in 0..3 {
            got.push(
                rx.recv_timeout(Duration::from_secs(30))
                    .expect("reading a token file hung"),
            );
        }
        for (e, want) in got.iter().zip([
            "a character device, not a regular file",
            "a FIFO, not a regular file",
            "larger than 4096 bytes",
        ]) {
            let e = e.as_ref().unwrap_err();
            assert!(e.contains("token file") && e.contains(want), "{e}");
        }
    }

    fn args(connect: &str, threads: Option<usize>, dial_timeout: f64) -> WorkerArgs {
        WorkerArgs {
            connect: connect.into(),
            threads,
            name: None,
            dial_timeout,
            replay: None,
            cost_scale: 1.0,
            verbose: false,
            token: TokenArgs {
                token: Some("t".into()),
                token_file: None,
            },
        }
    }

    #[test]
    fn bad_flags_are_usage_errors_not_panics() {
        for (a, want) in [
            (args("127.0.0.1:7878", Some(100_000), 30.0), "--threads"),
            (args("127.0.0.1:7878", Some(0), 30.0), "--threads"),
            (args("127.0.0.1:7878", None, 1e30), "--dial-timeout"),
            (args("127.0.0.1:7878", None, -1.0), "--dial-timeout"),
            (args("nothing", None, 30.0), "--connect nothing"),
            (args("127.0.0.1:notaport", None, 30.0), "--connect"),
        ] {
            let e = a.options().unwrap_err();
            assert!(e.is::<UsageError>(), "{e}");
            assert!(e.to_string().contains(want), "{e} lacks {want}");
        }
        let ok = args("127.0.0.1:7878", Some(4096), 0.5).options().unwrap();
        assert_eq!(ok.threads, 4096);
        assert_eq!(ok.dial_timeout, Duration::from_millis(500));
    }
}
