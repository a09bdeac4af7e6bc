//! A vertex count is checked against the bytes left before anything is allocated: a tiny file
//! claiming four billion vertices fails without asking the allocator for a large block. The
//! NFF test binary records allocations with its own global allocator, per thread, so the other
//! tests running beside this one do not count.

use parrt_render::nff::{self, Limits};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

/// The system allocator, recording the largest single request made by each thread.
struct Recording;

thread_local! {
    /// The largest request this thread made since it last reset the value. A `const`
    /// initialiser and no destructor: reading it never allocates, so the allocator may use it.
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

/// Raises this thread's largest request to `size` (ignored while the thread is torn down).
fn record(size: usize) {
    let _ = LARGEST.try_with(|l| l.set(l.get().max(size)));
}

// SAFETY: forwards every call unchanged to `System`, which upholds the `GlobalAlloc` contract;
// the only addition is a thread-local maximum, which never allocates.
unsafe impl GlobalAlloc for Recording {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        record(layout.size());
        // SAFETY: same layout, same contract as the caller's.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `System.alloc` with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        record(new_size);
        // SAFETY: forwarded unchanged.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Recording = Recording;

#[test]
fn huge_counts_in_tiny_files_fail_before_allocating() {
    let limits = Limits {
        max_vertices: u32::MAX,
        ..Limits::default()
    };
    let view =
        "v from 0 0 5 at 0 0 0 up 0 1 0 angle 45 hither 0 resolution 8 8\nf 1 1 1 1 0 0 0 0\n";
    for body in ["p 4000000000\n0 0 0\n", "pp 4294967295\n0 0 0 0 0 1\n"] {
        let src = format!("{view}{body}");
        LARGEST.with(|l| l.set(0));
        let e = nff::parse(&src, "tiny.nff", &limits).unwrap_err();
        let largest = LARGEST.with(Cell::get);
        assert_eq!(
            (e.line, e.column),
            (3, body.find(' ').unwrap() as u32 + 2),
            "{e}"
        );
        assert!(e.message.contains("count disagrees"), "{e}");
        assert!(
            largest < 4096,
            "largest allocation while parsing {body:?}: {largest} bytes"
        );
    }
}
