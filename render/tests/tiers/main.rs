//! The same bits on every instruction-set tier (docs/design-rendering.md, *Instruction sets*): each
//! tier this CPU runs ([`parrt_render::isa`]) renders every SPD file and the hard cases (far, tiny and
//! huge placements in f32, f64 and auto) to the same image bits and the same ray statistics as the
//! `scalar` tier, and the kernels follow the tier the process chose. The distributed render whose
//! workers run different tiers is in `tests/tests/distributed/tiers.rs` (it needs worker
//! processes).
//!
//! One test binary of its own: the tier is process-wide, so its tests take [`tiers::LOCK`] and
//! switch the tier with [`parrt_render::isa::force`] between renders; no other test shares the process.

use parrt_test_support as support;

mod cast;
mod dispatch;
mod eye_lanes;
mod hard;
mod spd;
mod tiers;
