//! A master that can die: `parrt render --workers 2 --checkpoint FILE` is SIGKILLed at random
//! points of a render slowed by the workers' tile delay, resumed each time with `--resume`, and
//! the final image must be the SMP render's bits (EXR: exact f32; PNG: the 8-bit path) with the
//! same ray statistics; only tiles in flight at a kill may be rendered twice. A checkpoint of
//! another scene or other settings is refused (exit 2, file unchanged); a torn last record and a
//! flipped byte in a middle record are dropped and their tiles rendered again.

use crate::EXE;
use parrt_protocol::PixelFormat;
use parrt_render::tile::tiles;
use parrt_runtime::checkpoint::{scan_records, scan_sealed_records, Scan, Seal, HEADER_LEN};
use parrt_tests::{spawn_worker_process, ChildGuard, TEST_TOKEN};
use parrt_worker::options::TILE_DELAY_ENV;
use rand::Rng;
use std::io::BufRead;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// 64 tiles of 8x8.
const SIZE: u32 = 64;
const TILE: u32 = 8;
const N_TILES: usize = 64;
/// Each tile's payload: tile id, seconds, 11 counters, 64 f32 pixels; then length and check.
const RECORD_F32: u64 = 4 + (4 + 8 + 88 + 64 * 12) + 8;
/// Per-tile delay on the workers: 64 tiles on 2 one-thread workers take about a second.
const DELAY_MS: u64 = 30;
/// Tiles a worker holds at once: a window of 2 per thread (batches are single tiles at this
/// cost: 30 ms a tile, at most 50 ms a batch).
const IN_FLIGHT_PER_KILL: usize = 2 * 2;

