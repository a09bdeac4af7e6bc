//! The film: a linear float RGB image that tiles are written into, and its output as PNG or PPM
//! (8-bit, clamped) or EXR (float, for error measurement). NaN and infinity never reach it. A
//! film made for an 8-bit output ([`Film::new_rgb8`]) keeps the 8-bit bytes themselves, so
//! 8-bit tiles from workers go in with a copy and out to the PNG without a float pass.
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
    /// 8-bit binary PPM (`P6`, the netpbm pixmap).
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

/// A sibling of `path` in the same directory that no one else is writing: `.NAME.parrt-PID-N.tmp`
/// (a file is written there whole, then renamed onto `path`).
pub fn temp_beside(path: &Path) -> std::path::PathBuf {
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
    /// Pixels, row-major; empty for an 8-bit film, whose pixels [`Film::get`] reads.
    pub pixels: Vec<Rgb>,
    /// An 8-bit film's RGB bytes, row-major ([`to_u8`] of each linear value); `None` for a
    /// linear film.
    rgb8: Option<Vec<u8>>,
}

/// An 8-bit value as a linear one, `b / 255`, which [`to_u8`] maps back to `b` exactly.
#[inline]
pub fn unit(b: u8) -> f32 {
    b as f32 / 255.0
}

/// Converts a linear value to 8 bits: clamp to [0, 1], scale, round to nearest.
#[inline]
pub fn to_u8(v: f32) -> u8 {
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    (v * 255.0 + 0.5) as u8
}

/// [`to_u8`] of each value of `src` into `dst` (as many as the shorter holds): the same bytes,
/// eight at a time in AVX2 registers on the `avx2` and `avx512` tiers ([`crate::isa`]) (8-bit
/// films, tiles sent as 8-bit, the live view's frame).
pub fn to_u8_into(dst: &mut [u8], src: &[f32]) {
    let n = dst.len().min(src.len());
    let (dst, src) = (&mut dst[..n], &src[..n]);
    #[cfg(target_arch = "x86_64")]
    if crate::isa::current().avx() {
        // SAFETY: the AVX tiers are only chosen on a CPU that has AVX2.
        return unsafe { to_u8_avx2(dst, src) };
    }
    for (d, &v) in dst.iter_mut().zip(src) {
        *d = to_u8(v);
    }
}

/// [`to_u8_into`] with AVX2, `dst` and `src` of one length: clamped by `max` (which gives its
/// second operand, 0, for NaN) and `min`, scaled, offset by a half and truncated, as [`to_u8`].
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn to_u8_avx2(dst: &mut [u8], src: &[f32]) {
    use std::arch::x86_64::*;
    let (zero, one) = (_mm256_set1_ps(0.0), _mm256_set1_ps(1.0));
    let (scale, half) = (_mm256_set1_ps(255.0), _mm256_set1_ps(0.5));
    let mut ints = [0i32; 8];
    let mut d8 = dst.chunks_exact_mut(8);
    let mut s8 = src.chunks_exact(8);
    for (d, s) in (&mut d8).zip(&mut s8) {
        // SAFETY: `s` holds 8 floats and `ints` 8 ints; unaligned loads and stores.
        unsafe {
            let v = _mm256_loadu_ps(s.as_ptr());
            let v = _mm256_min_ps(_mm256_max_ps(v, zero), one);
            let v = _mm256_add_ps(_mm256_mul_ps(v, scale), half);
            _mm256_storeu_si256(ints.as_mut_ptr().cast(), _mm256_cvttps_epi32(v));
        }
        for (d, &i) in d.iter_mut().zip(&ints) {
            *d = i as u8;
        }
    }
    for (d, &v) in d8.into_remainder().iter_mut().zip(s8.remainder()) {
        *d = to_u8(v);
    }
}

impl Film {
    /// A black film.
    pub fn new(width: u32, height: u32) -> Self {
        Film::from_pixels(
            width,
            height,
            vec![[0.0; 3]; width as usize * height as usize],
        )
    }

    /// A film holding `pixels` (row-major, `width × height` of them).
    pub fn from_pixels(width: u32, height: u32, pixels: Vec<Rgb>) -> Self {
        debug_assert_eq!(pixels.len(), width as usize * height as usize);
        Film {
            width,
            height,
            pixels,
            rgb8: None,
        }
    }

    /// A black film that keeps 8-bit RGB, for an output that keeps no more (PNG, PPM): a
    /// quarter of a linear film's memory, and [`Film::save`] writes its bytes as they are.
    /// Linear values written into it are stored as [`to_u8`] of each; [`Film::get`] gives a
    /// byte `b` back as `b / 255`.
    pub fn new_rgb8(width: u32, height: u32) -> Self {
        Film {
            width,
            height,
            pixels: Vec::new(),
            rgb8: Some(vec![0; width as usize * height as usize * 3]),
        }
    }

