//! Replaying a recorded render (a bench aid for `parrt bench cluster`): instead of tracing a
//! tile, a worker started with `--replay FILE` (its executor a [`crate::exec::ReplayExec`]) sleeps for the tile's measured one-thread cost
//! (times `--cost-scale`) on the rayon thread that took it, then returns the recorded render's
//! real pixels for the tile. Everything else (connection, scheduling, result encoding, film
//! assembly) is the real code, so an emulated cluster of many such workers on one machine
//! measures the distributed machinery at scale, and its image is still compared bit for bit.
//!
//! The file (little-endian): the magic `PARRTRP1`, then `width`, `height`, `tile` and the tile
//! count as u32, the tiles' one-thread seconds as f64 in tile-list order, then every tile's
//! pixels as f32 RGB, row-major within the tile, tile after tile. Workers read a tile's pixels
//! from the file when they need them (the page cache is shared by every worker on the machine).

use parrt_render::film::{Film, Rgb};
use parrt_render::tile::{tiles, Tile};
use std::fs::File;
use std::io::{BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};
use thiserror::Error;

/// The file's first bytes.
pub const MAGIC: &[u8; 8] = b"PARRTRP1";
/// Largest image a replay file may describe (pixels).
pub const MAX_PIXELS: u64 = 1 << 28;
/// Most tiles a replay file may describe (as `--max-pixels`' companion limit on the command
/// line: every tile costs the worker tens of bytes before the first is replayed).
pub const MAX_TILES: u64 = 1 << 22;
/// Largest cost scale (`--cost-scale`).
pub const MAX_COST_SCALE: f64 = 1e6;
/// Largest recorded cost of one tile, seconds.
pub const MAX_TILE_SECONDS: f64 = 3600.0;

const HEADER: u64 = 8 + 4 * 4;

/// What can be wrong with a replay file or a replayed tile.
#[derive(Debug, Error)]
pub enum ReplayError {
    /// The file cannot be read or written.
    #[error("replay file {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The file is not a replay file or is inconsistent.
    #[error("replay file {path}: {reason}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// The cost scale is not a positive number up to [`MAX_COST_SCALE`].
    #[error("cost scale {0} must be a number in (0, {MAX_COST_SCALE}]")]
    Scale(f64),
    /// The master asked for a tile the recording does not have.
    #[error("tile {id} ({w}x{h} at {x},{y}) is not in the recorded render ({width}x{height}, tile {tile}): replay the same size and tile size")]
    Mismatch {
        /// Tile id asked for.
        id: u32,
        /// Its x.
        x: u32,
        /// Its y.
        y: u32,
        /// Its w.
        w: u32,
        /// Its h.
        h: u32,
        /// Recorded width.
        width: u32,
        /// Recorded height.
        height: u32,
        /// Recorded tile size.
        tile: u32,
    },
}

/// A recorded render, opened for replay.
#[derive(Debug)]
pub struct Replay {
    path: PathBuf,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Tile edge the costs were measured at.
    pub tile: u32,
    /// The tile list of that size.
    pub tiles: Vec<Tile>,
    /// One-thread seconds per tile, as recorded.
    pub costs: Vec<f64>,
    /// Byte offset of each tile's pixels.
    offsets: Vec<u64>,
    scale: f64,
    file: Mutex<File>,
}

fn io(path: &Path) -> impl FnOnce(std::io::Error) -> ReplayError + '_ {
    move |source| ReplayError::Io {
        path: path.to_path_buf(),
        source,
    }
}

