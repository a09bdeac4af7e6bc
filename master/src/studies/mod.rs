//! The engines of the studies behind `parrt bench`: what a study measures and how, as a
//! library the bench commands (`crate::commands::bench`, which only parse flags and write
//! files) and the integration tests call. A study measures the renderer and the distributed
//! runtime through their public APIs, as a user would; nothing outside the bench commands
//! depends on a study.
//!
//! - [`accuracy`]: speed against error (`parrt bench accuracy`; its metrics also serve
//!   `parrt bench precision`).
//! - [`cluster`]: an emulated cluster (`parrt bench cluster`): real workers replaying a
//!   recorded render over an emulated LAN.

pub mod accuracy;
pub mod cluster;
pub mod efficiency;
pub mod simulate;
