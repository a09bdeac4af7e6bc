//! `parrt`: thin binary over the `parrt_master` library.
fn main() -> std::process::ExitCode {
    parrt_master::cli::main()
}
