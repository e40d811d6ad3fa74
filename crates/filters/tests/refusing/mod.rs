#![allow(unsafe_code)] // implementing GlobalAlloc is unsafe by definition; this one forwards or refuses.

//! A global allocator that refuses, on the calling thread only and while [`refusing`] runs, every
//! allocation of one layout: a deterministic stand-in for the system running out of memory, to
//! check that a buffer is allocated fallibly (an infallible allocation of that layout aborts the
//! test binary; a fallible one returns its error). Every other allocation, and every allocation
//! on other test threads, goes to the system allocator unchanged.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

pub struct Refusing;

thread_local! {
    /// The (size, align) refused on this thread, `None` for none.
    static REFUSED: Cell<Option<(usize, usize)>> = const { Cell::new(None) };
}

fn refused(layout: Layout) -> bool {
    REFUSED
        .try_with(|r| r.get() == Some((layout.size(), layout.align())))
        .unwrap_or(false)
}

// SAFETY: every call is forwarded unchanged to the system allocator, except that `alloc` and
// `realloc` return null (allocation failure, which the `GlobalAlloc` contract allows) for the
// refused layout.
unsafe impl GlobalAlloc for Refusing {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if refused(layout) {
            return std::ptr::null_mut();
        }
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        // A layout of `new_size` with the same alignment is valid: the caller guarantees it.
        if refused(unsafe { Layout::from_size_align_unchecked(new_size, layout.align()) }) {
            return std::ptr::null_mut();
        }
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Refusing = Refusing;

/// `f` run with every allocation of `count` values of `T` (the layout of `Vec::<T>` holding
/// exactly `count`) refused on this thread.
pub fn refusing<T, R>(count: usize, f: impl FnOnce() -> R) -> R {
    let layout = Layout::array::<T>(count).expect("a valid layout");
    REFUSED.with(|r| r.set(Some((layout.size(), layout.align()))));
    let result = f();
    REFUSED.with(|r| r.set(None));
    result
}
