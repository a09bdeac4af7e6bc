//! Distributed-test helpers: small scenes built in code, the SMP reference render, masters and
//! workers started in-process or as processes over loopback.

use parrt_protocol::Token;
use parrt_render::description::{Light, Material, Primitive, SceneDescription, Shape, View};
use parrt_render::film::Film;
use parrt_render::render::Renderer;
use parrt_render::settings::RenderSettings;
use parrt_render::smp::{render_smp, Executor, SmpOptions};
use parrt_render::stats::RayStats;
use parrt_render::vec3::Vec3d;
use parrt_runtime::{DistResult, Master, MasterConfig};
use parrt_worker::session::SessionSummary;
use parrt_worker::{WorkerError, WorkerOptions};
use std::net::SocketAddr;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;
use tokio::task::JoinHandle;
use tokio_util::sync::CancellationToken;

/// The token the tests share.
pub const TEST_TOKEN: &str = "parrt-test-token";

/// [`TEST_TOKEN`] as a token.
pub fn token() -> Token {
    Token::new(TEST_TOKEN).expect("non-empty")
}

/// The worker's side of the encrypted channel over `s`, with the test token: what a raw
/// test peer speaks inside, as a worker does.
pub async fn secure_client<S>(s: S) -> parrt_protocol::SecureStream<S>
where
    S: tokio::io::AsyncRead + tokio::io::AsyncWrite + Unpin,
{
    let key = parrt_protocol::LinkKey::from_token(&token());
    parrt_protocol::channel::connect(s, &key, None)
        .await
        .expect("the channel opens with the test token")
}

/// The master's side of the encrypted channel over `s`, with the test token (a fake master).
pub async fn secure_server<S>(s: S) -> parrt_protocol::SecureStream<S>
where
    S: tokio::io::AsyncRead + tokio::io::AsyncWrite + Unpin,
{
    let key = parrt_protocol::LinkKey::from_token(&token());
    parrt_protocol::channel::accept(s, &key, None)
        .await
        .expect("the channel opens with the test token")
}

/// A small scene: a floor polygon, a matte, a mirror and a glass sphere, two lights.
pub fn test_scene(width: u32, height: u32) -> SceneDescription {
    let v = Vec3d::new;
    let mat = |c: Vec3d, kd, ks, shine, t, ior| Material {
        color: c,
        kd,
        ks,
        shine,
        t,
        ior,
    };
    SceneDescription {
        background: v(0.2, 0.3, 0.5),
        view: View {
            from: v(0.0, 1.5, 6.0),
            at: v(0.0, 0.3, 0.0),
            up: v(0.0, 1.0, 0.0),
            angle: 45.0,
            hither: 0.01,
            width,
            height,
        },
        lights: vec![
            Light {
                position: v(4.0, 6.0, 4.0),
                color: None,
            },
            Light {
                position: v(-5.0, 3.0, 2.0),
                color: Some(v(0.8, 0.6, 0.4)),
            },
        ],
        materials: vec![
            mat(v(0.8, 0.8, 0.7), 0.9, 0.1, 10.0, 0.0, 1.0),
            mat(v(0.9, 0.2, 0.2), 0.7, 0.3, 30.0, 0.0, 1.0),
            mat(v(1.0, 1.0, 1.0), 0.1, 0.9, 100.0, 0.0, 1.0),
            mat(v(1.0, 1.0, 1.0), 0.1, 0.2, 80.0, 0.8, 1.5),
        ],
        primitives: vec![
            Primitive {
                shape: Shape::Polygon(
                    vec![
                        v(-5.0, -1.0, -5.0),
                        v(-5.0, -1.0, 5.0),
                        v(5.0, -1.0, 5.0),
                        v(5.0, -1.0, -5.0),
                    ]
                    .into(),
                ),
                material: 0,
            },
            Primitive {
                shape: Shape::Sphere {
                    center: v(-1.3, 0.0, 0.0),
                    radius: 1.0,
                },
                material: 1,
            },
            Primitive {
                shape: Shape::Sphere {
                    center: v(1.2, 0.0, -0.5),
                    radius: 1.0,
                },
                material: 2,
            },
            Primitive {
                shape: Shape::Sphere {
                    center: v(0.2, -0.4, 1.6),
                    radius: 0.6,
                },
                material: 3,
            },
        ],
    }
}

/// Settings for `desc` at its own size.
pub fn settings_for(desc: &SceneDescription) -> RenderSettings {
    RenderSettings::new(desc.view.width, desc.view.height)
}

/// The SMP reference render (one thread, queue executor).
pub fn smp_reference(
    desc: &SceneDescription,
    settings: &RenderSettings,
    tile: u32,
) -> (Film, RayStats) {
    let r = Renderer::new(desc, settings).expect("test scene builds");
    let out = render_smp(
        &r,
        &SmpOptions {
            threads: 1,
            tile,
            executor: Executor::Queue,
        },
        &|_, _| {},
    );
    (out.film, out.stats)
}

pub use parrt_test_support::film::assert_same_bits;

