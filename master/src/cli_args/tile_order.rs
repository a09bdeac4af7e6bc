//! `--costly-first FILE`: hand the tiles out costliest first, ranked by a previous render's
//! `--tile-costs` (the last frame of an animation, or a test render). On many cores a frame
//! in raster order can end waiting on one costly tile that started late; started first, it
//! overlaps the rest. The order changes when tiles are rendered, never their pixels.

use super::ArgError;
use clap::Args;
use parrt_render::tile::Tile;
use std::path::{Path, PathBuf};

/// The tile order flag.
#[derive(Debug, Args, Default)]
pub struct OrderArgs {
    /// Hand the tiles out costliest first, ranked by FILE: a previous render's --tile-costs at
    /// the same size and --tile (e.g. the last frame of an animation). On a big cluster the
    /// frame then does not end waiting on one costly tile handed out late. The image is the
    /// same bits.
    #[arg(long, value_name = "FILE")]
    pub costly_first: Option<PathBuf>,
}

impl OrderArgs {
    /// The handout order by tile id for a `width`×`height` render cut into `tile`-pixel
    /// tiles, or `None` without the flag. A file of another tiling is bad input (exit 2).
    pub fn order(&self, width: u32, height: u32, tile: u32) -> anyhow::Result<Option<Vec<u32>>> {
        let Some(path) = &self.costly_first else {
            return Ok(None);
        };
        let costs = read_costs(path)?;
        let want = parrt_render::tile::tiles(width, height, tile);
        let same = |(t, _): &(Tile, f64), w: &Tile| {
            (t.id, t.x, t.y, t.w, t.h) == (w.id, w.x, w.y, w.w, w.h)
        };
        if costs.len() != want.len() || !costs.iter().zip(&want).all(|(c, w)| same(c, w)) {
            return Err(ArgError::Value(format!(
                "--costly-first {}: its {} tiles are not this render's {} tiles of {tile} px at \
                 {width}x{height}; record it with --tile-costs at the same size and --tile",
                path.display(),
                costs.len(),
                want.len()
            ))
            .into());
        }
        Ok(Some(costly_first(&costs)))
    }
}

/// Tile ids by cost, costliest first; equal costs in id order.
pub fn costly_first(costs: &[(Tile, f64)]) -> Vec<u32> {
    let mut order: Vec<u32> = costs.iter().map(|(t, _)| t.id).collect();
    let cost = |id: u32| costs[id as usize].1;
    order.sort_by(|&a, &b| cost(b).total_cmp(&cost(a)).then(a.cmp(&b)));
    order
}

/// Reads a `--tile-costs` file (at most the default file limit, UTF-8, every line checked);
/// errors are bad input naming the path and line.
pub fn read_costs(path: &Path) -> anyhow::Result<Vec<(Tile, f64)>> {
    let bytes = super::limits::read_path(path, parrt_render::nff::limits::DEFAULT_MAX_FILE_BYTES)?;
    let text = String::from_utf8(bytes).map_err(|_| ArgError::file(path, "not UTF-8 text"))?;
    let costs =
        crate::studies::efficiency::read_tile_costs(&text).map_err(|e| ArgError::file(path, e))?;
    if costs.is_empty() {
        return Err(ArgError::file(path, "no tiles").into());
    }
    Ok(costs)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tile(id: u32) -> Tile {
        Tile {
            id,
            x: id * 4,
            y: 0,
            w: 4,
            h: 4,
        }
    }

    #[test]
    fn costliest_first_ties_in_id_order() {
        let costs: Vec<(Tile, f64)> = [0.1, 0.5, 0.1, 0.9]
            .iter()
            .enumerate()
            .map(|(i, &c)| (tile(i as u32), c))
            .collect();
        assert_eq!(costly_first(&costs), vec![3, 1, 0, 2]);
    }

    #[test]
    fn another_tiling_is_refused_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("costs.csv");
        let list = parrt_render::tile::tiles(64, 64, 16);
        crate::studies::efficiency::write_tile_costs(&path, &list, &vec![0.01; list.len()])
            .unwrap();
        let args = OrderArgs {
            costly_first: Some(path.clone()),
        };
        assert_eq!(args.order(64, 64, 16).unwrap().map(|o| o.len()), Some(16));
        let e = args.order(64, 64, 32).unwrap_err();
        assert!(ArgError::is_in(&e), "{e}");
        let text = format!("{e:#}");
        assert!(
            text.contains("costs.csv") && text.contains("16 tiles"),
            "{text}"
        );
        let e = args.order(128, 64, 16).unwrap_err();
        assert!(format!("{e:#}").contains("32 tiles"), "{e:#}");
    }
}
