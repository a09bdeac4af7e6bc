//! `--listen ADDR` of `parrt master` and `parrt cluster`: an address that resolves, checked
//! before the scene is read; whether it can be bound (a port in use) is found when binding,
//! and is not the user's typo.

use super::ArgError;
use parrt_runtime::DEFAULT_LISTEN;

/// Checks that `--listen` is an address that can be resolved (bad input otherwise).
pub fn check_listen(listen: &str) -> anyhow::Result<()> {
    use std::net::ToSocketAddrs;
    let mut addrs = listen.to_socket_addrs().map_err(|e| {
        ArgError::Value(format!(
            "--listen {listen}: not an address to listen on ({e}); use HOST:PORT, e.g. {DEFAULT_LISTEN}"
        ))
    })?;
    if addrs.next().is_none() {
        return Err(ArgError::Value(format!("--listen {listen}: resolves to no address")).into());
    }
    Ok(())
}
