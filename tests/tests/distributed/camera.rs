//! Frames that only move the camera: a worker renders a View of a job it holds with that job's
//! built scene, the same pixels as the turned scene's own Job; a View of a job it does not hold,
//! or with a view that is no camera, is answered with an Error (never a panic), and the worker
//! goes on. Through `parrt cluster`, an orbit sends each worker its scene once.

use crate::peers::{job, worker_holding_job};
use parrt_protocol::{Message, ViewSpec};
use parrt_render::sequence::turned;
use parrt_render::tile::Tile;
use parrt_tests::*;
use std::time::Duration;
use tokio::time::timeout;

/// The next message past heartbeats.
async fn next<S: tokio::io::AsyncRead + tokio::io::AsyncWrite + Unpin>(
    c: &mut parrt_protocol::Connection<S>,
) -> Message {
    loop {
        match timeout(Duration::from_secs(10), c.read()).await {
            Ok(Ok(Some(Message::Heartbeat))) => {}
            Ok(Ok(Some(m))) => return m,
            other => panic!("no message: {other:?}"),
        }
    }
}

const TILE: Tile = Tile {
    id: 0,
    x: 0,
    y: 0,
    w: 16,
    h: 16,
};

fn view_of(job_id: u64, base_job_id: u64, view: parrt_render::description::View) -> Message {
    let desc = test_scene(16, 16);
    Message::View(Box::new(ViewSpec {
        job_id,
        base_job_id,
        view,
        settings: settings_for(&desc),
        tile_size: 16,
        pixel_format: Default::default(),
        pack_pixels: true,
    }))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_view_of_a_held_job_renders_the_turned_scene_s_pixels() {
    let (_listener, worker, mut c) = worker_holding_job(16).await;
    let desc = test_scene(16, 16);
    let view = turned(&desc.view, 0.7);
    // Job 8: the camera alone; job 9: the turned scene's whole Job, built on its own.
    c.write(&view_of(8, 7, view.clone())).await.unwrap();
    assert!(matches!(
        next(&mut c).await,
        Message::Ready { job_id: 8, .. }
    ));
    let Message::Job(mut whole) = job(16, 16, 16) else {
        unreachable!()
    };
    whole.job_id = 9;
    whole.scene.view = view;
    c.write(&Message::Job(whole)).await.unwrap();
    assert!(matches!(
        next(&mut c).await,
        Message::Ready { job_id: 9, .. }
    ));
    // The base may go: the frame made from it keeps its build.
    c.write(&Message::Cancel { job_id: 7 }).await.unwrap();
    let mut pixels = Vec::new();
    for job_id in [8, 9, 7] {
        c.write(&Message::Assign {
            job_id,
            tile: TILE,
            attempt: 1,
        })
        .await
        .unwrap();
        match next(&mut c).await {
            Message::TileResult {
                job_id: j,
                pixels: p,
                ..
            } => {
                assert_eq!(j, job_id);
                pixels.push(p);
            }
            Message::Error { reason } => {
                assert_eq!(job_id, 7);
                assert_eq!(reason, "tile(s) [0] assigned for unknown job 7");
            }
            other => panic!("{other:?}"),
        }
    }
    assert_eq!(pixels.len(), 2);
    assert!(
        pixels[0] == pixels[1],
        "the View's pixels differ from the Job's"
    );
    c.write(&Message::Shutdown).await.unwrap();
    let summary = timeout(Duration::from_secs(10), worker)
        .await
        .unwrap()
        .unwrap()
        .unwrap();
    assert_eq!(summary.jobs, 3);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_view_of_an_unknown_job_or_of_no_camera_is_an_error_and_the_worker_goes_on() {
    let (_listener, worker, mut c) = worker_holding_job(16).await;
    let desc = test_scene(16, 16);
    c.write(&view_of(9, 99, desc.view.clone())).await.unwrap();
    match next(&mut c).await {
        Message::Error { reason } => assert_eq!(
            reason,
            "cannot build job 9: it is a view of job 99, which this worker does not hold"
        ),
        other => panic!("{other:?}"),
    }
    let mut bad = desc.view.clone();
    bad.at = bad.from;
    c.write(&view_of(10, 7, bad)).await.unwrap();
    match next(&mut c).await {
        Message::Error { reason } => assert_eq!(
            reason,
            "cannot build job 10: bad view: 'from' and 'at' are the same point, so there is no \
             view direction"
        ),
        other => panic!("{other:?}"),
    }
    for job_id in [9, 10] {
        c.write(&Message::Assign {
            job_id,
            tile: TILE,
            attempt: 1,
        })
        .await
        .unwrap();
        match next(&mut c).await {
            Message::Error { reason } => assert_eq!(
                reason,
                format!("tile(s) [0] assigned for unknown job {job_id}")
            ),
            other => panic!("{other:?}"),
        }
    }
    // The base still renders.
    c.write(&Message::Assign {
        job_id: 7,
        tile: TILE,
        attempt: 1,
    })
    .await
    .unwrap();
    assert!(matches!(
        next(&mut c).await,
        Message::TileResult { job_id: 7, .. }
    ));
    c.write(&Message::Shutdown).await.unwrap();
    timeout(Duration::from_secs(10), worker)
        .await
        .unwrap()
        .unwrap()
        .unwrap();
}
