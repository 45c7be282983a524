//! How much memory the machine (or the container) still has, for the stages' up-front checks.

/// Bytes available to this process: the smaller of `MemAvailable` (/proc/meminfo) and the
/// room left under a cgroup v2 limit. None where neither can be read (not Linux).
pub fn available_bytes() -> Option<u64> {
    let meminfo = std::fs::read_to_string("/proc/meminfo").ok().and_then(|t| {
        t.lines()
            .find(|l| l.starts_with("MemAvailable:"))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|kb| kb.parse::<u64>().ok())
            .map(|kb| kb * 1024)
    });
    let read = |p: &str| std::fs::read_to_string(p).ok();
    let cgroup = match (
        read("/sys/fs/cgroup/memory.max"),
        read("/sys/fs/cgroup/memory.current"),
    ) {
        (Some(max), Some(cur)) => match (max.trim().parse::<u64>(), cur.trim().parse::<u64>()) {
            (Ok(m), Ok(c)) => Some(m.saturating_sub(c)),
            _ => None,
        },
        _ => None,
    };
    match (meminfo, cgroup) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

/// This process's peak resident memory so far in MiB (`VmHWM`); None where unreadable.
pub fn peak_rss_mib() -> Option<f64> {
    status_mib("VmHWM:")
}

/// A figure of /proc/self/status in MiB.
fn status_mib(key: &str) -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with(key))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// The program's own allocator's release ([`set_release_hook`]).
static RELEASE_HOOK: std::sync::OnceLock<fn()> = std::sync::OnceLock::new();

/// Registers what [`release_free_memory`] calls to make the program's allocator return its free
/// pages (the `fipt` binary's mimalloc, which otherwise keeps them: see its `main.rs`). Once per
/// process; a second call is ignored.
pub fn set_release_hook(release: fn()) {
    let _ = RELEASE_HOOK.set(release);
}

/// Hands the heap's free pages back to the system (glibc's `malloc_trim`, and the hook of the
/// program's allocator when one is registered with [`set_release_hook`]), so that the resident
/// size follows the memory in use: after a stage frees its data, the next stage's peak starts
/// from what is live, and other processes get the memory back. Without a hook, memory of an
/// allocator other than glibc's stays where it is.
pub fn release_free_memory() {
    if let Some(release) = RELEASE_HOOK.get() {
        release();
    }
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        extern "C" {
            fn malloc_trim(pad: usize) -> i32;
        }
        // SAFETY: malloc_trim only walks glibc's own heap under its lock; any pad is valid.
        unsafe {
            malloc_trim(0);
        }
    }
}

/// Starts a new peak: after this, [`peak_rss_mib`] is the peak since now (Linux resets
/// `VmHWM` on writing 5 to /proc/self/clear_refs). False where it cannot.
pub fn reset_peak_rss() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// This process's resident memory now in MiB (`VmRSS`); None where unreadable.
pub fn rss_mib() -> Option<f64> {
    status_mib("VmRSS:")
}

/// Bytes in GiB, for messages.
pub fn gib(bytes: u64) -> f64 {
    bytes as f64 / (1u64 << 30) as f64
}

#[cfg(test)]
mod tests {
    #[test]
    fn available_memory_is_known_on_linux() {
        if cfg!(target_os = "linux") {
            let a = super::available_bytes().expect("readable on Linux");
            assert!(a > 1 << 20, "{a} bytes");
        }
    }

    #[test]
    fn freed_memory_goes_back_to_the_system() {
        if !cfg!(all(target_os = "linux", target_env = "gnu")) {
            return;
        }
        let rss = || {
            let s = std::fs::read_to_string("/proc/self/status").unwrap();
            let line = s
                .lines()
                .find(|l| l.starts_with("VmRSS:"))
                .unwrap()
                .to_string();
            line.split_whitespace()
                .nth(1)
                .unwrap()
                .parse::<f64>()
                .unwrap()
                / 1024.0
        };
        // Many small blocks (from the heap, not mapped one by one), freed.
        // A block allocated after them pins the heap's top, so that freeing them alone
        // returns nothing.
        let blocks: Vec<Vec<u8>> = (0..4096).map(|_| vec![1u8; 16 << 10]).collect();
        let pin = vec![1u8; 64];
        std::hint::black_box((&blocks, &pin));
        let held = rss();
        drop(blocks);
        super::release_free_memory();
        let after = rss();
        std::hint::black_box(&pin);
        assert!(
            after < held - 32.0,
            "{held:.0} MiB held, {after:.0} MiB after"
        );
    }

    #[test]
    fn the_peak_can_be_restarted() {
        if !cfg!(target_os = "linux") {
            return;
        }
        // 64 MiB touched, then freed: the peak holds it until restarted.
        let big = vec![1u8; 64 << 20];
        std::hint::black_box(&big);
        drop(big);
        let before = super::peak_rss_mib().unwrap();
        assert!(super::reset_peak_rss());
        let after = super::peak_rss_mib().unwrap();
        assert!(
            after < before - 32.0,
            "peak {before:.0} MiB, then {after:.0} MiB"
        );
    }
}

/// A hint to bring the cache line holding `*p` into every cache level ahead of its use: a
/// random lookup issued early so that other work hides its memory latency. No effect off
/// x86-64; reads nothing and never faults, whatever `p` is.
#[inline(always)]
pub fn prefetch<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint; it reads no data and raises no fault on any address.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p as *const i8)
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}
