//! # parrt
//!
//! The core library of parrt, a parallel Whitted ray tracer for Eric Haines' NFF scenes.
//!
//! ## Layout
//! - [`description`]: the scene as NFF describes it (`f64`), produced by [`nff`] and the generators.
//! - [`nff`]: the strict token-based reader and the round-tripping writer.
//! - [`real`], [`vec3`]: the scalar trait (`f32` fast path, `f64` reference path) and vectors.
//! - [`render`]: builds a render-ready scene and accelerator, renders tiles ([`packet_trace`]:
//!   eye rays and their shadow rays in packets).
//! - [`tile`], [`smp`], [`film`]: tile tasks, shared-memory executors, the image.
//! - [`settings`], [`stats`]: what decides pixels, and what was counted.
//! - [`frame`], [`precision`]: the camera-relative origin scenes are built in, and the choice of
//!   `f32` or `f64` a scene needs.
//! - [`protocol`]: the master/worker wire protocol (messages, codec, auth, connection).
//! - [`isa`]: the instruction-set tier every SIMD kernel follows, chosen once per process.
//! - [`build_info`]: what build a binary is, the one `--version` text of `parrt` and
//!   `parrt-worker`.
//! - [`window`], [`simulate`]: how much work a worker holds at once, and a model of the
//!   master/worker schedule.
#![deny(missing_docs)]
// `!(x > 0.0)` is used on purpose: unlike `x <= 0.0` it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod batch;
pub mod bits;
pub mod build_info;
pub mod camera;
pub mod cast;
pub mod description;
pub mod efficiency;
pub mod film;
pub mod frame;
pub mod geometry;
pub mod heap;
pub mod isa;
pub mod lanes;
pub mod nff;
pub mod packet_leaf;
pub mod packet_trace;
pub mod precision;
pub mod protocol;
pub mod real;
pub mod render;
pub mod scene;
pub mod scene_leaf;
pub mod seconds;
pub mod settings;
pub mod shade;
pub mod shadow16;
pub mod simulate;
pub mod smp;
pub mod stats;
pub mod tile;
pub mod vec3;
pub mod vertices;
pub mod window;
