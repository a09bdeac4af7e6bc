//! A sequence's master that can die: `parrt render --orbit … --workers 2 --checkpoint FILE` is
//! SIGKILLed once a frame is written and the next is partly in the file (the workers slowed by
//! their tile delay), then resumed: every frame must be the SMP sequence's bytes, the frame
//! written before is not written again, a frame whose file was damaged since is written again,
//! and the tiles in the file are not rendered again (the file ends with exactly one record per
//! tile). A checkpoint of another sequence, of other settings, of one frame given to a
//! sequence and of a sequence given to one frame is refused (exit 2, file unchanged).

use crate::EXE;
use parrt_protocol::PixelFormat;
use parrt_render::tile::tiles;
use parrt_runtime::checkpoint::{
    encode_frame_tile, scan_sequence, Seal, SequenceScan, SEQUENCE_HEADER_LEN,
};
use parrt_worker::options::TILE_DELAY_ENV;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const SIZE: u32 = 64;
const TILE: u32 = 8;
const FRAMES: usize = 3;
/// Tiles a frame.
const N_TILES: usize = 64;
/// A tile record of an 8-bit 8x8 tile: length, frame, kind, tile id, seconds, 11 counters,
/// 192 bytes of pixels, check.
const TILE_RECORD: u64 = 4 + (4 + 1 + 4 + 8 + 88 + 64 * 3) + 8;
/// A frame-written record: length, frame, kind, file length, SHA-256, check.
const WRITTEN_RECORD: u64 = 4 + (4 + 1 + 8 + 32) + 8;
const DELAY_MS: u64 = 30;

fn args(orbit: &str, frames: usize, out: &Path) -> Vec<String> {
    let mut a: Vec<String> = ["render", "--scene", "balls:2", "--orbit", orbit, "--frames"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    a.push(frames.to_string());
    for f in ["--width", "--height"] {
        a.push(f.into());
        a.push(SIZE.to_string());
    }
    a.extend(["--tile".into(), TILE.to_string(), "-o".into()]);
    a.push(out.join("f-%d.png").display().to_string());
    a
}

fn through_workers(mut a: Vec<String>, ckpt: &Path, resume: bool) -> Vec<String> {
    a.extend(["--workers", "2", "--threads", "1", "--checkpoint"].map(String::from));
    a.push(ckpt.display().to_string());
    if resume {
        a.push("--resume".into());
    }
    a
}

fn run(a: &[String], delay: bool) -> std::process::Output {
    let mut cmd = Command::new(EXE);
    cmd.args(a).env("PARRT_LOG", "warn");
    if delay {
        cmd.env(TILE_DELAY_ENV, DELAY_MS.to_string());
    } else {
        cmd.env_remove(TILE_DELAY_ENV);
    }
    cmd.output().expect("run parrt")
}

fn ok(o: &std::process::Output) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{err}");
    err
}

fn frame(dir: &Path, k: usize) -> PathBuf {
    dir.join(format!("f-{k}.png"))
}

fn scan(ckpt: &Path) -> SequenceScan {
    // Not there yet while the master starts.
    let bytes = std::fs::read(ckpt).unwrap_or_default();
    let list: Vec<_> = (0..FRAMES).map(|_| tiles(SIZE, SIZE, TILE)).collect();
    if bytes.len() < SEQUENCE_HEADER_LEN {
        return SequenceScan::default();
    }
    let head = &bytes[..SEQUENCE_HEADER_LEN];
    scan_sequence(
        &mut &bytes[SEQUENCE_HEADER_LEN..],
        bytes.len() as u64,
        &list,
        PixelFormat::Rgb8,
        &Seal::Plain,
        head,
    )
    .unwrap()
}

