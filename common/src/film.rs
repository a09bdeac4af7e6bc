//! The film: a linear float RGB image that tiles are written into, and its output as PNG or PPM
//! (8-bit, clamped) or EXR (float, for error measurement). NaN and infinity never reach it.

use crate::tile::Tile;
use std::path::Path;
use thiserror::Error;

/// A linear RGB pixel.
pub type Rgb = [f32; 3];

/// Errors writing an image.
#[derive(Debug, Error)]
pub enum FilmError {
    /// The output file could not be written.
    #[error("cannot write image {path}: {source}")]
    Write {
        /// The output path.
        path: String,
        /// The cause.
        source: image::ImageError,
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

    /// Writes the film; the format follows the file's extension.
    pub fn save(&self, path: &Path) -> Result<(), FilmError> {
        let format = ImageFormat::from_path(path)?;
        let err = |source| FilmError::Write {
            path: path.display().to_string(),
            source,
        };
        match format {
            ImageFormat::Png | ImageFormat::Ppm => {
                let img = image::RgbImage::from_raw(self.width, self.height, self.to_rgb8())
                    .expect("buffer size matches dimensions");
                let fmt = if format == ImageFormat::Png {
                    image::ImageFormat::Png
                } else {
                    image::ImageFormat::Pnm
                };
                img.save_with_format(path, fmt).map_err(err)
            }
            ImageFormat::Exr => {
                let flat: Vec<f32> = self.pixels.iter().flatten().copied().collect();
                let img = image::Rgb32FImage::from_raw(self.width, self.height, flat)
                    .expect("buffer size matches dimensions");
                img.save_with_format(path, image::ImageFormat::OpenExr)
                    .map_err(err)
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
}
