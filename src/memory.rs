//! Memory budgets: what a piece of work will allocate, estimated before it allocates, and
//! refused with the numbers when this process cannot have that much — rather than taking the
//! machine's memory until the kernel's OOM killer ends it.
//!
//! What "can have" means: the system's available memory, or less where a cgroup (a
//! container's limit, a Kubernetes pod, a Slurm job) or an address-space limit (`ulimit -v`)
//! allows less.

use anyhow::{Result, bail};

/// Worker threads accepted by `--threads`: more only cost memory (a stack and allocator
/// arenas each) and scheduling, on any machine there is.
pub const MAX_THREADS: usize = 1024;

/// `12.3 GB` for messages.
pub fn gigabytes(bytes: u64) -> String {
    format!("{:.1} GB", bytes as f64 / 1e9)
}

/// Refuses `what` if it needs more than [`available_memory`] (when that is known).
pub fn check(what: &str, needed: u64, advice: &str) -> Result<()> {
    check_within(what, needed, available_memory(), advice)
}

/// Refuses `what` if it needs more than `available` bytes (when known), saying how much it
/// needs, how much there is and `advice`.
pub fn check_within(what: &str, needed: u64, available: Option<u64>, advice: &str) -> Result<()> {
    if let Some(available) = available
        && needed > available
    {
        bail!(
            "{what} needs about {} of memory, but only {} is available; {advice}",
            gigabytes(needed),
            gigabytes(available)
        );
    }
    Ok(())
}

/// Memory this process can still use: the system's available memory, or less if a cgroup or
/// an address-space limit allows less. `None` where none of them can be read.
pub fn available_memory() -> Option<u64> {
    let system = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|text| meminfo_available(&text));
    [system, cgroup_headroom(), address_space_headroom()]
        .into_iter()
        .flatten()
        .min()
}

/// `MemAvailable` of /proc/meminfo, in bytes.
fn meminfo_available(meminfo: &str) -> Option<u64> {
    kilobytes_field(meminfo, "MemAvailable:")
}

/// A `Name:   123 kB` line of a /proc file, in bytes.
fn kilobytes_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|line| line.starts_with(name))?;
    let kilobytes: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kilobytes.saturating_mul(1024))
}

/// Limit minus working set of this process's cgroup (v2, else v1), if it has a limit. The
/// working set leaves out inactive file cache, which the kernel reclaims before it would kill
/// anything (as Kubernetes counts it): a long-running pod's usage is mostly cache.
fn cgroup_headroom() -> Option<u64> {
    let read = |path: &str| -> Option<String> { std::fs::read_to_string(path).ok() };
    let number = |path: &str| -> Option<u64> { read(path)?.trim().parse().ok() };
    let (limit, usage, inactive_file) = match number("/sys/fs/cgroup/memory.max") {
        Some(limit) => (
            limit,
            number("/sys/fs/cgroup/memory.current")?,
            read("/sys/fs/cgroup/memory.stat").and_then(|s| stat(&s, "inactive_file")),
        ),
        None => (
            number("/sys/fs/cgroup/memory/memory.limit_in_bytes")?,
            number("/sys/fs/cgroup/memory/memory.usage_in_bytes")?,
            read("/sys/fs/cgroup/memory/memory.stat").and_then(|s| stat(&s, "total_inactive_file")),
        ),
    };
    let working_set = usage.saturating_sub(inactive_file.unwrap_or(0));
    // cgroup v1 reports "no limit" as a number near i64::MAX.
    (limit < 1 << 60).then(|| limit.saturating_sub(working_set))
}

/// The value of `key` in a cgroup `memory.stat` ("key value" lines).
fn stat(text: &str, key: &str) -> Option<u64> {
    text.lines().find_map(|line| {
        let (name, value) = line.split_once(' ')?;
        (name == key).then(|| value.trim().parse().ok())?
    })
}

/// Address space left under `RLIMIT_AS` (`ulimit -v`), if one is set: the limit minus the
/// address space already mapped (`VmSize`).
#[cfg(unix)]
fn address_space_headroom() -> Option<u64> {
    let mut limit = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: `limit` is a valid, writable rlimit for the call to fill in.
    if unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut limit) } != 0
        || limit.rlim_cur == libc::RLIM_INFINITY
    {
        return None;
    }
    let mapped = std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|text| kilobytes_field(&text, "VmSize:"))
        .unwrap_or(0);
    // rlim_t is u64 on Linux but not on every Unix.
    #[allow(clippy::unnecessary_cast)]
    let limit = limit.rlim_cur as u64;
    Some(limit.saturating_sub(mapped))
}

#[cfg(not(unix))]
fn address_space_headroom() -> Option<u64> {
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn work_beyond_the_available_memory_is_refused_with_the_numbers() {
        assert!(check_within("the film", 10, None, "").is_ok());
        assert!(check_within("the film", 10, Some(10), "").is_ok());
        let message = check_within(
            "a 16384×16384 film",
            54_000_000_000,
            Some(20_000_000_000),
            "render a smaller image",
        )
        .unwrap_err()
        .to_string();
        assert_eq!(
            message,
            "a 16384×16384 film needs about 54.0 GB of memory, but only 20.0 GB is available; render a smaller image"
        );
    }

    #[test]
    fn meminfo_is_parsed() {
        let text = "MemTotal:       24000000 kB\nMemFree:  100 kB\nMemAvailable:   22000000 kB\n";
        assert_eq!(meminfo_available(text), Some(22_000_000 * 1024));
        assert_eq!(meminfo_available("MemTotal: 5 kB\n"), None);
        let status = "Name:\trealcam\nVmPeak:\t  300 kB\nVmSize:\t  200 kB\n";
        assert_eq!(kilobytes_field(status, "VmSize:"), Some(200 * 1024));
    }

    #[test]
    fn cgroup_stat_is_parsed() {
        let text = "active_file 100\ninactive_file 4096\ntotal_inactive_file 7\n";
        assert_eq!(stat(text, "inactive_file"), Some(4096));
        assert_eq!(stat(text, "total_inactive_file"), Some(7));
        assert_eq!(stat(text, "shmem"), None);
    }

    #[test]
    fn the_available_memory_is_known_here_and_plausible() {
        // Linux always has /proc/meminfo; the number must be some memory, not all of it.
        if cfg!(target_os = "linux") {
            let available = available_memory().expect("readable on Linux");
            assert!(available > 1 << 20, "{available}");
        }
    }
}