/// Starts the delayed sequence and SIGKILLs its master once a frame is written and at least
/// 3 tiles of the frames not written are in the checkpoint.
fn kill_mid_way(out: &Path, ckpt: &Path) -> SequenceScan {
    let mut child = Command::new(EXE)
        .args(through_workers(args("90", FRAMES, out), ckpt, false))
        .env("PARRT_LOG", "warn")
        .env(TILE_DELAY_ENV, DELAY_MS.to_string())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("start parrt render --workers");
    let t0 = Instant::now();
    loop {
        let s = scan(ckpt);
        let written = s.written.iter().filter(|w| w.is_some()).count();
        let partial: usize = (0..s.tiles.len())
            .filter(|&k| s.written[k].is_none())
            .map(|k| s.tiles[k].len())
            .sum();
        if written >= 1 && partial >= 3 {
            break;
        }
        assert!(
            child.try_wait().unwrap().is_none(),
            "the sequence ended before it could be killed mid-way"
        );
        assert!(t0.elapsed() < Duration::from_secs(30), "no progress");
        std::thread::sleep(Duration::from_millis(2));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    scan(ckpt)
}

#[test]
fn a_sequence_killed_mid_way_and_resumed_is_every_frame_of_the_smp_sequence() {
    let dir = tempfile::tempdir().unwrap();
    let smp = dir.path().join("smp");
    let mut a = args("90", FRAMES, &smp);
    a.extend(["--threads".into(), "2".into()]);
    ok(&run(&a, false));
    let out = dir.path().join("dist");
    let ckpt = dir.path().join("seq.ckpt");
    let killed = kill_mid_way(&out, &ckpt);
    let written: Vec<usize> = (0..FRAMES)
        .filter(|&k| killed.written[k].is_some())
        .collect();
    assert!(written.len() < FRAMES, "killed after the end");
    assert_eq!(killed.bad_records, 0);
    assert_eq!(killed.cut_bytes, 0, "a SIGKILL leaves whole records");
    // The first frame written is damaged after the kill (cut short): it must be written
    // again, from the checkpoint's tiles; any other stays as it is.
    let damaged = written[0];
    let kept: Vec<usize> = written[1..].to_vec();
    let bytes = std::fs::read(frame(&out, damaged)).unwrap();
    std::fs::write(frame(&out, damaged), &bytes[..bytes.len() / 2]).unwrap();
    let untouched: Vec<_> = kept
        .iter()
        .map(|&k| {
            std::fs::metadata(frame(&out, k))
                .unwrap()
                .modified()
                .unwrap()
        })
        .collect();
    let partial: usize = (0..FRAMES)
        .filter(|&k| killed.written[k].is_none())
        .map(|k| killed.tiles[k].len())
        .sum();
    let err = ok(&run(
        &through_workers(args("90", FRAMES, &out), &ckpt, true),
        true,
    ));
    assert!(
        err.contains(&format!(
            "checkpoint {}: {} of 3 frames already written, 1 assembled from it, {partial} \
             tiles of the others restored, 0 bad records dropped",
            ckpt.display(),
            kept.len()
        )),
        "{err}"
    );
    for k in 0..FRAMES {
        assert_eq!(
            std::fs::read(frame(&out, k)).unwrap(),
            std::fs::read(frame(&smp, k)).unwrap(),
            "frame {k} = the SMP sequence's"
        );
    }
    for (k, t) in kept.iter().zip(untouched) {
        let now = std::fs::metadata(frame(&out, *k))
            .unwrap()
            .modified()
            .unwrap();
        assert_eq!(now, t, "frame {k} was written again");
    }
    // One record per tile: none of those in the file was rendered (and recorded) again; one
    // written record per frame, and one more for the frame written again.
    let s = scan(&ckpt);
    assert!(s.written.iter().all(|w| w.is_some()));
    assert!(s.tiles.iter().all(|t| t.len() == N_TILES));
    let len = std::fs::metadata(&ckpt).unwrap().len();
    assert_eq!(
        len,
        SEQUENCE_HEADER_LEN as u64
            + (FRAMES * N_TILES) as u64 * TILE_RECORD
            + (FRAMES + 1) as u64 * WRITTEN_RECORD,
        "tiles restored were rendered again"
    );
}

#[test]
fn a_checkpoint_of_another_sequence_settings_or_frame_count_is_refused_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("a");
    let ckpt = dir.path().join("a.ckpt");
    ok(&run(
        &through_workers(args("90", FRAMES, &out), &ckpt, false),
        false,
    ));
    let before = std::fs::read(&ckpt).unwrap();
    let other = dir.path().join("b");
    let refused = |a: Vec<String>, says: String| {
        let o = run(&a, false);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(err.contains(&says), "{says}: {err}");
        assert_eq!(std::fs::read(&ckpt).unwrap(), before, "{says}: unchanged");
        assert!(!frame(&other, 0).exists());
    };
    let c = ckpt.display();
    refused(
        through_workers(args("45", FRAMES, &other), &ckpt, true),
        format!(
            "checkpoint {c} is of another sequence (its frames' scenes differ); it was left \
             unchanged (resume with the frames that wrote it, or remove it)"
        ),
    );
    refused(
        through_workers(args("90", FRAMES + 1, &other), &ckpt, true),
        format!(
            "checkpoint {c} was written with other settings (the file has 3 frames, this run 4)"
        ),
    );
    let mut spp = through_workers(args("90", FRAMES, &other), &ckpt, true);
    spp.extend(["--spp".into(), "4".into()]);
    refused(
        spp,
        format!("checkpoint {c} was written with other settings (image size or render flags"),
    );
    // The sequence's checkpoint given to one frame.
    let one = dir.path().join("one.png");
    let single = |ckpt: &Path, resume: bool| {
        let mut a: Vec<String> = ["render", "--scene", "balls:2", "--size", "64x64"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        a.extend(["--tile".into(), TILE.to_string(), "-o".into()]);
        a.push(one.display().to_string());
        through_workers(a, ckpt, resume)
    };
    refused(
        single(&ckpt, true),
        format!(
            "checkpoint {c} holds a sequence, not one frame; it was left unchanged (resume it \
             with the sequence that wrote it, or remove it)"
        ),
    );
    // A one-frame checkpoint given to the sequence.
    let one_ckpt = dir.path().join("one.ckpt");
    ok(&run(&single(&one_ckpt, false), false));
    let one_before = std::fs::read(&one_ckpt).unwrap();
    let o = run(
        &through_workers(args("90", FRAMES, &other), &one_ckpt, true),
        false,
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains(&format!(
            "checkpoint {} holds one frame, not a sequence; it was left unchanged",
            one_ckpt.display()
        )),
        "{err}"
    );
    assert_eq!(std::fs::read(&one_ckpt).unwrap(), one_before);
    // On this machine's threads a sequence keeps no checkpoint, as one frame keeps none.
    let mut smp = args("90", FRAMES, &other);
    smp.extend([
        "--checkpoint".into(),
        dir.path().join("smp.ckpt").display().to_string(),
    ]);
    let o = run(&smp, false);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--checkpoint records the tiles of a render through workers; add --workers N"),
        "{err}"
    );
    assert!(!dir.path().join("smp.ckpt").exists());
}

