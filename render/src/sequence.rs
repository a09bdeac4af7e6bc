//! A sequence: many frames rendered as one job. Each frame is a scene and the view it is seen
//! from; frames that only move the camera share one scene (an [`Arc`]), so a thousand-frame
//! orbit holds one description. A sequence is made from several scenes (each its own frame,
//! seen from its own view) or from one scene and a camera path ([`Sequence::orbit`]).
//!
//! ## The orbit
//! `orbit(scene, degrees, n)` turns the eye about the look-at point, around the axis through
//! `at` along the view's `up` vector: frame k is turned by k · degrees / n, so n frames of 360°
//! close the circle without repeating frame 0. The `at` point and the `up` vector are kept;
//! only `from` moves. The turn is Rodrigues' rotation of `from − at` about the unit axis
//! `k = up / |up|`, all in `f64`:
//!
//! `v' = v cos θ + (k × v) sin θ + k (k · v)(1 − cos θ)`,  `from' = at + v'`.
//!
//! A positive angle turns counter-clockwise seen from the tip of `up` looking down (the right
//! hand rule). Frame 0 is the scene's own view, used unchanged: it is never recomputed at angle
//! 0, since rounding could move the eye by an ulp and change pixels. The eye keeps its distance
//! to `at` and its angle to `up`, so a view that is valid at frame 0 is valid at every frame.
//! The rotation is undefined only when `up` gives no axis (zero or not finite); an `up`
//! parallel to the view direction is a defined rotation (the eye lies on the axis and stays),
//! but the parser has already refused that view as degenerate.

use crate::description::{SceneDescription, View};
use crate::vec3::Vec3d;
use std::borrow::Cow;
use std::sync::Arc;

/// Why a sequence cannot be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SequenceError {
    /// No frames asked for.
    #[error("a sequence needs at least one frame (--frames 0 renders nothing)")]
    NoFrames,
    /// The orbit's angle is not a finite number.
    #[error("--orbit {0}: the angle must be a finite number of degrees")]
    NotFinite(f64),
    /// The view's up vector gives no rotation axis.
    #[error(
        "--orbit turns the eye about the up vector, and this view's up ({0:?}) is zero or not \
         finite, so there is no axis to turn about"
    )]
    NoAxis([f64; 3]),
}

/// One frame: a scene (shared between frames that only move the camera) and its view.
#[derive(Clone, Debug)]
pub struct Frame {
    /// The scene; its own view is replaced by [`Frame::view`].
    pub scene: Arc<SceneDescription>,
    /// The view this frame is seen from.
    pub view: View,
}

impl From<SceneDescription> for Frame {
    /// The frame of a scene seen from its own view.
    fn from(desc: SceneDescription) -> Self {
        let view = desc.view.clone();
        Frame {
            scene: Arc::new(desc),
            view,
        }
    }
}

impl Frame {
    /// The description of this frame alone: the scene itself when the view is its own, else a
    /// copy with the view replaced (what rendering this frame on its own would read).
    pub fn description(&self) -> Cow<'_, SceneDescription> {
        if self.scene.view == self.view {
            Cow::Borrowed(&*self.scene)
        } else {
            let mut d = (*self.scene).clone();
            d.view = self.view.clone();
            Cow::Owned(d)
        }
    }
}

/// Frames in order, frame 0 first.
#[derive(Clone, Debug)]
pub struct Sequence {
    frames: Vec<Frame>,
}

impl Sequence {
    /// One frame per scene, each seen from its own view. Refuses an empty list.
    pub fn from_scenes(scenes: Vec<SceneDescription>) -> Result<Self, SequenceError> {
        if scenes.is_empty() {
            return Err(SequenceError::NoFrames);
        }
        let frames = scenes.into_iter().map(Frame::from).collect();
        Ok(Sequence { frames })
    }

