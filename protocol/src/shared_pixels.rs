//! Pixels through memory that a master shares with the workers it starts on its own machine.
//!
//! Over a socket, every byte of a tile is sealed by the worker, copied into the kernel, copied
//! out by the master and opened again; on one machine those steps take the cores the render
//! threads need. So a master that starts its own workers gives each a region of memory (a
//! `memfd`, sealed against shrinking and growing, passed by file descriptor, named in
//! [`SHARED_PIXELS_ENV`]): a worker writes a tile's bytes into a free slot of its region and
//! sends only the slot's number in its result ([`crate::Packing::Shared`]); the master's
//! connection task copies the slot out and frees it before the scheduler sees the result, which
//! from there on is an ordinary raw result, checked as any other.
//!
//! Each slot has a state word: free, being written (a worker's render thread took it) or full
//! (written, its result on the way). A worker takes a free slot with a compare-and-swap,
//! writes, and publishes it full (release); the master takes only a full slot (acquire),
//! copies, and frees it (release), which the worker's next compare-and-swap sees (acquire)
//! before it writes the slot again. A worker that finds no free slot, or a tile larger than a
//! slot, sends the pixels inline as before: the region is a fast path, never a place to wait.
//! A region belongs to one worker; its id (random, in the region's header) is what the worker
//! names in its results, and a master accepts it only from one connection at a time and only
//! for a region it made, so a worker on another machine cannot point it at anything.

use std::fs::File;
use std::os::fd::{AsRawFd, FromRawFd, OwnedFd, RawFd};
use std::sync::atomic::{AtomicU32, AtomicUsize, Ordering};
use thiserror::Error;

/// The environment variable through which a master tells a worker it starts which file
/// descriptor holds the worker's region.
pub const SHARED_PIXELS_ENV: &str = "PARRT_SHARED_PIXELS";

/// The header's first eight bytes: the layout's name and version.
const MAGIC: u64 = u64::from_le_bytes(*b"parrtpx1");
/// Bytes before the state words: magic, id, slot count, slot bytes (24), padded to a cache line.
const HEADER: usize = 64;
/// The most slots a region may have.
pub const MAX_SLOTS: u32 = 1 << 16;
/// The most bytes a slot may hold (a 128² tile of f32 pixels is 192 KiB).
pub const MAX_SLOT_BYTES: u32 = 1 << 20;

/// Slot states.
const FREE: u32 = 0;
const WRITING: u32 = 1;
const FULL: u32 = 2;

