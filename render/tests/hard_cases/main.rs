//! Numerically hard cases (docs/design-rendering.md, *Numeric robustness*): watertight meshes and
//! shared vertices, scenes far from the origin and tiny ones, grazing light on huge planes, nested
//! glass, axis-parallel rays, degenerate input, self-intersection of spawned rays (pbrt's
//! Reintersect tests) and concave polygons. Every test asserts on pixels or hits; images are small
//! so the suite stays fast.
//!
//! The scene-level cases run on every [`setup::PLACEMENTS`] copy of their scene — as written, moved by
//! 1e7 (mixed signs), scaled by 1e-6 and by 1e6 — in f32 (wherever auto picks it), f64 and auto:
//! the camera-relative frame ([`parrt_render::frame`]) must let no leak, acne or speckle in anywhere. (The
//! input checks and the spawned-ray tests work on primitives, not scenes: the latter already
//! span six orders of magnitude of scale and offsets of 100× it.)
//!
//! One test binary, a file per subject: [`meshes`], [`placement`], [`self_intersection`],
//! [`refraction`], [`axis_rays`], [`degenerate`]; [`setup`] holds what they share.

use parrt_test_support as support;

mod axis_rays;
mod degenerate;
mod meshes;
mod placement;
mod refraction;
mod self_intersection;
mod setup;
