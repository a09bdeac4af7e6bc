//! The scene a command renders, as every command takes it: an NFF file, a scene description in
//! parrt's JSON form (`--scene-json FILE`, or a file named `*.json`), or a generated scene
//! `NAME[:SIZE]`; none is the built-in default (mount at its default size). The one parser, and
//! the one set of errors (bad input, exit 2), for render, master, cluster and every bench study.

use super::ArgError;
use anyhow::Context;
use parrt_render::description::SceneDescription;
use parrt_render::nff::Limits;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The built-in default scene: the PARRT paper's fractal mountain.
pub const DEFAULT_SCENE: &str = "mount";

/// A scene chosen on the command line.
#[derive(Debug, Clone)]
pub enum SceneSpec {
    /// An NFF file.
    File(PathBuf),
    /// A scene description in parrt's JSON form (serde of `SceneDescription`).
    Json(PathBuf),
    /// A generator and optional size factor.
    Generated {
        /// Generator name.
        name: String,
        /// Size factor (`None`: default).
        size: Option<u32>,
    },
}

impl SceneSpec {
    /// The scene flags of `render`, `master` and `cluster`: a file argument, `--scene
    /// NAME[:SIZE]` or `--scene-json FILE`, at most one; none is the default scene.
    pub fn from_args(
        file: Option<PathBuf>,
        scene: Option<&str>,
        json: Option<PathBuf>,
    ) -> anyhow::Result<Self> {
        match (file, scene, json) {
            (Some(_), Some(_), _) => Err(ArgError::Conflict(
                "give either an NFF file or --scene, not both".into(),
            )
            .into()),
            (Some(_), None, Some(_)) | (None, Some(_), Some(_)) => Err(ArgError::Conflict(
                "give one of an NFF file, --scene and --scene-json".into(),
            )
            .into()),
            (None, None, Some(j)) => Ok(SceneSpec::Json(j)),
            (Some(f), None, None) => Ok(Self::file(f)),
            (None, Some(s), None) => Self::generated(s),
            (None, None, None) => Ok(SceneSpec::Generated {
                name: DEFAULT_SCENE.to_string(),
                size: None,
            }),
        }
    }

    /// A scene file: parrt's JSON form when its name ends in `.json`, else NFF.
    pub fn file(path: PathBuf) -> Self {
        if has_extension(&path, "json") {
            SceneSpec::Json(path)
        } else {
            SceneSpec::File(path)
        }
    }

    /// A scene argument of the benches: a file (named `*.nff` or `*.json`, or any path that
    /// exists), else a generated scene `NAME[:SIZE]`.
    pub fn parse(s: &str) -> anyhow::Result<Self> {
        let p = PathBuf::from(s);
        if has_extension(&p, "nff") || has_extension(&p, "json") || p.exists() {
            Ok(Self::file(p))
        } else {
            Self::generated(s)
        }
    }

    /// A generated scene, `NAME` or `NAME:SIZE`.
    pub fn generated(s: &str) -> anyhow::Result<Self> {
        let (name, size) = match s.split_once(':') {
            Some((n, z)) => {
                let size: u32 = z.parse().map_err(|_| {
                    ArgError::Value(format!(
                        "--scene {s}: size '{z}' is not a whole number (use NAME or NAME:SIZE)"
                    ))
                })?;
                (n, Some(size))
            }
            None => (s, None),
        };
        if name.is_empty() {
            return Err(ArgError::Value("--scene needs a generator name".into()).into());
        }
        Ok(SceneSpec::Generated {
            name: name.to_string(),
            size,
        })
    }

    /// A short label for messages, titles and reports: the scene as the user named it
    /// (`mount-6.nff`, `mount:6`, `mount`).
    pub fn label(&self) -> String {
        match self {
            SceneSpec::File(p) | SceneSpec::Json(p) => p.display().to_string(),
            SceneSpec::Generated { name, size } => match size {
                Some(s) => format!("{name}:{s}"),
                None => name.clone(),
            },
        }
    }

    /// Loads the description; returns it with the seconds spent parsing or generating. A file
    /// the user named that cannot be read or parsed is bad input (exit 2), named in the error.
    pub fn load(&self, limits: &Limits) -> anyhow::Result<(SceneDescription, f64)> {
        let t0 = Instant::now();
        let desc = match self {
            SceneSpec::File(p) => parrt_render::nff::parse_file(p, limits).map_err(|e| {
                if e.kind == parrt_render::nff::NffErrorKind::Io {
                    ArgError::file(&e.file, &e.message)
                } else {
                    ArgError::refused(e)
                }
            })?,
            SceneSpec::Json(p) => {
                let bytes = super::limits::read_path(p, limits.max_file_bytes)?;
                serde_json::from_slice(&bytes).map_err(|e| ArgError::file(p, e))?
            }
            SceneSpec::Generated { name, size } => parrt_scenes::generate(name, *size)
                .map_err(ArgError::refused)
                .with_context(|| format!("cannot generate scene {}", self.label()))?,
        };
        Ok((desc, t0.elapsed().as_secs_f64()))
    }
}

fn has_extension(p: &Path, ext: &str) -> bool {
    p.extension().is_some_and(|e| e == ext)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_parser_for_files_names_and_json() {
        assert!(matches!(
            SceneSpec::parse("a/b.nff").unwrap(),
            SceneSpec::File(_)
        ));
        assert!(matches!(
            SceneSpec::parse("a/b.json").unwrap(),
            SceneSpec::Json(_)
        ));
        let g = SceneSpec::parse("mount:6").unwrap();
        assert_eq!(g.label(), "mount:6");
        assert_eq!(SceneSpec::parse("balls").unwrap().label(), "balls");
        for bad in ["mount:x", ":3"] {
            let e = SceneSpec::parse(bad).unwrap_err();
            assert!(ArgError::is_in(&e), "{e}");
        }
        let both = SceneSpec::from_args(Some("a.nff".into()), Some("mount"), None).unwrap_err();
        assert!(both.to_string().contains("not both"), "{both}");
        let json = SceneSpec::from_args(None, None, Some("s.txt".into())).unwrap();
        assert!(matches!(json, SceneSpec::Json(_)));
        assert_eq!(
            SceneSpec::from_args(None, None, None).unwrap().label(),
            "mount"
        );
    }
}
