//! The bytes of the server-sent events a page is sent: `tiles` events (a PNG of a batch of tiles
//! laid side by side on a sheet, in standard base64, RFC 4648 with padding, and where each
//! tile goes) and one-line events (`reload`, `status`, `done`). Each is made once and the same
//! bytes go to every page. [`png_into`] also encodes the whole image for `GET /image.png`.

use super::limits::SHEET_SIDE;
use bytes::Bytes;
use parrt_render::tile::Tile;

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
    coarse: Vec<u8>,
}

/// Where a tile sits on its event's sheet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Placed {
    sx: u32,
    sy: u32,
}

/// The `tiles` events of `tiles` (whose 8-bit RGB pixels `rgb` holds row by row, one tile after
/// the other, in `tiles` order), each tile sent at full resolution (`scale` 1) or averaged over
/// blocks of `scale` × `scale` pixels (see [`coarsen`]): each event's first line is a PNG in
/// base64 of a sheet of its tiles laid in rows, left to right in landing order, then a line
/// `x,y,w,h,sx,sy` per tile (`x,y,w,h,sx,sy,scale` when `scale` > 1): where it goes in the image
/// and where it is on the sheet, where it is `ceil(w / scale)` × `ceil(h / scale)`. A sheet is
/// about square and at most [`SHEET_SIDE`] pixels a side (unless one tile is bigger); a larger
/// batch is sent as several events. One PNG per sheet, fast compression. Square sheets instead
/// of the tiles one under the other, on mount-8 at 1024² in 32-pixel tiles: 4.5 → 3.6 ms to
/// encode a frame's batches and 8 % fewer bytes (the rows are ten times longer).
pub fn tiles_events(tiles: &[Tile], rgb: &[u8], scale: u32, scratch: &mut Scratch) -> Vec<Bytes> {
    sheets(tiles, rgb, scale, scratch, SHEET_SIDE)
}

/// [`tiles_events`] on sheets at most `side` pixels a side.
fn sheets(tiles: &[Tile], rgb: &[u8], scale: u32, scratch: &mut Scratch, side: u32) -> Vec<Bytes> {
    let scale = scale.max(1);
    let mut coarse = std::mem::take(&mut scratch.coarse);
    let rgb = if scale > 1 {
        coarsen(tiles, rgb, scale, &mut coarse);
        &coarse[..]
    } else {
        rgb
    };
    let sizes: Vec<(u32, u32)> = tiles
        .iter()
        .map(|t| (t.w.div_ceil(scale), t.h.div_ceil(scale)))
        .collect();
    let mut events = Vec::new();
    let (mut first, mut at) = (0, 0);
    while first < tiles.len() {
        let (end, width, height, places) = layout(&sizes[first..], side);
        let range = first..first + end;
        let bytes: usize = sizes[range.clone()]
            .iter()
            .map(|&(w, h)| w as usize * h as usize * 3)
            .sum();
        let Some(px) = rgb.get(at..at + bytes) else {
            break;
        };
        let sheet = Sheet {
            width,
            height,
            scale,
            places: &places,
            sizes: &sizes[range.clone()],
        };
        if let Some(e) = sheet.event(&tiles[range], px, scratch) {
            events.push(e);
        }
        (first, at) = (first + end, at + bytes);
    }
    scratch.coarse = coarse;
    events
}

/// Replaces `out` with each tile's pixels (as [`tiles_events`] takes them) averaged over blocks
/// of `s` × `s` pixels aligned to the tile's corner, fewer at its right and bottom edges, each
/// channel's mean rounded half up: a tile `ceil(w / s)` × `ceil(h / s)`. Stops at a tile `rgb`
/// does not hold.
pub fn coarsen(tiles: &[Tile], rgb: &[u8], s: u32, out: &mut Vec<u8>) {
    out.clear();
    let s = s.max(1) as usize;
    let mut columns: Vec<u32> = Vec::new();
    let mut at = 0;
    for t in tiles {
        let (w, h) = (t.w as usize, t.h as usize);
        let Some(px) = rgb.get(at..at + w * h * 3) else {
            return;
        };
        at += w * h * 3;
        for top in (0..h).step_by(s) {
            let rows = (h - top).min(s);
            // The block row's columns summed down (a loop the compiler vectorizes), then
            // each block's columns summed across.
            columns.clear();
            columns.resize(w * 3, 0);
            for row in px[top * w * 3..(top + rows) * w * 3].chunks_exact(w * 3) {
                for (c, &v) in columns.iter_mut().zip(row) {
                    *c += u32::from(v);
                }
            }
            for block in columns.chunks(s * 3) {
                let n = (rows * block.len() / 3) as u32;
                for c in 0..3 {
                    let v: u32 = block[c..].iter().step_by(3).sum();
                    out.push(((v + n / 2) / n) as u8);
                }
            }
        }
    }
}

