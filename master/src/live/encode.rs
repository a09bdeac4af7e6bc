//! The bytes of the server-sent events a page is sent: a `tiles` event (a line per tile, its
//! pixels as a PNG in standard base64, RFC 4648 with padding) and one-line events (`reload`,
//! `status`, `done`). Each is made once and the same bytes go to every page.

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

/// A `tiles` event: a line `x,y,w,h,BASE64` per tile, where the base64 is of a PNG of its
/// 8-bit RGB pixels (fast compression: a fifth to a quarter of the raw bytes on the SPD scenes,
/// ~5 µs a 32-pixel tile); `rgb` holds the tiles' pixels row by row, one tile after the other,
/// in `tiles` order.
pub fn tiles_event(tiles: &[Tile], rgb: &[u8]) -> Bytes {
    let mut out = String::with_capacity(16 + tiles.len() * 32 + rgb.len() / 3);
    out.push_str("event: tiles\n");
    let mut png = Vec::new();
    let mut at = 0;
    for t in tiles {
        let n = t.pixel_count() * 3;
        let Some(px) = rgb.get(at..at + n) else {
            break;
        };
        at += n;
        png.clear();
        if png_into(px, t.w, t.h, &mut png).is_err() {
            // Not for a tile of the image's own size; the page gets it with the final image.
            continue;
        }
        use std::fmt::Write;
        let _ = write!(out, "data: {},{},{},{},", t.x, t.y, t.w, t.h);
        base64_into(&png, &mut out);
        out.push('\n');
    }
    out.push('\n');
    Bytes::from(out)
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

    #[test]
    fn a_tiles_event_has_a_png_line_per_tile() {
        let list = parrt::tile::tiles(3, 1, 2);
        let rgb = [1, 2, 3, 4, 5, 6, 255, 254, 253];
        let e = tiles_event(&list, &rgb);
        let e = std::str::from_utf8(&e).unwrap();
        let lines: Vec<&str> = e.split('\n').collect();
        assert_eq!(lines[0], "event: tiles");
        assert_eq!(lines[3..], ["", ""], "{e}");
        for (line, (t, px)) in lines[1..3]
            .iter()
            .zip([(list[0], &rgb[..6]), (list[1], &rgb[6..])])
        {
            let (head, b64) = line.rsplit_once(',').unwrap();
            assert_eq!(head, format!("data: {},{},{},{}", t.x, t.y, t.w, t.h));
            let img = image::load_from_memory(&unbase64(b64)).unwrap().to_rgb8();
            assert_eq!(img.dimensions(), (t.w, t.h));
            assert_eq!(img.into_raw(), px);
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
