//! The key a master tells built scenes apart by, so that a worker receives each distinct scene
//! once: a SHA-256 of everything in a frame's build but the camera, that is the scene's
//! content (background, lights, materials, primitives, in their wire encoding, whatever file
//! they came from), the rendering frame's origin the eye puts it in ([`parrt_render::frame`])
//! and the settings a build depends on (all but the size and samples per pixel). Two frames
//! with the same key have the same built scene and accelerator, bit for bit: the later may be
//! sent as a [`crate::ViewSpec`] of the earlier.

use parrt_render::description::{Bounds, SceneDescription, View};
use parrt_render::settings::RenderSettings;
use sha2::{Digest, Sha256};

/// A scene key ([`scene_key`]).
pub type SceneKey = [u8; 32];

/// The key of `desc` built with `settings` (see the module's documentation); `None` when
/// the description cannot be encoded (then the frame is always sent whole).
pub fn scene_key(desc: &SceneDescription, settings: &RenderSettings) -> Option<SceneKey> {
    SceneContent::new(desc)?.key(&desc.view, settings)
}

/// A scene's content hashed once, for the keys of the frames that show it from different
/// views: hashing the primitives is most of a key's cost, and a camera path's frames share
/// them. The bounds the rendering frame's origin is found from are kept too.
#[derive(Clone)]
pub struct SceneContent {
    hash: Sha256,
    bounds: Bounds,
}

impl SceneContent {
    /// The content of `desc` hashed (its view left out); `None` when it cannot be encoded.
    pub fn new(desc: &SceneDescription) -> Option<Self> {
        let mut h = Sha256::new();
        let content = (
            &desc.background,
            &desc.lights,
            &desc.materials,
            &desc.primitives,
        );
        h.update(postcard::to_stdvec(&content).ok()?);
        Some(SceneContent {
            hash: h,
            bounds: parrt_render::frame::sampled_bounds(desc),
        })
    }

    /// What [`scene_key`] gives for the content this was made from seen from `view` and built
    /// with `settings` (the content is not hashed again).
    pub fn key(&self, view: &View, settings: &RenderSettings) -> Option<SceneKey> {
        let mut h = self.hash.clone();
        let origin = parrt_render::frame::origin_for(&self.bounds, view.from);
        for c in origin.to_array() {
            h.update(c.to_bits().to_le_bytes());
        }
        let mut build = settings.clone();
        build.width = 0;
        build.height = 0;
        build.spp = 0;
        h.update(postcard::to_stdvec(&build).ok()?);
        Some(h.finalize().into())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene() -> SceneDescription {
        let text = "v from 0 -10 2 at 0 0 2 up 0 0 1 angle 40 hither 0.01 resolution 16 8\n\
                    l 5 5 5\nf 1 0 0 1 0 0 0 0\ns 0 0 0 1\n";
        parrt_render::nff::parse(text, "t.nff", &Default::default()).expect("parse")
    }

    #[test]
    fn the_key_ignores_the_camera_and_size_but_not_the_content_or_the_build() {
        let d = scene();
        let s = RenderSettings::new(16, 8);
        let k = scene_key(&d, &s).expect("key");
        let mut moved = d.clone();
        moved.view.from.x = 3.0;
        let mut bigger = s.clone();
        bigger.width = 64;
        bigger.spp = 4;
        assert_eq!(scene_key(&moved, &bigger), Some(k));
        let mut other = d.clone();
        other.lights[0].position.x = 6.0;
        assert_ne!(scene_key(&other, &s), Some(k));
        let mut f64s = s.clone();
        f64s.precision = parrt_render::settings::Precision::F64;
        assert_ne!(scene_key(&d, &f64s), Some(k));
    }

    #[test]
    fn content_hashed_once_gives_every_view_its_key() {
        let d = scene();
        let s = RenderSettings::new(16, 8);
        let content = SceneContent::new(&d).expect("content");
        let mut far = d.clone();
        far.view.from.x = 1e6;
        let mut f64s = s.clone();
        f64s.precision = parrt_render::settings::Precision::F64;
        for v in [&d, &far] {
            for s in [&s, &f64s] {
                assert_eq!(content.key(&v.view, s), scene_key(v, s));
            }
        }
        assert_ne!(content.key(&d.view, &f64s), content.key(&d.view, &s));
    }
}
