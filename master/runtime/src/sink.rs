//! Where accepted tiles go while the master runs: a [`TileSink`]. The run loop hands each
//! turn's accepted tiles over and must never wait on a disk, so the checkpoint file of a real
//! run sits behind a [`BackgroundWriter`]: its own thread, a bounded queue of batches, and
//! tiles the queue cannot take yet kept (in order) for the next turn, so a slow disk costs
//! memory bounded by the image, never a heartbeat. The deterministic simulation writes
//! inline (a [`Checkpoint`] is itself a sink), so what a crashed master left is the same on
//! every replay.

use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::scheduler::AcceptedTile;
use std::sync::mpsc::{sync_channel, SyncSender, TrySendError};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

/// Batches a [`BackgroundWriter`] queues before it keeps tiles back.
pub const WRITER_QUEUE: usize = 64;

/// A consumer of accepted tiles.
pub trait TileSink: Send {
    /// Takes the tiles accepted since the last call. A sink on the runtime's thread returns
    /// at once; an error ends the render.
    fn take(&mut self, tiles: Vec<AcceptedTile>) -> Result<(), CheckpointError>;
    /// Writes what is left and makes it durable; may block (called once, after the render).
    fn close(self: Box<Self>) -> Result<(), CheckpointError>;
}

impl TileSink for Checkpoint {
    fn take(&mut self, tiles: Vec<AcceptedTile>) -> Result<(), CheckpointError> {
        self.append(&tiles)
    }

    fn close(mut self: Box<Self>) -> Result<(), CheckpointError> {
        self.sync()
    }
}

/// A sink run on a thread of its own behind a bounded queue.
pub struct BackgroundWriter {
    tx: Option<SyncSender<Vec<AcceptedTile>>>,
    /// Tiles the queue had no room for yet, oldest first.
    pending: Vec<AcceptedTile>,
    /// The first error the thread met, reported on the next [`TileSink::take`].
    failed: Arc<Mutex<Option<CheckpointError>>>,
    thread: Option<JoinHandle<Result<(), CheckpointError>>>,
}

impl BackgroundWriter {
    /// Runs `inner` on a new thread with a queue of `depth` batches. If no thread can be
    /// started, the caller gets the inner sink back (to run inline).
    pub fn start(
        inner: Box<dyn TileSink>,
        depth: usize,
    ) -> Result<BackgroundWriter, (Box<dyn TileSink>, std::io::Error)> {
        let (tx, rx) = sync_channel::<Vec<AcceptedTile>>(depth.max(1));
        let failed = Arc::new(Mutex::new(None));
        let theirs = failed.clone();
        // The sink moves to the thread only if the thread starts: hand it over through a slot.
        let slot = Arc::new(Mutex::new(Some(inner)));
        let taken = slot.clone();
        let spawned = std::thread::Builder::new()
            .name("parrt-checkpoint".into())
            .spawn(move || {
                let Some(mut sink) = taken.lock().unwrap_or_else(|p| p.into_inner()).take() else {
                    return Ok(());
                };
                for batch in rx {
                    if let Err(e) = sink.take(batch) {
                        *theirs.lock().unwrap_or_else(|p| p.into_inner()) = Some(e);
                        // Stop reading: the next send fails and the loop learns of it.
                        return Ok(());
                    }
                }
                sink.close()
            });
        match spawned {
            Ok(thread) => Ok(BackgroundWriter {
                tx: Some(tx),
                pending: Vec::new(),
                failed,
                thread: Some(thread),
            }),
            Err(e) => {
                let inner = slot
                    .lock()
                    .unwrap_or_else(|p| p.into_inner())
                    .take()
                    .expect("the thread never started, so the sink is still in its slot");
                Err((inner, e))
            }
        }
    }

    /// Tiles kept back because the queue was full.
    pub fn backlog(&self) -> usize {
        self.pending.len()
    }

    fn thread_error(&self) -> Option<CheckpointError> {
        self.failed.lock().unwrap_or_else(|p| p.into_inner()).take()
    }
}

