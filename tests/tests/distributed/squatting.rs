//! Handshake squatting: peers without the token that open TCP connections, send nothing, and
//! reopen each one the moment the master drops it, for the whole render: 16 from the honest
//! workers' own address (its per-address budget), and 64 from four other loopback addresses
//! (the whole handshake budget). The master evicts the silent ones for newcomers, so honest
//! workers still join and the render completes, bit for bit the SMP image. Loopback only; the
//! attack ends with the render, and every wait is bounded.

use parrt_tests::*;
use std::net::{IpAddr, SocketAddr};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::io::AsyncReadExt;
use tokio::net::TcpSocket;
use tokio::time::timeout;

/// Keeps `n` silent connections from `from` to `to` open, reopening each as it is dropped,
/// until `stop`; counts the (re)openings.
fn squat(from: IpAddr, to: SocketAddr, n: usize, stop: Arc<AtomicBool>, opened: Arc<AtomicU64>) {
    for _ in 0..n {
        let (stop, opened) = (stop.clone(), opened.clone());
        tokio::spawn(async move {
            while !stop.load(Ordering::Relaxed) {
                let Ok(sock) = TcpSocket::new_v4() else {
                    return;
                };
                if sock.bind(SocketAddr::new(from, 0)).is_err() {
                    return;
                }
                let Ok(Ok(mut s)) = timeout(Duration::from_secs(2), sock.connect(to)).await else {
                    tokio::time::sleep(Duration::from_millis(10)).await;
                    continue;
                };
                opened.fetch_add(1, Ordering::Relaxed);
                // Silent: wait for the master to drop us (or the end), then reopen at once.
                let mut b = [0u8; 64];
                loop {
                    if stop.load(Ordering::Relaxed) {
                        return;
                    }
                    match timeout(Duration::from_millis(200), s.read(&mut b)).await {
                        Ok(Ok(0)) | Ok(Err(_)) => break,
                        _ => {}
                    }
                }
            }
        });
    }
}

/// Runs a render of two honest workers from 127.0.0.1 under squatters from `addresses`
/// (`per` silent connections each).
async fn render_under_squatters(addresses: &[IpAddr], per: usize) {
    let desc = test_scene(32, 32);
    let settings = settings_for(&desc);
    let (reference, _) = smp_reference(&desc, &settings, 8);
    let mut opts = test_options(8);
    opts.schedule.min_workers = 2;
    opts.schedule.wait_workers = Duration::from_secs(60);
    let m = start_master(&desc, &settings, &opts).await;
    let (stop, opened) = (
        Arc::new(AtomicBool::new(false)),
        Arc::new(AtomicU64::new(0)),
    );
    for ip in addresses {
        squat(*ip, m.addr, per, stop.clone(), opened.clone());
    }
    // Let the squatters fill their budgets before the workers come.
    let full = (addresses.len() * per) as u64;
    let filled = timeout(Duration::from_secs(30), async {
        while opened.load(Ordering::Relaxed) < full {
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
    })
    .await;
    assert!(
        filled.is_ok(),
        "the squatters opened only {}",
        opened.load(Ordering::Relaxed)
    );
    let began = Instant::now();
    let workers: Vec<_> = (0..2)
        .map(|i| {
            let mut w = worker_options(m.addr, 1, &format!("honest{i}"));
            w.dial_timeout = Duration::from_secs(30);
            start_worker(w)
        })
        .collect();
    let r = timeout(Duration::from_secs(120), m.handle)
        .await
        .expect("the render ended within 120 s")
        .unwrap();
    stop.store(true, Ordering::Relaxed);
    let r = r.expect("the render completed despite the squatters");
    eprintln!(
        "{} squatters from {} address(es), reopened {} times: render done {:.2} s after the \
         workers started",
        addresses.len() * per,
        addresses.len(),
        opened.load(Ordering::Relaxed) - full,
        began.elapsed().as_secs_f64()
    );
    assert_same_bits(&r.film, &reference, "under squatters");
    assert_eq!(r.per_worker.len(), 2, "both honest workers joined");
    for w in workers {
        let s = timeout(Duration::from_secs(30), w)
            .await
            .expect("the worker ended")
            .unwrap()
            .expect("the worker's session ended well");
        assert_eq!(s.end, parrt_worker::session::SessionEnd::Shutdown);
    }
}

/// 16 silent connections from the workers' own address fill its per-address budget.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn squatters_on_the_workers_address_do_not_keep_them_out() {
    render_under_squatters(&[IpAddr::from([127, 0, 0, 1])], 16).await;
}

/// 64 silent connections from four other addresses fill the whole handshake budget.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn squatters_filling_the_whole_budget_do_not_keep_workers_out() {
    let from: Vec<IpAddr> = (2..6).map(|d| IpAddr::from([127, 0, 0, d])).collect();
    render_under_squatters(&from, 16).await;
}
