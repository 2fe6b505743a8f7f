//! Storage for the node and packet arrays of a wide BVH: large arrays are aligned to 2 MiB and,
//! on Linux, advised for transparent huge pages before they are first written.
//!
//! Incoherent rays touch the tree's memory at random; with 4 KiB pages a tree of tens of MiB
//! spans thousands of pages, more than the CPU's TLBs hold, so traversal pays a page walk on
//! many node and packet loads. With 2 MiB pages a few dozen entries cover it. The kernel
//! grants huge pages only to 2 MiB-aligned ranges, and on systems whose transparent huge page
//! policy is `madvise` (a common default) only to ranges advised with `MADV_HUGEPAGE` — Embree's
//! allocator does the same for its BVH. Where the advice is refused (another OS, THP
//! disabled), the memory is ordinary memory: only speed depends on it, never results.

use std::alloc::{self, Layout};
use std::fmt;
use std::ops::Deref;
use std::ptr::NonNull;

/// Arrays at least this large are aligned to [`HUGE_PAGE`] and advised (smaller ones would
/// waste most of a huge page). Under Miri 4 KiB, so that the small trees Miri can afford take
/// the aligned path (`advise_huge_pages` is skipped there: Miri cannot call `madvise`).
const HUGE_THRESHOLD: usize = if cfg!(miri) { 4 << 10 } else { 1 << 20 };

/// The huge page size of x86-64 and of most aarch64 Linux kernels.
const HUGE_PAGE: usize = 2 << 20;

/// A fixed-length array of `Copy` values, allocated once from a slice (see the
/// [module documentation](self)). It dereferences to a slice.
pub(crate) struct HugeSlice<T: Copy> {
    ptr: NonNull<T>,
    len: usize,
    /// The allocation's layout (size 0: nothing allocated).
    layout: Layout,
}

// SAFETY: `HugeSlice<T>` owns its elements like a `Box<[T]>`.
unsafe impl<T: Copy + Send> Send for HugeSlice<T> {}
// SAFETY: shared access only hands out `&[T]`.
unsafe impl<T: Copy + Sync> Sync for HugeSlice<T> {}

impl<T: Copy> HugeSlice<T> {
    /// An empty array.
    pub(crate) fn empty() -> Self {
        Self {
            ptr: NonNull::dangling(),
            len: 0,
            layout: Layout::new::<()>(),
        }
    }

    /// A copy of `items`.
    ///
    /// # Panics
    /// If the allocation fails (as `Vec` does) or its size overflows.
    pub(crate) fn from_slice(items: &[T]) -> Self {
        // SAFETY: the closure initialises all `items.len()` elements.
        unsafe {
            Self::from_init(items.len(), |out| {
                // SAFETY: `out` holds `items.len()` values of `T`, does not overlap `items`,
                // and `T: Copy`.
                std::ptr::copy_nonoverlapping(items.as_ptr(), out.as_mut_ptr().cast(), items.len())
            })
        }
    }

    /// An array of `len` values written by `init` straight into the final (huge-page advised)
    /// memory, with no intermediate copy: the wide collapse writes its blocks there in
    /// parallel. `init` runs exactly once, also when `len` is 0.
    ///
    /// # Safety
    /// `init` must initialise every element of the slice it is given.
    ///
    /// # Panics
    /// If the allocation fails or its size overflows; a panic of `init` leaks the memory.
    pub(crate) unsafe fn from_init(
        len: usize,
        init: impl FnOnce(&mut [std::mem::MaybeUninit<T>]),
    ) -> Self {
        assert!(
            std::mem::size_of::<T>() > 0,
            "no arrays of zero-sized values"
        );
        let bytes = len
            .checked_mul(std::mem::size_of::<T>())
            .expect("array too large");
        if bytes == 0 {
            // `init` still runs (on no elements): callers may nest their writing in it.
            init(&mut []);
            return Self::empty();
        }
        let huge = bytes >= HUGE_THRESHOLD;
        let (size, align) = if huge {
            (bytes.next_multiple_of(HUGE_PAGE), HUGE_PAGE)
        } else {
            (bytes, std::mem::align_of::<T>())
        };
        let layout = Layout::from_size_align(size, align.max(std::mem::align_of::<T>()))
            .expect("array too large");
        // SAFETY: `layout` has a non-zero size.
        let raw = unsafe { alloc::alloc(layout) };
        let Some(ptr) = NonNull::new(raw.cast::<T>()) else {
            alloc::handle_alloc_error(layout)
        };
        if huge {
            advise_huge_pages(raw, size);
        }
        // SAFETY: the allocation holds `len` values of `T` (size and alignment above), not
        // yet initialised, which `MaybeUninit` allows.
        init(unsafe {
            std::slice::from_raw_parts_mut(ptr.as_ptr().cast::<std::mem::MaybeUninit<T>>(), len)
        });
        // Every element is initialised now (the caller's contract).
        Self { ptr, len, layout }
    }