/// Why a region cannot be made, opened or read.
#[derive(Debug, Error)]
pub enum SharedError {
    /// The slot count or size is out of range.
    #[error("a region of {slots} slots of {slot_bytes} bytes is out of range")]
    Size {
        /// Slots asked for.
        slots: u32,
        /// Bytes per slot asked for.
        slot_bytes: u32,
    },
    /// The environment variable does not name an open file descriptor.
    #[error("{SHARED_PIXELS_ENV}={0:?} does not name an open file descriptor")]
    NotOpen(String),
    /// The file is not a region of this layout (or not sealed against resizing).
    #[error("not a shared pixel region: {0}")]
    Layout(&'static str),
    /// A system call failed.
    #[error("shared pixel region: {what}: {source}")]
    Io {
        /// The step that failed.
        what: &'static str,
        /// The cause.
        source: std::io::Error,
    },
    /// A result named a slot the region does not have.
    #[error("slot {slot} of a region of {slots}")]
    NoSlot {
        /// The slot named.
        slot: u32,
        /// Slots in the region.
        slots: u32,
    },
    /// A result claimed more bytes than a slot holds.
    #[error("{len} bytes in a slot of {slot_bytes}")]
    TooLong {
        /// Bytes claimed.
        len: u32,
        /// Bytes a slot holds.
        slot_bytes: u32,
    },
    /// A result named a slot that holds no published pixels (never written, or taken already).
    #[error("slot {0} holds no pixels")]
    NotFull(u32),
}

/// One worker's region, mapped in this process (the master's, or the worker's).
#[derive(Debug)]
pub struct SharedPixels {
    map: memmap2::MmapRaw,
    id: u64,
    slots: u32,
    slot_bytes: u32,
    /// Where a worker's next search for a free slot starts (this process's own, not shared).
    next: AtomicUsize,
}

/// Where slot data starts: after the header and the state words, on a cache line.
fn data_offset(slots: u32) -> usize {
    (HEADER + 4 * slots as usize).next_multiple_of(64)
}

/// The region's byte size, or `None` when the sizes are out of range.
fn region_len(slots: u32, slot_bytes: u32) -> Option<usize> {
    if !(1..=MAX_SLOTS).contains(&slots) || !(1..=MAX_SLOT_BYTES).contains(&slot_bytes) {
        return None;
    }
    Some(data_offset(slots) + slots as usize * slot_bytes as usize)
}

/// The error of the last system call, as the step `what`.
fn last_os_error(what: &'static str) -> SharedError {
    SharedError::Io {
        what,
        source: std::io::Error::last_os_error(),
    }
}

impl SharedPixels {
    /// The master's side: a new region of `slots` slots of `slot_bytes` bytes named `id`, and
    /// the descriptor to hand the worker (close-on-exec: the spawner clears that flag in the
    /// one child it is for). The memory starts zeroed, every slot free.
    pub fn create(slots: u32, slot_bytes: u32, id: u64) -> Result<(Self, OwnedFd), SharedError> {
        let len = region_len(slots, slot_bytes).ok_or(SharedError::Size { slots, slot_bytes })?;
        // SAFETY: the name is a NUL-terminated string; the flags are valid.
        let fd = unsafe {
            libc::memfd_create(
                c"parrt-pixels".as_ptr(),
                libc::MFD_CLOEXEC | libc::MFD_ALLOW_SEALING,
            )
        };
        if fd < 0 {
            return Err(last_os_error("memfd_create"));
        }
        // SAFETY: memfd_create returned a new descriptor that nothing else owns.
        let file = File::from(unsafe { OwnedFd::from_raw_fd(fd) });
        file.set_len(len as u64).map_err(|source| SharedError::Io {
            what: "sizing",
            source,
        })?;
        // Neither side can resize it now: a mapping of it never faults past its end.
        let seals = libc::F_SEAL_SHRINK | libc::F_SEAL_GROW | libc::F_SEAL_SEAL;
        // SAFETY: fcntl on a descriptor this function owns.
        if unsafe { libc::fcntl(file.as_raw_fd(), libc::F_ADD_SEALS, seals) } != 0 {
            return Err(last_os_error("sealing"));
        }
        let map = memmap2::MmapRaw::map_raw(&file).map_err(|source| SharedError::Io {
            what: "mapping",
            source,
        })?;
        let header = [MAGIC, id, u64::from(slots) | (u64::from(slot_bytes) << 32)];
        for (i, word) in header.iter().enumerate() {
            // SAFETY: the mapping is at least HEADER bytes, page-aligned, and no one else has
            // it yet.
            unsafe { (map.as_mut_ptr() as *mut u64).add(i).write(word.to_le()) };
        }
        let region = SharedPixels {
            map,
            id,
            slots,
            slot_bytes,
            next: AtomicUsize::new(0),
        };
        Ok((region, OwnedFd::from(file)))
    }

    /// The worker's side: the region the master passed in [`SHARED_PIXELS_ENV`], `None` when
    /// the variable is not set, or on any call but a process's first (the descriptor has one
    /// owner).
    pub fn from_env() -> Option<Result<Self, SharedError>> {
        static TAKEN: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
        let text = std::env::var(SHARED_PIXELS_ENV).ok()?;
        if TAKEN.swap(true, Ordering::AcqRel) {
            return None;
        }
        Some(Self::from_fd_text(&text))
    }

