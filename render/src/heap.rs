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

/// Takes the items of `v` from the last to the first into `f` (with the index each had),
/// handing the memory of those taken back to the system every 1/32 of the way (every 4096
/// items at least), so that `v` and what is built from it are never both whole at once.
/// Stops at `f`'s first error.
pub fn drain_back<T, E>(
    mut v: Vec<T>,
    mut f: impl FnMut(usize, T) -> Result<(), E>,
) -> Result<(), E> {
    let step = (v.len() / 32).max(4096);
    let mut next = v.len().saturating_sub(step);
    while let Some(x) = v.pop() {
        f(v.len(), x)?;
        if v.len() == next {
            v.shrink_to_fit();
            give_back_free_pages();
            next = next.saturating_sub(step);
        }
    }
    drop(v);
    give_back_free_pages();
    Ok(())
}