fn base_args(out: &Path) -> Vec<String> {
    let mut a: Vec<String> = ["render", "--scene", "balls:2", "--tile"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    a.push(TILE.to_string());
    for f in ["--width", "--height"] {
        a.push(f.into());
        a.push(SIZE.to_string());
    }
    a.push("-o".into());
    a.push(out.display().to_string());
    a
}

fn dist_args(out: &Path, ckpt: &Path, resume: bool) -> Vec<String> {
    let mut a = base_args(out);
    a.extend(["--workers", "2", "--threads", "1", "--checkpoint"].map(String::from));
    a.push(ckpt.display().to_string());
    if resume {
        a.push("--resume".into());
    }
    a
}

fn run(args: &[String], delay: bool) -> std::process::Output {
    let mut cmd = Command::new(EXE);
    cmd.args(args).env("PARRT_LOG", "warn");
    if delay {
        cmd.env(TILE_DELAY_ENV, DELAY_MS.to_string());
    } else {
        cmd.env_remove(TILE_DELAY_ENV);
    }
    cmd.output().expect("run parrt")
}

fn ok(out: &std::process::Output) {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn json(p: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
}

/// The SMP reference render to `name` in `dir`, with its stats.
fn reference(dir: &Path, name: &str) -> (Vec<u8>, serde_json::Value) {
    let out = dir.join(name);
    let stats = dir.join(format!("{name}.json"));
    let mut a = base_args(&out);
    a.extend(["--threads".into(), "2".into(), "--stats-json".into()]);
    a.push(stats.display().to_string());
    ok(&run(&a, false));
    (std::fs::read(&out).unwrap(), json(&stats))
}

fn scan(ckpt: &Path, format: PixelFormat) -> Scan {
    let bytes = std::fs::read(ckpt).unwrap();
    let list = tiles(SIZE, SIZE, TILE);
    let head: [u8; HEADER_LEN] = bytes[..HEADER_LEN].try_into().unwrap();
    let plain = scan_records(
        &mut &bytes[HEADER_LEN..],
        bytes.len() as u64,
        &list,
        format,
        &head,
    )
    .unwrap();
    if !plain.tiles.is_empty() || plain.bad_records == 0 {
        return plain;
    }
    // `parrt master` seals its records with its token (render --workers cannot: its token is
    // new every run).
    let keyed = Seal::from_secret(TEST_TOKEN.as_bytes());
    scan_sealed_records(
        &mut &bytes[HEADER_LEN..],
        bytes.len() as u64,
        &list,
        format,
        &keyed,
        &head,
    )
    .unwrap()
}

/// Every counter of the ray statistics.
const COUNTERS: [&str; 12] = [
    "eye_rays",
    "eye_hits",
    "shadow_rays",
    "shadow_hits",
    "reflection_rays",
    "reflection_hits",
    "refraction_rays",
    "refraction_hits",
    "box_tests",
    "primitive_tests",
    "cell_steps",
    "total_rays",
];

fn same_stats(a: &serde_json::Value, b: &serde_json::Value, what: &str) {
    for k in COUNTERS {
        assert_eq!(a[k], b[k], "{what}: {k}");
    }
}

/// Tiles the workers of one run sent (their `worker done … tiles=N` lines at info level).
fn worker_tiles(stderr: &str) -> Vec<u64> {
    stderr
        .lines()
        .filter(|l| l.contains("worker done"))
        .filter_map(|l| {
            let rest = &l[l.find(" tiles=")? + 7..];
            rest.split(|c: char| !c.is_ascii_digit())
                .next()?
                .parse()
                .ok()
        })
        .collect()
}

/// Starts a delayed distributed render and SIGKILLs its master once the checkpoint holds at
/// least `target` records. Returns the tiles the workers sent before they saw it die, when
/// they lived to say.
fn kill_at(out: &Path, ckpt: &Path, resume: bool, target: u64) -> Option<u64> {
    let mut child = Command::new(EXE)
        .args(dist_args(out, ckpt, resume))
        .env("PARRT_LOG", "info")
        .env(TILE_DELAY_ENV, DELAY_MS.to_string())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start parrt render --workers");
    let t0 = Instant::now();
    let want = HEADER_LEN as u64 + target * RECORD_F32;
    loop {
        let len = std::fs::metadata(ckpt).map_or(0, |m| m.len());
        if len >= want {
            break;
        }
        assert!(
            child.try_wait().unwrap().is_none(),
            "the render ended before {target} records"
        );
        assert!(t0.elapsed() < Duration::from_secs(15), "no progress");
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    // The workers inherit the pipe; it closes when both have seen the master die and exited.
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    // The workers die with their master (PR_SET_PDEATHSIG), mostly before they can say what
    // they sent: the count is known only when both said it (a worker still dialling when the
    // master died says nothing either), else `None`.
    let sent = worker_tiles(&err);
    (sent.len() == 2).then(|| sent.iter().sum())
}

#[test]
fn killed_at_random_points_and_resumed_the_image_and_stats_are_an_uninterrupted_runs() {
    let dir = tempfile::tempdir().unwrap();
    let (smp, smp_stats) = reference(dir.path(), "ref.exr");
    let ckpt = dir.path().join("render.ckpt");
    let out = dir.path().join("dist.exr");
    let mut rng = rand::thread_rng();
    let mut records = 0u64;
    let mut rendered_twice = 0u64;
    let kills = 3;
    for k in 0..kills {
        let target = records + rng.gen_range(3..=14);
        let sent = kill_at(&out, &ckpt, k > 0, target);
        let s = scan(&ckpt, PixelFormat::F32);
        assert_eq!(s.bad_records, 0);
        assert_eq!(s.cut_bytes, 0, "a SIGKILL leaves whole records");
        let now = s.tiles.len() as u64;
        assert!(now >= target && (now as usize) < N_TILES, "{now}");
        let added = now - records;
        if let Some(sent) = sent {
            assert!(sent >= added, "workers sent {sent}, {added} recorded");
            rendered_twice += sent - added;
            eprintln!(
                "kill {k}: at {now} records ({added} new; {} lost in flight)",
                sent - added
            );
        }
        records = now;
        assert!(!out.exists(), "a killed render writes no image");
    }
    let stats = dir.path().join("dist.json");
    let mut a = dist_args(&out, &ckpt, true);
    a.push("--stats-json".into());
    a.push(stats.display().to_string());
    ok(&run(&a, true));
    assert_eq!(std::fs::read(&out).unwrap(), smp, "resumed EXR = SMP EXR");
    let st = json(&stats);
    same_stats(&st, &smp_stats, "resumed");
    assert_eq!(st["restored_tiles"], records);
    let last: u64 = st["tiles_per_worker"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .sum();
    assert_eq!(last, N_TILES as u64 - records, "only the missing tiles");
    let s = scan(&ckpt, PixelFormat::F32);
    let mut ids: Vec<u32> = s.tiles.iter().map(|t| t.tile_id).collect();
    ids.sort_unstable();
    assert_eq!(ids, (0..N_TILES as u32).collect::<Vec<_>>());
    assert_eq!(s.bad_records, 0);
    eprintln!("{rendered_twice} tiles rendered twice over {kills} kills");
    assert!(
        rendered_twice <= (kills * IN_FLIGHT_PER_KILL) as u64,
        "{rendered_twice} tiles rendered twice: more than were in flight"
    );
}

/// A complete checkpoint from one uninterrupted distributed render (no delay).
fn full_checkpoint(dir: &Path, out: &str) -> PathBuf {
    let ckpt = dir.join(format!("{out}.ckpt"));
    ok(&run(&dist_args(&dir.join(out), &ckpt, false), false));
    ckpt
}

#[test]
fn a_checkpoint_of_another_scene_or_settings_or_without_resume_is_refused_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let ckpt = full_checkpoint(dir.path(), "a.exr");
    let before = std::fs::read(&ckpt).unwrap();
    let out = dir.path().join("b.exr");
    let refused = |args: Vec<String>, says: &str| {
        let o = run(&args, false);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(says), "{says}: {err}");
        assert_eq!(std::fs::read(&ckpt).unwrap(), before, "{says}: unchanged");
        assert!(!out.exists());
    };
    refused(
        dist_args(&out, &ckpt, false),
        "exists; pass --resume to continue it, or remove it",
    );
    let mut other_scene = dist_args(&out, &ckpt, true);
    other_scene[2] = "balls:1".into();
    refused(other_scene, "is of another scene");
    let mut other_spp = dist_args(&out, &ckpt, true);
    other_spp.extend(["--spp".into(), "4".into()]);
    refused(other_spp, "was written with other settings");
    let png = dir.path().join("b.png");
    let o = run(&dist_args(&png, &ckpt, true), false);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("the file has F32 pixels, this run Rgb8"));
    assert_eq!(std::fs::read(&ckpt).unwrap(), before);
    // The checkpoint cannot be the image too.
    let o = run(&dist_args(&out, &out, false), false);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("are the same file"));
    assert!(!out.exists());
    // parrt master refuses it too, before listening.
    let o = Command::new(EXE)
        .args(["master", "--listen", "127.0.0.1:0", "--scene", "balls:2"])
        .arg("--checkpoint")
        .arg(&ckpt)
        .arg("-o")
        .arg(&out)
        .env("PARRT_TOKEN", TEST_TOKEN)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("exists; pass --resume"), "{err}");
    assert!(!err.contains("listening"), "{err}");
    assert_eq!(std::fs::read(&ckpt).unwrap(), before);
}