impl TileSink for BackgroundWriter {
    fn take(&mut self, tiles: Vec<AcceptedTile>) -> Result<(), CheckpointError> {
        if let Some(e) = self.thread_error() {
            return Err(e);
        }
        self.pending.extend(tiles);
        if self.pending.is_empty() {
            return Ok(());
        }
        let Some(tx) = &self.tx else { return Ok(()) };
        match tx.try_send(std::mem::take(&mut self.pending)) {
            Ok(()) => Ok(()),
            Err(TrySendError::Full(back)) => {
                self.pending = back;
                Ok(())
            }
            Err(TrySendError::Disconnected(back)) => {
                self.pending = back;
                Err(self.thread_error().unwrap_or(CheckpointError::WriterGone))
            }
        }
    }

    fn close(mut self: Box<Self>) -> Result<(), CheckpointError> {
        if let Some(tx) = self.tx.take() {
            let rest = std::mem::take(&mut self.pending);
            if !rest.is_empty() {
                // After the render: waiting for the disk is fine now.
                let _ = tx.send(rest);
            }
        }
        let joined = match self.thread.take() {
            Some(t) => t.join().unwrap_or(Err(CheckpointError::WriterGone)),
            None => Ok(()),
        };
        match self.thread_error() {
            Some(e) => Err(e),
            None => joined,
        }
    }
}

impl Drop for BackgroundWriter {
    fn drop(&mut self) {
        // Closing the queue lets the thread finish what it has and sync; not waited for.
        self.tx.take();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use parrt_protocol::{Packing, PixelFormat, TilePixels};
    use parrt_render::stats::RayStats;
    use std::time::{Duration, Instant};

    fn tile(id: u32) -> AcceptedTile {
        AcceptedTile {
            frame: 0,
            tile_id: id,
            pixels: TilePixels {
                format: PixelFormat::Rgb8,
                packing: Packing::Raw,
                bytes: vec![id as u8; 3],
            },
            stats: RayStats::default(),
            seconds: 0.0,
        }
    }

    /// Records tile ids, sleeping `stall` per batch like a slow disk.
    struct Slow {
        stall: Duration,
        seen: Arc<Mutex<Vec<u32>>>,
        fail_at: Option<u32>,
    }

    impl TileSink for Slow {
        fn take(&mut self, tiles: Vec<AcceptedTile>) -> Result<(), CheckpointError> {
            std::thread::sleep(self.stall);
            let mut seen = self.seen.lock().unwrap();
            for t in tiles {
                if Some(t.tile_id) == self.fail_at {
                    return Err(CheckpointError::WriterGone);
                }
                seen.push(t.tile_id);
            }
            Ok(())
        }
        fn close(self: Box<Self>) -> Result<(), CheckpointError> {
            Ok(())
        }
    }

    #[test]
    fn a_stalled_disk_never_blocks_take_and_loses_nothing() {
        let seen = Arc::new(Mutex::new(Vec::new()));
        let slow = Slow {
            stall: Duration::from_millis(300),
            seen: seen.clone(),
            fail_at: None,
        };
        let Ok(mut w) = BackgroundWriter::start(Box::new(slow), 2) else {
            panic!("no thread")
        };
        let t0 = Instant::now();
        for id in 0..40 {
            w.take(vec![tile(id)]).unwrap();
        }
        assert!(
            t0.elapsed() < Duration::from_millis(250),
            "take waited for the disk: {:?}",
            t0.elapsed()
        );
        assert!(
            w.backlog() > 0,
            "the queue of 2 cannot have taken 40 batches"
        );
        Box::new(w).close().unwrap();
        assert_eq!(*seen.lock().unwrap(), (0..40).collect::<Vec<_>>());
    }

    #[test]
    fn the_threads_error_reaches_the_next_take() {
        let slow = Slow {
            stall: Duration::ZERO,
            seen: Arc::default(),
            fail_at: Some(3),
        };
        let Ok(mut w) = BackgroundWriter::start(Box::new(slow), 1) else {
            panic!("no thread")
        };
        let deadline = Instant::now() + Duration::from_secs(20);
        let mut id = 0;
        let err = loop {
            match w.take(vec![tile(id)]) {
                Ok(()) => {}
                Err(e) => break e,
            }
            id += 1;
            assert!(Instant::now() < deadline, "the error never came back");
            std::thread::sleep(Duration::from_millis(5));
        };
        assert!(matches!(err, CheckpointError::WriterGone), "{err}");
    }
}