    /// The region in the descriptor numbered `text` (as [`SHARED_PIXELS_ENV`] holds it), which
    /// this process takes ownership of.
    fn from_fd_text(text: &str) -> Result<Self, SharedError> {
        let not_open = || SharedError::NotOpen(text.chars().take(32).collect());
        let fd: RawFd = text.trim().parse().map_err(|_| not_open())?;
        // Never the standard streams; and the number must be open here.
        // SAFETY: F_GETFD on any number only reads the descriptor table.
        if fd <= 2 || unsafe { libc::fcntl(fd, libc::F_GETFD) } < 0 {
            return Err(not_open());
        }
        // Close-on-exec again, so nothing this worker starts inherits it.
        // SAFETY: as above, on a descriptor just checked to be open.
        unsafe { libc::fcntl(fd, libc::F_SETFD, libc::FD_CLOEXEC) };
        // SAFETY: the descriptor is open, and was passed to this process only for this region:
        // nothing else in it uses that number.
        Self::open(unsafe { OwnedFd::from_raw_fd(fd) })
    }

    /// Maps the region in `fd`, after checking it is sealed against resizing and laid out as
    /// its header says.
    pub fn open(fd: OwnedFd) -> Result<Self, SharedError> {
        let file = File::from(fd);
        // SAFETY: fcntl on a descriptor this function owns.
        let seals = unsafe { libc::fcntl(file.as_raw_fd(), libc::F_GET_SEALS) };
        let need = libc::F_SEAL_SHRINK | libc::F_SEAL_GROW;
        if seals < 0 || seals & need != need {
            return Err(SharedError::Layout("not sealed against resizing"));
        }
        let len = file
            .metadata()
            .map_err(|source| SharedError::Io {
                what: "reading its size",
                source,
            })?
            .len();
        if len < HEADER as u64 {
            return Err(SharedError::Layout("shorter than its header"));
        }
        let map = memmap2::MmapRaw::map_raw(&file).map_err(|source| SharedError::Io {
            what: "mapping",
            source,
        })?;
        let mut header = [0u64; 3];
        for (i, word) in header.iter_mut().enumerate() {
            // SAFETY: the mapping holds at least HEADER bytes and is page-aligned; the master
            // wrote the header before it passed the descriptor on.
            *word = u64::from_le(unsafe { (map.as_ptr() as *const u64).add(i).read() });
        }
        if header[0] != MAGIC {
            return Err(SharedError::Layout("wrong magic"));
        }
        let (slots, slot_bytes) = (header[2] as u32, (header[2] >> 32) as u32);
        if region_len(slots, slot_bytes) != Some(map.len()) {
            return Err(SharedError::Layout("its size does not match its header"));
        }
        Ok(SharedPixels {
            map,
            id: header[1],
            slots,
            slot_bytes,
            next: AtomicUsize::new(0),
        })
    }

    /// The region's id: what a worker's results name it by.
    pub fn id(&self) -> u64 {
        self.id
    }

    /// Bytes one slot holds.
    pub fn slot_bytes(&self) -> u32 {
        self.slot_bytes
    }

    /// Slot `slot`'s state word.
    fn state(&self, slot: u32) -> &AtomicU32 {
        debug_assert!(slot < self.slots);
        // SAFETY: in bounds (slot < slots, the words follow the header), 4-aligned (the
        // mapping is page-aligned, HEADER a multiple of 4), valid as long as `self`; both
        // processes touch it only atomically.
        unsafe { AtomicU32::from_ptr(self.map.as_mut_ptr().add(HEADER + 4 * slot as usize).cast()) }
    }

    /// Slot `slot`'s first byte.
    fn data(&self, slot: u32) -> *mut u8 {
        debug_assert!(slot < self.slots);
        // SAFETY: in bounds: data_offset + slots × slot_bytes is the mapping's length.
        unsafe {
            self.map
                .as_mut_ptr()
                .add(data_offset(self.slots) + slot as usize * self.slot_bytes as usize)
        }
    }

