//! Test-only copy of the `parrt` binary, so integration tests can run the real command line via
//! `env!("CARGO_BIN_EXE_parrt-cli")` and its master can spawn workers from the same executable.
fn main() -> std::process::ExitCode {
    parrt_master::cli::main()
}
