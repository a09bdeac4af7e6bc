//! The worker's real session code over an in-memory stream, driven by a scripted master: with
//! the inline executor it renders the same pixels as the renderer itself, and its simulated
//! costs advance tokio's paused clock by exactly what was configured; with the rayon executor
//! the pixels are the same. Also: a seeded nonce repeats run after run. The scripted master
//! speaks inside the encrypted channel the worker opens, as a real master does.

use parrt_protocol::message::NONCE_LEN;
use parrt_protocol::{
    Connection, JobSpec, LinkKey, Message, PixelFormat, SecureStream, TilePixels, Token,
    DEFAULT_MAX_FRAME, PROTOCOL_VERSION,
};
use parrt_render::description::SceneDescription;
use parrt_render::render::Renderer;
use parrt_render::settings::RenderSettings;
use parrt_render::stats::RayStats;
use parrt_render::tile::{tiles, Tile};
use parrt_worker::exec::{Execute, InlineExec, RayonExec};
use parrt_worker::net::Preconnected;
use parrt_worker::session::{self, SessionEnd, SessionSummary};
use parrt_worker::{WorkerError, WorkerOptions};
use std::time::Duration;
use tokio::io::DuplexStream;
use tokio::task::JoinHandle;
use tokio::time::Instant;
use tokio_util::sync::CancellationToken;

const SIZE: u32 = 16;
const TILE: u32 = 8;
const JOB: u64 = 42;

fn scene() -> SceneDescription {
    parrt_test_support::scene::one_sphere(SIZE)
}

fn job() -> JobSpec {
    JobSpec {
        job_id: JOB,
        scene: scene(),
        settings: RenderSettings::new(SIZE, SIZE),
        tile_size: TILE,
        pixel_format: PixelFormat::F32,
        pack_pixels: true,
    }
}

fn token() -> Token {
    Token::new("sim secret").unwrap()
}

/// The master's end of the encrypted channel the worker opens first.
type Secure = SecureStream<DuplexStream>;

async fn secure(end: DuplexStream) -> Secure {
    parrt_protocol::channel::accept(end, &LinkKey::from_token(&token()), None)
        .await
        .expect("the worker opens the channel with our token")
}

fn options(threads: usize) -> WorkerOptions {
    let mut o = WorkerOptions::new("master.sim:7878", token());
    o.threads = threads;
    o.name = "sim-worker".into();
    o.tile_delay = None;
    o.nonce_seed = Some(7);
    o
}

/// Runs a worker session over the given streams on its own task.
fn spawn_worker<E: Execute + 'static>(
    opts: WorkerOptions,
    streams: Vec<DuplexStream>,
    exec: E,
) -> JoinHandle<Result<SessionSummary, WorkerError>> {
    tokio::spawn(async move {
        let dial = Preconnected::new(streams);
        session::run_with(&opts, CancellationToken::new(), &dial, exec).await
    })
}

/// The master's side of the handshake; returns the threads the worker announced.
async fn accept(conn: &mut Connection<Secure>) -> u32 {
    let Some(Message::Hello {
        version,
        threads,
        nonce,
        ..
    }) = conn.read().await.unwrap()
    else {
        panic!("expected Hello");
    };
    assert_eq!(version, PROTOCOL_VERSION);
    let ours = [9u8; NONCE_LEN];
    let proof = token().master_proof(&nonce, &ours);
    conn.write(&Message::Challenge { nonce: ours, proof })
        .await
        .unwrap();
    let Some(Message::Auth { mac }) = conn.read().await.unwrap() else {
        panic!("expected Auth");
    };
    assert!(token().verify_worker_proof(&ours, &nonce, &mac));
    conn.write(&Message::Welcome).await.unwrap();
    threads
}

/// The next message that is not a heartbeat.
async fn next(conn: &mut Connection<Secure>) -> Message {
    loop {
        match conn.read().await.unwrap() {
            Some(Message::Heartbeat) => {}
            Some(m) => return m,
            None => panic!("the worker closed the connection"),
        }
    }
}

/// What the renderer itself gives for `tile`, as the wire carries it.
fn expected(tile: &Tile) -> (TilePixels, RayStats) {
    let r = Renderer::new(&scene(), &RenderSettings::new(SIZE, SIZE)).unwrap();
    let (mut px, mut stats) = (Vec::new(), RayStats::default());
    r.render_tile(tile, &mut px, &mut stats);
    (TilePixels::encode(&px, PixelFormat::F32), stats)
}

