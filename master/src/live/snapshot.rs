//! The frame as `GET /frame` and `GET /image.png` serve it: one snapshot shared by every
//! response (reference-counted bytes, copied from the frame in bands so the render never waits
//! for it; its PNG encoded once, off the server's thread), taken again at most every
//! [`SNAPSHOT_EVERY`], and at most [`MAX_IMAGE_RESPONSES`] responses at once. Unread responses
//! so pin at most that many snapshots, not a frame each.
//!
//! A snapshot is taken again, whatever its age, when a page was told to reload since it was
//! taken (the page must see every tile that landed before its stream opened) and when the
//! render ended with tiles it lacks (the last frame is served exactly).

use super::encode::png_into;
use super::limits::{MAX_IMAGE_RESPONSES, SNAPSHOT_EVERY};
use super::state::LiveState;
use bytes::Bytes;
use std::sync::{Arc, Mutex};
use std::time::Instant;
use tokio::sync::{OnceCell, OwnedSemaphorePermit, Semaphore};

/// One copy of the frame, and its PNG once asked for.
pub struct Snapshot {
    /// 8-bit RGB, row by row.
    pub rgb: Bytes,
    /// Image width and height.
    pub size: (u32, u32),
    png: OnceCell<Bytes>,
    taken: Instant,
    landed: u64,
    reloads: u64,
}

/// The current snapshot and the responses' permits.
pub struct Snapshots {
    state: Arc<LiveState>,
    current: Mutex<Option<Arc<Snapshot>>>,
    responses: Arc<Semaphore>,
}

/// What an image response holds while its body is sent: the snapshot and its place among the
/// [`MAX_IMAGE_RESPONSES`].
pub struct Lease {
    /// The snapshot to send.
    pub snapshot: Arc<Snapshot>,
    _permit: OwnedSemaphorePermit,
}

impl Snapshots {
    /// Snapshots of `state`'s frame.
    pub fn new(state: Arc<LiveState>) -> Self {
        Snapshots {
            state,
            current: Mutex::new(None),
            responses: Arc::new(Semaphore::new(MAX_IMAGE_RESPONSES)),
        }
    }

    /// A snapshot to send and a place to send it from; `None` when
    /// [`MAX_IMAGE_RESPONSES`] are being sent already.
    pub fn lease(&self) -> Option<Lease> {
        let permit = self.responses.clone().try_acquire_owned().ok()?;
        Some(Lease {
            snapshot: self.fresh(),
            _permit: permit,
        })
    }

    /// The current snapshot, taken again if it is too old (see the module's doc).
    pub fn fresh(&self) -> Arc<Snapshot> {
        let mut current = self.current.lock().unwrap_or_else(|e| e.into_inner());
        let landed = self.state.landed_total();
        let reloads = self.state.reloads();
        if let Some(s) = &*current {
            let same = s.landed == landed;
            let young = s.taken.elapsed() < SNAPSHOT_EVERY;
            if s.reloads == reloads && (same || (young && !self.state.ended())) {
                return s.clone();
            }
        }
        let status = self.state.status();
        let mut rgb = Vec::new();
        self.state.copy_frame(&mut rgb);
        let s = Arc::new(Snapshot {
            rgb: Bytes::from(rgb),
            size: (status.width, status.height),
            png: OnceCell::new(),
            taken: Instant::now(),
            landed,
            reloads,
        });
        *current = Some(s.clone());
        s
    }
}

impl Snapshot {
    /// The snapshot as a PNG, encoded once (on the blocking pool, not the server's thread).
    pub async fn png(self: &Arc<Self>) -> anyhow::Result<Bytes> {
        let me = self.clone();
        self.png
            .get_or_try_init(|| async move {
                let encoded = tokio::task::spawn_blocking(move || {
                    let mut out = Vec::new();
                    png_into(&me.rgb, me.size.0, me.size.1, &mut out).map(|()| Bytes::from(out))
                })
                .await?;
                anyhow::Ok(encoded?)
            })
            .await
            .cloned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::live::state::tests::land;
    use crate::live::state::JobInfo;

    fn state() -> Arc<LiveState> {
        LiveState::new(JobInfo {
            scene: "test".into(),
            mode: "smp",
            width: 4,
            height: 2,
            tile_size: 2,
        })
    }

    #[test]
    fn responses_share_one_snapshot_and_are_capped() {
        let s = state();
        let snaps = Snapshots::new(s.clone());
        let leases: Vec<Lease> = (0..MAX_IMAGE_RESPONSES)
            .map(|_| snaps.lease().expect("a place"))
            .collect();
        assert!(snaps.lease().is_none(), "past the cap");
        for l in &leases {
            assert_eq!(l.snapshot.rgb.as_ptr(), leases[0].snapshot.rgb.as_ptr());
        }
        drop(leases);
        assert!(snaps.lease().is_some(), "a place again");
    }

    #[test]
    fn a_snapshot_is_taken_again_after_a_reload_or_the_end_whatever_its_age() {
        let s = state();
        let snaps = Snapshots::new(s.clone());
        let tiles = parrt_render::tile::tiles(4, 2, 2);
        let first = snaps.fresh();
        land(&s, 0, &tiles[0], &[[1.0; 3]; 4], 1);
        // Young and nothing asked for a reload: the same one (a page may be 100 ms behind).
        assert!(Arc::ptr_eq(&first, &snaps.fresh()));
        let _rx = s.subscribe();
        let second = snaps.fresh();
        assert!(!Arc::ptr_eq(&first, &second), "a page reloads: taken again");
        assert_eq!(&second.rgb[..3], &[255, 255, 255]);
        land(&s, 0, &tiles[1], &[[1.0; 3]; 4], 1);
        assert!(Arc::ptr_eq(&second, &snaps.fresh()));
        parrt_runtime::observer::Observer::finished(&*s, true, tokio::time::Instant::now());
        let last = snaps.fresh();
        assert_eq!(&last.rgb[..], &[255; 24][..], "the end is served exactly");
        assert!(Arc::ptr_eq(&last, &snaps.fresh()), "and then kept");
    }
}
