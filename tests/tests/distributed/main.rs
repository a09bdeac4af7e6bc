//! Distributed rendering, one test binary with a file per subject: the image equals SMP
//! (`identical`), worker faults (`faults`), the master killed and resumed (`checkpoint`),
//! a sequence's master killed and resumed (`sequence_checkpoint`),
//! cluster launchers and the emulated cluster (`cluster_launch`, `cluster_emulated`), the
//! command lines (`cli`), and hostile or careless peers by what they attack: the token
//! (`token`), the handshake (`handshake`), frames after it (`frames`) and what a peer can cost
//! (`limits`), a relay in the middle (`relay`), and
//! handshake squatters (`squatting`); the handout order from a previous
//! render's costs (`order`); `peers` holds their raw clients; workers on
//! different instruction-set tiers (`tiers`); frames that only move the camera (`camera`); pixels
//! through memory shared with the workers a master starts (`shared_pixels`). The soak is its own binary
//! (`distributed_soak.rs`): it measures this process's memory, which tests running beside it
//! here would disturb.

mod camera;
mod checkpoint;
mod cli;
mod cluster_emulated;
mod cluster_launch;
mod faults;
mod frames;
mod handshake;
mod identical;
mod limits;
mod order;
mod peers;
mod relay;
mod sequence_checkpoint;
mod shared_pixels;
mod squatting;
mod tiers;
mod token;

use parrt_test_support as support;

/// The package's `parrt` executable (master, worker, `render --workers`, cluster).
const EXE: &str = env!("CARGO_BIN_EXE_parrt-cli");