/// Checks a batch's results: one per tile, in tile order, with the renderer's pixels and
/// statistics; returns the seconds each reported.
fn check_results(msgs: &[Message], batch: &[(Tile, u32)]) -> Vec<f64> {
    assert_eq!(msgs.len(), batch.len());
    let mut seconds = Vec::new();
    for (m, (tile, attempt)) in msgs.iter().zip(batch) {
        let Message::TileResult {
            job_id,
            tile_id,
            attempt: a,
            pixels,
            stats,
            seconds: s,
        } = m
        else {
            panic!("expected a TileResult, got {}", m.kind());
        };
        assert_eq!((*job_id, *tile_id, *a), (JOB, tile.id, *attempt));
        let (want_px, want_stats) = expected(tile);
        let got = pixels.clone().unpack(tile.pixel_count()).unwrap();
        assert_eq!(got, want_px, "tile {} pixels differ", tile.id);
        assert_eq!(*stats, want_stats, "tile {} statistics differ", tile.id);
        seconds.push(*s);
    }
    seconds
}

/// Reads `n` TileResults (they come back in one write per batch; order within the lot is the
/// executor's), returned in the order read.
async fn results(conn: &mut Connection<Secure>, n: usize) -> Vec<Message> {
    let mut got = Vec::new();
    while got.len() < n {
        got.push(next(conn).await);
    }
    got
}

/// Plays a master that builds a job, assigns three tiles in one batch, and shuts down; checks
/// virtual time at each step. Returns (build wait, batch wait, the results' seconds).
async fn scripted_run(threads: usize, build_cost: Duration) -> (Duration, Duration, Vec<f64>) {
    let (ours, theirs) = tokio::io::duplex(1 << 20);
    let cost = |t: &Tile| Duration::from_millis([100, 300, 200, 50][t.id as usize]);
    let exec = InlineExec::new(cost).with_build_cost(build_cost);
    let worker = spawn_worker(options(threads), vec![theirs], exec);
    let mut conn = Connection::new(secure(ours).await, DEFAULT_MAX_FRAME);
    assert_eq!(accept(&mut conn).await, threads as u32);

    let t0 = Instant::now();
    conn.write(&Message::Job(Box::new(job()))).await.unwrap();
    let Message::Ready { job_id, build_s } = next(&mut conn).await else {
        panic!("expected Ready");
    };
    let build_wait = t0.elapsed();
    assert_eq!(job_id, JOB);
    assert_eq!(build_s, build_cost.as_secs_f64());

    let list = tiles(SIZE, SIZE, TILE);
    let batch: Vec<(Tile, u32)> = list[..3].iter().map(|t| (*t, 1)).collect();
    let t1 = Instant::now();
    conn.write(&Message::AssignBatch {
        job_id: JOB,
        tiles: batch.clone(),
    })
    .await
    .unwrap();
    let msgs = results(&mut conn, batch.len()).await;
    let batch_wait = t1.elapsed();
    let seconds = check_results(&msgs, &batch);

    conn.write(&Message::Shutdown).await.unwrap();
    let summary = worker.await.unwrap().unwrap();
    assert_eq!(summary.end, SessionEnd::Shutdown);
    assert_eq!((summary.jobs, summary.tiles_rendered), (1, 3));
    (build_wait, batch_wait, seconds)
}

#[tokio::test(start_paused = true)]
async fn inline_session_renders_real_pixels_in_simulated_time() {
    // One thread: the tiles run one after the other, 100 + 300 + 200 ms.
    let (build, batch, seconds) = scripted_run(1, Duration::from_secs(2)).await;
    assert_eq!(build, Duration::from_secs(2));
    assert_eq!(batch, Duration::from_millis(600));
    assert_eq!(seconds, [0.1, 0.3, 0.2]);
    // Two threads take tiles first come, first served: tile 0 (0-100 ms) then tile 2
    // (100-300 ms) on one, tile 1 (0-300 ms) on the other; the batch is done at 300 ms.
    let (build, batch, _) = scripted_run(2, Duration::ZERO).await;
    assert_eq!(build, Duration::ZERO);
    assert_eq!(batch, Duration::from_millis(300));
}