/// Writes a replay file from a render's tile costs (by tile id, at tile size `tile`) and film.
pub fn write(path: &Path, tile: u32, costs: &[f64], film: &Film) -> Result<(), ReplayError> {
    let list = tiles(film.width, film.height, tile);
    if list.len() != costs.len() {
        return Err(ReplayError::Format {
            path: path.into(),
            reason: format!("{} costs for {} tiles", costs.len(), list.len()),
        });
    }
    let mut out = BufWriter::new(File::create(path).map_err(io(path))?);
    let mut bytes = Vec::with_capacity(HEADER as usize + 8 * costs.len());
    bytes.extend_from_slice(MAGIC);
    for v in [film.width, film.height, tile, list.len() as u32] {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    for c in costs {
        bytes.extend_from_slice(&c.to_le_bytes());
    }
    out.write_all(&bytes).map_err(io(path))?;
    let mut buf = Vec::new();
    for t in &list {
        buf.clear();
        for y in t.y..t.y + t.h {
            for x in t.x..t.x + t.w {
                for c in film.get(x, y) {
                    buf.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
        out.write_all(&buf).map_err(io(path))?;
    }
    out.flush().map_err(io(path))
}

impl Replay {
    /// Opens and checks a replay file; each tile will last its cost × `scale`.
    pub fn open(path: &Path, scale: f64) -> Result<Replay, ReplayError> {
        if !(scale.is_finite() && scale > 0.0 && scale <= MAX_COST_SCALE) {
            return Err(ReplayError::Scale(scale));
        }
        let bad = |reason: String| ReplayError::Format {
            path: path.into(),
            reason,
        };
        // Not blocking on a FIFO: opened non-blocking, then only a regular file is read.
        let mut file = {
            use std::os::unix::fs::OpenOptionsExt;
            std::fs::OpenOptions::new()
                .read(true)
                .custom_flags(libc::O_NONBLOCK)
                .open(path)
                .map_err(io(path))?
        };
        let meta = file.metadata().map_err(io(path))?;
        if !meta.is_file() {
            return Err(bad("not a regular file".into()));
        }
        let len = meta.len();
        let mut head = [0u8; HEADER as usize];
        file.read_exact(&mut head)
            .map_err(|_| bad("too short for a header".into()))?;
        if &head[..8] != MAGIC {
            return Err(bad("not a parrt replay file".into()));
        }
        let word = |i: usize| {
            let mut b = [0u8; 4];
            b.copy_from_slice(&head[8 + 4 * i..12 + 4 * i]);
            u32::from_le_bytes(b)
        };
        let (width, height, tile, count) = (word(0), word(1), word(2), word(3));
        let pixels = width as u64 * height as u64;
        if width == 0 || height == 0 || tile == 0 || pixels > MAX_PIXELS {
            return Err(bad(format!(
                "image {width}x{height} with tile {tile} is outside the limits (at most {MAX_PIXELS} pixels)"
            )));
        }
        // Everything the header claims is checked against the file's length before anything
        // is allocated for it (a 24-byte file may claim 16384² pixels in tiles of 1).
        let n = (width as u64).div_ceil(tile as u64) * (height as u64).div_ceil(tile as u64);
        if n > MAX_TILES {
            return Err(bad(format!(
                "{width}x{height} at tile {tile} is {n} tiles, more than the {MAX_TILES} a replay may have"
            )));
        }
        let expect = HEADER + 8 * n + 12 * pixels;
        if count as u64 != n || len != expect {
            return Err(bad(format!(
                "{count} tiles and {len} bytes, expected {n} tiles and {expect} bytes for {width}x{height} at tile {tile}"
            )));
        }
        let list = tiles(width, height, tile);
        let mut raw = vec![0u8; 8 * list.len()];
        file.read_exact(&mut raw).map_err(io(path))?;
        let mut costs = Vec::with_capacity(list.len());
        for (i, b) in raw.chunks_exact(8).enumerate() {
            let mut a = [0u8; 8];
            a.copy_from_slice(b);
            let c = f64::from_le_bytes(a);
            if !(c.is_finite() && (0.0..=MAX_TILE_SECONDS).contains(&c)) {
                return Err(bad(format!(
                    "tile {i} costs {c} s (must be in 0..={MAX_TILE_SECONDS})"
                )));
            }
            costs.push(c);
        }
        let mut offsets = Vec::with_capacity(list.len());
        let mut at = HEADER + 8 * list.len() as u64;
        for t in &list {
            offsets.push(at);
            at += 12 * t.pixel_count() as u64;
        }
        Ok(Replay {
            path: path.into(),
            width,
            height,
            tile,
            tiles: list,
            costs,
            offsets,
            scale,
            file: Mutex::new(file),
        })
    }

    /// The recorded film (all tiles' pixels), for comparing an assembled image against.
    pub fn film(&self) -> Result<Film, ReplayError> {
        let mut film = Film::new(self.width, self.height);
        let mut px = Vec::new();
        for t in &self.tiles {
            self.read_pixels(t.id as usize, &mut px)?;
            film.write_tile(t, &px).map_err(|e| ReplayError::Format {
                path: self.path.clone(),
                reason: e.to_string(),
            })?;
        }
        Ok(film)
    }

    fn read_pixels(&self, i: usize, out: &mut Vec<Rgb>) -> Result<(), ReplayError> {
        let n = self.tiles[i].pixel_count();
        let mut raw = vec![0u8; 12 * n];
        {
            let mut f = self.file.lock().unwrap_or_else(|e| e.into_inner());
            f.seek(SeekFrom::Start(self.offsets[i]))
                .and_then(|_| f.read_exact(&mut raw))
                .map_err(io(&self.path))?;
        }
        out.clear();
        out.extend(raw.chunks_exact(12).map(|p| {
            let c = |k: usize| f32::from_le_bytes([p[k], p[k + 1], p[k + 2], p[k + 3]]);
            [c(0), c(4), c(8)]
        }));
        Ok(())
    }

    /// Plays `tile`: its recorded pixels into `out`, returned no sooner than its cost × scale
    /// after the call (the calling thread sleeps, as it would have been busy tracing).
    pub fn play(&self, tile: &Tile, out: &mut Vec<Rgb>) -> Result<(), ReplayError> {
        let start = Instant::now();
        let due = start + self.cost(tile)?;
        self.pixels(tile, out)?;
        let now = Instant::now();
        if due > now {
            std::thread::sleep(due - now);
        }
        Ok(())
    }

    /// The recording's index of `tile`, or why it has none.
    fn index(&self, tile: &Tile) -> Result<usize, ReplayError> {
        let i = tile.id as usize;
        if self.tiles.get(i) != Some(tile) {
            return Err(ReplayError::Mismatch {
                id: tile.id,
                x: tile.x,
                y: tile.y,
                w: tile.w,
                h: tile.h,
                width: self.width,
                height: self.height,
                tile: self.tile,
            });
        }
        Ok(i)
    }

    /// `tile`'s recorded pixels into `out`, at once (no sleeping): for a simulated worker,
    /// which spends the cost in virtual time instead ([`crate::exec::ReplayExec::simulated`]).
    pub fn pixels(&self, tile: &Tile, out: &mut Vec<Rgb>) -> Result<(), ReplayError> {
        let i = self.index(tile)?;
        self.read_pixels(i, out)
    }

    /// How long `tile` lasts when replayed: its recorded one-thread cost × the scale.
    pub fn cost(&self, tile: &Tile) -> Result<Duration, ReplayError> {
        let i = self.index(tile)?;
        Ok(Duration::from_secs_f64(self.costs[i] * self.scale))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn film(w: u32, h: u32) -> Film {
        let mut f = Film::new(w, h);
        for (i, p) in f.pixels.iter_mut().enumerate() {
            *p = [i as f32, 0.5, -(i as f32)];
        }
        f
    }

    #[test]
    fn round_trip_pixels_costs_and_mismatch() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.replay");
        let f = film(10, 7);
        let list = tiles(10, 7, 4);
        let costs: Vec<f64> = (0..list.len()).map(|i| i as f64 * 1e-4).collect();
        write(&path, 4, &costs, &f).unwrap();
        let r = Replay::open(&path, 2.0).unwrap();
        assert_eq!(r.costs, costs);
        assert_eq!(r.film().unwrap(), f);
        let mut px = Vec::new();
        let t0 = Instant::now();
        r.play(&list[5], &mut px).unwrap();
        assert!(t0.elapsed() >= Duration::from_secs_f64(2.0 * costs[5]));
        let mut expect = Film::new(10, 7);
        expect.write_tile(&list[5], &px).unwrap();
        assert_eq!(
            expect.get(list[5].x, list[5].y),
            f.get(list[5].x, list[5].y)
        );
        let wrong = Tile { w: 3, ..list[5] };
        assert!(matches!(
            r.play(&wrong, &mut px),
            Err(ReplayError::Mismatch { .. })
        ));
    }

    #[test]
    fn bad_files_and_scales_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.replay");
        write(&path, 4, &[0.0; 6], &film(10, 7)).unwrap();
        for s in [0.0, -1.0, f64::NAN, 1e9] {
            assert!(matches!(Replay::open(&path, s), Err(ReplayError::Scale(_))));
        }
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 1]).unwrap();
        assert!(matches!(
            Replay::open(&path, 1.0),
            Err(ReplayError::Format { .. })
        ));
        std::fs::write(&path, b"PARRTRP").unwrap();
        assert!(matches!(
            Replay::open(&path, 1.0),
            Err(ReplayError::Format { .. })
        ));
        assert!(matches!(
            Replay::open(&dir.path().join("none"), 1.0),
            Err(ReplayError::Io { .. })
        ));
    }
}
