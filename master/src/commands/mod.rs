//! One module per subcommand; each exposes an `Args` struct and `run(args)`.

pub mod bench;
pub mod cluster;
pub mod info;
pub mod master;
pub mod plot_timeline;
pub mod render;
pub mod scene;
pub mod worker;
