//! The bytes of the server-sent events a page is sent: `tiles` events (a PNG of a batch of tiles
//! laid side by side on a sheet, in standard base64, RFC 4648 with padding, and where each
//! tile goes) and one-line events (`reload`, `status`, `done`). Each is made once and the same
//! bytes go to every page.

use super::limits::SHEET_SIDE;
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

/// The memory the `tiles` events are made in, kept from batch to batch so that a batch does
/// not fault in fresh pages for its megabytes.
#[derive(Default)]
pub struct Scratch {
    sheet: Vec<u8>,
    png: Vec<u8>,
}

/// Where a tile sits on its event's sheet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Placed {
    sx: u32,
    sy: u32,
}

/// The `tiles` events of `tiles` (whose 8-bit RGB pixels `rgb` holds row by row, one tile after
/// the other, in `tiles` order): each event's first line is a PNG in base64 of a sheet of its
/// tiles laid in rows, left to right in landing order, then a line `x,y,w,h,sx,sy` per tile:
/// where it goes in the image and where it is on the sheet. A sheet is about square and at
/// most [`SHEET_SIDE`] pixels a side (unless one tile is bigger); a larger batch is sent as
/// several events. One PNG per sheet, fast compression. Square sheets instead of the tiles
/// one under the other, on mount-8 at 1024² in 32-pixel tiles: 4.5 → 3.6 ms to encode a
/// frame's batches and 8 % fewer bytes (the rows are ten times longer).
pub fn tiles_events(tiles: &[Tile], rgb: &[u8], scratch: &mut Scratch) -> Vec<Bytes> {
    sheets(tiles, rgb, scratch, SHEET_SIDE)
}

/// [`tiles_events`] on sheets at most `side` pixels a side.
fn sheets(tiles: &[Tile], rgb: &[u8], scratch: &mut Scratch, side: u32) -> Vec<Bytes> {
    let mut events = Vec::new();
    let (mut first, mut at) = (0, 0);
    while first < tiles.len() {
        let (end, width, height, places) = layout(&tiles[first..], side);
        let chunk = &tiles[first..first + end];
        let bytes: usize = chunk.iter().map(|t| t.pixel_count() * 3).sum();
        let Some(px) = rgb.get(at..at + bytes) else {
            break;
        };
        if let Some(e) = sheet_event(chunk, px, &places, width, height, scratch) {
            events.push(e);
        }
        (first, at) = (first + end, at + bytes);
    }
    events
}

/// The first sheet of `tiles` (at least one tile): how many tiles it holds, its width and
/// height, and where each of them sits. Rows ("shelves") as wide as the square root of the
/// tiles' area (at least the widest tile, at most `max_side`), each as tall as its tallest
/// tile; the sheet ends before a tile that would take it past `max_side` rows.
fn layout(tiles: &[Tile], max_side: u32) -> (usize, u32, u32, Vec<Placed>) {
    let area: u64 = tiles.iter().map(|t| t.pixel_count() as u64).sum();
    let widest = tiles.iter().map(|t| t.w).max().unwrap_or(0);
    let side = ((area as f64).sqrt().ceil() as u32).min(max_side);
    let row_width = side.max(widest);
    let (mut x, mut y, mut shelf, mut width) = (0u32, 0u32, 0u32, 0u32);
    let mut places = Vec::with_capacity(tiles.len());
    for t in tiles {
        if x > 0 && x + t.w > row_width {
            (x, y, shelf) = (0, y + shelf, 0);
        }
        if !places.is_empty() && y + t.h.max(shelf) > max_side {
            break;
        }
        places.push(Placed { sx: x, sy: y });
        x += t.w;
        shelf = shelf.max(t.h);
        width = width.max(x);
    }
    (places.len(), width, y + shelf, places)
}