    /// The worker's side: takes a free slot, lets `fill` write `len` bytes into it, and
    /// publishes it. `None` (and `fill` not called) when `len` exceeds a slot or no slot is
    /// free: the caller sends the pixels inline.
    pub fn put(&self, len: usize, fill: impl FnOnce(&mut [u8])) -> Option<u32> {
        if len > self.slot_bytes as usize {
            return None;
        }
        let n = self.slots as usize;
        let start = self.next.load(Ordering::Relaxed);
        for k in 0..n {
            let slot = ((start + k) % n) as u32;
            let state = self.state(slot);
            if state.load(Ordering::Relaxed) != FREE
                || state
                    .compare_exchange(FREE, WRITING, Ordering::Acquire, Ordering::Relaxed)
                    .is_err()
            {
                continue;
            }
            self.next.store(slot as usize + 1, Ordering::Relaxed);
            // SAFETY: the slot is this thread's alone until it is published: the master reads
            // only full slots, and other threads take only free ones. `len` fits the slot.
            let bytes = unsafe { std::slice::from_raw_parts_mut(self.data(slot), len) };
            fill(bytes);
            state.store(FULL, Ordering::Release);
            return Some(slot);
        }
        None
    }

    /// The master's side: copies the `len` bytes a worker published in `slot` and frees the
    /// slot, or says why the result's claim is false.
    pub fn take(&self, slot: u32, len: u32) -> Result<Vec<u8>, SharedError> {
        if slot >= self.slots {
            return Err(SharedError::NoSlot {
                slot,
                slots: self.slots,
            });
        }
        if len > self.slot_bytes {
            return Err(SharedError::TooLong {
                len,
                slot_bytes: self.slot_bytes,
            });
        }
        let state = self.state(slot);
        if state.load(Ordering::Acquire) != FULL {
            return Err(SharedError::NotFull(slot));
        }
        // SAFETY: in bounds (len ≤ slot_bytes); the slot is published and, until this thread
        // frees it, an honest worker does not write it again. A dishonest one could only spoil
        // its own tile's bytes: the region is sealed, so the read never faults. Copied straight
        // into a new vector (not zeroed first).
        let bytes = unsafe { std::slice::from_raw_parts(self.data(slot), len as usize) }.to_vec();
        state
            .compare_exchange(FULL, FREE, Ordering::Release, Ordering::Relaxed)
            .map_err(|_| SharedError::NotFull(slot))?;
        Ok(bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The master's mapping and a worker's mapping of the same region (through a second
    /// descriptor, as a child would hold it).
    fn pair(slots: u32, slot_bytes: u32) -> (SharedPixels, SharedPixels) {
        let (master, fd) = SharedPixels::create(slots, slot_bytes, 0xfeed_beef).unwrap();
        let worker = SharedPixels::open(fd.try_clone().unwrap()).unwrap();
        (master, worker)
    }

    #[test]
    fn bytes_put_by_the_worker_are_taken_by_the_master_once() {
        let (master, worker) = pair(4, 64);
        assert_eq!(worker.id(), 0xfeed_beef);
        assert_eq!(worker.slot_bytes(), 64);
        let slot = worker.put(5, |b| b.copy_from_slice(b"pixel")).unwrap();
        assert_eq!(master.take(slot, 5).unwrap(), b"pixel");
        // Taken: the same claim again is false, and the slot is free for the worker again.
        assert!(matches!(master.take(slot, 5), Err(SharedError::NotFull(s)) if s == slot));
        let again = worker.put(3, |b| b.copy_from_slice(b"abc"));
        assert!(again.is_some());
        assert_eq!(master.take(again.unwrap(), 3).unwrap(), b"abc");
    }

    #[test]
    fn a_full_region_or_a_large_tile_sends_inline() {
        let (master, worker) = pair(2, 8);
        assert_eq!(worker.put(9, |_| panic!("no slot fits")), None);
        let a = worker.put(8, |b| b.fill(1)).unwrap();
        let b = worker.put(8, |b| b.fill(2)).unwrap();
        assert_ne!(a, b);
        assert_eq!(worker.put(1, |_| panic!("no slot is free")), None);
        assert_eq!(master.take(b, 8).unwrap(), [2; 8]);
        let c = worker.put(1, |x| x[0] = 3).unwrap();
        assert_eq!(c, b, "the freed slot is the free one");
        assert_eq!(master.take(a, 8).unwrap(), [1; 8]);
        assert_eq!(master.take(c, 1).unwrap(), [3]);
    }

    #[test]
    fn false_claims_are_refused() {
        let (master, worker) = pair(2, 8);
        assert!(matches!(
            master.take(2, 1),
            Err(SharedError::NoSlot { slot: 2, slots: 2 })
        ));
        assert!(matches!(master.take(0, 1), Err(SharedError::NotFull(0))));
        let s = worker.put(4, |b| b.fill(7)).unwrap();
        assert!(matches!(
            master.take(s, 9),
            Err(SharedError::TooLong {
                len: 9,
                slot_bytes: 8
            })
        ));
        // A refused claim leaves the slot as it was.
        assert_eq!(master.take(s, 4).unwrap(), [7; 4]);
    }

    #[test]
    fn threads_of_one_worker_never_share_a_slot() {
        let (master, worker) = pair(64, 4);
        let taken: Vec<u32> = std::thread::scope(|s| {
            let handles: Vec<_> = (0..4u8)
                .map(|t| {
                    let w = &worker;
                    s.spawn(move || {
                        (0..16)
                            .map(|_| w.put(4, |b| b.fill(t)).unwrap())
                            .collect::<Vec<_>>()
                    })
                })
                .collect();
            handles
                .into_iter()
                .flat_map(|h| h.join().unwrap())
                .collect()
        });
        let mut distinct = taken.clone();
        distinct.sort_unstable();
        distinct.dedup();
        assert_eq!(distinct.len(), 64);
        // Each slot holds one thread's bytes whole.
        for s in taken {
            let b = master.take(s, 4).unwrap();
            assert!(b.iter().all(|&x| x == b[0]), "{b:?}");
        }
    }

    #[test]
    fn sizes_out_of_range_are_refused() {
        for (slots, bytes) in [(0, 8), (8, 0), (MAX_SLOTS + 1, 8), (8, MAX_SLOT_BYTES + 1)] {
            assert!(matches!(
                SharedPixels::create(slots, bytes, 1),
                Err(SharedError::Size { .. })
            ));
        }
    }

    #[test]
    fn what_is_not_a_region_is_refused() {
        for text in ["", "x", "-1", "2", "987654"] {
            assert!(
                matches!(
                    SharedPixels::from_fd_text(text),
                    Err(SharedError::NotOpen(_))
                ),
                "{text:?}"
            );
        }
        // An ordinary file cannot be sealed: refused before it is mapped.
        let file = tempfile_in_memory(b"parrtpx1 and then some bytes that are not a region");
        assert!(matches!(
            SharedPixels::open(file),
            Err(SharedError::Layout("not sealed against resizing"))
        ));
    }

    /// A file with `bytes` in it, not sealed.
    fn tempfile_in_memory(bytes: &[u8]) -> OwnedFd {
        use std::io::Write;
        // SAFETY: as in `create`.
        let fd = unsafe { libc::memfd_create(c"test".as_ptr(), libc::MFD_CLOEXEC) };
        assert!(fd >= 0);
        // SAFETY: a new descriptor nothing else owns.
        let mut file = File::from(unsafe { OwnedFd::from_raw_fd(fd) });
        file.write_all(bytes).unwrap();
        OwnedFd::from(file)
    }

    #[test]
    fn a_sealed_region_with_a_false_header_is_refused() {
        let (master, fd) = SharedPixels::create(2, 8, 5).unwrap();
        // SAFETY: the test's own mapping; no other thread uses it.
        unsafe {
            (master.map.as_mut_ptr() as *mut u64)
                .add(2)
                .write(3 | (8 << 32))
        };
        assert!(matches!(
            SharedPixels::open(fd.try_clone().unwrap()),
            Err(SharedError::Layout("its size does not match its header"))
        ));
        // SAFETY: as above.
        unsafe { (master.map.as_mut_ptr() as *mut u64).write(0) };
        assert!(matches!(
            SharedPixels::open(fd),
            Err(SharedError::Layout("wrong magic"))
        ));
    }
}
