//! The one task on the server's thread that turns what the renderer noted into events for the
//! pages: every [`PUSH_EVERY`] the tiles landed since become one `tiles` event (one PNG, encoded
//! once, the same bytes sent to every page; more events for very many tiles), and the status,
//! when it changed and was last sent at least [`STATUS_EVERY`] ago, one `status` (`done` once
//! the render ended). With no page open it sleeps.
//!
//! Tiles go at full resolution while they land at up to the full rate (`--http-full-rate`,
//! pixels a second); a tick whose tiles came faster sends them averaged over 2×2, 4×4 or 8×8
//! blocks, the least coarse that brings them under the rate ([`preview_scale`]). What watching
//! costs is so bounded by the rate, not by how fast the render runs; the page gets the whole
//! image at full resolution when the render ends.

use super::encode::{event, tiles_events, Scratch};
use super::limits::{MAX_PREVIEW_SCALE, PUSH_EVERY, STATUS_EVERY};
use super::state::{LiveState, Phase};
use std::sync::Arc;
use tokio::time::Instant;

/// The batcher's memory between ticks.
pub struct Batcher {
    state: Arc<LiveState>,
    sent_version: Option<u64>,
    status_at: Option<Instant>,
    /// Pixels a second sent at full resolution.
    full_rate: f64,
    /// The last tick while a page was open (`None` after none was).
    ticked: Option<Instant>,
    /// The landed tiles' pixels and the encoder's memory, kept from tick to tick.
    rgb: Vec<u8>,
    scratch: Scratch,
}