/// One `tiles` event of `tiles` (pixels `rgb`) placed at `places` on a `width` × `height`
/// sheet; `None` if the PNG cannot be made (not for tiles of an image's own size: the page
/// gets them with the final image).
fn sheet_event(
    tiles: &[Tile],
    rgb: &[u8],
    places: &[Placed],
    width: u32,
    height: u32,
    scratch: &mut Scratch,
) -> Option<Bytes> {
    let row = width as usize * 3;
    let sheet = &mut scratch.sheet;
    sheet.clear();
    sheet.resize(row * height as usize, 0);
    let mut src = 0;
    for (t, p) in tiles.iter().zip(places) {
        let n = t.w as usize * 3;
        let mut dst = p.sy as usize * row + p.sx as usize * 3;
        for _ in 0..t.h {
            sheet[dst..dst + n].copy_from_slice(rgb.get(src..src + n)?);
            (src, dst) = (src + n, dst + row);
        }
    }
    let png = &mut scratch.png;
    png.clear();
    png_into(sheet, width, height, png).ok()?;
    let mut out = String::with_capacity(32 + png.len().div_ceil(3) * 4 + tiles.len() * 32);
    out.push_str("event: tiles\ndata: ");
    base64_into(png, &mut out);
    for (t, p) in tiles.iter().zip(places) {
        use std::fmt::Write;
        let _ = write!(
            out,
            "\ndata: {},{},{},{},{},{}",
            t.x, t.y, t.w, t.h, p.sx, p.sy
        );
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

    /// The tiles an event carries: each one's rectangle and pixels, cut from the sheet.
    pub fn decode_tiles(event: &[u8]) -> Vec<(Tile, Vec<u8>)> {
        let text = std::str::from_utf8(event).expect("text");
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some("event: tiles"));
        let png = lines
            .next()
            .and_then(|l| l.strip_prefix("data: "))
            .expect("the PNG");
        let sheet = image::load_from_memory(&unbase64(png))
            .expect("a PNG")
            .to_rgb8();
        let mut out = Vec::new();
        let mut covered = 0;
        for line in lines.take_while(|l| !l.is_empty()) {
            let v: Vec<u32> = line
                .strip_prefix("data: ")
                .expect("data")
                .split(',')
                .map(|n| n.parse().expect("a number"))
                .collect();
            let [x, y, w, h, sx, sy] = v[..] else {
                panic!("x,y,w,h,sx,sy: {line}");
            };
            assert!(
                sx + w <= sheet.width() && sy + h <= sheet.height(),
                "on the sheet"
            );
            let px = image::imageops::crop_imm(&sheet, sx, sy, w, h).to_image();
            covered += w * h;
            let tile = Tile { id: 0, x, y, w, h };
            out.push((tile, px.into_raw()));
        }
        assert!(covered <= sheet.width() * sheet.height());
        out
    }

    #[test]
    fn tiles_events_carry_each_tiles_pixels_on_sheets_of_bounded_size() {
        // (image width, height, tile size, sheets' side, sheets): 6 × 3 tiles of 40 px (the
        // last column 20 wide, the last row 30 high) on one sheet; 513 tiles of 16 px one
        // under the other on one sheet 363 px wide; on 64-px sheets, 16 a sheet (33 sheets);
        // two 50 × 20 tiles (a 100 × 20 image), wider than a square of their area: one under
        // the other on a 64-px sheet, on two 32-px sheets, and on two 10-px ones (a tile
        // bigger than a sheet goes alone).
        for (w, h, size, side, sheets) in [
            (220, 110, 40, SHEET_SIDE, 1),
            (16, 8208, 16, SHEET_SIDE, 1),
            (16, 8208, 16, 64, 33),
            (100, 20, 50, 64, 1),
            (100, 20, 50, 32, 2),
            (100, 20, 50, 10, 2),
        ] {
            let img: Vec<u8> = (0..w * h * 3).map(|i| (i * 7 % 251) as u8).collect();
            let list = parrt::tile::tiles(w as u32, h as u32, size);
            let mut rgb = Vec::new();
            for t in &list {
                for y in t.y..t.y + t.h {
                    let at = (y as usize * w + t.x as usize) * 3;
                    rgb.extend_from_slice(&img[at..at + t.w as usize * 3]);
                }
            }
            let events = super::sheets(&list, &rgb, &mut Scratch::default(), side);
            assert_eq!(
                events.len(),
                sheets,
                "{w} × {h} in {size}-px tiles on {side}-px sheets"
            );
            for e in &events {
                let text = std::str::from_utf8(e).expect("text");
                let png = text.lines().nth(1).and_then(|l| l.strip_prefix("data: "));
                let sheet =
                    image::load_from_memory(&unbase64(png.expect("the PNG"))).expect("a PNG");
                let most = side.max(size);
                assert!(
                    sheet.width() <= most && sheet.height() <= most,
                    "{side}-px sheets"
                );
            }
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
