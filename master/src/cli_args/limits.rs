//! Limit flags (`--max-vertices`, `--max-primitives`, `--max-pixels`, `--max-file-bytes`) and
//! the checks made with them, once, before anything is allocated: the image's size and tile
//! count, and the files a user names. Every refusal is bad input (exit 2) with the flag that
//! raises the limit; nothing here reads more than the limit allows.

use super::ArgError;
use clap::Args;
use parrt_render::nff::Limits;
use std::path::Path;

/// Parser limits, raisable from the command line.
#[derive(Debug, Clone, Args)]
pub struct LimitArgs {
    /// Maximum vertices in one polygon or patch.
    #[arg(long, value_name = "N", default_value_t = parrt_render::nff::limits::DEFAULT_MAX_VERTICES)]
    pub max_vertices: u32,
    /// Maximum primitives in a scene.
    #[arg(long, value_name = "N", default_value_t = parrt_render::nff::limits::DEFAULT_MAX_PRIMITIVES)]
    pub max_primitives: u64,
    /// Maximum pixels (width × height) of an image.
    #[arg(long, value_name = "N", default_value_t = parrt_render::nff::limits::DEFAULT_MAX_PIXELS)]
    pub max_pixels: u64,
    /// Maximum bytes of a scene or other input file (only regular files are read).
    #[arg(long, value_name = "BYTES", default_value_t = parrt_render::nff::limits::DEFAULT_MAX_FILE_BYTES)]
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
            return Err(ArgError::Value(format!(
                "{width}x{height} is {pixels} pixels, over the limit of {} (raise it with --max-pixels)",
                self.max_pixels
            ))
            .into());
        }
        if tile == 0 {
            return Err(ArgError::Value("--tile must be at least 1".into()).into());
        }
        let count = |t: u32| (width as u64).div_ceil(t as u64) * (height as u64).div_ceil(t as u64);
        if count(tile) > MAX_TILES {
            let fits = (tile..=width.max(height).max(tile))
                .find(|&t| count(t) <= MAX_TILES)
                .unwrap_or(tile);
            return Err(ArgError::Value(format!(
                "--tile {tile} cuts {width}x{height} into {} tiles, over the limit of {MAX_TILES}; use --tile {fits} or larger",
                count(tile)
            ))
            .into());
        }
        Ok(())
    }

    /// Reads a file named on the command line (`--scene-json`, `--tile-costs`, `parrt info`'s
    /// file): only a regular file, at most `--max-file-bytes`. Failures are bad input (exit 2)
    /// and name the path.
    pub fn read_file(&self, path: &Path) -> anyhow::Result<Vec<u8>> {
        read_path(path, self.max_file_bytes)
    }
}

/// [`LimitArgs::read_file`] with an explicit limit, for commands without the limit flags.
pub fn read_path(path: &Path, max_bytes: u64) -> anyhow::Result<Vec<u8>> {
    parrt_render::nff::read_bounded(path, max_bytes).map_err(|e| ArgError::file(path, e).into())
}