    /// A black film that keeps what `format` writes and no more: 8-bit RGB for PNG and PPM
    /// ([`Film::new_rgb8`], 3 bytes a pixel), linear floats for EXR ([`Film::new`], 12). The
    /// file written is the same bytes either way: tiles land in an 8-bit film through the one
    /// conversion ([`to_u8`]) a linear film's PNG goes through when it is written.
    pub fn for_output(width: u32, height: u32, format: ImageFormat) -> Self {
        match format {
            ImageFormat::Png | ImageFormat::Ppm => Film::new_rgb8(width, height),
            ImageFormat::Exr => Film::new(width, height),
        }
    }

    /// Whether this film keeps 8-bit RGB ([`Film::new_rgb8`]).
    pub fn is_rgb8(&self) -> bool {
        self.rgb8.is_some()
    }

    /// Checks that `tile` lies inside the film and that `values` is its pixel count times
    /// `per_pixel` (1 for pixels, 3 for bytes).
    fn check_fit(&self, tile: &Tile, values: usize, per_pixel: usize) -> Result<(), FilmError> {
        let fits = tile.x.checked_add(tile.w).is_some_and(|r| r <= self.width)
            && tile.y.checked_add(tile.h).is_some_and(|b| b <= self.height)
            && Some(values) == tile.pixel_count().checked_mul(per_pixel);
        if fits {
            return Ok(());
        }
        Err(FilmError::BadTile {
            id: tile.id,
            x: tile.x,
            y: tile.y,
            w: tile.w,
            h: tile.h,
            width: self.width,
            height: self.height,
            len: values / per_pixel,
        })
    }

    /// Copies a tile's pixels (row-major within the tile) into place.
    pub fn write_tile(&mut self, tile: &Tile, pixels: &[Rgb]) -> Result<(), FilmError> {
        self.check_fit(tile, pixels.len(), 1)?;
        let (w, width) = (tile.w as usize, self.width as usize);
        for (row, src) in pixels.chunks_exact(w.max(1)).enumerate() {
            let dst = (tile.y as usize + row) * width + tile.x as usize;
            match &mut self.rgb8 {
                None => self.pixels[dst..dst + w].copy_from_slice(src),
                Some(bytes) => to_u8_into(&mut bytes[dst * 3..(dst + w) * 3], src.as_flattened()),
            }
        }
        Ok(())
    }

    /// Copies a tile's 8-bit RGB bytes (3 a pixel, row-major within the tile) into place: as
    /// they are into an 8-bit film, as `b / 255` into a linear one.
    pub fn write_tile_rgb8(&mut self, tile: &Tile, bytes: &[u8]) -> Result<(), FilmError> {
        self.check_fit(tile, bytes.len(), 3)?;
        let (w, width) = (tile.w as usize, self.width as usize);
        for (row, src) in bytes.chunks_exact((w * 3).max(1)).enumerate() {
            let dst = (tile.y as usize + row) * width + tile.x as usize;
            match &mut self.rgb8 {
                Some(film) => film[dst * 3..(dst + w) * 3].copy_from_slice(src),
                None => {
                    for (d, b) in self.pixels[dst..dst + w]
                        .iter_mut()
                        .zip(src.chunks_exact(3))
                    {
                        *d = [unit(b[0]), unit(b[1]), unit(b[2])];
                    }
                }
            }
        }
        Ok(())
    }

    /// The pixel at column `x`, row `y`.
    pub fn get(&self, x: u32, y: u32) -> Rgb {
        let i = y as usize * self.width as usize + x as usize;
        match &self.rgb8 {
            None => self.pixels[i],
            Some(b) => [unit(b[3 * i]), unit(b[3 * i + 1]), unit(b[3 * i + 2])],
        }
    }

    /// The image as 8-bit RGB bytes.
    pub fn to_rgb8(&self) -> Vec<u8> {
        self.rgb8_bytes().into_owned()
    }

