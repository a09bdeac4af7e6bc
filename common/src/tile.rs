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

impl Tile {
    /// Number of pixels.
    pub fn pixel_count(&self) -> usize {
        self.w as usize * self.h as usize
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
}