    /// True when the array lies in memory aligned to a huge page (arrays of at least 1 MiB).
    #[cfg(test)]
    pub(crate) fn is_huge_aligned(&self) -> bool {
        self.layout.align() == HUGE_PAGE
    }
}

/// Asks the kernel to back `[ptr, ptr + len)` with transparent huge pages when it is first
/// touched. Best effort: an error (no THP support, another policy) is ignored.
#[cfg(all(target_os = "linux", not(miri)))]
fn advise_huge_pages(ptr: *mut u8, len: usize) {
    // SAFETY: the range is one live allocation of ours; `madvise` with `MADV_HUGEPAGE` only
    // changes how the kernel backs it, not its contents or validity.
    unsafe {
        libc::madvise(ptr.cast(), len, libc::MADV_HUGEPAGE);
    }
}

/// No advice off Linux, nor under Miri, which cannot call `madvise` (the call only changes how
/// the kernel backs the pages; `tests::small_large_and_empty_arrays_round_trip` runs it
/// outside Miri).
#[cfg(any(not(target_os = "linux"), miri))]
fn advise_huge_pages(_: *mut u8, _: usize) {}

impl<T: Copy> Drop for HugeSlice<T> {
    fn drop(&mut self) {
        if self.layout.size() != 0 {
            // SAFETY: allocated in `from_slice` with this layout.
            unsafe { alloc::dealloc(self.ptr.as_ptr().cast(), self.layout) };
        }
    }
}

impl<T: Copy> Deref for HugeSlice<T> {
    type Target = [T];

    #[inline(always)]
    fn deref(&self) -> &[T] {
        // SAFETY: `ptr` holds `len` initialised values (or is dangling with `len == 0`).
        unsafe { std::slice::from_raw_parts(self.ptr.as_ptr(), self.len) }
    }
}

impl<T: Copy> std::ops::DerefMut for HugeSlice<T> {
    /// Mutable access (refitting rewrites bounds and packets in place).
    #[inline(always)]
    fn deref_mut(&mut self) -> &mut [T] {
        // SAFETY: as in `deref`; `&mut self` is the only access to the elements.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.as_ptr(), self.len) }
    }
}

impl<'a, T: Copy> IntoIterator for &'a HugeSlice<T> {
    type Item = &'a T;
    type IntoIter = std::slice::Iter<'a, T>;

    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl<T: Copy> Clone for HugeSlice<T> {
    fn clone(&self) -> Self {
        Self::from_slice(self)
    }
}

impl<T: Copy + fmt::Debug> fmt::Debug for HugeSlice<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(&**self, f)
    }
}

impl<T: Copy> From<Vec<T>> for HugeSlice<T> {
    fn from(v: Vec<T>) -> Self {
        Self::from_slice(&v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_large_and_empty_arrays_round_trip() {
        let e = HugeSlice::<u64>::from_slice(&[]);
        assert!(e.is_empty() && !e.is_huge_aligned());
        let small: Vec<u32> = (0..1000).collect();
        let s = HugeSlice::from_slice(&small);
        assert_eq!(&*s, &small[..]);
        assert!(!s.is_huge_aligned());
        let large: Vec<[f32; 4]> = (0..100_000).map(|i| [i as f32; 4]).collect();
        let l = HugeSlice::from(large.clone());
        assert_eq!(&*l, &large[..]);
        assert!(l.is_huge_aligned());
        assert_eq!(l.as_ptr() as usize % HUGE_PAGE, 0);
        let c = l.clone();
        drop(l);
        assert_eq!(&*c, &large[..]);
    }
}
