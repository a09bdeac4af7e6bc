//! The live-view flags (`--http`, `--http-linger`, `--http-full-rate`) of `render`, `master` and
//! `cluster`, checked here into the [`LiveOptions`] a live view starts from; a bad value is bad
//! input (exit 2) naming the flag. The live view itself never sees a flag.

use super::ArgError;
use crate::live::limits::{FULL_RATE, MAX_LINGER};
use crate::live::LiveOptions;
use clap::Args;
use std::net::ToSocketAddrs;
use std::time::Duration;

/// The live-view flags.
#[derive(Debug, Clone, Args)]
pub struct LiveArgs {
    /// Serve a live view of the render at ADDR (HOST:PORT; port 0 picks one). Loopback
    /// addresses are open to local users (through a Host naming them); any other address
    /// needs the view key, derived one way from the token (not the token), as
    /// `Authorization: Bearer KEY` or `?key=KEY`: printed on a terminal, else written to a
    /// file only you can read. Without this flag no port is opened.
    #[arg(long, value_name = "ADDR")]
    pub http: Option<String>,
    /// With --http: keep serving the finished image this many seconds after the render
    /// (Ctrl-C ends it sooner).
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0, requires = "http")]
    pub http_linger: f64,
    /// With --http: send tiles to the page at full resolution while they land at up to this
    /// many megapixels a second; tiles landing faster are sent averaged over 2×2, 4×4 or 8×8
    /// blocks, so that watching costs the render little however fast it runs. The image at
    /// the end (and image.png) is always full resolution.
    #[arg(long, value_name = "MPIXELS", default_value_t = FULL_RATE / 1e6, requires = "http")]
    pub http_full_rate: f64,
}

impl LiveArgs {
    /// The live view these flags ask for (`None` without `--http`), checked.
    pub fn options(&self) -> anyhow::Result<Option<LiveOptions>> {
        let Some(http) = &self.http else {
            return Ok(None);
        };
        let linger = self.http_linger;
        if !linger.is_finite() || linger < 0.0 || linger > MAX_LINGER.as_secs_f64() {
            return Err(ArgError::Value(format!(
                "--http-linger {linger}: must be between 0 and {} seconds",
                MAX_LINGER.as_secs()
            ))
            .into());
        }
        let rate = self.http_full_rate;
        if !rate.is_finite() || rate <= 0.0 || rate > 1e6 {
            return Err(ArgError::Value(format!(
                "--http-full-rate {rate}: must be more than 0 and at most 1000000 megapixels a second"
            ))
            .into());
        }
        let addr = http
            .to_socket_addrs()
            .ok()
            .and_then(|mut a| a.next())
            .ok_or_else(|| {
                ArgError::Value(format!(
                    "--http {http}: not an address to listen on; use HOST:PORT, e.g. 127.0.0.1:8080"
                ))
            })?;
        Ok(Some(LiveOptions {
            addr,
            linger: Duration::from_secs_f64(linger),
            full_rate: rate * 1e6,
        }))
    }
}