/// The first sheet of tiles of `sizes` (width and height on the sheet, at least one tile): how
/// many tiles it holds, its width and height, and where each of them sits. Rows ("shelves") as
/// wide as the square root of the tiles' area (at least the widest tile, at most `max_side`),
/// each as tall as its tallest tile; the sheet ends before a tile that would take it past
/// `max_side` rows.
fn layout(sizes: &[(u32, u32)], max_side: u32) -> (usize, u32, u32, Vec<Placed>) {
    let area: u64 = sizes
        .iter()
        .map(|&(w, h)| u64::from(w) * u64::from(h))
        .sum();
    let widest = sizes.iter().map(|&(w, _)| w).max().unwrap_or(0);
    let side = ((area as f64).sqrt().ceil() as u32).min(max_side);
    let row_width = side.max(widest);
    let (mut x, mut y, mut shelf, mut width) = (0u32, 0u32, 0u32, 0u32);
    let mut places = Vec::with_capacity(sizes.len());
    for &(w, h) in sizes {
        if x > 0 && x + w > row_width {
            (x, y, shelf) = (0, y + shelf, 0);
        }
        if !places.is_empty() && y + h.max(shelf) > max_side {
            break;
        }
        places.push(Placed { sx: x, sy: y });
        x += w;
        shelf = shelf.max(h);
        width = width.max(x);
    }
    (places.len(), width, y + shelf, places)
}

/// One sheet of a batch: its size, the scale its tiles are sent at, and where each of its
/// tiles sits and how big it is there.
struct Sheet<'a> {
    width: u32,
    height: u32,
    scale: u32,
    places: &'a [Placed],
    sizes: &'a [(u32, u32)],
}

impl Sheet<'_> {
    /// The `tiles` event of `tiles` (pixels `rgb`, at the sheet's scale); `None` if the PNG
    /// cannot be made (not for tiles of an image's own size: the page gets them with the final
    /// image).
    fn event(&self, tiles: &[Tile], rgb: &[u8], scratch: &mut Scratch) -> Option<Bytes> {
        let row = self.width as usize * 3;
        let sheet = &mut scratch.sheet;
        sheet.clear();
        sheet.resize(row * self.height as usize, 0);
        let mut src = 0;
        for (&(w, h), p) in self.sizes.iter().zip(self.places) {
            let n = w as usize * 3;
            let mut dst = p.sy as usize * row + p.sx as usize * 3;
            for _ in 0..h {
                sheet[dst..dst + n].copy_from_slice(rgb.get(src..src + n)?);
                (src, dst) = (src + n, dst + row);
            }
        }
        let png = &mut scratch.png;
        png.clear();
        png_into(sheet, self.width, self.height, png).ok()?;
        let mut out = String::with_capacity(32 + png.len().div_ceil(3) * 4 + tiles.len() * 32);
        out.push_str("event: tiles\ndata: ");
        base64_into(png, &mut out);
        for (t, p) in tiles.iter().zip(self.places) {
            use std::fmt::Write;
            let _ = write!(
                out,
                "\ndata: {},{},{},{},{},{}",
                t.x, t.y, t.w, t.h, p.sx, p.sy
            );
            if self.scale > 1 {
                let _ = write!(out, ",{}", self.scale);
            }
        }
        out.push_str("\n\n");
        Some(Bytes::from(out))
    }
}

