//! Where a command's scene comes from: an NFF file, a generated scene (`--scene NAME[:SIZE]`), or
//! the built-in default (mount at its default size). Shared by render, master and bench.

use crate::exit::input_error;
use anyhow::Context;
use clap::Args;
use parrt::description::SceneDescription;
use parrt::nff::Limits;
use std::path::PathBuf;
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
}

impl LimitArgs {
    /// The parser limits these flags describe.
    pub fn limits(&self) -> Limits {
        Limits {
            max_vertices: self.max_vertices,
            max_primitives: self.max_primitives,
            max_pixels: self.max_pixels,
        }
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
