//! # parrt-render
//!
//! The renderer of parrt, a parallel Whitted ray tracer for Eric Haines' NFF scenes: read a
//! scene, build a renderer once, render any tile of the image on any thread — or on another
//! machine — and get the same bits. It knows nothing of the network: the wire protocol is
//! `parrt-protocol`, the distributed master `parrt-runtime`, the worker `parrt-worker`, all
//! built on this crate. The design behind it is in the repository's `docs/design.md`.
//!
//! ## Example
//! Parse an NFF scene, render it on two threads, and read pixels from the image in memory:
//! ```
//! use parrt_render::render::Renderer;
//! use parrt_render::settings::RenderSettings;
//! use parrt_render::smp::{render_smp, Executor, SmpOptions};
//!
//! let text = "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0.01 resolution 64 48\n\
//!             l 5 5 5\n\
//!             f 1 0 0 1 0 0 0 0\n\
//!             s 0 0 0 1\n";
//! let desc = parrt_render::nff::parse(text, "ball.nff", &parrt_render::nff::Limits::default())?;
//! let settings = RenderSettings::new(desc.view.width, desc.view.height);
//! let renderer = Renderer::new(&desc, &settings)?;
//! let opts = SmpOptions { threads: 2, tile: 16, executor: Executor::Queue };
//! let result = render_smp(&renderer, &opts, &|_tile, _stats| {});
//!
//! let [r, g, b] = result.film.get(32, 24); // the middle of the image: the red sphere, lit
//! assert!(r > 0.7 && g == 0.0 && b == 0.0);
//! assert_eq!(result.film.get(0, 0), [0.0, 0.0, 0.0]); // a corner: the black background
//! assert_eq!(result.stats.eye_rays, 64 * 48);
//! // result.film.save(std::path::Path::new("ball.png")) would write it as a PNG.
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! ## Modules
//! The scene and its file format:
//! - [`description`]: the scene as NFF describes it (`f64`), made by [`nff`] and the generators.
//! - [`nff`]: the strict token-based reader and the round-tripping writer.
//! - [`vertices`]: a polygon's vertex list (a triangle's three inline).
//!
//! Building and rendering:
//! - [`render`]: the renderer facade: builds a render-ready scene and accelerator once, renders
//!   any tile on any thread.
//! - [`settings`]: everything besides the scene that decides an image's pixels.
//! - [`scene`]: the render-ready scene (primitives in the renderer's precision, lights, materials).
//! - [`frame`], [`precision`]: the camera-relative origin scenes are built in, and the choice of
//!   `f32` or `f64` a scene needs.
//! - [`camera`]: the pinhole camera of the NFF view.
//! - [`shade`]: Whitted shading and the recursion of reflected and refracted rays.
//! - [`packet`]: rays in packets: eye rays and their shadow, reflection and refraction rays
//!   ([`packet::trace`]), a packet against a leaf ([`packet::leaf`]), its shadow rays made in
//!   lanes ([`packet::shadow`]), the scene's primitive test as the accelerators call it, four
//!   at a time ([`packet::scene_leaf`]).
//! - [`real`], [`vec3`]: the scalar trait (`f32` fast path, `f64` reference path) and vectors.
//!
//! Geometry and acceleration:
//! - [`geometry`]: rays, boxes, the primitives' intersection tests, hit records, SIMD kernels.
//! - [`accel`]: the BVH, the uniform grid and brute force, which all return the same hit.
//! - [`isa`]: the instruction-set tier every SIMD kernel follows, chosen once per process, and
//!   the one dispatch point that runs a kernel on it.
//! - [`lanes`]: the lane types every SIMD kernel is written against (scalar, 4, 8, 16 lanes).
//! - [`bits`]: the set bits of a lane mask, lowest first.
//!
//! Parallel work and its output:
//! - [`tile`]: the image's tiles, in a fixed order.
//! - [`smp`]: shared-memory executors (`queue`, `rayon`, `morton`, `guided`).
//! - [`sequence`], [`sequence_smp`]: many frames as one job (several scenes, or one scene and
//!   an orbit of the camera), rendered on this machine with a window of frames in flight.
//! - [`film`]: the image, and its output as PNG, PPM or EXR.
//! - [`stats`]: ray statistics, counted per tile and merged by addition.
//! - [`cast`]: casting only (eye and shadow rays, no shading), to compare raw ray throughput.
//!
//! Process support:
//! - [`build_info`](mod@build_info): what build a binary is, the one `--version` text of
//!   `parrt` and `parrt-worker`.
//! - [`heap`]: handing freed heap memory back to the operating system.
#![deny(missing_docs)]
// `!(x > 0.0)` is used on purpose: unlike `x <= 0.0` it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod accel;
pub mod bits;
pub mod build_info;
pub mod camera;
pub mod cast;
pub mod description;
pub mod film;
pub mod frame;
pub mod geometry;
pub mod heap;
pub mod isa;
pub mod lanes;
pub mod nff;
pub mod packet;
pub mod precision;
pub mod real;
pub mod render;
pub mod scene;
pub mod sequence;
pub mod sequence_build;
pub mod sequence_smp;
pub mod settings;
pub mod shade;
pub mod smp;
pub mod stats;
pub mod tile;
pub mod vec3;
pub mod vertices;
