//! `parrt worker` and `parrt-worker`: the same arguments and the same entry point, so the master
//! can spawn workers from its own executable. Also the token flags shared with `parrt master`.

use crate::options::WorkerOptions;
use crate::session::{self, SessionEnd};
use anyhow::Context;
use clap::Args;
use parrt::protocol::Token;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;
use tokio_util::sync::CancellationToken;

/// The environment variable holding the shared token.
pub const TOKEN_ENV: &str = "PARRT_TOKEN";

/// The environment variable with the log filter (tracing-subscriber syntax, e.g. `debug`).
pub const LOG_ENV: &str = "PARRT_LOG";

/// A usage error (exit status 2): bad flags, missing token.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);

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
            std::fs::read_to_string(f)
                .map_err(|e| UsageError(format!("cannot read token file {}: {e}", f.display())))?
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

/// Arguments of `parrt worker` / `parrt-worker`.
#[derive(Debug, Clone, Args)]
pub struct WorkerArgs {
    /// The master's address, HOST:PORT.
    #[arg(long, value_name = "ADDR")]
    pub connect: String,
    /// Render threads (default: all cores).
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
}

impl WorkerArgs {
    /// The worker options these arguments describe.
    pub fn options(&self) -> anyhow::Result<WorkerOptions> {
        let token = self.token.require("a worker")?;
        let mut opts = WorkerOptions::new(self.connect.clone(), token);
        if let Some(t) = self.threads {
            if t == 0 {
                return Err(UsageError("--threads must be at least 1".into()).into());
            }
            opts.threads = t;
        }
        if let Some(n) = &self.name {
            opts.name = n.clone();
        }
        if !(self.dial_timeout.is_finite() && self.dial_timeout >= 0.0) {
            return Err(UsageError("--dial-timeout must be a number of seconds".into()).into());
        }
        opts.dial_timeout = Duration::from_secs_f64(self.dial_timeout);
        Ok(opts)
    }
}

/// Installs a stderr log subscriber filtered by `$PARRT_LOG` (default `default`); harmless if
/// one is already installed.
pub fn init_logging(default: &str) {
    let filter = tracing_subscriber::EnvFilter::try_from_env(LOG_ENV)
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .try_init();
}

/// Runs a worker until the master says Shutdown or goes away (exit 0), or Ctrl-C (exit 1).
pub fn run(args: WorkerArgs) -> anyhow::Result<ExitCode> {
    init_logging("info");
    let opts = args.options()?;
    if let Some(path) = &args.replay {
        let replay = crate::replay::Replay::open(path, args.cost_scale)
            .map_err(|e| UsageError(e.to_string()))?;
        crate::replay::install(replay);
    }
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context("cannot start the async runtime")?;
    let summary = rt.block_on(async {
        let stop = CancellationToken::new();
        let on_signal = stop.clone();
        tokio::spawn(async move {
            if tokio::signal::ctrl_c().await.is_ok() {
                on_signal.cancel();
            }
        });
        session::run(&opts, stop).await
    });
    let summary = summary.with_context(|| format!("worker for {}", opts.connect))?;
    tracing::info!(
        jobs = summary.jobs,
        tiles = summary.tiles_rendered,
        end = ?summary.end,
        "worker done"
    );
    if summary.end == SessionEnd::Stopped {
        anyhow::bail!("interrupted: disconnected from the master");
    }
    Ok(ExitCode::SUCCESS)
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
}
