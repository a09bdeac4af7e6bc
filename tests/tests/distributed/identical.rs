//! A distributed render equals the SMP render bit for bit (docs/design.md, *Determinism*): for 1–3
//! workers, 1–2 threads each, tile sizes 8, 13 and 32; with in-process workers, with worker
//! processes, and through the real command line.

use crate::EXE;
use parrt_tests::*;
use std::process::Command;
use std::time::Duration;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn matches_smp_for_workers_threads_and_tile_sizes() {
    let desc = test_scene(64, 64);
    let settings = settings_for(&desc);
    let (reference, ref_stats) = smp_reference(&desc, &settings, 16);
    for tile in [8, 13, 32] {
        for workers in 1..=3 {
            for threads in 1..=2 {
                let what = format!("{workers} workers × {threads} threads, tile {tile}");
                // Every worker takes part: none arrives after a small job is already done.
                let mut opts = test_options(tile);
                opts.schedule.min_workers = workers;
                let m = start_master(&desc, &settings, &opts).await;
                let ws: Vec<_> = (0..workers)
                    .map(|i| start_worker(worker_options(m.addr, threads, &format!("w{i}"))))
                    .collect();
                let r = m
                    .handle
                    .await
                    .unwrap()
                    .unwrap_or_else(|e| panic!("{what}: {e}"));
                assert_same_bits(&r.film, &reference, &what);
                if tile % parrt_render::tile::BLOCK == 0 {
                    assert_eq!(r.stats, ref_stats, "{what}: stats");
                } else {
                    // Tiles that cut the image's 4 × 4 packet blocks trace other packets, so
                    // the box and primitive test counts differ; the rays do not.
                    let rays = |s: &parrt_render::stats::RayStats| {
                        let mut s = *s;
                        (s.box_tests, s.primitive_tests) = (0, 0);
                        s
                    };
                    assert_eq!(rays(&r.stats), rays(&ref_stats), "{what}: ray counts");
                }
                assert_eq!(r.tile_seconds.len(), r.tiles);
                assert_eq!(
                    r.per_worker.iter().map(|w| w.tiles).sum::<u64>(),
                    r.tiles as u64,
                    "{what}: every tile delivered once"
                );
                assert!(r.faults.refused.is_empty() && r.faults.rejected_results == 0);
                for w in ws {
                    let s = w
                        .await
                        .unwrap()
                        .unwrap_or_else(|e| panic!("{what}: worker: {e}"));
                    assert_eq!(s.end, parrt_worker::session::SessionEnd::Shutdown, "{what}");
                }
            }
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn worker_processes_from_the_cli_executable_match_smp() {
    let desc = test_scene(96, 80);
    let settings = settings_for(&desc);
    let (reference, ref_stats) = smp_reference(&desc, &settings, 13);
    let mut opts = test_options(13);
    opts.schedule.min_workers = 2;
    let m = start_master(&desc, &settings, &opts).await;
    let _workers =
        parrt_runtime::spawn::spawn_workers_from(EXE.as_ref(), 2, 2, m.addr, &token()).unwrap();
    let r = tokio::time::timeout(Duration::from_secs(60), m.handle)
        .await
        .expect("render finishes")
        .unwrap()
        .unwrap();
    assert_same_bits(&r.film, &reference, "2 worker processes");
    assert_eq!(r.stats, ref_stats);
    assert_eq!(r.per_worker.len(), 2);
    // Protocol overhead: pixels are 12 bytes each (f32 pixels travel raw); each result
    // adds a small header (tile id, attempt, ray statistics) and a handful of heartbeats and
    // handshake frames come along. Backup copies that lost the race are whole extra results
    // (at most 13×13 pixels each).
    let dups = r.faults.duplicate_results;
    let pixel_bytes = packed_pixel_bytes(&reference, 13, parrt_protocol::PixelFormat::F32);
    let overhead = r.bytes_received.saturating_sub(pixel_bytes);
    assert!(
        r.bytes_received >= pixel_bytes,
        "{} bytes received",
        r.bytes_received
    );
    assert!(
        overhead < (r.tiles as u64 + dups) * 80 + dups * 13 * 13 * 12 + 2048,
        "{overhead} bytes of overhead for {} tiles and {dups} duplicates",
        r.tiles
    );
}

#[test]
fn render_distributed_spawns_its_own_workers_and_matches_smp() {
    let desc = test_scene(80, 64);
    let settings = settings_for(&desc);
    let (reference, ref_stats) = smp_reference(&desc, &settings, 16);
    let mut opts = test_options(16);
    opts.spawn.count = 3;
    opts.spawn.threads = 1;
    opts.spawn.command.exe = Some(EXE.into());
    opts.net.token = None; // generated, and handed to the children through their environment
    opts.schedule.min_workers = 3;
    let mut listened = None;
    let job = parrt_runtime::Job::<parrt_runtime::DistError>::ready(desc.clone(), settings.clone());
    let r = parrt_runtime::run(
        &opts,
        job,
        &mut |a| {
            listened = Some(a);
            Ok(None)
        },
        None,
    )
    .unwrap()
    .result;
    assert!(listened.unwrap().ip().is_loopback());
    assert_same_bits(
        &r.film,
        &reference,
        "render_distributed with 3 spawned workers",
    );
    assert_eq!(r.stats, ref_stats);
    assert_eq!(r.per_worker.len(), 3);
    assert!(r.per_worker.iter().all(|w| w.name.starts_with("local-")));
}

#[test]
fn master_and_workers_on_the_command_line_write_the_smp_image() {
    let dir = tempfile::tempdir().unwrap();
    let desc = test_scene(64, 48);
    let settings = settings_for(&desc);
    let (reference, _) = smp_reference(&desc, &settings, 8);
    let scene = dir.path().join("scene.json");
    std::fs::write(&scene, serde_json::to_string(&desc).unwrap()).unwrap();
    let token_file = dir.path().join("token");
    std::fs::write(&token_file, format!("{TEST_TOKEN}\n")).unwrap();
    let out = dir.path().join("out.exr");
    let report = dir.path().join("report.json");
    let mut master = std::process::Command::new(EXE);
    master
        .args(["master", "--scene-json"])
        .arg(&scene)
        .args([
            "--listen",
            "127.0.0.1:0",
            "--tile",
            "8",
            "--wait-workers",
            "30",
        ])
        .arg("--token-file")
        .arg(&token_file)
        .arg("-o")
        .arg(&out)
        .arg("--report-json")
        .arg(&report)
        .env_remove("PARRT_TOKEN");
    let (status, log) = run_master_with_workers(&mut master, &[1, 2]);
    assert!(status.success(), "master failed: {log}");
    let img = image::open(&out).unwrap().into_rgb32f();
    let film = parrt_render::film::Film::from_pixels(
        img.width(),
        img.height(),
        img.pixels().map(|p| p.0).collect(),
    );
    assert_same_bits(&film, &reference, "CLI master + 2 CLI workers");
    let rep: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&report).unwrap()).unwrap();
    assert_eq!(rep["tiles"], 48);
    assert!(rep["bytes_per_tile"].as_f64().unwrap() > 0.0);
}

/// Runs `master` (a `parrt master` command line listening on port 0), starts one worker
/// process per entry of `threads` (that many threads each) once it listens, and returns its
/// exit status and the rest of its stderr.
pub fn run_master_with_workers(
    master: &mut Command,
    threads: &[usize],
) -> (std::process::ExitStatus, String) {
    let mut master = master.stderr(std::process::Stdio::piped()).spawn().unwrap();
    // The master prints the port it bound.
    let mut stderr = std::io::BufReader::new(master.stderr.take().unwrap());
    let addr = read_listen_addr(&mut stderr);
    let _workers: Vec<_> = threads
        .iter()
        .map(|&t| spawn_worker_process(EXE.as_ref(), addr, t, None, TEST_TOKEN))
        .collect();
    let rest = std::thread::spawn(move || {
        let mut s = String::new();
        std::io::Read::read_to_string(&mut stderr, &mut s).unwrap();
        s
    });
    let status = master.wait().unwrap();
    (status, rest.join().unwrap())
}

/// Reads the master's stderr up to its "listening on ADDR" line.
pub fn read_listen_addr(r: &mut impl std::io::BufRead) -> std::net::SocketAddr {
    let mut line = String::new();
    loop {
        line.clear();
        assert!(
            r.read_line(&mut line).unwrap() > 0,
            "master ended before listening"
        );
        if let Some(rest) = line.split("listening on ").nth(1) {
            let addr = rest.split(';').next().unwrap().trim();
            return addr.parse().unwrap();
        }
    }
}

/// The bytes of `film`'s pixels as workers send them in tiles of `tile`: in `format`, each
/// tile packed where that makes it smaller.
fn packed_pixel_bytes(
    film: &parrt_render::film::Film,
    tile: u32,
    format: parrt_protocol::PixelFormat,
) -> u64 {
    let (w, h) = (film.width, film.height);
    parrt_render::tile::tiles(w, h, tile)
        .iter()
        .map(|t| {
            let px: Vec<_> = (t.y..t.y + t.h)
                .flat_map(|y| (t.x..t.x + t.w).map(move |x| (x, y)))
                .map(|(x, y)| film.get(x, y))
                .collect();
            parrt_protocol::TilePixels::encode(&px, format)
                .pack()
                .bytes
                .len() as u64
        })
        .sum()
}

/// For an 8-bit output the workers send 3 bytes a pixel instead of 12, quantized by the
/// film's own 8-bit rule, so the written image is the SMP image's bytes; 8-bit pixels travel
/// packed where that is smaller unless the master says not to (its own machine's workers),
/// and f32 ones raw: what the master receives is exactly the tiles' bytes as sent plus the
/// messages' headers.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn rgb8_pixels_write_the_smp_png_and_travel_packed_when_asked() {
    use parrt_protocol::PixelFormat;
    let desc = test_scene(96, 64);
    let settings = settings_for(&desc);
    let (reference, ref_stats) = smp_reference(&desc, &settings, 16);
    let pixels = 96 * 64;
    let runs = [
        (PixelFormat::F32, true, pixels * 12),
        (PixelFormat::Rgb8, false, pixels * 3),
        (
            PixelFormat::Rgb8,
            true,
            packed_pixel_bytes(&reference, 16, PixelFormat::Rgb8),
        ),
    ];
    for (format, pack, sent) in runs {
        let mut opts = test_options(16);
        opts.schedule.min_workers = 2;
        opts.schedule.backups = false;
        opts.schedule.pixel_format = format;
        opts.schedule.pack_pixels = pack;
        let m = start_master(&desc, &settings, &opts).await;
        let _ws: Vec<_> = (0..2)
            .map(|i| start_worker(worker_options(m.addr, 1, &format!("w{i}"))))
            .collect();
        let r = m.handle.await.unwrap().unwrap();
        assert_eq!(
            r.film.to_rgb8(),
            reference.to_rgb8(),
            "{format:?}: 8-bit image"
        );
        assert_eq!(r.stats, ref_stats, "{format:?}");
        let headers = r.bytes_received.checked_sub(sent);
        assert!(
            headers.is_some_and(|b| b < r.tiles as u64 * 80 + 2048),
            "{format:?}, packed {pack}: {} bytes received for {sent} bytes of pixels in {} tiles",
            r.bytes_received,
            r.tiles
        );
    }
    // Packing is worth asking for: the test scene's 8-bit tiles pack to less than half.
    assert!(
        runs[2].2 * 2 < runs[1].2,
        "{} packed bytes of {}",
        runs[2].2,
        runs[1].2
    );
}

