//! The regions of memory a master shares with the workers it starts
//! ([`parrt_protocol::shared_pixels`]): made one per worker as it is started, found by the id a
//! worker's results name, and held by one connection at a time. A result that names a region
//! this master did not make, or one another connection holds, or a slot holding nothing, is a
//! protocol violation of that connection alone.

use parrt_protocol::{Packing, SharedError, SharedPixels, TilePixels};
use std::collections::HashMap;
use std::os::fd::OwnedFd;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// The regions made for this master's workers, by id.
#[derive(Debug, Default)]
pub struct SharedRegions {
    regions: Mutex<HashMap<u64, Region>>,
    /// Tiles whose pixels came through a region.
    tiles: AtomicU64,
}

#[derive(Debug)]
struct Region {
    pixels: Arc<SharedPixels>,
    /// Whether a connection holds it.
    held: bool,
}

impl SharedRegions {
    /// Makes a region of `slots` slots of `slot_bytes` bytes under a fresh random id; returns
    /// the descriptor to hand the worker it is for.
    pub fn create(&self, slots: u32, slot_bytes: u32) -> Result<OwnedFd, SharedError> {
        let mut regions = self.regions.lock().unwrap_or_else(|p| p.into_inner());
        let id = loop {
            let id = rand::random::<u64>();
            if !regions.contains_key(&id) {
                break id;
            }
        };
        let (pixels, fd) = SharedPixels::create(slots, slot_bytes, id)?;
        regions.insert(
            id,
            Region {
                pixels: Arc::new(pixels),
                held: false,
            },
        );
        Ok(fd)
    }

    /// How many regions were made.
    pub fn len(&self) -> usize {
        self.regions.lock().map_or(0, |r| r.len())
    }

    /// Whether none was made.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// How many tiles' pixels came through the regions so far.
    pub fn tiles(&self) -> u64 {
        self.tiles.load(Ordering::Relaxed)
    }

    /// Region `id` for one connection, until the returned hold is dropped; `None` when this
    /// master made no such region or another connection holds it.
    fn hold(self: &Arc<Self>, id: u64) -> Option<Hold> {
        let mut regions = self.regions.lock().unwrap_or_else(|p| p.into_inner());
        let r = regions.get_mut(&id).filter(|r| !r.held)?;
        r.held = true;
        Some(Hold {
            pixels: r.pixels.clone(),
            regions: self.clone(),
        })
    }
}

/// A connection's hold on its worker's region; let go when dropped (the connection closed).
#[derive(Debug)]
pub struct Hold {
    pixels: Arc<SharedPixels>,
    regions: Arc<SharedRegions>,
}

impl Drop for Hold {
    fn drop(&mut self) {
        let mut regions = self
            .regions
            .regions
            .lock()
            .unwrap_or_else(|p| p.into_inner());
        if let Some(r) = regions.get_mut(&self.pixels.id()) {
            r.held = false;
        }
    }
}

/// One connection's view of the shared regions: which one it holds, once its worker has named
/// one.
#[derive(Debug)]
pub struct ConnRegion {
    regions: Arc<SharedRegions>,
    held: Option<Hold>,
}

impl ConnRegion {
    /// A connection that holds no region yet.
    pub fn new(regions: Arc<SharedRegions>) -> Self {
        ConnRegion {
            regions,
            held: None,
        }
    }

    /// `pixels` with any bytes in shared memory copied out of their slot (which is freed), so
    /// that they are raw; or why the worker's claim is false. Pixels sent inline pass as they
    /// are.
    pub fn resolve(&mut self, pixels: TilePixels) -> Result<TilePixels, String> {
        let Packing::Shared { region, slot, len } = pixels.packing else {
            return Ok(pixels);
        };
        let held = match self.held.take() {
            Some(h) if h.pixels.id() == region => h,
            Some(h) => {
                self.held = Some(h);
                return Err("pixels in a second shared region".into());
            }
            None => self.regions.hold(region).ok_or_else(|| {
                "pixels in a shared region this master did not give this worker".to_string()
            })?,
        };
        let taken = held.pixels.take(slot, len);
        self.held = Some(held);
        let bytes = taken.map_err(|e| format!("pixels in shared memory: {e}"))?;
        self.regions.tiles.fetch_add(1, Ordering::Relaxed);
        Ok(TilePixels {
            format: pixels.format,
            packing: Packing::Raw,
            bytes,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use parrt_protocol::PixelFormat;

    /// A region made by the registry, and a worker's mapping of it.
    fn made(regions: &SharedRegions) -> SharedPixels {
        let fd = regions.create(4, 12).unwrap();
        SharedPixels::open(fd).unwrap()
    }

    fn shared(worker: &SharedPixels, value: f32) -> TilePixels {
        TilePixels::encode_shared(&[[value; 3]], PixelFormat::F32, worker).unwrap()
    }

    #[test]
    fn a_connection_takes_its_workers_pixels_out_and_holds_the_region_alone() {
        let regions = Arc::new(SharedRegions::default());
        let worker = made(&regions);
        assert_eq!(regions.len(), 1);
        let mut conn = ConnRegion::new(regions.clone());
        let raw = conn.resolve(shared(&worker, 0.5)).unwrap();
        assert_eq!(raw, TilePixels::encode(&[[0.5; 3]], PixelFormat::F32));
        assert_eq!(regions.tiles(), 1);
        // Inline pixels pass untouched.
        let inline = TilePixels::encode(&[[0.25; 3]], PixelFormat::F32);
        assert_eq!(conn.resolve(inline.clone()).unwrap(), inline);
        // Another connection naming the same region is refused while this one holds it...
        let mut other = ConnRegion::new(regions.clone());
        let e = other.resolve(shared(&worker, 1.0)).unwrap_err();
        assert!(e.contains("did not give this worker"), "{e}");
        // ...and may take it once this one has closed (a worker that dialled again).
        drop(conn);
        let again = TilePixels::encode_shared(&[[2.0; 3]], PixelFormat::F32, &worker).unwrap();
        assert_eq!(
            other.resolve(again).unwrap(),
            TilePixels::encode(&[[2.0; 3]], PixelFormat::F32)
        );
    }

    #[test]
    fn false_claims_are_violations_not_panics() {
        let regions = Arc::new(SharedRegions::default());
        let (a, b) = (made(&regions), made(&regions));
        let mut conn = ConnRegion::new(regions.clone());
        let first = shared(&a, 0.5);
        // A slot named twice: the second time it holds nothing.
        conn.resolve(first.clone()).unwrap();
        let e = conn.resolve(first).unwrap_err();
        assert!(e.contains("holds no pixels"), "{e}");
        // A second region on one connection.
        let e = conn.resolve(shared(&b, 0.5)).unwrap_err();
        assert!(e.contains("second shared region"), "{e}");
        // A region nobody made (a worker this master did not start).
        let mut stranger = ConnRegion::new(Arc::new(SharedRegions::default()));
        let forged = TilePixels {
            format: PixelFormat::F32,
            packing: Packing::Shared {
                region: a.id(),
                slot: 0,
                len: 12,
            },
            bytes: Vec::new(),
        };
        let e = stranger.resolve(forged).unwrap_err();
        assert!(e.contains("did not give"), "{e}");
    }
}