/// Test-friendly master options: loopback, a free port, the test token, no progress bar.
pub fn test_options(tile: u32) -> MasterConfig {
    let mut c = MasterConfig::default();
    c.schedule.tile = tile;
    c.schedule.wait_workers = Duration::from_secs(20);
    c.net.listen = "127.0.0.1:0".into();
    c.net.token = Some(token());
    c
}

/// A master running in a task of the current runtime.
pub struct RunningMaster {
    /// Where it listens.
    pub addr: SocketAddr,
    /// Its result.
    pub handle: JoinHandle<Result<DistResult, parrt_runtime::DistError>>,
    /// Cancels it (as Ctrl-C would).
    pub cancel: CancellationToken,
}

/// Binds a master and starts rendering in a task.
pub async fn start_master(
    desc: &SceneDescription,
    settings: &RenderSettings,
    opts: &MasterConfig,
) -> RunningMaster {
    let master = Master::bind(opts, opts.net.token.clone().unwrap_or_else(token))
        .await
        .expect("bind loopback");
    let addr = master.local_addr();
    let cancel = CancellationToken::new();
    let (desc, settings, c) = (desc.clone(), settings.clone(), cancel.clone());
    let handle = tokio::spawn(async move { master.render(&desc, &settings, c).await });
    RunningMaster {
        addr,
        handle,
        cancel,
    }
}

/// Options of an in-process worker dialling `addr`.
pub fn worker_options(addr: SocketAddr, threads: usize, name: &str) -> WorkerOptions {
    let mut o = WorkerOptions::new(addr.to_string(), token());
    o.threads = threads;
    o.name = name.into();
    o.dial_timeout = Duration::from_secs(10);
    o.tile_delay = None;
    o
}

/// Runs a worker session in a task of the current runtime.
pub fn start_worker(opts: WorkerOptions) -> JoinHandle<Result<SessionSummary, WorkerError>> {
    tokio::spawn(async move { parrt_worker::session::run(&opts, CancellationToken::new()).await })
}

/// A child process killed (and reaped) when dropped.
pub struct ChildGuard(pub Child);

impl ChildGuard {
    /// Its process id.
    pub fn pid(&self) -> u32 {
        self.0.id()
    }
    /// Sends a signal by name (`KILL`, `STOP`, `CONT`, `INT`) with kill(1).
    pub fn signal(&self, sig: &str) {
        let ok = Command::new("kill")
            .arg(format!("-{sig}"))
            .arg(self.pid().to_string())
            .status()
            .expect("run kill")
            .success();
        assert!(ok, "kill -{sig} {}", self.pid());
    }
}

impl Drop for ChildGuard {
    fn drop(&mut self) {
        // Already exited (and now reaped): its pid may belong to someone else; leave it.
        if let Ok(Some(_)) = self.0.try_wait() {
            return;
        }
        let _ = Command::new("kill")
            .arg("-CONT")
            .arg(self.0.id().to_string())
            .status();
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts `exe worker --connect addr --threads n` with the test token in its environment and
/// an optional per-tile delay (the worker's test hook). Its stderr is dropped, so the expected
/// ends of fault tests ("interrupted by SIGTERM", warnings) do not read as
/// failures in a green run; set `PARRT_LOG` (e.g. `PARRT_LOG=info cargo test ...`) to see it.
pub fn spawn_worker_process(
    exe: &Path,
    addr: SocketAddr,
    threads: usize,
    delay_ms: Option<u64>,
    token: &str,
) -> ChildGuard {
    let mut cmd = Command::new(exe);
    cmd.args(["worker", "--connect", &addr.to_string(), "--threads"])
        .arg(threads.to_string())
        .env("PARRT_TOKEN", token)
        .stdin(Stdio::null())
        .stdout(Stdio::null());
    match std::env::var_os(parrt_protocol::LOG_ENV) {
        Some(level) => cmd.env(parrt_protocol::LOG_ENV, level),
        None => cmd.stderr(Stdio::null()),
    };
    match delay_ms {
        Some(ms) => cmd.env(parrt_worker::options::TILE_DELAY_ENV, ms.to_string()),
        None => cmd.env_remove(parrt_worker::options::TILE_DELAY_ENV),
    };
    ChildGuard(cmd.spawn().expect("spawn worker process"))
}

/// `msg` as one frame on the wire (length prefix and postcard payload), for raw-byte peers.
pub fn frame(msg: &parrt_protocol::Message) -> bytes::BytesMut {
    use tokio_util::codec::Encoder;
    let mut buf = bytes::BytesMut::new();
    parrt_protocol::MessageCodec::new(1 << 28)
        .encode(msg, &mut buf)
        .expect("a test message encodes");
    buf
}

/// Reads and discards until the peer closes; true when it closed within 5 s.
pub async fn closed_within_5s<S: tokio::io::AsyncRead + Unpin>(s: &mut S) -> bool {
    use tokio::io::AsyncReadExt;
    let mut buf = [0u8; 4096];
    tokio::time::timeout(Duration::from_secs(5), async {
        loop {
            match s.read(&mut buf).await {
                Ok(0) | Err(_) => return,
                Ok(_) => {}
            }
        }
    })
    .await
    .is_ok()
}
