//! Handing freed heap memory back to the operating system. glibc keeps the pages of freed small
//! blocks (a description's per-polygon vertex vectors) as part of the process, so without this
//! the memory of a freed description would still count in the peak when the BVH is built.

/// Returns the free pages of the C heap to the system (`malloc_trim(0)` on glibc; nothing
/// elsewhere). Takes a few milliseconds for a heap of hundreds of megabytes.
pub fn give_back_free_pages() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: malloc_trim only walks the allocator's own free lists; it has no preconditions.
    unsafe {
        libc::malloc_trim(0);
    }
}
