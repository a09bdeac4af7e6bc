//! A checkpoint disk that stalls for seconds does not stall the master: with the sink behind
//! the background writer, heartbeats keep flowing (no worker is judged silent, though each
//! stall is longer than the heartbeat timeout), every worker stays to the end, the image equals
//! the SMP image, and the sink still receives every tile once the render is over.

use parrt_protocol::Token;
use parrt_render::render::Renderer;
use parrt_render::settings::RenderSettings;
use parrt_render::smp::{render_smp, Executor, SmpOptions};
use parrt_runtime::checkpoint::CheckpointError;
use parrt_runtime::scheduler::AcceptedTile;
use parrt_runtime::sink::{BackgroundWriter, TileSink};
use parrt_runtime::{Master, MasterConfig};
use parrt_worker::WorkerOptions;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio_util::sync::CancellationToken;

/// Sleeps `stall` on every batch, like a disk that hangs; records the tile ids it got.
struct StallingDisk {
    stall: Duration,
    got: Arc<Mutex<Vec<u32>>>,
}

impl TileSink for StallingDisk {
    fn take(&mut self, tiles: Vec<AcceptedTile>) -> Result<(), CheckpointError> {
        std::thread::sleep(self.stall);
        self.got
            .lock()
            .unwrap()
            .extend(tiles.iter().map(|t| t.tile_id));
        Ok(())
    }
    fn close(self: Box<Self>) -> Result<(), CheckpointError> {
        Ok(())
    }
}

/// The scene and settings: balls at 64×48.
fn job() -> (parrt_render::description::SceneDescription, RenderSettings) {
    let desc = parrt_scenes::generate("balls", Some(1)).expect("balls builds");
    (desc, RenderSettings::new(64, 48))
}

/// Renders balls at 64×48 on two in-process workers that give up on a master silent for
/// 2 s, with every accepted batch going to a disk that stalls 2.5 s, behind the background
/// writer or (to show the test can fail) inline on the master's thread.
async fn render_with_stalling_disk(
    background: bool,
) -> (
    Result<parrt_runtime::DistResult, parrt_runtime::DistError>,
    Arc<Mutex<Vec<u32>>>,
) {
    let (desc, settings) = job();
    let token = Token::new("stalled-sink-test").unwrap();
    let mut config = MasterConfig::default();
    config.schedule.tile = 8;
    config.schedule.min_workers = 2;
    config.schedule.wait_workers = Duration::from_secs(if background { 30 } else { 3 });
    config.net.token = Some(token.clone());
    config.net.heartbeat_timeout = Duration::from_secs(2);
    let mut master = Master::bind(&config, token.clone()).await.expect("binds");
    let got = Arc::new(Mutex::new(Vec::new()));
    let disk = StallingDisk {
        stall: Duration::from_millis(2_500),
        got: got.clone(),
    };
    if background {
        let Ok(writer) = BackgroundWriter::start(Box::new(disk), 1) else {
            panic!("no writer thread")
        };
        master.set_sink(Box::new(writer), Vec::new(), 0);
    } else {
        master.set_sink(Box::new(disk), Vec::new(), 0);
    }
    let addr = master.local_addr().to_string();
    let mut workers = Vec::new();
    for i in 0..2 {
        let mut o = WorkerOptions::new(addr.clone(), token.clone());
        o.threads = 1;
        o.name = format!("w{i}");
        o.tile_delay = Some(Duration::from_millis(40)); // ~2 s of work: stalls meet it
        o.master_timeout = Duration::from_secs(2);
        workers.push(tokio::spawn(async move {
            parrt_worker::session::run(&o, CancellationToken::new()).await
        }));
    }
    let r = master
        .render(&desc, &settings, CancellationToken::new())
        .await;
    for w in workers {
        let _ = w.await;
    }
    (r, got)
}

#[tokio::test(flavor = "current_thread")]
async fn a_disk_stalling_longer_than_the_heartbeat_timeout_stalls_nothing() {
    let t0 = Instant::now();
    let (r, got) = render_with_stalling_disk(true).await;
    let r = r.expect("the render ends well");
    let tiles = r.tiles;
    assert!(
        t0.elapsed() > Duration::from_secs(1),
        "the render was long enough to meet stalls"
    );
    for w in &r.per_worker {
        assert!(w.left.is_none(), "{} left: {:?}", w.name, w.left);
        assert!(w.tiles > 0, "{} rendered nothing", w.name);
    }
    let (desc, settings) = job();
    let reference = render_smp(
        &Renderer::new(&desc, &settings).unwrap(),
        &SmpOptions {
            threads: 1,
            tile: 8,
            executor: Executor::Queue,
        },
        &|_, _| {},
    );
    let same = r
        .film
        .pixels
        .iter()
        .zip(&reference.film.pixels)
        .all(|(a, b)| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()));
    assert!(same, "the image differs from the SMP image");
    let mut got = got.lock().unwrap().clone();
    got.sort_unstable();
    assert_eq!(
        got,
        (0..tiles as u32).collect::<Vec<_>>(),
        "every tile reached the disk"
    );
}

/// The same disk written on the master's own thread stalls everything: the workers hear
/// nothing for longer than they wait, and leave.
#[tokio::test(flavor = "current_thread")]
async fn the_same_disk_inline_would_stall_the_master() {
    let (r, _) = render_with_stalling_disk(false).await;
    let left = match &r {
        Ok(r) => r.per_worker.iter().filter(|w| w.left.is_some()).count(),
        Err(_) => 2,
    };
    assert!(
        left > 0,
        "no worker noticed a master stalled 2.5 s at a time"
    );
}
