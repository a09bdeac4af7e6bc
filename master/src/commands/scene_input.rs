//! Where a command's scene comes from: an NFF file, a generated scene (`--scene NAME[:SIZE]`), or
//! the built-in default (mount at its default size). Shared by render, master and bench.

use crate::exit::input_error;
use anyhow::Context;
use clap::Args;
use parrt::description::SceneDescription;
use parrt::nff::Limits;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The built-in default scene: the PARRT paper's fractal mountain.
pub const DEFAULT_SCENE: &str = "mount";

/// Parser limits, raisable from the command line.
#[derive(Debug, Clone, Args)]
pub struct LimitArgs {
    /// Maximum vertices in one polygon or patch.
    #[arg(long, value_name = "N", default_value_t = parrt::nff::limits::DEFAULT_MAX_VERTICES)]
    pub max_vertices: u32,
    /// Maximum primitives in a scene.
    #[arg(long, value_name = "N", default_value_t = parrt::nff::limits::DEFAULT_MAX_PRIMITIVES)]
    pub max_primitives: u64,
    /// Maximum pixels (width × height) of an image.
    #[arg(long, value_name = "N", default_value_t = parrt::nff::limits::DEFAULT_MAX_PIXELS)]
    pub max_pixels: u64,
    /// Maximum bytes of a scene or other input file (only regular files are read).
    #[arg(long, value_name = "BYTES", default_value_t = parrt::nff::limits::DEFAULT_MAX_FILE_BYTES)]
    pub max_file_bytes: u64,
}

/// Most tiles an image may be cut into (4 Mi): every tile costs the schedulers tens of bytes, so
/// a 16384² image at `--tile 1` (268 M tiles) would take gigabytes before the first ray.
pub const MAX_TILES: u64 = 1 << 22;

impl LimitArgs {
    /// The parser limits these flags describe.
    pub fn limits(&self) -> Limits {
        Limits {
            max_vertices: self.max_vertices,
            max_primitives: self.max_primitives,
            max_pixels: self.max_pixels,
            max_file_bytes: self.max_file_bytes,
        }
    }

    /// Checks the image a command is about to render, before anything is allocated for it:
    /// width × height within `--max-pixels`, and at most [`MAX_TILES`] tiles of `tile` pixels.
    /// The one check `render`, `master` and the benches share.
    pub fn check_image(&self, width: u32, height: u32, tile: u32) -> anyhow::Result<()> {
        let pixels = width as u64 * height as u64;
        if pixels > self.max_pixels {
            return Err(input_error(anyhow::anyhow!(
                "{width}x{height} is {pixels} pixels, over the limit of {} (raise it with --max-pixels)",
                self.max_pixels
            )));
        }
        if tile == 0 {
            return Err(input_error(anyhow::anyhow!("--tile must be at least 1")));
        }
        let count = |t: u32| (width as u64).div_ceil(t as u64) * (height as u64).div_ceil(t as u64);
        if count(tile) > MAX_TILES {
            let fits = (tile..=width.max(height).max(tile))
                .find(|&t| count(t) <= MAX_TILES)
                .unwrap_or(tile);
            return Err(input_error(anyhow::anyhow!(
                "--tile {tile} cuts {width}x{height} into {} tiles, over the limit of {MAX_TILES}; use --tile {fits} or larger",
                count(tile)
            )));
        }
        Ok(())
    }

    /// Reads a file named on the command line (`--scene-json`, `--tile-costs`, `parrt info`'s
    /// file): only a regular file, at most `--max-file-bytes`. Failures are bad input (exit 2)
    /// and name the path.
    pub fn read_file(&self, path: &Path) -> anyhow::Result<Vec<u8>> {
        Self::read_path(path, self.max_file_bytes)
    }

    /// [`Self::read_file`] with an explicit limit, for commands without the limit flags.
    pub fn read_path(path: &Path, max_bytes: u64) -> anyhow::Result<Vec<u8>> {
        parrt::nff::read_bounded(path, max_bytes)
            .map_err(|e| input_error(anyhow::anyhow!("{}: {e}", path.display())))
    }
}

/// A scene chosen on the command line.
#[derive(Debug, Clone)]
pub enum SceneSpec {
    /// An NFF file.
    File(PathBuf),
    /// A generator and optional size factor.
    Generated {
        /// Generator name.
        name: String,
        /// Size factor (`None`: default).
        size: Option<u32>,
    },
}

impl SceneSpec {
    /// Chooses between a file argument and `--scene NAME[:SIZE]`; neither means the default scene.
    pub fn from_args(file: Option<PathBuf>, scene: Option<&str>) -> anyhow::Result<Self> {
        match (file, scene) {
            (Some(_), Some(_)) => Err(input_error(anyhow::anyhow!(
                "give either an NFF file or --scene, not both"
            ))),
            (Some(f), None) => Ok(SceneSpec::File(f)),
            (None, Some(s)) => parse_scene_name(s),
            (None, None) => Ok(SceneSpec::Generated {
                name: DEFAULT_SCENE.to_string(),
                size: None,
            }),
        }
    }

    /// A short label for messages (`mount-6.nff`, `mount:default`).
    pub fn label(&self) -> String {
        match self {
            SceneSpec::File(p) => p.display().to_string(),
            SceneSpec::Generated { name, size } => match size {
                Some(s) => format!("{name}:{s}"),
                None => format!("{name}:default"),
            },
        }
    }

    /// Loads the description; returns it with the seconds spent parsing or generating.
    pub fn load(&self, limits: &Limits) -> anyhow::Result<(SceneDescription, f64)> {
        let t0 = Instant::now();
        let desc = match self {
            // A file the user named that cannot be read is bad input too (exit 2).
            SceneSpec::File(p) => parrt::nff::parse_file(p, limits).map_err(|e| {
                if e.kind == parrt::nff::NffErrorKind::Io {
                    input_error(anyhow::anyhow!("{}: {}", e.file, e.message))
                } else {
                    input_error(e)
                }
            })?,
            SceneSpec::Generated { name, size } => parrt_scenes::generate(name, *size)
                .map_err(input_error)
                .with_context(|| format!("cannot generate scene {}", self.label()))?,
        };
        Ok((desc, t0.elapsed().as_secs_f64()))
    }
}

/// Parses `NAME` or `NAME:SIZE`.
pub fn parse_scene_name(s: &str) -> anyhow::Result<SceneSpec> {
    let (name, size) = match s.split_once(':') {
        Some((n, z)) => {
            let size: u32 = z.parse().map_err(|_| {
                input_error(anyhow::anyhow!(
                    "--scene {s}: size '{z}' is not a whole number (use NAME or NAME:SIZE)"
                ))
            })?;
            (n, Some(size))
        }
        None => (s, None),
    };
    if name.is_empty() {
        return Err(input_error(anyhow::anyhow!(
            "--scene needs a generator name"
        )));
    }
    Ok(SceneSpec::Generated {
        name: name.to_string(),
        size,
    })
}
