//! A counting global allocator: how many bytes are live, and the most that were live since a
//! case began. A binary that fuzzes declares it as its `#[global_allocator]`; the oracle reads
//! the peak after each case. The counters are process-wide, so cases run one at a time per
//! process (the fuzz example runs several processes for `--jobs`).

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Bytes allocated and not yet freed.
static LIVE: AtomicUsize = AtomicUsize::new(0);
/// The largest `LIVE` seen since the last [`begin_case`].
static PEAK: AtomicUsize = AtomicUsize::new(0);
/// Allocations that would take `LIVE` beyond this fail (a safety net for the machine, far
/// above any case's bound; the case is then reported over its bound).
static HARD_CAP: AtomicUsize = AtomicUsize::new(usize::MAX);
/// Set when an allocation was refused at the hard cap.
static REFUSED: AtomicBool = AtomicBool::new(false);

/// The system allocator, counting.
pub struct CountingAllocator;

fn reserve(bytes: usize) -> bool {
    let live = LIVE
        .fetch_add(bytes, Ordering::Relaxed)
        .saturating_add(bytes);
    if live > HARD_CAP.load(Ordering::Relaxed) {
        LIVE.fetch_sub(bytes, Ordering::Relaxed);
        REFUSED.store(true, Ordering::Relaxed);
        return false;
    }
    PEAK.fetch_max(live, Ordering::Relaxed);
    true
}

fn release(bytes: usize) {
    LIVE.fetch_sub(bytes, Ordering::Relaxed);
}

// SAFETY: every call is forwarded to `System` with the same layout; the counters only watch.
unsafe impl GlobalAlloc for CountingAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if !reserve(layout.size()) {
            return std::ptr::null_mut();
        }
        // SAFETY: the caller's layout contract is passed on unchanged.
        let pointer = unsafe { System.alloc(layout) };
        if pointer.is_null() {
            release(layout.size());
        }
        pointer
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if !reserve(layout.size()) {
            return std::ptr::null_mut();
        }
        // SAFETY: as for `alloc`.
        let pointer = unsafe { System.alloc_zeroed(layout) };
        if pointer.is_null() {
            release(layout.size());
        }
        pointer
    }

    unsafe fn dealloc(&self, pointer: *mut u8, layout: Layout) {
        // SAFETY: `pointer` came from this allocator (so from `System`) with `layout`.
        unsafe { System.dealloc(pointer, layout) };
        release(layout.size());
    }

    unsafe fn realloc(&self, pointer: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let old_size = layout.size();
        if new_size > old_size && !reserve(new_size - old_size) {
            return std::ptr::null_mut();
        }
        // SAFETY: as for `dealloc`; `new_size` is the caller's.
        let moved = unsafe { System.realloc(pointer, layout, new_size) };
        if moved.is_null() {
            if new_size > old_size {
                release(new_size - old_size);
            }
        } else if new_size < old_size {
            release(old_size - new_size);
        }
        moved
    }
}

/// Starts measuring a case: returns the bytes live now (the baseline) and resets the peak.
pub fn begin_case() -> usize {
    REFUSED.store(false, Ordering::Relaxed);
    let live = LIVE.load(Ordering::Relaxed);
    PEAK.store(live, Ordering::Relaxed);
    live
}

/// The most bytes live since [`begin_case`] returned `baseline`, beyond it; `usize::MAX` when
/// an allocation was refused at the hard cap.
pub fn peak_since(baseline: usize) -> usize {
    if REFUSED.load(Ordering::Relaxed) {
        return usize::MAX;
    }
    PEAK.load(Ordering::Relaxed).saturating_sub(baseline)
}

/// Bytes live now.
pub fn live() -> usize {
    LIVE.load(Ordering::Relaxed)
}

/// Refuses allocations beyond `bytes` live in total (the process then aborts, unless the
/// allocation was fallible): keeps a runaway case from taking the machine's memory.
pub fn set_hard_cap(bytes: usize) {
    HARD_CAP.store(bytes, Ordering::Relaxed);
}
