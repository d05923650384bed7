//! The `realcam` binary's memory allocator: mimalloc instead of glibc's malloc.
//!
//! Why: the first pass of a render gives every tile its batches (some 75 arrays a tile, 400
//! tiles at 640²), each allocated on the rayon worker that first renders the tile. glibc gives
//! each worker thread an arena of its own and grows it exactly as far as each allocation needs,
//! an `mprotect` call each time (30,000 at 640²), each taking the process's memory-map lock
//! that the other threads' page faults wait on. On a 16-core machine, sixteen threads of one
//! process ran at 0.79–0.87× the summed rate of sixteen one-thread processes doing the same
//! work (which share no memory map). With mimalloc (per-thread heaps carved from large reserved regions) the 16-thread
//! frames of the peer scenes ran 0.99–1.35× the glibc binary's rate in the same runs, at
//! 0.86–0.97× the processes' rate (glibc: 0.76–0.87×), and on two cores 1.03–1.18×
//! (BENCHMARKS.md, "The allocator", 2026-11-27).
//!
//! Built without transparent huge pages (`no_thp`: mimalloc does not ask the kernel for them;
//! a system that gives them to every process still does): on a machine whose memory was
//! fragmented, asking for them stalled page faults in the kernel's compaction, up to a second
//! of system time on one scene load.
//!
//! The cost is memory: the 1M-triangle scene's peak resident size went from 413 to 610 MB
//! (mimalloc keeps the BVH build's freed arrays in its heaps for the allocations after them).
//!
//! The library itself sets no allocator: its tests and benches run on the system's, and the
//! library's allocation test installs a counting one.

/// The binary's global allocator (`#[global_allocator]` in `main.rs`).
pub type Allocator = mimalloc::MiMalloc;

/// mimalloc's `mi_option_purge_delay` (`mimalloc.h`, `mi_option_e`): milliseconds after which
/// freed memory goes back to the system; −1 never.
const OPTION_PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;

/// Keeps freed memory in the process instead of returning it to the system a second after it
/// is freed (mimalloc 3's default): the BVH build frees and allocates arrays of tens of
/// megabytes in turn, and memory returned comes back as fresh page faults. Freed memory is
/// still reused by the process's next allocations; the peak resident size was the same either
/// way (610 MB on the 1M-triangle scene). With it, that scene's load + BVH took 0.71–0.75 s on
/// two cores against glibc's 0.77–0.86 (five rounds, interleaved).
pub fn keep_freed_memory() {
    // SAFETY: sets one of mimalloc's options, which it reads when it decides to purge; safe at
    // any time, from any thread.
    unsafe { libmimalloc_sys::mi_option_set(OPTION_PURGE_DELAY, -1) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The option's number is mimalloc's: before it is set, it reads mimalloc 3's default
    /// (1000 ms, `options.c`; its neighbours' defaults are 0 and 1), unless the environment
    /// overrides it; after, −1.
    #[test]
    fn the_purge_delay_option_is_mimallocs() {
        // SAFETY: reads an option.
        let before = unsafe { libmimalloc_sys::mi_option_get(OPTION_PURGE_DELAY) };
        if std::env::var_os("MIMALLOC_PURGE_DELAY").is_none() {
            assert_eq!(before, 1000, "mimalloc's default purge delay");
        }
        keep_freed_memory();
        // SAFETY: reads an option.
        assert_eq!(
            unsafe { libmimalloc_sys::mi_option_get(OPTION_PURGE_DELAY) },
            -1
        );
    }
}
