//! `parrt cluster` as a launcher would start it: three processes with Slurm's (or Open MPI's)
//! rank variables meet through a rendezvous file and render the SMP image bit for bit, then the
//! file is gone; no launcher in the environment, a stale or foreign rendezvous file, and a
//! worker rank with no master are clear errors (exit 2) that overwrite nothing.

use crate::EXE;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Every variable `parrt cluster` reads from a launcher, removed so the test's own environment
/// (a test run under srun, say) cannot leak in.
const LAUNCHER_VARS: [&str; 12] = [
    "SLURM_PROCID",
    "SLURM_NTASKS",
    "SLURM_JOB_ID",
    "SLURM_STEP_ID",
    "SLURM_CPUS_PER_TASK",
    "OMPI_COMM_WORLD_RANK",
    "OMPI_COMM_WORLD_SIZE",
    "OMPI_MCA_ess_base_jobid",
    "OMPI_MCA_orte_ess_jobid",
    "PMIX_NAMESPACE",
    "PMI_RANK",
    "PMI_SIZE",
];

const SCENE: [&str; 6] = ["--scene", "balls:1", "--width", "64", "--height", "48"];

fn cluster(dir: &Path, env: &[(&str, String)], extra: &[&str]) -> Command {
    let mut c = Command::new(EXE);
    c.arg("cluster")
        .args(SCENE)
        .args(["--tile", "16", "--listen", "127.0.0.1:0"])
        .args(extra)
        .current_dir(dir);
    for v in LAUNCHER_VARS {
        c.env_remove(v);
    }
    c.env_remove("PARRT_TOKEN");
    for (k, v) in env {
        c.env(k, v);
    }
    c
}

