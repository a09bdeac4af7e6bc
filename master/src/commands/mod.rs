//! One module per subcommand; each exposes an `Args` struct and `run(args)`. Two modules are
//! shared by the commands that render, and import no command: [`watch`] (the observers the
//! flags ask for) and [`report`] (what a finished render prints); [`distributed`] builds the
//! master configuration the three distributed entry points share, and [`sequence_watch`] what
//! watches a sequence on workers that dial in. The flags several commands
//! take are [`crate::cli_args`]'s.

pub mod bench;
pub mod cluster;
pub mod completions;
pub mod distributed;
pub mod info;
pub mod man;
pub mod master;
pub mod plot_timeline;
pub mod render;
pub mod render_sequence;
pub mod report;
pub mod scene;
pub mod sequence_watch;
pub mod watch;
pub mod worker;
