//! Test support for parrt's test binaries (a dev-dependency only; never part of a build of
//! `parrt` or `parrt-worker`): where the SPD scenes are and their files, the tables of their
//! README, the three-accelerator oracle, scenes built in code (the shared fixtures), rendering a
//! built scene, and bit-for-bit film comparison.
//!
//! The SPD files live in the repository at `data/spd` (Haines' Standard Procedural Databases,
//! public domain); `PARRT_SPD_DIR` points the tests at another copy.

pub mod film;
pub mod readme;
pub mod render;
pub mod scene;
pub mod spd;

use std::path::{Path, PathBuf};

/// The environment variable that points the tests at another copy of the SPD files.
pub const SPD_DIR_ENV: &str = "PARRT_SPD_DIR";

/// The SPD scene directory: `$PARRT_SPD_DIR` if set, else the repository's `data/spd`. Panics
/// with a clear message when the directory is missing: the tests must not pass by skipping.
pub fn spd_dir() -> PathBuf {
    if let Some(d) = std::env::var_os(SPD_DIR_ENV) {
        let d = PathBuf::from(d);
        assert!(
            d.is_dir(),
            "{SPD_DIR_ENV}={} is not a directory",
            d.display()
        );
        return d;
    }
    let dir = repository().join("data").join("spd");
    assert!(
        dir.is_dir(),
        "cannot find the SPD scenes: {} is not a directory (set {SPD_DIR_ENV} to use another copy)",
        dir.display()
    );
    dir
}

/// The repository's root directory (the workspace this crate belongs to).
pub fn repository() -> PathBuf {
    let here = Path::new(env!("CARGO_MANIFEST_DIR"));
    here.parent().unwrap_or(here).to_path_buf()
}

/// Every `*.nff` in the SPD directory, sorted by name (panics when there are none).
pub fn spd_files() -> Vec<PathBuf> {
    let dir = spd_dir();
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("cannot list {}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "nff"))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no .nff files in {}", dir.display());
    files
}

/// Every SPD file (there are 27), parsed one at a time, with its name (`"mount-4"`); panics
/// when the set is not the 27 files or one does not parse.
pub fn spd_scenes() -> impl Iterator<Item = (String, parrt_render::description::SceneDescription)> {
    let files = spd_files();
    assert_eq!(files.len(), 27, "the SPD set has 27 files");
    files.into_iter().map(|path| {
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        let desc = parrt_render::nff::parse_file(&path, &Default::default())
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        (name, desc)
    })
}

/// The bytes of the SPD file `name` (e.g. `"tetra-4.nff"`).
pub fn spd_bytes(name: &str) -> Vec<u8> {
    let p = spd_dir().join(name);
    std::fs::read(&p).unwrap_or_else(|e| panic!("cannot read {}: {e}", p.display()))
}
