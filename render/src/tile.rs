//! Tiles: the rectangles of the image handed out as tasks. A tile list depends only on the image
//! size and the tile size, and is always in the same (row-major) order.

use serde::{Deserialize, Serialize};

/// A rectangle of pixels, `[x, x+w) × [y, y+h)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Tile {
    /// Position in the tile list.
    pub id: u32,
    /// Left column.
    pub x: u32,
    /// Top row.
    pub y: u32,
    /// Width in pixels.
    pub w: u32,
    /// Height in pixels.
    pub h: u32,
}

/// Edge of the pixel blocks whose eye rays are traced as one packet.
pub const BLOCK: u32 = 4;

impl Tile {
    /// Number of pixels.
    pub fn pixel_count(&self) -> usize {
        self.w as usize * self.h as usize
    }

    /// The tile's part of each [`BLOCK`] × [`BLOCK`] block of the image grid it overlaps, as
    /// `[x, x+w) × [y, y+h)` in image pixels, row by row. Blocks are aligned to the image, not
    /// to the tile, so tilings whose tile size is a multiple of [`BLOCK`] form the same packets.
    pub fn blocks(&self) -> impl Iterator<Item = (u32, u32, u32, u32)> + '_ {
        let (x_end, y_end) = (self.x + self.w, self.y + self.h);
        let first = |v: u32| v - v % BLOCK;
        (first(self.y)..y_end)
            .step_by(BLOCK as usize)
            .flat_map(move |by| {
                (first(self.x)..x_end)
                    .step_by(BLOCK as usize)
                    .map(move |bx| (bx, by))
            })
            .map(move |(bx, by)| {
                let (x0, y0) = (bx.max(self.x), by.max(self.y));
                let (x1, y1) = ((bx + BLOCK).min(x_end), (by + BLOCK).min(y_end));
                (x0, y0, x1 - x0, y1 - y0)
            })
    }
}

/// Cuts a `width × height` image into tiles of `size × size` (smaller at the right and bottom
/// edges), row by row. A size of 0 is treated as 1.
pub fn tiles(width: u32, height: u32, size: u32) -> Vec<Tile> {
    let size = size.max(1);
    let mut out = Vec::with_capacity(
        (width.div_ceil(size) as usize).saturating_mul(height.div_ceil(size) as usize),
    );
    let mut y = 0;
    while y < height {
        let h = size.min(height - y);
        let mut x = 0;
        while x < width {
            let w = size.min(width - x);
            out.push(Tile {
                id: out.len() as u32,
                x,
                y,
                w,
                h,
            });
            x += w;
        }
        y += h;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tiles_cover_image_exactly_once() {
        for (w, h, s) in [(512, 512, 32), (100, 37, 13), (1, 1, 64), (65, 64, 64)] {
            let ts = tiles(w, h, s);
            let mut seen = vec![0u8; (w * h) as usize];
            for t in &ts {
                for y in t.y..t.y + t.h {
                    for x in t.x..t.x + t.w {
                        seen[(y * w + x) as usize] += 1;
                    }
                }
            }
            assert!(seen.iter().all(|&c| c == 1), "{w}x{h} tile {s}");
            assert!(ts.iter().enumerate().all(|(i, t)| t.id as usize == i));
        }
    }

    #[test]
    fn blocks_cover_the_tile_once_aligned_to_the_image() {
        for t in [
            Tile {
                id: 0,
                x: 0,
                y: 0,
                w: 8,
                h: 8,
            },
            Tile {
                id: 0,
                x: 13,
                y: 26,
                w: 13,
                h: 7,
            },
            Tile {
                id: 0,
                x: 5,
                y: 1,
                w: 1,
                h: 1,
            },
        ] {
            let mut seen = vec![0u32; t.pixel_count()];
            for (x, y, w, h) in t.blocks() {
                assert!((1..=BLOCK).contains(&w) && (1..=BLOCK).contains(&h));
                // Never crosses a line of the image's 4-pixel grid.
                assert_eq!(x / BLOCK, (x + w - 1) / BLOCK);
                assert_eq!(y / BLOCK, (y + h - 1) / BLOCK);
                for py in y..y + h {
                    for px in x..x + w {
                        seen[((py - t.y) * t.w + px - t.x) as usize] += 1;
                    }
                }
            }
            assert!(seen.iter().all(|&c| c == 1), "{t:?}: {seen:?}");
        }
        let b: Vec<_> = Tile {
            id: 0,
            x: 2,
            y: 0,
            w: 7,
            h: 2,
        }
        .blocks()
        .collect();
        assert_eq!(b, vec![(2, 0, 2, 2), (4, 0, 4, 2), (8, 0, 1, 2)]);
    }
}
