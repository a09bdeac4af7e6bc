//! The film: a linear float RGB image that tiles are written into, and its output as PNG or PPM
//! (8-bit, clamped) or EXR (float, for error measurement). NaN and infinity never reach it.
//! [`check_output`] tells before a render whether its image can be written; [`Film::save`]
//! writes a temporary file beside the target and renames it, so a failed write leaves no
//! half-written image.

use crate::tile::Tile;
use std::path::Path;
use thiserror::Error;

/// A linear RGB pixel.
pub type Rgb = [f32; 3];

/// Errors writing an image.
#[derive(Debug, Error)]
pub enum FilmError {
    /// The output file could not be written. (The cause is the error's source, printed after
    /// the message by `{:#}`; it is not repeated here.)
    #[error("cannot write image {path}")]
    Write {
        /// The output path.
        path: String,
        /// The cause.
        source: image::ImageError,
    },
    /// The output path cannot take a file (checked before rendering).
    #[error("cannot write {path}: {reason}")]
    Unwritable {
        /// The output path.
        path: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The temporary file could not be renamed onto the output.
    #[error("cannot write image {path}: {error}")]
    Rename {
        /// The output path.
        path: String,
        /// The cause (shown in the message, not as a source, so it is printed once).
        error: std::io::Error,
    },
    /// The extension names no format we write.
    #[error("unknown image format for {0}: use .png, .ppm or .exr")]
    UnknownFormat(String),
    /// A tile's pixels do not match its size or lie outside the film.
    #[error(
        "tile {id} ({w}x{h} at {x},{y}) does not fit a {width}x{height} film or has {len} pixels"
    )]
    BadTile {
        /// Tile id.
        id: u32,
        /// Tile x.
        x: u32,
        /// Tile y.
        y: u32,
        /// Tile width.
        w: u32,
        /// Tile height.
        h: u32,
        /// Film width.
        width: u32,
        /// Film height.
        height: u32,
        /// Pixels supplied.
        len: usize,
    },
}

/// Output image formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// 8-bit PNG.
    Png,
    /// 8-bit binary PPM.
    Ppm,
    /// 32-bit float OpenEXR.
    Exr,
}

impl ImageFormat {
    /// Picks the format from a file name's extension.
    pub fn from_path(path: &Path) -> Result<Self, FilmError> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .as_deref()
        {
            Some("png") => Ok(ImageFormat::Png),
            Some("ppm") => Ok(ImageFormat::Ppm),
            Some("exr") => Ok(ImageFormat::Exr),
            _ => Err(FilmError::UnknownFormat(path.display().to_string())),
        }
    }
}

/// A sibling of `path` in the same directory that no one else is writing: `.NAME.parrt-PID-N.tmp`.
fn temp_beside(path: &Path) -> std::path::PathBuf {
    use std::sync::atomic::{AtomicU64, Ordering};
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    path.with_file_name(format!(".{name}.parrt-{}-{n}.tmp", std::process::id()))
}

/// Checks that a file can be written at `path` before any work is done: the path is not a
/// directory, its parent exists and is a directory, and a file can be created there (tried with
/// a temporary file, removed at once). An existing file at `path` is fine; it will be replaced.
pub fn check_writable(path: &Path) -> Result<(), FilmError> {
    let bad = |reason: String| FilmError::Unwritable {
        path: path.display().to_string(),
        reason,
    };
    if path.is_dir() {
        return Err(bad("it is a directory".into()));
    }
    if path.file_name().is_none() {
        return Err(bad("it names no file".into()));
    }
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    match std::fs::metadata(parent) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => return Err(bad(format!("{} is not a directory", parent.display()))),
        Err(e) => return Err(bad(format!("directory {}: {e}", parent.display()))),
    }
    let probe = temp_beside(path);
    match std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
    {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => Err(bad(format!(
            "cannot create a file in {}: {e}",
            parent.display()
        ))),
    }
}

/// Checks an image output before rendering: a format we write ([`ImageFormat::from_path`]) and
/// a writable place ([`check_writable`]). Returns the format.
pub fn check_output(path: &Path) -> Result<ImageFormat, FilmError> {
    let format = ImageFormat::from_path(path)?;
    check_writable(path)?;
    Ok(format)
}

/// A `width × height` linear RGB image, row-major from the top-left.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Pixels, row-major.
    pub pixels: Vec<Rgb>,
}

/// Converts a linear value to 8 bits: clamp to [0, 1], scale, round to nearest.
#[inline]
pub fn to_u8(v: f32) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    (v * 255.0 + 0.5) as u8
}

impl Film {
    /// A black film.
    pub fn new(width: u32, height: u32) -> Self {
        Film {
            width,
            height,
            pixels: vec![[0.0; 3]; width as usize * height as usize],
        }
    }