impl Batcher {
    /// A batcher of `state`'s events, sending tiles at full resolution up to `full_rate`
    /// pixels a second.
    pub fn new(state: Arc<LiveState>, full_rate: f64) -> Self {
        Batcher {
            state,
            sent_version: None,
            status_at: None,
            full_rate,
            ticked: None,
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
            self.ticked = None;
            return;
        }
        let since = self
            .ticked
            .map_or(PUSH_EVERY, |t| now.duration_since(t))
            .max(PUSH_EVERY);
        self.ticked = Some(now);
        if landed.overflow {
            self.state.send(event("reload", "overflow"));
        } else {
            let pixels = landed.tiles.iter().map(|t| t.pixel_count()).sum();
            let scale = preview_scale(pixels, since, self.full_rate);
            for e in tiles_events(&landed.tiles, &self.rgb, scale, &mut self.scratch) {
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

/// The scale a tick sends `pixels` landed over `since` at: 1 (full resolution) when they came
/// at up to `full_rate` pixels a second, else the least of 2, 4, … [`MAX_PREVIEW_SCALE`]
/// that brings their `pixels / scale²` under it (the largest when none does).
pub fn preview_scale(pixels: usize, since: std::time::Duration, full_rate: f64) -> u32 {
    let budget = full_rate * since.as_secs_f64();
    let mut scale = 1;
    while scale < MAX_PREVIEW_SCALE && pixels as f64 > budget * f64::from(scale * scale) {
        scale *= 2;
    }
    scale
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
    use crate::live::state::tests::land;
    use crate::live::state::JobInfo;
    use parrt_runtime::observer::Observer;
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
        let mut batcher = Batcher::new(s.clone(), 1e6);
        let t0 = Instant::now();
        let list = parrt_render::tile::tiles(4, 2, 2);
        land(&s, 0, &list[1], &[[1.0, 0.0, 0.0]; 4], 1);
        land(&s, 0, &list[0], &[[0.0, 0.0, 1.0]; 4], 1);
        batcher.tick(t0);
        let (ta, tb) = (a.try_recv().unwrap(), b.try_recv().unwrap());
        assert_eq!(ta.as_ptr(), tb.as_ptr(), "one encoding, shared");
        let tiles = crate::live::encode::tests::decode_tiles(&ta);
        let got: Vec<_> = tiles
            .iter()
            .map(|(t, _, px)| ((t.x, t.y, t.w, t.h), &px[..]))
            .collect();
        let (red, blue) = ([255, 0, 0].repeat(4), [0, 0, 255].repeat(4));
        assert_eq!(got, [((2, 0, 2, 2), &red[..]), ((0, 0, 2, 2), &blue[..])]);
        assert_eq!(name(&a.try_recv().unwrap()), "status");
        // Nothing landed, the status was sent 100 ms ago: nothing.
        batcher.tick(t0 + Duration::from_millis(100));
        assert!(a.try_recv().is_err());
        s.finished(true, tokio::time::Instant::now());
        // Changed, but not due until 250 ms after the last.
        batcher.tick(t0 + Duration::from_millis(200));
        assert!(a.try_recv().is_err());
        batcher.tick(t0 + Duration::from_millis(300));
        assert_eq!(name(&a.try_recv().unwrap()), "done");
    }

    #[test]
    fn preview_scale_is_the_least_that_brings_the_tiles_under_the_full_rate() {
        let tick = Duration::from_millis(100);
        // At 1 Mpx/s, 100 000 pixels a tick go at full resolution, 4 × as many at 2, ...
        for (pixels, since, want) in [
            (0, tick, 1),
            (100_000, tick, 1),
            (100_001, tick, 2),
            (400_000, tick, 2),
            (400_001, tick, 4),
            (1_600_001, tick, 8),
            (usize::MAX, tick, MAX_PREVIEW_SCALE),
            (400_000, 4 * tick, 1),
        ] {
            assert_eq!(
                preview_scale(pixels, since, 1e6),
                want,
                "{pixels} in {since:?}"
            );
        }
    }

    #[test]
    fn tiles_that_land_too_fast_go_as_block_means() {
        let s = state();
        let mut rx = s.subscribe();
        // 20 pixels a second at full resolution, 2 a tick: the two 2 × 2 tiles (8 pixels) go
        // as one mean each (8 / 2² = 2).
        let mut batcher = Batcher::new(s.clone(), 20.0);
        let list = parrt_render::tile::tiles(4, 2, 2);
        let one_red = [[1.0, 0.0, 0.0], [0.0; 3], [0.0; 3], [0.0; 3]];
        land(&s, 0, &list[0], &one_red, 1);
        land(&s, 0, &list[1], &[[0.0, 0.0, 1.0]; 4], 1);
        let t0 = Instant::now();
        batcher.tick(t0);
        let tiles = crate::live::encode::tests::decode_tiles(&rx.try_recv().unwrap());
        let got: Vec<_> = tiles
            .iter()
            .map(|(t, scale, px)| ((t.x, t.y, t.w, t.h), *scale, &px[..]))
            .collect();
        assert_eq!(
            got,
            [
                ((0, 0, 2, 2), 2, &[64, 0, 0][..]),
                ((2, 0, 2, 2), 2, &[0, 0, 255][..])
            ]
        );
        // One tile over four ticks' time: under the rate, at full resolution.
        land(&s, 0, &list[0], &one_red, 1);
        while rx.try_recv().is_ok() {}
        batcher.tick(t0 + Duration::from_millis(400));
        let tiles = crate::live::encode::tests::decode_tiles(&rx.try_recv().unwrap());
        assert_eq!(tiles.len(), 1);
        assert_eq!((tiles[0].1, &tiles[0].2[..3]), (1, &[255, 0, 0][..]));
    }

    #[test]
    fn more_tiles_than_noted_make_the_pages_reload() {
        let s = state();
        let mut rx = s.subscribe();
        let mut batcher = Batcher::new(s.clone(), 1e6);
        let tile = parrt_render::tile::tiles(4, 2, 2)[0];
        for _ in 0..3 {
            land(&s, 0, &tile, &[[0.0; 3]; 4], 1);
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
        let mut batcher = Batcher::new(s.clone(), 1e6);
        let tile = parrt_render::tile::tiles(4, 2, 2)[0];
        land(&s, 0, &tile, &[[0.0; 3]; 4], 1);
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