#[tokio::test(start_paused = true)]
async fn inline_session_given_pixels_and_early_tiles() {
    let (ours, theirs) = tokio::io::duplex(1 << 20);
    let exec = InlineExec::constant(Duration::from_millis(40))
        .with_build_cost(Duration::from_secs(1))
        .with_pixels(|t: &Tile, out: &mut Vec<[f32; 3]>| {
            out.extend((0..t.pixel_count()).map(|i| [t.id as f32, i as f32, 0.5]));
            Ok(())
        });
    let worker = spawn_worker(options(4), vec![theirs], exec);
    let mut conn = Connection::new(secure(ours).await, DEFAULT_MAX_FRAME);
    accept(&mut conn).await;
    let t0 = Instant::now();
    conn.write(&Message::Job(Box::new(job()))).await.unwrap();
    // Assigned before the renderer is ready: held, then rendered once it is.
    let list = tiles(SIZE, SIZE, TILE);
    conn.write(&Message::Assign {
        job_id: JOB,
        tile: list[3],
        attempt: 2,
    })
    .await
    .unwrap();
    assert!(matches!(next(&mut conn).await, Message::Ready { .. }));
    let Message::TileResult {
        tile_id,
        attempt,
        pixels,
        stats,
        ..
    } = next(&mut conn).await
    else {
        panic!("expected a TileResult");
    };
    assert_eq!(t0.elapsed(), Duration::from_millis(1040));
    assert_eq!((tile_id, attempt), (3, 2));
    let want: Vec<[f32; 3]> = (0..list[3].pixel_count())
        .map(|i| [3.0, i as f32, 0.5])
        .collect();
    // f32 pixels travel raw (only 8-bit ones are packed).
    assert_eq!(pixels, TilePixels::encode(&want, PixelFormat::F32));
    let settings = RenderSettings::new(SIZE, SIZE);
    assert_eq!(
        stats.eye_rays,
        RayStats::expected_eye_rays(&list[3], &settings)
    );
    drop(conn);
    let summary = worker.await.unwrap().unwrap();
    assert_eq!(summary.end, SessionEnd::MasterClosed);
}

#[tokio::test]
async fn rayon_session_over_a_duplex_gives_the_same_pixels() {
    let (ours, theirs) = tokio::io::duplex(1 << 20);
    let worker = spawn_worker(options(2), vec![theirs], RayonExec::new());
    let mut conn = Connection::new(secure(ours).await, DEFAULT_MAX_FRAME);
    accept(&mut conn).await;
    conn.write(&Message::Job(Box::new(job()))).await.unwrap();
    assert!(matches!(next(&mut conn).await, Message::Ready { .. }));
    let batch: Vec<(Tile, u32)> = tiles(SIZE, SIZE, TILE).iter().map(|t| (*t, 1)).collect();
    conn.write(&Message::AssignBatch {
        job_id: JOB,
        tiles: batch.clone(),
    })
    .await
    .unwrap();
    // The pool sends results in the order tiles finish: put them in tile order.
    let mut msgs = results(&mut conn, batch.len()).await;
    msgs.sort_by_key(|m| match m {
        Message::TileResult { tile_id, .. } => *tile_id,
        _ => u32::MAX,
    });
    check_results(&msgs, &batch);
    conn.write(&Message::Shutdown).await.unwrap();
    assert_eq!(worker.await.unwrap().unwrap().end, SessionEnd::Shutdown);
}

/// The Hello nonces of a session whose first handshake is cut after Hello and whose second is
/// refused.
async fn nonces(seed: Option<u64>) -> Vec<[u8; NONCE_LEN]> {
    let (a, a_worker) = tokio::io::duplex(1 << 16);
    let (b, b_worker) = tokio::io::duplex(1 << 16);
    let mut opts = options(1);
    opts.nonce_seed = seed;
    let worker = spawn_worker(
        opts,
        vec![a_worker, b_worker],
        InlineExec::constant(Duration::ZERO),
    );
    let mut got = Vec::new();
    for (i, end) in [a, b].into_iter().enumerate() {
        let mut conn = Connection::new(secure(end).await, DEFAULT_MAX_FRAME);
        let Some(Message::Hello { nonce, .. }) = conn.read().await.unwrap() else {
            panic!("expected Hello");
        };
        got.push(nonce);
        if i == 1 {
            conn.write(&Message::Refused {
                reason: "enough".into(),
            })
            .await
            .unwrap();
        }
    }
    assert!(matches!(
        worker.await.unwrap(),
        Err(WorkerError::Refused(_))
    ));
    got
}

#[tokio::test(start_paused = true)]
async fn seeded_nonces_repeat_and_differ_per_attempt() {
    let first = nonces(Some(11)).await;
    assert_ne!(first[0], first[1], "each attempt needs a fresh nonce");
    assert_eq!(nonces(Some(11)).await, first);
    assert_ne!(nonces(Some(12)).await, first);
    let unseeded = nonces(None).await;
    assert_ne!(unseeded, nonces(None).await);
}