    /// Copies a tile's pixels (row-major within the tile) into place.
    pub fn write_tile(&mut self, tile: &Tile, pixels: &[Rgb]) -> Result<(), FilmError> {
        let fits = tile.x.checked_add(tile.w).is_some_and(|r| r <= self.width)
            && tile.y.checked_add(tile.h).is_some_and(|b| b <= self.height)
            && pixels.len() == tile.pixel_count();
        if !fits {
            return Err(FilmError::BadTile {
                id: tile.id,
                x: tile.x,
                y: tile.y,
                w: tile.w,
                h: tile.h,
                width: self.width,
                height: self.height,
                len: pixels.len(),
            });
        }
        let w = tile.w as usize;
        for row in 0..tile.h as usize {
            let dst = (tile.y as usize + row) * self.width as usize + tile.x as usize;
            self.pixels[dst..dst + w].copy_from_slice(&pixels[row * w..row * w + w]);
        }
        Ok(())
    }

    /// The pixel at column `x`, row `y`.
    pub fn get(&self, x: u32, y: u32) -> Rgb {
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// The image as 8-bit RGB bytes.
    pub fn to_rgb8(&self) -> Vec<u8> {
        self.pixels
            .iter()
            .flat_map(|p| [to_u8(p[0]), to_u8(p[1]), to_u8(p[2])])
            .collect()
    }

    /// Writes the film; the format follows the file's extension. The image goes to a temporary
    /// file in the same directory first and is renamed onto `path` only when complete, so a
    /// failure (disk full, a killed process) never leaves a half-written image at `path`.
    pub fn save(&self, path: &Path) -> Result<(), FilmError> {
        let format = ImageFormat::from_path(path)?;
        let tmp = temp_beside(path);
        let written = self
            .write_as(&tmp, format)
            .map_err(|source| FilmError::Write {
                path: path.display().to_string(),
                source,
            });
        let renamed = written.and_then(|()| {
            std::fs::rename(&tmp, path).map_err(|error| FilmError::Rename {
                path: path.display().to_string(),
                error,
            })
        });
        if renamed.is_err() {
            let _ = std::fs::remove_file(&tmp);
        }
        renamed
    }

    fn write_as(&self, path: &Path, format: ImageFormat) -> Result<(), image::ImageError> {
        match format {
            ImageFormat::Png | ImageFormat::Ppm => {
                let img = image::RgbImage::from_raw(self.width, self.height, self.to_rgb8())
                    .expect("buffer size matches dimensions");
                let fmt = if format == ImageFormat::Png {
                    image::ImageFormat::Png
                } else {
                    image::ImageFormat::Pnm
                };
                img.save_with_format(path, fmt)
            }
            ImageFormat::Exr => {
                let flat: Vec<f32> = self.pixels.iter().flatten().copied().collect();
                let img = image::Rgb32FImage::from_raw(self.width, self.height, flat)
                    .expect("buffer size matches dimensions");
                img.save_with_format(path, image::ImageFormat::OpenExr)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn to_u8_clamps_and_rounds() {
        assert_eq!(to_u8(-1.0), 0);
        assert_eq!(to_u8(f32::NAN), 0);
        assert_eq!(to_u8(2.0), 255);
        assert_eq!(to_u8(0.5), 128);
    }

    #[test]
    fn write_tile_rejects_misfit() {
        let mut f = Film::new(4, 4);
        let t = Tile {
            id: 0,
            x: 2,
            y: 2,
            w: 3,
            h: 1,
        };
        assert!(f.write_tile(&t, &[[0.0; 3]; 3]).is_err());
        let t = Tile {
            id: 0,
            x: 2,
            y: 2,
            w: 2,
            h: 2,
        };
        assert!(f.write_tile(&t, &[[1.0; 3]; 4]).is_ok());
        assert_eq!(f.get(3, 3), [1.0; 3]);
        assert_eq!(f.get(1, 1), [0.0; 3]);
    }

    #[test]
    fn outputs_are_checked_before_and_written_whole() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let e = check_output(&d.join("no/such/dir/x.png")).unwrap_err();
        assert!(e.to_string().contains("No such file or directory"), "{e}");
        assert_eq!(
            check_output(d).unwrap_err().to_string(),
            format!(
                "unknown image format for {}: use .png, .ppm or .exr",
                d.display()
            )
        );
        let sub = d.join("sub.png");
        std::fs::create_dir(&sub).unwrap();
        assert_eq!(
            check_output(&sub).unwrap_err().to_string(),
            format!("cannot write {}: it is a directory", sub.display())
        );
        assert!(check_output(&d.join("x.jpg")).is_err());
        let out = d.join("ok.exr");
        assert_eq!(check_output(&out).unwrap(), ImageFormat::Exr);
        Film::new(3, 2).save(&out).unwrap();
        Film::new(3, 2).save(&d.join("ok.png")).unwrap();
        // Only the two images and the directory: no probe or temporary file left behind.
        let mut names: Vec<_> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect();
        names.sort();
        assert_eq!(names, ["ok.exr", "ok.png", "sub.png"]);
    }

    #[test]
    fn a_failed_write_names_its_cause_once() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("gone/x.png");
        let e = Film::new(2, 2).save(&out).unwrap_err();
        // The whole chain, as anyhow's `{:#}` prints it.
        let mut msg = e.to_string();
        let mut cause = std::error::Error::source(&e);
        while let Some(c) = cause {
            msg += &format!(": {c}");
            cause = c.source();
        }
        assert_eq!(msg.matches("No such file or directory").count(), 1, "{msg}");
    }
}
