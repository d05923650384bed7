//! The `realcam` binary's memory allocator: mimalloc instead of glibc's malloc.
//!
//! Why: the first pass of a render gives every tile its batches (some 75 arrays a tile, 400
//! tiles at 640²), each allocated on the rayon worker that first renders the tile. glibc gives
//! each worker thread an arena of its own and grows it exactly as far as each allocation needs,
//! an `mprotect` call each time (30,000 at 640²), each taking the process's memory-map lock
//! that the other threads' page faults wait on. On a 16-core machine, sixteen threads of one
//! process ran at 0.79–0.87× the summed rate of sixteen one-thread processes doing the same
//! work (which share no memory map). With mimalloc (per-thread heaps carved from large
//! reserved regions) the 16-thread frames of the peer scenes ran 0.99–1.35× the glibc binary's
//! rate in the same runs, at 0.86–0.97× the processes' rate (glibc: 0.76–0.87×), and on two
//! cores 1.03–1.18× (BENCHMARKS.md, "The allocator", 2026-11-27).
//!
//! Built without transparent huge pages (`no_thp`: mimalloc does not ask the kernel for them;
//! a system that gives them to every process still does): on a machine whose memory was
//! fragmented, asking for them stalled page faults in the kernel's compaction, up to a second
//! of system time on one scene load.
//!
//! Freed memory goes back to the system at once (see [`return_freed_memory_at_once`]): with
//! mimalloc's defaults the 1M-triangle scene's peak resident size was 555–610 MB against
//! glibc's 390–413; returned at once, it is 380 MB.
//!
//! The library itself sets no allocator: its tests and benches run on the system's, and the
//! library's allocation test installs a counting one.

/// The binary's global allocator (`#[global_allocator]` in `main.rs`).
pub type Allocator = mimalloc::MiMalloc;

/// mimalloc's `mi_option_purge_delay` (`mimalloc.h`, `mi_option_e`): milliseconds after which
/// freed memory goes back to the system; 0 at once, −1 never.
const OPTION_PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;

/// Returns memory to the system as soon as it is freed, instead of a second later (mimalloc
/// 3's default) or never. Loading a scene and building its BVH allocate arrays of tens to
/// hundreds of megabytes, grow them (a larger copy, the smaller one freed) and free them in
/// turn, all within a second: memory kept for a second is still resident when the next array
/// is allocated elsewhere, so the peak was the sum of arrays that never live together. That
/// peak is what the scene's memory guard (`scene::gltf_loader::budget`, calibrated on glibc's
/// peaks) must cover. Returned at once (BENCHMARKS.md, "Sixteen threads again, and the
/// allocator's peak", 2026-11-27, 2 threads): the 1M-triangle scene peaks at 380 MB instead of
/// 555, a 2M-triangle, 6M-vertex mesh at 950 MB instead of 1,280 (glibc: 390–413 and
/// 970–1,020), for 0.04–0.11 s more of the 1M-triangle load and BVH build and less of the 2M
/// one. A pass allocates next to nothing once
/// its tiles have their batches, so the render itself does not notice (16 threads: 0.98–1.03×
/// the pass rate with memory kept).
pub fn return_freed_memory_at_once() {
    // SAFETY: sets one of mimalloc's options, which it reads when it decides to purge; safe at
    // any time, from any thread.
    unsafe { libmimalloc_sys::mi_option_set(OPTION_PURGE_DELAY, 0) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The option's number is mimalloc's: before it is set, it reads mimalloc 3's default
    /// (1000 ms, `options.c`; its neighbours' defaults are 0 and 1), unless the environment
    /// overrides it; after, 0.
    #[test]
    fn the_purge_delay_option_is_mimallocs() {
        // SAFETY: reads an option.
        let before = unsafe { libmimalloc_sys::mi_option_get(OPTION_PURGE_DELAY) };
        if std::env::var_os("MIMALLOC_PURGE_DELAY").is_none() {
            assert_eq!(before, 1000, "mimalloc's default purge delay");
        }
        return_freed_memory_at_once();
        // SAFETY: reads an option.
        assert_eq!(
            unsafe { libmimalloc_sys::mi_option_get(OPTION_PURGE_DELAY) },
            0
        );
    }
}