/// Resumes `ckpt` with its stats; returns (restored, bad records, tiles rendered now).
fn resume(dir: &Path, out: &str, ckpt: &Path) -> (u64, u64, u64) {
    let stats = dir.join(format!("{out}.resume.json"));
    let mut a = dist_args(&dir.join(out), ckpt, true);
    a.push("--stats-json".into());
    a.push(stats.display().to_string());
    ok(&run(&a, false));
    let st = json(&stats);
    let rendered = st["tiles_per_worker"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .sum();
    (
        st["restored_tiles"].as_u64().unwrap(),
        st["checkpoint_bad_records"].as_u64().unwrap(),
        rendered,
    )
}

#[test]
fn a_torn_last_record_and_a_flipped_middle_byte_are_dropped_and_rendered_again() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (smp_exr, _) = reference(d, "ref.exr");
    let (smp_png, _) = reference(d, "ref.png");

    // Torn: the last record loses its checksum and part of its pixels (8-bit path).
    let ckpt = full_checkpoint(d, "torn.png");
    let full = std::fs::read(&ckpt).unwrap();
    std::fs::write(&ckpt, &full[..full.len() - 20]).unwrap();
    let (restored, bad, rendered) = resume(d, "torn2.png", &ckpt);
    assert_eq!((restored, bad, rendered), (N_TILES as u64 - 1, 0, 1));
    assert_eq!(std::fs::read(d.join("torn2.png")).unwrap(), smp_png);
    let s = scan(&ckpt, PixelFormat::Rgb8);
    assert_eq!((s.tiles.len(), s.bad_records, s.cut_bytes), (N_TILES, 0, 0));
    assert_eq!(std::fs::metadata(&ckpt).unwrap().len(), full.len() as u64);

    // Flipped: one pixel byte of record 20 (of 64): only that tile is rendered again.
    let ckpt = full_checkpoint(d, "flip.exr");
    let mut bytes = std::fs::read(&ckpt).unwrap();
    let at = HEADER_LEN + 20 * RECORD_F32 as usize + 4 + 100 + 17;
    bytes[at] ^= 0x04;
    let flipped_tile = {
        let s = {
            let head: [u8; HEADER_LEN] = bytes[..HEADER_LEN].try_into().unwrap();
            let mut r = &bytes[HEADER_LEN..];
            scan_records(
                &mut r,
                bytes.len() as u64,
                &tiles(SIZE, SIZE, TILE),
                PixelFormat::F32,
                &head,
            )
            .unwrap()
        };
        assert_eq!(s.bad_records, 1);
        let ids: Vec<u32> = s.tiles.iter().map(|t| t.tile_id).collect();
        (0..N_TILES as u32).find(|t| !ids.contains(t)).unwrap()
    };
    std::fs::write(&ckpt, &bytes).unwrap();
    let (restored, bad, rendered) = resume(d, "flip2.exr", &ckpt);
    assert_eq!((restored, bad, rendered), (N_TILES as u64 - 1, 1, 1));
    assert_eq!(std::fs::read(d.join("flip2.exr")).unwrap(), smp_exr);
    let s = scan(&ckpt, PixelFormat::F32);
    assert_eq!(s.bad_records, 1, "the bad record stays, never trusted");
    assert_eq!(s.tiles.len(), N_TILES);
    assert_eq!(s.tiles.last().unwrap().tile_id, flipped_tile, "re-rendered");
}

