//! Raw peers for the handshake, frame and limit tests: a Hello (ours, and version 1's bytes), a
//! raw client through the whole handshake, a raw fake master that welcomes one worker, and a
//! job. Written with `parrt_protocol` directly, never a real worker; the raw client and the
//! fake master speak inside the encrypted channel, as real peers do.

use parrt_protocol::{Connection, JobSpec, Message, SecureStream, PROTOCOL_VERSION};
use parrt_tests::*;
use std::net::SocketAddr;
use tokio::net::{TcpListener, TcpStream};

pub fn hello(name: &str, threads: u32, nonce: [u8; 32]) -> Message {
    Message::Hello {
        version: PROTOCOL_VERSION,
        name: name.into(),
        threads,
        nonce,
        isa: parrt_render::isa::Isa::Scalar,
    }
}

/// A frame holding a version-1 Hello (no nonce): variant 0, version, name, threads.
pub fn v1_hello_frame(version: u32, name: &[u8], threads: u32) -> Vec<u8> {
    fn varint(mut v: u64, out: &mut Vec<u8>) {
        loop {
            let b = (v & 0x7f) as u8;
            v >>= 7;
            if v == 0 {
                out.push(b);
                return;
            }
            out.push(b | 0x80);
        }
    }
    let mut p = vec![0u8];
    varint(version.into(), &mut p);
    varint(name.len() as u64, &mut p);
    p.extend_from_slice(name);
    varint(threads.into(), &mut p);
    let mut f = (p.len() as u32).to_be_bytes().to_vec();
    f.extend(p);
    f
}

/// A raw client through the whole handshake with the test token: Welcome received.
pub async fn authenticate(
    addr: SocketAddr,
    name: &str,
    threads: u32,
) -> Connection<SecureStream<TcpStream>> {
    let s = TcpStream::connect(addr).await.unwrap();
    let mut c = Connection::new(secure_client(s).await, 1 << 28);
    let ours = [0x5a; 32];
    c.write(&hello(name, threads, ours)).await.unwrap();
    let Some(Message::Challenge { nonce, proof }) = c.read().await.unwrap() else {
        panic!("no challenge")
    };
    assert!(token().verify_master_proof(&ours, &nonce, &proof));
    c.write(&Message::Auth {
        mac: token().worker_proof(&nonce, &ours),
    })
    .await
    .unwrap();
    assert_eq!(c.read().await.unwrap(), Some(Message::Welcome));
    c
}

/// A raw fake master with the test token: accepts one worker and welcomes it.
pub async fn welcome_one(listener: &TcpListener) -> Connection<SecureStream<TcpStream>> {
    let (s, _) = listener.accept().await.unwrap();
    let mut c = Connection::new(secure_server(s).await, 1 << 20);
    let Some(Message::Hello { nonce: theirs, .. }) = c.read().await.unwrap() else {
        panic!("no hello")
    };
    let nonce = [0x33; 32];
    let proof = token().master_proof(&theirs, &nonce);
    c.write(&Message::Challenge { nonce, proof }).await.unwrap();
    let Some(Message::Auth { mac }) = c.read().await.unwrap() else {
        panic!("no auth")
    };
    assert!(token().verify_worker_proof(&nonce, &theirs, &mac));
    c.write(&Message::Welcome).await.unwrap();
    c
}

pub fn job(width: u32, height: u32, tile: u32) -> Message {
    let desc = test_scene(width, height);
    let settings = settings_for(&desc);
    Message::Job(Box::new(JobSpec {
        job_id: 7,
        scene: desc,
        settings,
        tile_size: tile,
        pixel_format: Default::default(),
        pack_pixels: true,
    }))
}

/// A one-thread worker, welcomed by a raw fake master and sent job 7 (`job(16, 16, tile)`),
/// once it has answered Ready: the listener it dialled, its task and the master's end.
pub async fn worker_holding_job(
    tile: u32,
) -> (
    TcpListener,
    tokio::task::JoinHandle<
        Result<parrt_worker::session::SessionSummary, parrt_worker::WorkerError>,
    >,
    Connection<SecureStream<TcpStream>>,
) {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let worker = start_worker(worker_options(listener.local_addr().unwrap(), 1, "w"));
    let mut c = welcome_one(&listener).await;
    c.write(&job(16, 16, tile)).await.unwrap();
    assert_eq!(next_ready(&mut c).await, 7);
    (listener, worker, c)
}

/// The Ready a worker sends next, past heartbeats: its job id.
pub async fn next_ready(c: &mut Connection<SecureStream<TcpStream>>) -> u64 {
    loop {
        match tokio::time::timeout(std::time::Duration::from_secs(10), c.read()).await {
            Ok(Ok(Some(Message::Ready { job_id, .. }))) => return job_id,
            Ok(Ok(Some(Message::Heartbeat))) => {}
            other => panic!("no Ready: {other:?}"),
        }
    }
}
