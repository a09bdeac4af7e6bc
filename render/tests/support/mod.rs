//! Helpers shared by the test binaries of `render/tests/` (and, by path, `master/tests/` and
//! `tests/src`): where the SPD scenes are and their files, the three-accelerator oracle, scenes
//! built in code, and bit-for-bit film comparison. Test support only; never used by the renderer.
#![allow(dead_code)] // each test binary uses a different subset

pub mod film;
pub mod scene;
pub mod spd;

use std::path::{Path, PathBuf};

/// The SPD scene directory: `$PARRT_SPD_DIR` if set, else the first `shared/spd` found walking up
/// from this crate's directory (the repository has `shared/` beside it). Panics with a clear
/// message when neither exists: the tests must not pass by skipping.
pub fn spd_dir() -> PathBuf {
    if let Some(d) = std::env::var_os("PARRT_SPD_DIR") {
        let d = PathBuf::from(d);
        assert!(
            d.is_dir(),
            "PARRT_SPD_DIR={} is not a directory",
            d.display()
        );
        return d;
    }
    let start = Path::new(env!("CARGO_MANIFEST_DIR"));
    for dir in start.ancestors() {
        let cand = dir.join("shared").join("spd");
        if cand.is_dir() {
            return cand;
        }
    }
    panic!(
        "cannot find the SPD scenes: set PARRT_SPD_DIR, or put shared/spd beside the repository \
         (searched upward from {})",
        start.display()
    );
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
pub fn spd_scenes() -> impl Iterator<Item = (String, parrt::description::SceneDescription)> {
    let files = spd_files();
    assert_eq!(files.len(), 27, "the SPD set has 27 files");
    files.into_iter().map(|path| {
        let name = path.file_stem().unwrap().to_string_lossy().into_owned();
        let desc = parrt::nff::parse_file(&path, &Default::default())
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        (name, desc)
    })
}

/// The bytes of the SPD file `name` (e.g. `"tetra-4.nff"`).
pub fn spd_bytes(name: &str) -> Vec<u8> {
    let p = spd_dir().join(name);
    std::fs::read(&p).unwrap_or_else(|e| panic!("cannot read {}: {e}", p.display()))
}
