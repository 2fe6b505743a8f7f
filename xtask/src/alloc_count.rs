//! A counting global allocator: the exact number of heap bytes live now and the most live
//! since the last [`reset_peak`], for the build-memory figures of `cargo xtask bvh` and
//! `cargo xtask build-bench`; and the running peak it counts with ([`RunningPeak`]), which
//! also sums the byte deltas of Embree's memory monitor (`engine/embree.rs`).
//!
//! Every allocation goes to the system allocator; the wrapper only adds relaxed atomic
//! updates per call (a `fetch_add`, and a `fetch_max` when the heap grew), which no figure of
//! the xtask notices; it is always on, timed builds included.
//! The counts are process-wide: a measurement is only exact while nothing else allocates
//! (the xtask measures one build at a time, after loading the scene).

use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicI64, Ordering};

/// A running sum of signed byte deltas (allocations positive, frees negative) and the largest
/// value the sum reached since the last [`RunningPeak::reset_peak`]. Lock-free (two relaxed
/// atomics), so it may be fed from any number of threads at once; under concurrent updates
/// the peak is the largest sum of some order of the deltas.
pub struct RunningPeak {
    live: AtomicI64,
    peak: AtomicI64,
}

impl RunningPeak {
    /// Sum and peak zero.
    pub const fn new() -> Self {
        Self {
            live: AtomicI64::new(0),
            peak: AtomicI64::new(0),
        }
    }

    /// Adds `delta` bytes to the sum and raises the peak to the new sum if it is higher.
    #[inline]
    pub fn record(&self, delta: i64) {
        let now = self.live.fetch_add(delta, Ordering::Relaxed) + delta;
        if delta > 0 {
            self.peak.fetch_max(now, Ordering::Relaxed);
        }
    }

    /// The sum now.
    pub fn live(&self) -> i64 {
        self.live.load(Ordering::Relaxed)
    }

    /// The largest sum since the last [`RunningPeak::reset_peak`] (or since zero).
    pub fn peak(&self) -> i64 {
        self.peak.load(Ordering::Relaxed)
    }

    /// Starts a new peak measurement: the peak becomes the sum now. Returns that.
    pub fn reset_peak(&self) -> i64 {
        let now = self.live();
        self.peak.store(now, Ordering::Relaxed);
        now
    }
}

/// The system allocator with live-byte and peak-byte counters.
pub struct Counting;

/// The heap's bytes, as the allocator counts them.
static HEAP: RunningPeak = RunningPeak::new();

#[inline]
fn grew(bytes: usize) {
    HEAP.record(bytes as i64);
}

#[inline]
fn shrank(bytes: usize) {
    HEAP.record(-(bytes as i64));
}

// SAFETY: every call is forwarded to `System` with the caller's arguments; the counters do
// not touch the memory.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded contract.
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        // SAFETY: forwarded contract.
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            grew(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded contract.
        unsafe { System.dealloc(ptr, layout) };
        shrank(layout.size());
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // SAFETY: forwarded contract.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            if new_size >= layout.size() {
                grew(new_size - layout.size());
            } else {
                shrank(layout.size() - new_size);
            }
        }
        p
    }
}

/// Heap bytes live now.
pub fn live() -> usize {
    HEAP.live().max(0) as usize
}

/// Starts a new peak measurement: the peak becomes what is live now. Returns that.
pub fn reset_peak() -> usize {
    HEAP.reset_peak().max(0) as usize
}

/// The most heap bytes live at once since the last [`reset_peak`].
pub fn peak() -> usize {
    HEAP.peak().max(0) as usize
}

/// Held by the tests that measure the heap's peak, so that none of them frees a large block
/// while another measures (a free lowers the live bytes under the other's starting point).
#[cfg(test)]
pub static MEASURING: std::sync::Mutex<()> = std::sync::Mutex::new(());

#[cfg(test)]
mod tests {
    use super::RunningPeak;

    #[test]
    fn the_running_peak_of_a_sequence_of_deltas() {
        let m = RunningPeak::new();
        for d in [100, 50, -120, 60, -90] {
            m.record(d);
        }
        // Sums 100, 150, 30, 90, 0.
        assert_eq!((m.live(), m.peak()), (0, 150));
        // A new measurement starts from the sum now; a dip below it does not lower the peak.
        m.record(40);
        assert_eq!(m.reset_peak(), 40);
        m.record(-40);
        m.record(25);
        assert_eq!((m.live(), m.peak()), (25, 40));
        m.record(30);
        assert_eq!((m.live(), m.peak()), (55, 55));
        // Frees of memory allocated before the counting began take the sum below zero.
        let m = RunningPeak::new();
        m.record(-10);
        m.record(5);
        assert_eq!((m.live(), m.peak()), (-5, 0));
    }

    #[test]
    fn the_peak_holds_a_freed_allocation() {
        // 256 MiB, zeroed (lazily mapped, so cheap): far above anything else the test process
        // holds, so the assertions hold whatever other test threads allocate meanwhile.
        const BIG: usize = 1 << 28;
        let _only = super::MEASURING.lock().unwrap_or_else(|e| e.into_inner());
        super::reset_peak();
        let v = vec![0u8; BIG];
        assert!(super::live() >= BIG);
        drop(v);
        assert!(super::peak() >= BIG);
        assert!(super::live() < BIG);
    }
}