/// Appends a PNG of `w` × `h` 8-bit RGB pixels to `out`: the live view's one PNG encoder, for
/// the sheets of `tiles` events and for `GET /image.png`. Fast compression: a page waits for
/// these, and they are made while the render runs.
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

    /// The tiles an event carries: each one's rectangle in the image, its scale and its pixels
    /// as sent, cut from the sheet.
    pub fn decode_tiles(event: &[u8]) -> Vec<(Tile, u32, Vec<u8>)> {
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
            let (x, y, w, h, sx, sy, scale) = match v[..] {
                [x, y, w, h, sx, sy] => (x, y, w, h, sx, sy, 1),
                [x, y, w, h, sx, sy, s] if s > 1 => (x, y, w, h, sx, sy, s),
                _ => panic!("x,y,w,h,sx,sy[,scale]: {line}"),
            };
            let (cw, ch) = (w.div_ceil(scale), h.div_ceil(scale));
            assert!(
                sx + cw <= sheet.width() && sy + ch <= sheet.height(),
                "on the sheet"
            );
            let px = image::imageops::crop_imm(&sheet, sx, sy, cw, ch).to_image();
            covered += cw * ch;
            let tile = Tile { id: 0, x, y, w, h };
            out.push((tile, scale, px.into_raw()));
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
            let list = parrt_render::tile::tiles(w as u32, h as u32, size);
            let mut rgb = Vec::new();
            for t in &list {
                for y in t.y..t.y + t.h {
                    let at = (y as usize * w + t.x as usize) * 3;
                    rgb.extend_from_slice(&img[at..at + t.w as usize * 3]);
                }
            }
            let events = super::sheets(&list, &rgb, 1, &mut Scratch::default(), side);
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
            let got: Vec<(Tile, u32, Vec<u8>)> =
                events.iter().flat_map(|e| decode_tiles(e)).collect();
            assert_eq!(got.len(), list.len());
            let mut at = 0;
            for ((t, scale, px), want) in got.iter().zip(&list) {
                assert_eq!((t.x, t.y, t.w, t.h), (want.x, want.y, want.w, want.h));
                assert_eq!(*scale, 1);
                let n = want.pixel_count() * 3;
                assert_eq!(px[..], rgb[at..at + n], "tile at {},{}", t.x, t.y);
                at += n;
            }
        }
    }

    /// Tiles sent at scale `s`: each sheet tile is the block means of the tile's pixels, blocks
    /// cut short at the right and bottom edges, means rounded half up.
    #[test]
    fn coarse_tiles_carry_block_means() {
        // A 7 × 5 image in tiles of 4: widths 4 and 3, heights 4 and 1.
        let (w, h) = (7usize, 5usize);
        let img: Vec<u8> = (0..w * h * 3).map(|i| (i * 37 % 256) as u8).collect();
        let list = parrt_render::tile::tiles(w as u32, h as u32, 4);
        let mut rgb = Vec::new();
        for t in &list {
            for y in t.y..t.y + t.h {
                let at = (y as usize * w + t.x as usize) * 3;
                rgb.extend_from_slice(&img[at..at + t.w as usize * 3]);
            }
        }
        for s in [2u32, 4, 8] {
            let events = super::sheets(&list, &rgb, s, &mut Scratch::default(), SHEET_SIDE);
            let got: Vec<_> = events.iter().flat_map(|e| decode_tiles(e)).collect();
            assert_eq!(got.len(), list.len());
            for ((t, scale, px), want) in got.iter().zip(&list) {
                assert_eq!(
                    (t.x, t.y, t.w, t.h, *scale),
                    (want.x, want.y, want.w, want.h, s)
                );
                let mut mean = Vec::new();
                for by in (t.y..t.y + t.h).step_by(s as usize) {
                    for bx in (t.x..t.x + t.w).step_by(s as usize) {
                        let (ys, xs) = (by..(by + s).min(t.y + t.h), bx..(bx + s).min(t.x + t.w));
                        let n = (ys.len() * xs.len()) as u32;
                        for c in 0..3 {
                            let sum: u32 = ys
                                .clone()
                                .flat_map(|y| xs.clone().map(move |x| (y, x)))
                                .map(|(y, x)| u32::from(img[(y as usize * w + x as usize) * 3 + c]))
                                .sum();
                            mean.push(((sum + n / 2) / n) as u8);
                        }
                    }
                }
                assert_eq!(*px, mean, "tile at {},{} at scale {s}", t.x, t.y);
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