#[test]
fn render_workers_png_is_byte_identical_to_smp_png() {
    let dir = tempfile::tempdir().unwrap();
    let smp = dir.path().join("smp.png");
    let dist = dir.path().join("dist.png");
    let run = |out: &std::path::Path, extra: &[&str]| {
        let o = Command::new(EXE)
            .args([
                "render", "--scene", "mount:3", "--width", "96", "--height", "72",
            ])
            .args(["--tile", "16", "-o"])
            .arg(out)
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    run(&smp, &["--threads", "2"]);
    run(&dist, &["--workers", "2", "--threads", "1"]);
    assert_eq!(std::fs::read(&smp).unwrap(), std::fs::read(&dist).unwrap());
}

/// Many local workers arriving at once meet the master's handshake budgets (16 per address):
/// the latest are turned away for a moment and retry. That is routine, so a plain
/// `render --workers 24` says nothing about it, and still writes the SMP image.
#[test]
fn many_local_workers_render_quietly() {
    let dir = tempfile::tempdir().unwrap();
    let (smp, dist) = (dir.path().join("smp.png"), dir.path().join("dist.png"));
    let run = |out: &std::path::Path, extra: &[&str]| {
        let o = Command::new(EXE)
            .args([
                "render", "--scene", "mount:1", "--width", "48", "--height", "32",
            ])
            .args(["--tile", "8", "-o"])
            .arg(out)
            .args(extra)
            .env_remove("PARRT_LOG")
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    run(&smp, &["--threads", "1"]);
    let log = run(&dist, &["--workers", "24", "--threads", "1"]);
    assert!(!log.contains("WARN") && !log.contains("warning:"), "{log}");
    assert_eq!(std::fs::read(&smp).unwrap(), std::fs::read(&dist).unwrap());
}
