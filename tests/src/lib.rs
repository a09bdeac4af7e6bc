//! Helpers shared by parrt's integration tests.

use std::path::PathBuf;

/// The directory of the SPD scenes: `$PARRT_SPD_DIR`, else `shared/spd` found by walking up from
/// this crate (the repository sits beside `shared/`). Panics with a clear message when missing:
/// the tests need those files, and CI has them.
pub fn spd_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("PARRT_SPD_DIR") {
        return PathBuf::from(d);
    }
    let mut dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    loop {
        let cand = dir.join("shared").join("spd");
        if cand.join("README.md").is_file() {
            return cand;
        }
        if !dir.pop() {
            panic!(
                "cannot find shared/spd above {}: set PARRT_SPD_DIR to the SPD scenes directory",
                env!("CARGO_MANIFEST_DIR")
            );
        }
    }
}

pub mod deliveries;
pub use deliveries::Deliveries;
pub mod dist;
/// Deterministic simulation of the distributed system (turmoil).
pub mod sim;
pub use dist::*;
pub mod spd;

/// A test scene of `shapes` seen through `view`: black background, no lights, every shape in
/// one white material (what the hit-agreement tests need, which never shade).
pub fn scene_of(
    shapes: Vec<parrt::description::Shape>,
    view: parrt::description::View,
) -> parrt::description::SceneDescription {
    use parrt::description::{Material, Primitive, SceneDescription};
    use parrt::vec3::V3;
    SceneDescription {
        background: V3::new(0.0, 0.0, 0.0),
        view,
        lights: Vec::new(),
        materials: vec![Material::default_white()],
        primitives: shapes
            .into_iter()
            .map(|shape| Primitive { shape, material: 0 })
            .collect(),
    }
}