/// Starts `parrt master` with `--checkpoint` and two delayed worker processes; returns the
/// master (its stderr after the listening line) and the workers.
fn master_with_workers(
    out: &Path,
    ckpt: &Path,
    resume: bool,
    report: Option<&Path>,
) -> (
    ChildGuard,
    std::io::BufReader<std::process::ChildStderr>,
    Vec<ChildGuard>,
) {
    let mut cmd = Command::new(EXE);
    cmd.args(["master", "--listen", "127.0.0.1:0", "--min-workers", "2"])
        .args(&base_args(out)[1..])
        .arg("--checkpoint")
        .arg(ckpt)
        .env("PARRT_TOKEN", TEST_TOKEN)
        .env("PARRT_LOG", "warn")
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    if resume {
        cmd.arg("--resume");
    }
    if let Some(r) = report {
        cmd.arg("--report-json").arg(r);
    }
    let mut master = cmd.spawn().expect("start parrt master");
    let mut stderr = std::io::BufReader::new(master.stderr.take().unwrap());
    let master = ChildGuard(master);
    let mut line = String::new();
    let addr = loop {
        line.clear();
        assert!(
            stderr.read_line(&mut line).unwrap() > 0,
            "master ended early"
        );
        if let Some(rest) = line.split("listening on ").nth(1) {
            break rest.split(';').next().unwrap().trim().parse().unwrap();
        }
    };
    let workers = (0..2)
        .map(|_| spawn_worker_process(EXE.as_ref(), addr, 1, Some(DELAY_MS), TEST_TOKEN))
        .collect();
    (master, stderr, workers)
}

#[test]
fn a_killed_parrt_master_resumes_with_its_workers_to_the_same_bits() {
    let dir = tempfile::tempdir().unwrap();
    let (smp, smp_stats) = reference(dir.path(), "ref.exr");
    let ckpt = dir.path().join("master.ckpt");
    let out = dir.path().join("master.exr");
    let target = rand::thread_rng().gen_range(5..=40);
    let (mut master, _err, _workers) = master_with_workers(&out, &ckpt, false, None);
    let t0 = Instant::now();
    while std::fs::metadata(&ckpt).map_or(0, |m| m.len()) < HEADER_LEN as u64 + target * RECORD_F32
    {
        assert!(master.0.try_wait().unwrap().is_none(), "ended early");
        assert!(t0.elapsed() < Duration::from_secs(15), "no progress");
        std::thread::sleep(Duration::from_millis(2));
    }
    master.signal("KILL");
    master.0.wait().unwrap();
    let before = scan(&ckpt, PixelFormat::F32).tiles.len() as u64;
    assert!(before >= target && before < N_TILES as u64, "{before}");

    let report = dir.path().join("report.json");
    let (mut master, mut err, _workers) = master_with_workers(&out, &ckpt, true, Some(&report));
    let status = master.0.wait().unwrap();
    let mut rest = String::new();
    err.read_to_string(&mut rest).unwrap();
    assert!(status.success(), "{rest}");
    assert!(
        rest.contains(&format!("checkpoint: {before} tiles restored")),
        "{rest}"
    );
    assert_eq!(
        std::fs::read(&out).unwrap(),
        smp,
        "resumed master EXR = SMP EXR"
    );
    let r = json(&report);
    assert_eq!(r["restored_tiles"], before);
    assert_eq!(r["eye_rays"], smp_stats["eye_rays"]);
    let rendered: u64 = r["workers"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w["tiles"].as_u64().unwrap())
        .sum();
    assert_eq!(rendered, N_TILES as u64 - before, "only the missing tiles");
    assert!(
        rest.contains(&format!("{} rays", smp_stats["total_rays"])),
        "{rest}"
    );
}
