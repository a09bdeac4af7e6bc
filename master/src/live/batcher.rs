//! The one task on the server's thread that turns what the renderer noted into events for the
//! pages: every [`PUSH_EVERY`] the tiles landed since become one `tiles` event (one PNG, encoded
//! once, the same bytes sent to every page; more events for very many tiles), and the status,
//! when it changed and was last sent at least [`STATUS_EVERY`] ago, one `status` (`done` once
//! the render ended). With no page open it sleeps.

use super::encode::{event, tiles_events, Scratch};
use super::limits::{PUSH_EVERY, STATUS_EVERY};
use super::state::{LiveState, Phase};
use std::sync::Arc;
use tokio::time::Instant;

/// The batcher's memory between ticks.
pub struct Batcher {
    state: Arc<LiveState>,
    sent_version: Option<u64>,
    status_at: Option<Instant>,
    /// The landed tiles' pixels and the encoder's memory, kept from tick to tick.
    rgb: Vec<u8>,
    scratch: Scratch,
}

impl Batcher {
    /// A batcher of `state`'s events.
    pub fn new(state: Arc<LiveState>) -> Self {
        Batcher {
            state,
            sent_version: None,
            status_at: None,
            rgb: Vec::new(),
            scratch: Scratch::default(),
        }
    }

    /// Runs until the runtime stops.
    pub async fn run(mut self) {
        let mut tick = tokio::time::interval(PUSH_EVERY);
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        loop {
            if !self.state.watched() {
                self.sent_version = None;
                self.state.page_opened().await;
            }
            tick.tick().await;
            self.tick(Instant::now());
        }
    }

    /// One tick at `now`: sends what is due to the open pages.
    pub fn tick(&mut self, now: Instant) {
        let landed = self.state.take_landed(&mut self.rgb);
        if !self.state.watched() {
            self.sent_version = None;
            return;
        }
        if landed.overflow {
            self.state.send(event("reload", "overflow"));
        } else {
            for e in tiles_events(&landed.tiles, &self.rgb, &mut self.scratch) {
                self.state.send(e);
            }
        }
        let v = self.state.version();
        let due = self
            .status_at
            .is_none_or(|t| now.duration_since(t) >= STATUS_EVERY);
        if self.sent_version != Some(v) && due {
            self.sent_version = Some(v);
            self.status_at = Some(now);
            self.state.send(status_event(&self.state));
        }
    }
}

/// The status as an event: `status`, or `done` once the render ended.
pub fn status_event(state: &LiveState) -> bytes::Bytes {
    let s = state.status();
    let name = if matches!(s.state, Phase::Done | Phase::Failed) {
        "done"
    } else {
        "status"
    };
    event(
        name,
        &serde_json::to_string(&s).unwrap_or_else(|_| "{}".into()),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::live::state::JobInfo;
    use std::time::Duration;

    fn state() -> Arc<LiveState> {
        LiveState::new(JobInfo {
            scene: "test".into(),
            mode: "smp",
            width: 4,
            height: 2,
            tile_size: 2,
        })
    }

    fn name(e: &[u8]) -> &str {
        let e = std::str::from_utf8(e).expect("text");
        e.lines()
            .next()
            .and_then(|l| l.strip_prefix("event: "))
            .expect("an event")
    }

    #[test]
    fn one_tiles_event_per_tick_the_same_bytes_for_every_page() {
        let s = state();
        let (mut a, mut b) = (s.subscribe(), s.subscribe());
        let mut batcher = Batcher::new(s.clone());
        let t0 = Instant::now();
        let list = parrt::tile::tiles(4, 2, 2);
        s.tile_done(0, &list[1], &[[1.0, 0.0, 0.0]; 4], 1);
        s.tile_done(0, &list[0], &[[0.0, 0.0, 1.0]; 4], 1);
        batcher.tick(t0);
        let (ta, tb) = (a.try_recv().unwrap(), b.try_recv().unwrap());
        assert_eq!(ta.as_ptr(), tb.as_ptr(), "one encoding, shared");
        let tiles = crate::live::encode::tests::decode_tiles(&ta);
        let got: Vec<_> = tiles
            .iter()
            .map(|(t, px)| ((t.x, t.y, t.w, t.h), &px[..]))
            .collect();
        let (red, blue) = ([255, 0, 0].repeat(4), [0, 0, 255].repeat(4));
        assert_eq!(got, [((2, 0, 2, 2), &red[..]), ((0, 0, 2, 2), &blue[..])]);
        assert_eq!(name(&a.try_recv().unwrap()), "status");
        // Nothing landed, the status was sent 100 ms ago: nothing.
        batcher.tick(t0 + Duration::from_millis(100));
        assert!(a.try_recv().is_err());
        s.finish(true);
        // Changed, but not due until 250 ms after the last.
        batcher.tick(t0 + Duration::from_millis(200));
        assert!(a.try_recv().is_err());
        batcher.tick(t0 + Duration::from_millis(300));
        assert_eq!(name(&a.try_recv().unwrap()), "done");
    }

    #[test]
    fn more_tiles_than_noted_make_the_pages_reload() {
        let s = state();
        let mut rx = s.subscribe();
        let mut batcher = Batcher::new(s.clone());
        let tile = parrt::tile::tiles(4, 2, 2)[0];
        for _ in 0..3 {
            s.tile_done(0, &tile, &[[0.0; 3]; 4], 1);
        }
        batcher.tick(Instant::now());
        assert_eq!(
            &rx.try_recv().unwrap()[..],
            b"event: reload\ndata: overflow\n\n"
        );
    }

    #[test]
    fn with_no_page_open_nothing_is_made() {
        let s = state();
        let mut batcher = Batcher::new(s.clone());
        let tile = parrt::tile::tiles(4, 2, 2)[0];
        s.tile_done(0, &tile, &[[0.0; 3]; 4], 1);
        batcher.tick(Instant::now());
        let mut rx = s.subscribe();
        assert!(rx.try_recv().is_err());
        batcher.tick(Instant::now());
        assert_eq!(
            name(&rx.try_recv().unwrap()),
            "status",
            "no tiles: none landed since"
        );
    }
}