    /// `frames` frames of `scene`, frame k with the eye turned by k · `degrees` / `frames`
    /// about the look-at point around the up vector (see the module's documentation). Frame 0
    /// is the scene's own view. The frames share the scene.
    pub fn orbit(
        scene: SceneDescription,
        degrees: f64,
        frames: usize,
    ) -> Result<Self, SequenceError> {
        if frames == 0 {
            return Err(SequenceError::NoFrames);
        }
        if !degrees.is_finite() {
            return Err(SequenceError::NotFinite(degrees));
        }
        let up = scene.view.up;
        let len = up.length();
        if !(len > 0.0) || !len.is_finite() {
            return Err(SequenceError::NoAxis([up.x, up.y, up.z]));
        }
        let scene = Arc::new(scene);
        let frames = (0..frames)
            .map(|k| {
                let view = if k == 0 {
                    scene.view.clone()
                } else {
                    let angle = (k as f64 * degrees / frames as f64).to_radians();
                    turned(&scene.view, angle)
                };
                Frame {
                    scene: scene.clone(),
                    view,
                }
            })
            .collect();
        Ok(Sequence { frames })
    }

    /// The frames, frame 0 first.
    pub fn frames(&self) -> &[Frame] {
        &self.frames
    }

    /// How many frames.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Never true: a sequence has at least one frame.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }
}

/// `view` with its eye turned by `radians` about the axis through `at` along `up` (Rodrigues'
/// rotation in `f64`); `at`, `up` and everything else kept. `up` must be non-zero.
pub fn turned(view: &View, radians: f64) -> View {
    let k = view.up.normalize();
    let v = view.from - view.at;
    let (sin, cos) = radians.sin_cos();
    let turned: Vec3d = v * cos + k.cross(v) * sin + k * (k.dot(v) * (1.0 - cos));
    View {
        from: view.at + turned,
        ..view.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene() -> SceneDescription {
        let text = "v from 0 -10 2 at 0 0 2 up 0 0 1 angle 40 hither 0.01 resolution 16 8\n\
                    l 5 5 5\nf 1 0 0 1 0 0 0 0\ns 0 0 0 1\n";
        crate::nff::parse(text, "t.nff", &crate::nff::Limits::default()).unwrap()
    }

    #[test]
    fn frame_zero_is_the_scene_view_and_frames_share_the_scene() {
        let d = scene();
        let s = Sequence::orbit(d.clone(), 360.0, 4).unwrap();
        assert_eq!(s.len(), 4);
        assert_eq!(s.frames()[0].view, d.view);
        assert!(matches!(s.frames()[0].description(), Cow::Borrowed(_)));
        assert!(Arc::ptr_eq(&s.frames()[0].scene, &s.frames()[3].scene));
    }

    #[test]
    fn a_quarter_turn_is_counter_clockwise_about_up() {
        let s = Sequence::orbit(scene(), 360.0, 4).unwrap();
        let f = s.frames()[1].view.from;
        // (0, -10) turned by +90° about +z is (10, 0); the height is kept.
        assert!((f - Vec3d::new(10.0, 0.0, 2.0)).length() < 1e-12, "{f:?}");
        let half = s.frames()[2].view.from;
        assert!(
            (half - Vec3d::new(0.0, 10.0, 2.0)).length() < 1e-12,
            "{half:?}"
        );
        assert_eq!(s.frames()[1].view.at, scene().view.at);
        assert_eq!(s.frames()[1].view.up, scene().view.up);
        assert_eq!(s.frames()[3].description().view, s.frames()[3].view);
    }

    #[test]
    fn bad_orbits_are_refused() {
        assert_eq!(
            Sequence::orbit(scene(), 90.0, 0).unwrap_err(),
            SequenceError::NoFrames
        );
        assert!(matches!(
            Sequence::orbit(scene(), f64::NAN, 3).unwrap_err(),
            SequenceError::NotFinite(_)
        ));
        let mut d = scene();
        d.view.up = Vec3d::zero();
        assert!(matches!(
            Sequence::orbit(d, 90.0, 3).unwrap_err(),
            SequenceError::NoAxis(_)
        ));
        assert_eq!(
            Sequence::from_scenes(vec![]).unwrap_err(),
            SequenceError::NoFrames
        );
    }
}
