//! The bytes of the server-sent events a page is sent: `tiles` events (a PNG of a batch of tiles
//! in standard base64, RFC 4648 with padding, and where each goes) and one-line events
//! (`reload`, `status`, `done`). Each is made once and the same bytes go to every page.

use super::limits::STRIP_ROWS;
use bytes::Bytes;
use parrt::tile::Tile;

const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Appends the base64 text of `bytes` to `out`.
pub fn base64_into(bytes: &[u8], out: &mut String) {
    out.reserve(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            chunk.get(1).copied().unwrap_or(0),
            chunk.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(ALPHABET[((n >> (18 - 6 * i)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
}

/// An event whose data is one line (`data` must hold no line break).
pub fn event(name: &str, data: &str) -> Bytes {
    Bytes::from(format!("event: {name}\ndata: {data}\n\n"))
}

/// The `tiles` events of `tiles` (whose 8-bit RGB pixels `rgb` holds row by row, one tile after
/// the other, in `tiles` order): each event's first line is a PNG in base64 of a strip of its
/// tiles one under the other (as wide as the widest, at most [`STRIP_ROWS`] rows unless one tile
/// is taller), then a line `x,y,w,h` per tile, in strip order. One PNG per batch, fast
/// compression: a sixth of the raw bytes on mount-8, ~5 ms for a 1024² frame.
pub fn tiles_events(tiles: &[Tile], rgb: &[u8]) -> Vec<Bytes> {
    let mut events = Vec::new();
    let (mut first, mut at) = (0, 0);
    while first < tiles.len() {
        // The next strip: tiles while the rows fit (at least one).
        let mut rows = 0;
        let mut end = first;
        while end < tiles.len() && (end == first || rows + tiles[end].h <= STRIP_ROWS) {
            rows += tiles[end].h;
            end += 1;
        }
        let chunk = &tiles[first..end];
        let bytes: usize = chunk.iter().map(|t| t.pixel_count() * 3).sum();
        let Some(px) = rgb.get(at..at + bytes) else {
            break;
        };
        if let Some(e) = strip_event(chunk, px, rows) {
            events.push(e);
        }
        (first, at) = (end, at + bytes);
    }
    events
}

/// One `tiles` event of `tiles` (pixels `rgb`, `rows` rows in all); `None` if the PNG cannot
/// be made (not for tiles of an image's own size: the page gets them with the final image).
fn strip_event(tiles: &[Tile], rgb: &[u8], rows: u32) -> Option<Bytes> {
    let width = tiles.iter().map(|t| t.w).max()?;
    let row = width as usize * 3;
    let mut strip = vec![0u8; row * rows as usize];
    let (mut src, mut dst) = (0, 0);
    for t in tiles {
        let n = t.w as usize * 3;
        for _ in 0..t.h {
            strip[dst..dst + n].copy_from_slice(rgb.get(src..src + n)?);
            (src, dst) = (src + n, dst + row);
        }
    }
    let mut png = Vec::new();
    png_into(&strip, width, rows, &mut png).ok()?;
    let mut out = String::with_capacity(32 + png.len().div_ceil(3) * 4 + tiles.len() * 24);
    out.push_str("event: tiles\ndata: ");
    base64_into(&png, &mut out);
    for t in tiles {
        use std::fmt::Write;
        let _ = write!(out, "\ndata: {},{},{},{}", t.x, t.y, t.w, t.h);
    }
    out.push_str("\n\n");
    Some(Bytes::from(out))
}

/// Appends a PNG of `w` × `h` 8-bit RGB pixels to `out`.
pub fn png_into(rgb: &[u8], w: u32, h: u32, out: &mut Vec<u8>) -> image::ImageResult<()> {
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    use image::ImageEncoder;
    PngEncoder::new_with_quality(out, CompressionType::Fast, FilterType::Adaptive).write_image(
        rgb,
        w,
        h,
        image::ExtendedColorType::Rgb8,
    )
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Standard base64 back to bytes (for the tests).
    pub fn unbase64(s: &str) -> Vec<u8> {
        let v = |c: u8| ALPHABET.iter().position(|&a| a == c).expect("base64") as u32;
        let s = s.trim_end_matches('=').as_bytes();
        let mut out = Vec::new();
        for chunk in s.chunks(4) {
            let n = chunk
                .iter()
                .enumerate()
                .fold(0, |n, (i, &c)| n | v(c) << (18 - 6 * i));
            out.extend_from_slice(&n.to_be_bytes()[1..chunk.len()]);
        }
        out
    }

    /// The tiles an event carries: each one's rectangle and pixels, cut from the strip.
    pub fn decode_tiles(event: &[u8]) -> Vec<(Tile, Vec<u8>)> {
        let text = std::str::from_utf8(event).expect("text");
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some("event: tiles"));
        let png = lines
            .next()
            .and_then(|l| l.strip_prefix("data: "))
            .expect("the PNG");
        let strip = image::load_from_memory(&unbase64(png))
            .expect("a PNG")
            .to_rgb8();
        let mut sy = 0;
        let mut out = Vec::new();
        for line in lines.take_while(|l| !l.is_empty()) {
            let v: Vec<u32> = line
                .strip_prefix("data: ")
                .expect("data")
                .split(',')
                .map(|n| n.parse().expect("a number"))
                .collect();
            let (x, y, w, h) = (v[0], v[1], v[2], v[3]);
            let px = image::imageops::crop_imm(&strip, 0, sy, w, h).to_image();
            sy += h;
            let tile = Tile { id: 0, x, y, w, h };
            out.push((tile, px.into_raw()));
        }
        assert_eq!(sy, strip.height(), "the rows of the strip are the tiles'");
        out
    }

    #[test]
    fn tiles_events_carry_each_tiles_pixels_in_strips_of_bounded_height() {
        // 6 × 3 tiles of 40 px (the last column 20 wide, the last row 30 high): one strip;
        // 513 tiles of 16 px one under the other: 8208 rows, three strips.
        for (w, h, size, strips) in [(220, 110, 40, 1), (16, 8208, 16, 3)] {
            let img: Vec<u8> = (0..w * h * 3).map(|i| (i * 7 % 251) as u8).collect();
            let list = parrt::tile::tiles(w as u32, h as u32, size);
            let mut rgb = Vec::new();
            for t in &list {
                for y in t.y..t.y + t.h {
                    let at = (y as usize * w + t.x as usize) * 3;
                    rgb.extend_from_slice(&img[at..at + t.w as usize * 3]);
                }
            }
            let events = tiles_events(&list, &rgb);
            assert_eq!(events.len(), strips);
            let got: Vec<(Tile, Vec<u8>)> = events.iter().flat_map(|e| decode_tiles(e)).collect();
            assert_eq!(got.len(), list.len());
            let mut at = 0;
            for ((t, px), want) in got.iter().zip(&list) {
                assert_eq!((t.x, t.y, t.w, t.h), (want.x, want.y, want.w, want.h));
                let n = want.pixel_count() * 3;
                assert_eq!(px[..], rgb[at..at + n], "tile at {},{}", t.x, t.y);
                at += n;
            }
        }
    }

    #[test]
    fn matches_rfc_4648_vectors() {
        for (raw, want) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            let mut s = String::new();
            base64_into(raw.as_bytes(), &mut s);
            assert_eq!(s, want);
        }
        let mut s = String::new();
        base64_into(&[255, 254, 253], &mut s);
        assert_eq!(s, "//79");
    }
}
