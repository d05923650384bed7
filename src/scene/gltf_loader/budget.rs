//! The memory guard: a scene too large to render is refused from its accessor counts, before
//! any buffer is read, with the numbers and what to do, rather than dying out of memory an
//! hour into loading.

use anyhow::{Result, bail};

use crate::memory::gigabytes;

/// Scenes with more (instanced) triangles than this are refused, whatever the memory.
pub const MAX_TRIANGLES: u64 = 50_000_000;
/// Vertices over all distinct primitives, likewise.
pub const MAX_VERTICES: u64 = 3 * MAX_TRIANGLES;

/// Peak memory per instanced triangle and per vertex while loading and building the BVH,
/// rounded up from measurements: 2 M triangles over 1 M vertices peak at 0.80 GB, over 6 M
/// vertices at 1.02 GB (mesh, world triangle soup, BVH build, shading attributes; glibc's
/// malloc). The `realcam` binary's allocator peaks at 0.72 and 0.95 GB on the same meshes, since
/// it returns freed memory at once (`crate::allocator`; keeping it, it peaked at 1.05 and 1.28
/// GB, over these estimates); `benches/memory_peak.py` measures both.
const BYTES_PER_TRIANGLE: u64 = 400;
const BYTES_PER_VERTEX: u64 = 48;

/// Memory a scene of `triangles` (instanced) and `vertices` (distinct) needs, in bytes.
pub(super) fn estimated_bytes(triangles: u64, vertices: u64) -> u64 {
    triangles
        .saturating_mul(BYTES_PER_TRIANGLE)
        .saturating_add(vertices.saturating_mul(BYTES_PER_VERTEX))
}

/// Refuses a scene over the fixed limits, or needing more than `available` bytes (when known).
pub(super) fn check(triangles: u64, vertices: u64, available: Option<u64>) -> Result<()> {
    if triangles > MAX_TRIANGLES || vertices > MAX_VERTICES {
        bail!(
            "the scene would have about {} M triangles ({} M vertices), more than realcam's limit of {} M triangles ({} M vertices); decimate the scene or remove instances",
            triangles / 1_000_000,
            vertices / 1_000_000,
            MAX_TRIANGLES / 1_000_000,
            MAX_VERTICES / 1_000_000
        );
    }
    let needed = estimated_bytes(triangles, vertices);
    if let Some(available) = available
        && needed > available
    {
        bail!(
            "the scene ({:.1} M triangles, {:.1} M vertices) needs about {} of memory to render, but only {} is available; decimate the scene, remove instances, or render on a machine (or with a memory limit) with more memory",
            triangles as f64 / 1e6,
            vertices as f64 / 1e6,
            gigabytes(needed),
            gigabytes(available)
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scenes_over_the_fixed_limits_are_refused() {
        let message = check(MAX_TRIANGLES + 1, 10, None).unwrap_err().to_string();
        assert!(message.contains("limit of 50 M triangles"), "{message}");
        assert!(check(10, MAX_VERTICES + 1, None).is_err());
        assert!(check(MAX_TRIANGLES, MAX_VERTICES, None).is_ok());
    }

    #[test]
    fn scenes_over_the_available_memory_are_refused_with_the_numbers() {
        let two_million = 2_000_000;
        let needed = estimated_bytes(two_million, two_million / 2);
        // The measured 0.80 GB peak for this scene lies under the estimate.
        assert!((800_000_000..1_000_000_000).contains(&needed), "{needed}");
        assert!(check(two_million, two_million / 2, Some(needed)).is_ok());
        let message = check(two_million, two_million / 2, Some(500_000_000))
            .unwrap_err()
            .to_string();
        assert!(
            message.contains("needs about 0.8 GB") && message.contains("only 0.5 GB"),
            "{message}"
        );
    }
}
