//! Building a sequence's renderers: a frame that only moves the camera of the scene last built
//! shares that build ([`Renderer::with_view`]: same bits as a fresh build), any other frame is
//! built afresh and becomes the one shared. An orbit builds its scene once.

use crate::description::SceneDescription;
use crate::render::{RenderError, Renderer};
use crate::sequence::Sequence;
use crate::settings::RenderSettings;
use std::sync::{Arc, Mutex};

/// Makes frame k's renderer of a sequence, sharing the latest build of the same scene. Safe to
/// call from several threads (frames built in parallel each take the latest build there is).
pub struct FrameBuilder<'a> {
    sequence: &'a Sequence,
    /// The scene last built from, and its renderer.
    latest: Mutex<Option<(Arc<SceneDescription>, Arc<Renderer>)>>,
}

impl<'a> FrameBuilder<'a> {
    /// A builder of `sequence`'s frames, nothing built yet.
    pub fn new(sequence: &'a Sequence) -> Self {
        FrameBuilder {
            sequence,
            latest: Mutex::new(None),
        }
    }

    /// Frame `k`'s renderer with `settings`: a view of the latest build when frame `k` has the
    /// same scene and the build allows it, else a fresh build (kept as the latest).
    ///
    /// # Panics
    /// If `k` is not a frame of the sequence.
    pub fn build(&self, k: usize, settings: &RenderSettings) -> Result<Renderer, RenderError> {
        let frame = &self.sequence.frames()[k];
        let base = self
            .latest
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .as_ref()
            .filter(|(scene, _)| Arc::ptr_eq(scene, &frame.scene))
            .map(|(_, r)| r.clone());
        if let Some(r) = base.and_then(|b| b.with_view(&frame.view, settings).ok()) {
            return Ok(r);
        }
        let r = Arc::new(Renderer::new(&frame.description(), settings)?);
        *self.latest.lock().unwrap_or_else(|e| e.into_inner()) =
            Some((frame.scene.clone(), r.clone()));
        r.with_view(&frame.view, settings)
    }
}
