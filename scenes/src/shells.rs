//! `shells` generator (in progress).
use crate::GenError;
use parrt::description::SceneDescription;
/// Generates the scene.
pub fn generate(size: u32) -> Result<SceneDescription, GenError> {
    Err(GenError::BadSize {
        name: "shells".into(),
        size,
        why: "not yet".into(),
    })
}