fn smp_image(dir: &Path) -> Vec<u8> {
    let out = dir.join("smp.exr");
    let st = Command::new(EXE)
        .arg("render")
        .args(SCENE)
        .args(["--tile", "16", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(st.status.success(), "{st:?}");
    std::fs::read(out).unwrap()
}

fn run_ranks(dir: &Path, env_of: &dyn Fn(usize) -> Vec<(&'static str, String)>, extra: &[&str]) {
    let children: Vec<_> = (0..3)
        .map(|r| {
            cluster(dir, &env_of(r), extra)
                .arg("-o")
                .arg(dir.join("out.exr"))
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    for (r, c) in children.into_iter().enumerate() {
        let out = c.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "rank {r}: {err}");
        if r == 0 {
            assert!(err.contains("is the master on"), "{err}");
        }
    }
}

fn rendezvous_files(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().contains("rendezvous"))
        .collect()
}

#[test]
fn three_slurm_ranks_render_the_smp_image_and_clean_up() {
    let dir = tempfile::tempdir().unwrap();
    let rdv = dir.path().join("shared");
    std::fs::create_dir(&rdv).unwrap();
    let rdv_arg = rdv.to_string_lossy().to_string();
    run_ranks(
        dir.path(),
        &|r| {
            vec![
                ("SLURM_JOB_ID", "4242".into()),
                ("SLURM_STEP_ID", "0".into()),
                ("SLURM_PROCID", r.to_string()),
                ("SLURM_NTASKS", "3".into()),
                ("SLURM_CPUS_PER_TASK", "1".into()),
            ]
        },
        &["--rendezvous", &rdv_arg],
    );
    assert_eq!(
        std::fs::read(dir.path().join("out.exr")).unwrap(),
        smp_image(dir.path()),
        "cluster image differs from SMP"
    );
    assert_eq!(std::fs::read_dir(&rdv).unwrap().count(), 0, "file left");
}

#[test]
fn three_open_mpi_ranks_meet_in_the_working_directory() {
    let dir = tempfile::tempdir().unwrap();
    run_ranks(
        dir.path(),
        &|r| {
            vec![
                ("OMPI_MCA_ess_base_jobid", "31337".into()),
                ("OMPI_COMM_WORLD_RANK", r.to_string()),
                ("OMPI_COMM_WORLD_SIZE", "3".into()),
            ]
        },
        &["--threads", "1"],
    );
    assert_eq!(
        std::fs::read(dir.path().join("out.exr")).unwrap(),
        smp_image(dir.path())
    );
    assert!(rendezvous_files(dir.path()).is_empty());
}

#[test]
fn a_resume_with_every_tile_restored_still_releases_the_worker_ranks() {
    let dir = tempfile::tempdir().unwrap();
    let env = |job: &'static str| {
        move |r: usize| {
            vec![
                ("SLURM_JOB_ID", job.to_string()),
                ("SLURM_PROCID", r.to_string()),
                ("SLURM_NTASKS", "3".into()),
                ("SLURM_CPUS_PER_TASK", "1".into()),
            ]
        }
    };
    let t0 = Instant::now();
    let ckpt = ["--checkpoint", "run.ckpt", "--rendezvous-timeout", "10"];
    run_ranks(dir.path(), &env("5"), &ckpt);
    std::fs::remove_file(dir.path().join("out.exr")).unwrap();
    // The checkpoint holds every tile: rank 0 renders nothing, but must still meet both workers
    // and tell them to stop, or they would wait for it until the timeout and fail.
    run_ranks(dir.path(), &env("6"), &[&ckpt[..], &["--resume"]].concat());
    assert!(t0.elapsed() < Duration::from_secs(10), "{:?}", t0.elapsed());
    assert_eq!(
        std::fs::read(dir.path().join("out.exr")).unwrap(),
        smp_image(dir.path())
    );
    assert!(rendezvous_files(dir.path()).is_empty());
}

fn slurm(rank: usize, job: &str) -> Vec<(&'static str, String)> {
    vec![
        ("SLURM_JOB_ID", job.into()),
        ("SLURM_PROCID", rank.to_string()),
        ("SLURM_NTASKS", "3".into()),
    ]
}

fn run_one(dir: &Path, env: &[(&str, String)], extra: &[&str]) -> (Output, String) {
    let out = cluster(dir, env, extra)
        .arg("-o")
        .arg(dir.join("out.png"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    (out, err)
}

/// [`run_one`], killed and failed if it runs past `limit` (a rank blocked on a FIFO never
/// returns by itself).
fn run_one_within(
    dir: &Path,
    env: &[(&str, String)],
    extra: &[&str],
    limit: Duration,
) -> (Output, String) {
    let mut child = cluster(dir, env, extra)
        .arg("-o")
        .arg(dir.join("out.png"))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t0.elapsed() > limit {
            let _ = child.kill();
            let out = child.wait_with_output().unwrap();
            panic!(
                "parrt cluster {extra:?} still running after {limit:?}: {}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    (out, err)
}

#[test]
fn no_launcher_in_the_environment_is_a_usage_error() {
    let dir = tempfile::tempdir().unwrap();
    let (out, err) = run_one(dir.path(), &[], &[]);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("no rank in the environment"), "{err}");
    assert!(err.contains("SLURM_PROCID"), "{err}");
    // Two launchers that disagree.
    let mut env = slurm(0, "1");
    env.push(("PMI_RANK", "1".into()));
    env.push(("PMI_SIZE", "3".into()));
    let (out, err) = run_one(dir.path(), &env, &[]);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("disagree"), "{err}");
    assert!(!dir.path().join("out.png").exists());
}

#[test]
fn a_missing_rendezvous_directory_is_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let (out, err) = run_one(dir.path(), &slurm(0, "3"), &["--rendezvous", "no/such/dir"]);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("not a directory"), "{err}");
}

fn leftover(dir: &Path, job_in_name: &str, job_inside: &str, pid: u32, age: u64) -> PathBuf {
    let path = dir.join(format!("parrt-rendezvous-slurm-{job_in_name}.json"));
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_secs();
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname")
        .unwrap()
        .trim()
        .to_string();
    let body = serde_json::json!({
        "version": 1, "job": format!("slurm-{job_inside}"), "size": 3,
        "address": "127.0.0.1:9", "token": "00112233445566778899aabbccddeeff",
        "pid": pid, "host": host, "created": now - age,
    });
    std::fs::write(&path, body.to_string()).unwrap();
    // Private, as rank 0 writes it (it holds the job's token).
    std::fs::set_permissions(&path, std::os::unix::fs::PermissionsExt::from_mode(0o600)).unwrap();
    path
}

/// A file planted by another user (`nobody`) naming their master, and a FIFO at the rendezvous
/// path: every rank refuses at once (exit 2) and none dials.
#[test]
fn a_planted_or_fifo_rendezvous_file_is_refused_by_every_rank() {
    let dir = tempfile::tempdir().unwrap();
    let path = leftover(dir.path(), "5", "5", std::process::id(), 0);
    // The tests run as root, who may give the file to `nobody`; anyone else cannot.
    if std::os::unix::fs::chown(&path, Some(65534), Some(65534)).is_ok() {
        for rank in [0, 1] {
            let (out, err) = run_one(dir.path(), &slurm(rank, "5"), &[]);
            assert_eq!(out.status.code(), Some(2), "rank {rank}: {err}");
            assert!(err.contains("owned by uid 65534"), "rank {rank}: {err}");
        }
    } else {
        eprintln!("not root: the planted-by-another-user case needs chown");
    }
    std::fs::remove_file(&path).unwrap();
    let made = Command::new("mkfifo").arg(&path).status().unwrap();
    assert!(made.success());
    for rank in [0, 1] {
        // A hang guard, not a timing: without the check every rank hung on the FIFO, past its
        // --rendezvous-timeout of 5 s.
        let (out, err) = run_one_within(
            dir.path(),
            &slurm(rank, "5"),
            &["--rendezvous-timeout", "5"],
            Duration::from_secs(30),
        );
        assert_eq!(out.status.code(), Some(2), "rank {rank}: {err}");
        assert!(
            err.contains("a FIFO, not a regular file"),
            "rank {rank}: {err}"
        );
    }
}

#[test]
fn stale_or_foreign_rendezvous_files_are_refused_and_kept() {
    let dir = tempfile::tempdir().unwrap();
    // A dead job's file: its pid (a child that has exited) is gone.
    let mut gone = Command::new("true").spawn().unwrap();
    let dead = gone.id();
    gone.wait().unwrap();
    for (name, inside, pid, age, rank0_says, rank1_says) in [
        ("9", "9", dead, 0, "stale", "is stale"),
        ("9", "9", std::process::id(), 3600, "3600 s ago", "is stale"),
        (
            "9",
            "8",
            std::process::id(),
            0,
            "belongs to job",
            "not to this job",
        ),
    ] {
        let path = leftover(dir.path(), name, inside, pid, age);
        let before = std::fs::read(&path).unwrap();
        for (rank, want) in [(0, rank0_says), (1, rank1_says)] {
            let (out, err) = run_one(dir.path(), &slurm(rank, name), &[]);
            assert_eq!(out.status.code(), Some(2), "rank {rank}: {err}");
            assert!(err.contains(want), "rank {rank} lacks {want:?}: {err}");
            assert_eq!(std::fs::read(&path).unwrap(), before, "overwritten");
            assert!(!dir.path().join("out.png").exists());
        }
        std::fs::remove_file(&path).unwrap();
    }
}

#[test]
fn a_worker_rank_without_a_master_times_out_clearly() {
    let dir = tempfile::tempdir().unwrap();
    let t0 = Instant::now();
    let (out, err) = run_one(
        dir.path(),
        &slurm(2, "77"),
        &["--rendezvous-timeout", "0.5"],
    );
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("no rendezvous file"), "{err}");
    assert!(err.contains("rank 2 of 3"), "{err}");
    assert!(t0.elapsed() < Duration::from_secs(20));
}

#[test]
fn three_slurm_ranks_render_a_sequence_to_the_smp_sequence_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let orbit = ["--orbit", "120", "--frames", "3"];
    let children: Vec<_> = (0..3)
        .map(|r| {
            cluster(dir.path(), &slurm(r, "5151"), &["--threads", "1"])
                .args(orbit)
                .arg("-o")
                .arg(dir.path().join("cl-%d.exr"))
                .stdout(Stdio::null())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    for (r, c) in children.into_iter().enumerate() {
        let out = c.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "rank {r}: {err}");
        if r == 0 {
            assert!(err.contains("parrt cluster: wrote 3 frames"), "{err}");
        }
    }
    let st = Command::new(EXE)
        .arg("render")
        .args(SCENE)
        .args(orbit)
        .args(["--tile", "16", "-o"])
        .arg(dir.path().join("smp-%d.exr"))
        .output()
        .unwrap();
    assert!(st.status.success(), "{st:?}");
    for k in 0..3 {
        let read = |name: String| std::fs::read(dir.path().join(name)).unwrap();
        assert!(
            read(format!("cl-{k}.exr")) == read(format!("smp-{k}.exr")),
            "frame {k} of the cluster differs from SMP"
        );
    }
    assert!(!dir.path().join("cl-3.exr").exists());
    assert!(rendezvous_files(dir.path()).is_empty());
}

#[test]
fn an_orbit_through_cluster_ranks_sends_each_worker_its_scene_once() {
    let dir = tempfile::tempdir().unwrap();
    let scene = ["--scene", "balls:3", "--width", "32", "--height", "32"];
    let desc = parrt_scenes::generate("balls", Some(3)).unwrap();
    let job = parrt_protocol::Message::Job(Box::new(parrt_protocol::JobSpec {
        job_id: 1,
        scene: desc,
        settings: parrt_render::settings::RenderSettings::new(32, 32),
        tile_size: 16,
        pixel_format: Default::default(),
        pack_pixels: true,
    }));
    let job_bytes = parrt_protocol::Encoded::new(&job).unwrap().len() as u64;
    let children: Vec<_> = (0..3)
        .map(|r| {
            let mut c = Command::new(EXE);
            c.arg("cluster")
                .args(scene)
                .args(["--tile", "16", "--listen", "127.0.0.1:0", "--threads", "1"])
                .args(["--orbit", "120", "--frames", "3", "-o"])
                .arg(dir.path().join("o-%d.png"))
                .current_dir(dir.path());
            for v in LAUNCHER_VARS {
                c.env_remove(v);
            }
            c.env_remove("PARRT_TOKEN");
            for (k, v) in slurm(r, "5252") {
                c.env(k, v);
            }
            c.stdout(Stdio::null())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    let mut sent = None;
    for (r, c) in children.into_iter().enumerate() {
        let out = c.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr).to_string();
        assert!(out.status.success(), "rank {r}: {err}");
        if r == 0 {
            let before = err.split(" bytes out").next().unwrap();
            let n = before.rsplit(' ').next().unwrap();
            sent = Some(n.parse::<u64>().unwrap_or_else(|_| panic!("{err}")));
        }
    }
    // Two workers, three frames of one scene: the scene goes to each worker once, the later
    // frames as their camera (each frame's whole Job would be six scenes).
    let sent = sent.unwrap();
    assert!(
        sent > 2 * job_bytes && sent < 2 * job_bytes + 16 * 1024,
        "{sent} bytes out for a {job_bytes}-byte Job"
    );
    assert!(dir.path().join("o-2.png").exists());
    assert!(rendezvous_files(dir.path()).is_empty());
}