/// Tiles of every frame in the file, none written: each frame's tiles are restored when that
/// frame opens (the first at once, the later ones as the window reaches them) and only the
/// others are rendered.
#[test]
fn the_tiles_of_several_partial_frames_are_restored_each_when_its_frame_opens() {
    let dir = tempfile::tempdir().unwrap();
    let smp = dir.path().join("smp");
    let mut a = args("90", FRAMES, &smp);
    a.extend(["--threads".into(), "2".into()]);
    ok(&run(&a, false));
    let out = dir.path().join("dist");
    let ckpt = dir.path().join("seq.ckpt");
    ok(&run(
        &through_workers(args("90", FRAMES, &out), &ckpt, false),
        false,
    ));
    // Keep 40, 20 and 10 tiles of frames 0, 1 and 2 (every other tile id, so the holes are
    // spread over each image), no frame written; the outputs are gone.
    let full = scan(&ckpt);
    let bytes = std::fs::read(&ckpt).unwrap();
    let head = &bytes[..SEQUENCE_HEADER_LEN];
    let mut kept = head.to_vec();
    let keep = [40, 20, 10];
    for (k, n) in keep.iter().enumerate() {
        let mut ts: Vec<_> = full.tiles[k]
            .iter()
            .filter(|t| t.tile_id % 2 == 0)
            .collect();
        ts.extend(full.tiles[k].iter().filter(|t| t.tile_id % 2 == 1));
        for t in ts.into_iter().take(*n) {
            encode_frame_tile(t, &Seal::Plain, head, &mut kept);
        }
        std::fs::remove_file(frame(&out, k)).unwrap();
    }
    std::fs::write(&ckpt, &kept).unwrap();
    let err = ok(&run(
        &through_workers(args("90", FRAMES, &out), &ckpt, true),
        false,
    ));
    assert!(
        err.contains(
            "0 of 3 frames already written, 0 assembled from it, 70 tiles of the others \
             restored"
        ),
        "{err}"
    );
    for k in 0..FRAMES {
        assert_eq!(
            std::fs::read(frame(&out, k)).unwrap(),
            std::fs::read(frame(&smp, k)).unwrap(),
            "frame {k} = the SMP sequence's"
        );
    }
    let len = std::fs::metadata(&ckpt).unwrap().len();
    assert_eq!(
        len,
        SEQUENCE_HEADER_LEN as u64
            + (FRAMES * N_TILES) as u64 * TILE_RECORD
            + FRAMES as u64 * WRITTEN_RECORD,
        "tiles restored were rendered again"
    );
}
