//! Hints to the memory system that data will be read soon, for gathers whose indices are known
//! ahead (the wavefront knows every path's hit before it shades any). A hint never changes a
//! result: a prefetch reads nothing the program sees and never faults.

/// Asks for the cache line holding `value`.
#[inline(always)]
pub(crate) fn prefetch<T>(value: &T) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        // SAFETY: SSE is part of x86_64, and a prefetch reads nothing the program sees (it
        // never faults); the address is a live reference's anyway.
        unsafe { _mm_prefetch::<_MM_HINT_T0>((value as *const T).cast()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = value;
}

/// Asks for `values[i]`, if there is one.
#[inline(always)]
pub(crate) fn prefetch_at<T>(values: &[T], i: usize) {
    if let Some(value) = values.get(i) {
        prefetch(value);
    }
}