    /// The image as 8-bit RGB bytes, borrowed from an 8-bit film.
    fn rgb8_bytes(&self) -> std::borrow::Cow<'_, [u8]> {
        match &self.rgb8 {
            Some(b) => std::borrow::Cow::Borrowed(b),
            None => {
                let mut bytes = vec![0; self.pixels.len() * 3];
                to_u8_into(&mut bytes, self.pixels.as_flattened());
                std::borrow::Cow::Owned(bytes)
            }
        }
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
            ImageFormat::Png => image::save_buffer_with_format(
                path,
                &self.rgb8_bytes(),
                self.width,
                self.height,
                image::ExtendedColorType::Rgb8,
                image::ImageFormat::Png,
            ),
            // `image`'s PNM encoder left to choose writes a PAM (`P7`), which most PPM
            // readers refuse: the binary pixmap subtype is asked for by name.
            ImageFormat::Ppm => {
                use image::codecs::pnm::{PnmEncoder, PnmSubtype, SampleEncoding};
                use image::ImageEncoder;
                let file = std::io::BufWriter::new(std::fs::File::create(path)?);
                PnmEncoder::new(file)
                    .with_subtype(PnmSubtype::Pixmap(SampleEncoding::Binary))
                    .write_image(
                        &self.rgb8_bytes(),
                        self.width,
                        self.height,
                        image::ExtendedColorType::Rgb8,
                    )
            }
            // Encoded from the film's own floats: no full-size copy (12 bytes a pixel) first.
            ImageFormat::Exr => {
                use image::codecs::openexr::OpenExrEncoder;
                use image::ImageEncoder;
                let converted: Vec<f32>;
                let floats: &[f32] = match &self.rgb8 {
                    None => self.pixels.as_flattened(),
                    Some(b) => {
                        converted = b.iter().map(|&v| unit(v)).collect();
                        &converted
                    }
                };
                // SAFETY: the bytes of initialized `f32`s, in their own memory, for as long as
                // `floats` lives; `u8` needs no alignment and any byte value is valid.
                let bytes = unsafe {
                    std::slice::from_raw_parts(floats.as_ptr().cast::<u8>(), size_of_val(floats))
                };
                let file = std::io::BufWriter::new(std::fs::File::create(path)?);
                OpenExrEncoder::new(file).write_image(
                    bytes,
                    self.width,
                    self.height,
                    image::ExtendedColorType::Rgb32F,
                )
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Tile `id`: `w`×`h` pixels from column `x`, row `y`.
    fn tile(id: u32, x: u32, y: u32, w: u32, h: u32) -> Tile {
        Tile { id, x, y, w, h }
    }

    #[test]
    fn to_u8_clamps_and_rounds() {
        assert_eq!(to_u8(-1.0), 0);
        assert_eq!(to_u8(f32::NAN), 0);
        assert_eq!(to_u8(2.0), 255);
        assert_eq!(to_u8(0.5), 128);
    }

    #[test]
    fn to_u8_into_is_to_u8_of_each() {
        // The odd values first, so that they go through the vector code too (eight at a
        // time), and a length that leaves a remainder.
        let mut src = vec![
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            -0.0,
            -1e-30,
            1.0 + 1e-7,
            2.0,
            -f32::NAN,
        ];
        src.extend(
            (0..=255u8).flat_map(|b| [unit(b), (f32::from(b) + 0.5) / 255.0, f32::from(b) / 254.9]),
        );
        src.extend([f32::NAN, 0.25, 3.0]);
        let mut dst = vec![7u8; src.len() + 1];
        to_u8_into(&mut dst, &src);
        let want: Vec<u8> = src.iter().map(|&v| to_u8(v)).chain([7]).collect();
        assert_eq!(dst, want);
    }

    #[test]
    fn write_tile_rejects_misfit() {
        let mut f = Film::new(4, 4);
        let t = tile(0, 2, 2, 3, 1);
        assert!(f.write_tile(&t, &[[0.0; 3]; 3]).is_err());
        let t = tile(0, 2, 2, 2, 2);
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

    /// The EXR is written from the film's own floats: the bytes `image` writes for the same
    /// values handed over as an owned buffer, every float bit kept.
    #[test]
    fn an_exr_is_the_films_floats_as_image_writes_them() {
        let (w, h) = (7u32, 3u32);
        let px: Vec<Rgb> = (0..w * h)
            .map(|i| [i as f32 * 0.37, -1.5e-3 * i as f32, 1e9 / (1 + i) as f32])
            .collect();
        let film = Film::from_pixels(w, h, px.clone());
        let d = tempfile::tempdir().unwrap();
        let (ours, theirs) = (d.path().join("a.exr"), d.path().join("b.exr"));
        film.save(&ours).unwrap();
        image::Rgb32FImage::from_raw(w, h, px.as_flattened().to_vec())
            .unwrap()
            .save_with_format(&theirs, image::ImageFormat::OpenExr)
            .unwrap();
        let bytes = std::fs::read(&ours).unwrap();
        assert!(bytes.len() > (w * h * 12) as usize / 4, "{}", bytes.len());
        assert!(bytes == std::fs::read(&theirs).unwrap());
        let back = image::open(&ours).unwrap().into_rgb32f();
        assert!(back.as_raw() == px.as_flattened());
    }

    /// A `.ppm` is a binary netpbm pixmap (`P6`), which every PPM reader takes, not a PAM
    /// (`P7`): its header, then the 8-bit RGB bytes row by row.
    #[test]
    fn a_ppm_is_a_binary_pixmap() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("x.ppm");
        let mut f = Film::new_rgb8(2, 1);
        let t = tile(0, 0, 0, 2, 1);
        f.write_tile_rgb8(&t, &[255, 0, 0, 1, 2, 3]).unwrap();
        f.save(&out).unwrap();
        let bytes = std::fs::read(&out).unwrap();
        assert_eq!(bytes, b"P6\n2 1 255\n\xff\x00\x00\x01\x02\x03");
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
