//! Large allocations on 2 MiB pages where the system allows it (Linux's transparent huge
//! pages in `madvise` mode). A wide BVH of a few hundred thousand triangles spans tens of
//! megabytes, the island's two levels over a hundred, and a ray's walk touches a node here
//! and a triangle block there: with 4 KiB pages nearly every step needs a page-table walk
//! as well as its cache line, as the TLB holds a few thousand pages. On 2 MiB pages the
//! same TLB covers gigabytes. The pages also fault in 512 times fewer: a build that fills
//! its arrays once pays the kernel that much less.
//!
//! The allocator is the system's, with one `madvise` call on each allocation of at least
//! `LARGE` bytes; elsewhere (another OS, huge pages off) the advice is a no-op.

use std::alloc::{GlobalAlloc, Layout, System};

/// The system allocator, with large allocations advised onto huge pages.
pub struct HugePages;

/// Allocations of this size and more are advised: a few huge pages at least, so the
/// part of the allocation on its own 2 MiB pages is most of it.
pub const LARGE: usize = 4 << 20;

// SAFETY: every call is the system allocator's with the same arguments; the advice changes
// how the kernel backs the pages, not their contents or ownership.
unsafe impl GlobalAlloc for HugePages {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: the caller keeps `GlobalAlloc::alloc`'s contract, which we pass on.
        let p = unsafe { System.alloc(layout) };
        advise(p, layout.size());
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: as above.
        let p = unsafe { System.alloc_zeroed(layout) };
        advise(p, layout.size());
        p
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: as above.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        advise(p, new_size);
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: as above.
        unsafe { System.dealloc(ptr, layout) }
    }
}

/// Advises the whole pages of `len` bytes at `p` onto huge pages; whether the kernel took
/// the advice (false for a small or null allocation, or where it is not supported).
pub fn advise(p: *mut u8, len: usize) -> bool {
    if p.is_null() || len < LARGE {
        return false;
    }
    advise_pages(p, len)
}

#[cfg(target_os = "linux")]
fn advise_pages(p: *mut u8, len: usize) -> bool {
    const PAGE: usize = 4096;
    let start = (p as usize).next_multiple_of(PAGE);
    let end = (p as usize + len) / PAGE * PAGE;
    // SAFETY: the range lies within one live allocation of ours, whole pages only; the
    // advice does not change what the memory holds.
    end > start
        && unsafe {
            libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE) == 0
        }
}

#[cfg(not(target_os = "linux"))]
fn advise_pages(_: *mut u8, _: usize) -> bool {
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_and_null_allocations_are_not_advised() {
        let mut small = vec![0u8; LARGE - 1];
        assert!(!advise(small.as_mut_ptr(), small.len()));
        assert!(!advise(std::ptr::null_mut(), LARGE * 2));
    }

    /// Where the kernel offers huge pages on advice, a large allocation takes it.
    #[test]
    fn large_allocations_are_advised_where_the_kernel_allows() {
        let mode = std::fs::read_to_string("/sys/kernel/mm/transparent_hugepage/enabled");
        let mut large = vec![1u8; 4 * LARGE];
        let advised = advise(large.as_mut_ptr(), large.len());
        match mode {
            Ok(mode) if cfg!(target_os = "linux") && !mode.contains("[never]") => {
                assert!(advised, "THP mode {mode:?}")
            }
            _ => {}
        }
    }

    /// The allocator keeps what the system allocator keeps: contents through growth and
    /// shrinking, zeroed memory zeroed.
    #[test]
    fn the_allocator_keeps_contents_across_reallocation() {
        let a = HugePages;
        let layout = Layout::from_size_align(LARGE, 64).unwrap();
        // SAFETY: the layouts are non-zero and each pointer is freed once, with its layout.
        unsafe {
            let p = a.alloc_zeroed(layout);
            assert!(!p.is_null());
            assert!(std::slice::from_raw_parts(p, LARGE).iter().all(|&b| b == 0));
            for k in 0..LARGE {
                *p.add(k) = (k % 251) as u8;
            }
            let q = a.realloc(p, layout, 3 * LARGE);
            assert!(!q.is_null());
            assert!((0..LARGE).all(|k| *q.add(k) == (k % 251) as u8));
            let grown = Layout::from_size_align(3 * LARGE, 64).unwrap();
            let r = a.realloc(q, grown, 100);
            assert!((0..100).all(|k| *r.add(k) == (k % 251) as u8));
            a.dealloc(r, Layout::from_size_align(100, 64).unwrap());
            let s = a.alloc(Layout::from_size_align(16, 8).unwrap());
            assert!(!s.is_null());
            a.dealloc(s, Layout::from_size_align(16, 8).unwrap());
        }
    }
}
