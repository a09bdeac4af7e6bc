//! `parrt render` of a sequence end to end through the real binary: every frame is the same
//! bytes as that frame rendered alone (orbit frames, several files, a frame LIST), whatever the
//! threads, tile size, executor and window; and the usage errors (output pattern, flags that
//! contradict one another, a bad LIST line, `--checkpoint`) exit 2 with their exact message.
//! Through local workers (`--workers 2`) every frame is the same bytes as the SMP sequence's.

use crate::{parrt, spd, stderr};
use parrt_render::sequence::Sequence;
use std::path::Path;

/// The small image every test renders.
const SIZE: [&str; 4] = ["--width", "48", "--height", "32"];

fn bytes(p: &Path) -> Vec<u8> {
    std::fs::read(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Renders `args` (plus the small size) and asserts success.
fn render_ok(args: &[&str]) {
    let mut all = vec!["render"];
    all.extend_from_slice(args);
    all.extend_from_slice(&SIZE);
    let o = parrt(&all);
    assert!(o.status.success(), "{all:?}: {}", stderr(&o));
}

/// Renders `args` expecting bad usage: exit 2 and exactly `message` after `parrt: `.
fn refused(args: &[&str], message: &str) {
    let mut all = vec!["render"];
    all.extend_from_slice(args);
    let o = parrt(&all);
    assert_eq!(o.status.code(), Some(2), "{all:?}: {}", stderr(&o));
    assert_eq!(stderr(&o), format!("parrt: {message}\n"), "{all:?}");
}

#[test]
fn orbit_frames_equal_each_frame_rendered_alone() {
    let dir = tempfile::tempdir().unwrap();
    let scene = spd("mount-4.nff");
    // The output folder does not exist yet: it is created.
    let pattern = dir.path().join("orbit/f-%02d.png");
    render_ok(&[
        &scene,
        "--orbit",
        "360",
        "--frames",
        "4",
        "-o",
        pattern.to_str().unwrap(),
    ]);
    let frame = |k: usize| bytes(&dir.path().join(format!("orbit/f-{k:02}.png")));
    // Frame 0 is the scene's own view: the plain render.
    let plain = dir.path().join("plain.png");
    render_ok(&[&scene, "-o", plain.to_str().unwrap()]);
    assert_eq!(frame(0), bytes(&plain), "frame 0 is the plain render");
    // Frame k is the scene turned by k·90° written out and rendered on its own.
    let desc =
        parrt_render::nff::parse_file(Path::new(&scene), &parrt_render::nff::Limits::default())
            .unwrap();
    let orbit = Sequence::orbit(desc, 360.0, 4).unwrap();
    for k in 1..4 {
        let json = dir.path().join(format!("turned-{k}.json"));
        let turned = orbit.frames()[k].description().into_owned();
        std::fs::write(&json, serde_json::to_vec(&turned).unwrap()).unwrap();
        let alone = dir.path().join(format!("alone-{k}.png"));
        render_ok(&[json.to_str().unwrap(), "-o", alone.to_str().unwrap()]);
        assert_eq!(
            frame(k),
            bytes(&alone),
            "frame {k} differs from its own render"
        );
        assert_ne!(frame(k), frame(k - 1), "the orbit turns: frame {k}");
    }
    assert!(!dir.path().join("orbit/f-04.png").exists());
}

#[test]
fn several_files_and_a_frame_list_write_each_scene_render() {
    let dir = tempfile::tempdir().unwrap();
    let names = ["tetra-4.nff", "mount-4.nff", "gears-1.nff"];
    let scenes: Vec<String> = names.iter().map(|n| spd(n)).collect();
    let out = dir.path().join("seq-%d.png");
    let mut args: Vec<&str> = scenes.iter().map(String::as_str).collect();
    args.extend(["-o", out.to_str().unwrap(), "--threads", "2"]);
    render_ok(&args);
    // The same frames from a LIST, its paths relative to its folder.
    std::fs::create_dir(dir.path().join("scenes")).unwrap();
    let mut list = String::from("# three SPD scenes\n\n");
    for n in names {
        std::fs::copy(spd(n), dir.path().join("scenes").join(n)).unwrap();
        list.push_str(&format!("scenes/{n}\n"));
    }
    let list_path = dir.path().join("frames.txt");
    std::fs::write(&list_path, list).unwrap();
    let listed = dir.path().join("listed/l%03d.png");
    render_ok(&[
        "--frames-from",
        list_path.to_str().unwrap(),
        "-o",
        listed.to_str().unwrap(),
    ]);
    for (k, scene) in scenes.iter().enumerate() {
        let alone = dir.path().join(format!("alone-{k}.png"));
        render_ok(&[scene, "-o", alone.to_str().unwrap()]);
        let want = bytes(&alone);
        assert_eq!(
            bytes(&dir.path().join(format!("seq-{k}.png"))),
            want,
            "{scene}"
        );
        assert_eq!(
            bytes(&dir.path().join(format!("listed/l{k:03}.png"))),
            want,
            "{scene} from the list"
        );
    }
}

#[test]
fn threads_tiles_executors_and_windows_give_the_same_frames() {
    let dir = tempfile::tempdir().unwrap();
    let scene = spd("mount-4.nff");
    let runs: [&[&str]; 4] = [
        &["--threads", "1", "--tile", "32", "--window", "1"],
        &["--threads", "2", "--tile", "8", "--window", "3"],
        &["--threads", "2", "--tile", "32", "--executor", "morton"],
        &["--threads", "3", "--tile", "5", "--window", "2"],
    ];
    for (r, flags) in runs.iter().enumerate() {
        let out = dir.path().join(format!("run{r}-%d.png"));
        let mut args = vec![scene.as_str(), "--orbit", "-90", "--frames", "3"];
        args.extend(["-o", out.to_str().unwrap()]);
        args.extend_from_slice(flags);
        render_ok(&args);
    }
    for k in 0..3 {
        let first = bytes(&dir.path().join(format!("run0-{k}.png")));
        for (r, flags) in runs.iter().enumerate().skip(1) {
            let other = bytes(&dir.path().join(format!("run{r}-{k}.png")));
            assert!(first == other, "frame {k}: run {r} {flags:?} differs");
        }
    }
}

#[test]
fn a_sequence_through_two_local_workers_is_the_smp_sequence() {
    let dir = tempfile::tempdir().unwrap();
    let d = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    let scene = spd("mount-4.nff");
    // A 3-frame orbit: frames that only move the camera.
    let orbit = [
        scene.as_str(),
        "--orbit",
        "270",
        "--frames",
        "3",
        "--tile",
        "8",
    ];
    for (out, extra) in [
        ("smp-o%d.png", &["--threads", "2"][..]),
        ("w-o%d.png", &["--workers", "2", "--threads", "1"][..]),
    ] {
        let mut args = orbit.to_vec();
        let (out, json) = (d(out), d(&format!("{}.json", &out[..1])));
        args.extend(["-o", out.as_str(), "--stats-json", json.as_str()]);
        args.extend_from_slice(extra);
        render_ok(&args);
    }
    // Through workers the report says what crossed the network and what the master spent;
    // SMP has neither to say.
    let json = |name: &str| -> serde_json::Value {
        serde_json::from_slice(&bytes(&dir.path().join(name))).expect("--stats-json is JSON")
    };
    let (smp, workers) = (json("s.json"), json("w.json"));
    let eye_rays = workers["eye_rays"].as_u64().expect("eye_rays");
    assert_eq!(smp["eye_rays"].as_u64(), Some(eye_rays));
    // Every tile's pixels came through the memory the master shares with the workers it
    // started, not over the connections (3 bytes a pixel would be more than came); a backup's
    // result, second to arrive, counts too.
    let tiles = workers["tiles"].as_u64().expect("tiles");
    let shared = workers["tiles_shared"].as_u64().expect("tiles_shared");
    assert!(
        shared >= tiles,
        "{shared} of {tiles} tiles through shared memory"
    );
    let got = workers["bytes_received"].as_u64().expect("bytes_received");
    assert!(got < 3 * eye_rays, "{got} bytes for {eye_rays} pixels");
    assert!(workers["bytes_sent"].as_u64().is_some_and(|b| b > 0));
    assert!(workers["master_cpu_s"].as_f64().is_some_and(|s| s > 0.0));
    for key in [
        "bytes_sent",
        "bytes_received",
        "tiles_shared",
        "master_cpu_s",
    ] {
        assert!(smp.get(key).is_none(), "SMP reports {key}");
    }
    // Two scene files of different scenes (and so different Jobs).
    let (a, b) = (spd("tetra-4.nff"), spd("gears-1.nff"));
    for (out, extra) in [
        ("smp-f%d.ppm", &["--threads", "2"][..]),
        (
            "w-f%d.ppm",
            &["--workers", "2", "--threads", "1", "--tile", "5"][..],
        ),
    ] {
        let out = d(out);
        let mut args = vec![a.as_str(), b.as_str(), "-o", out.as_str()];
        args.extend_from_slice(extra);
        render_ok(&args);
    }
    for k in 0..3 {
        let smp = bytes(&dir.path().join(format!("smp-o{k}.png")));
        assert!(
            smp == bytes(&dir.path().join(format!("w-o{k}.png"))),
            "orbit frame {k} through workers differs from SMP"
        );
    }
    assert!(!dir.path().join("w-o3.png").exists());
    for (k, scene) in [&a, &b].into_iter().enumerate() {
        let alone = d(&format!("alone-{k}.ppm"));
        render_ok(&[scene, "-o", &alone]);
        let want = bytes(Path::new(&alone));
        assert!(
            want == bytes(&dir.path().join(format!("smp-f{k}.ppm"))),
            "{scene}: SMP"
        );
        assert!(
            want == bytes(&dir.path().join(format!("w-f{k}.ppm"))),
            "{scene}: workers"
        );
    }
}

#[test]
fn output_patterns_and_sequence_flags_are_checked_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().display().to_string();
    let a = spd("tetra-4.nff");
    let b = spd("mount-4.nff");
    let out = format!("{d}/f-%d.png");
    refused(
        &[&a, &b, "-o", &format!("{d}/one.png")],
        &format!(
            "-o {d}/one.png: no frame number field (%d or %04d) for a sequence of 2 frames: \
             they would all be written to one file"
        ),
    );
    refused(
        &[&a, &b, "-o", &format!("{d}/f%d-%04d.png")],
        &format!("-o {d}/f%d-%04d.png: 2 frame number fields; give exactly one (%d or %04d)"),
    );
    // Frame 1's output would overwrite the scene file of frame 1.
    let input = format!("{d}/f-1.png");
    std::fs::copy(&a, &input).unwrap();
    refused(
        &[&b, &input, "-o", &out],
        &format!("-o {input} and a scene {input} are the same file; give each its own"),
    );
    assert_eq!(
        bytes(Path::new(&input)),
        bytes(Path::new(&a)),
        "left as it was"
    );
    // The timeline would overwrite a scene file.
    refused(
        &[
            &b,
            &input,
            "--timeline",
            &input,
            "-o",
            &format!("{d}/g-%d.png"),
        ],
        &format!("a scene {input} and --timeline {input} are the same file; give each its own"),
    );
    assert_eq!(bytes(Path::new(&input)), bytes(Path::new(&a)));
    refused(
        &[&a, "--orbit", "360", "--frames", "0", "-o", &out],
        "a sequence needs at least one frame (--frames 0 renders nothing)",
    );
    refused(
        &[&a, "--orbit", "inf", "--frames", "3", "-o", &out],
        "--orbit inf: the angle must be a finite number of degrees",
    );
    refused(
        &[&a, "--frames", "3", "-o", &out],
        "--frames N counts the frames of --orbit; give --orbit DEGREES too (several files or \
         --frames-from make one frame each)",
    );
    refused(
        &[&a, &b, "--orbit", "90", "--frames", "3", "-o", &out],
        "--orbit turns the camera about one scene; give one scene file (or --scene), not \
         several files or --frames-from",
    );
    refused(
        &[&a, &b, "--checkpoint", &format!("{d}/c.ckpt"), "-o", &out],
        "--checkpoint records the tiles of a render through workers; add --workers N (a render \
         on this machine's threads keeps no checkpoint)",
    );
    refused(
        &[&a, &b, "--workers", "0", "-o", &out],
        "--workers must be at least 1",
    );
    refused(
        &[&a, "--window", "3", "-o", &format!("{d}/one.png")],
        "--window sets how many frames of a sequence are in flight; this render has one frame \
         (give several scene files, --frames-from or --orbit)",
    );
    let written: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(written.len(), 1, "only the copied scene: {written:?}");
}

#[test]
fn a_bad_line_of_a_frame_list_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let list = dir.path().join("frames.txt");
    std::fs::copy(spd("tetra-4.nff"), dir.path().join("a.nff")).unwrap();
    std::fs::write(&list, "a.nff\n# a comment\n\nmissing.nff\n").unwrap();
    let out = dir.path().join("f-%d.png");
    let o = parrt(&[
        "render",
        "--frames-from",
        list.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    let at = format!(
        "parrt: {}:4: {}/missing.nff: ",
        list.display(),
        dir.path().display()
    );
    assert!(err.starts_with(&at), "{err}");
    // A line naming a malformed scene is named too, and so is the line in the scene.
    std::fs::write(dir.path().join("bad.nff"), "v\nfrom 0 0\n").unwrap();
    std::fs::write(&list, "a.nff\nbad.nff\n").unwrap();
    let o = parrt(&[
        "render",
        "--frames-from",
        list.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.starts_with(&format!("parrt: {}:2: ", list.display())),
        "{err}"
    );
    assert!(err.contains("bad.nff"), "{err}");
    assert!(
        !out.with_file_name("f-0.png").exists(),
        "no frame before the check"
    );
}

/// Ctrl-C once the first frame is written: exit 130, every frame on disk complete (a PNG of
/// the full size), no temporary file left, and not every frame written. Waits for a file, not
/// for a time.
#[test]
fn ctrl_c_leaves_only_complete_frames_and_exits_130() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("f-%03d.png");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_parrt"))
        .args([
            "render",
            &spd("mount-6.nff"),
            "--orbit",
            "360",
            "--frames",
            "400",
        ])
        .args([
            "--width",
            "96",
            "--height",
            "64",
            "--threads",
            "1",
            "--tile",
            "16",
        ])
        .arg("-o")
        .arg(&out)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("parrt starts");
    let first = dir.path().join("f-000.png");
    while !first.exists() {
        if let Some(status) = child.try_wait().unwrap() {
            panic!("parrt ended before its first frame: {status}");
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let killed = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(killed.success());
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(err.starts_with("parrt: stopped by Ctrl-C; "), "{err}");
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        !names.is_empty() && names.len() < 400,
        "{} frames",
        names.len()
    );
    for n in &names {
        assert!(
            n.starts_with("f-") && n.ends_with(".png"),
            "left behind: {n}"
        );
        let img = bytes(&dir.path().join(n));
        assert_eq!(&img[1..4], b"PNG", "{n}");
        let be = |i: usize| u32::from_be_bytes([img[i], img[i + 1], img[i + 2], img[i + 3]]);
        assert_eq!((be(16), be(20)), (96, 64), "{n}");
    }
    assert!(
        err.contains(&format!("{} of 400 frames written", names.len())),
        "{err}"
    );
}
