//! Watching a render while it runs and after, one test binary: the live view over HTTP
//! (`live_view`), its defences against hostile clients (`live_guard`) and the `--timeline`
//! trace of every tile (`timeline`).

mod live_guard;
mod live_view;
mod timeline;

/// The package's `parrt` executable.
const EXE: &str = env!("CARGO_BIN_EXE_parrt-cli");
