//! The speed-against-error study behind `parrt bench accuracy` (docs/design-measures.md,
//! *Accuracy*), one concept per file:
//! - [`configs`]: the configurations measured and the reference;
//! - [`metrics`]: image error metrics on the clamped linear film;
//! - [`study`]: renders the references and configurations of one scene;
//! - [`pareto`]: the time–error Pareto front;
//! - [`report`]: Markdown and CSV tables and the recommended defaults;
//! - [`plot`]: Pareto plots (SVG and PNG).
//!
//! Nothing here asserts timings; it measures and prints.

pub mod configs;
pub mod metrics;
pub mod pareto;
pub mod plot;
pub mod report;
pub mod study;
