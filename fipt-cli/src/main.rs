//! `fipt`: recover materials and emitters of indoor scenes by factorized inverse path tracing.
//!
//! The binary: the allocator settings, then `fipt_cli::main_with` with the built-in components.

/// candle allocates a fresh tensor per op; mimalloc made training steps 1.7–2× faster than
/// glibc malloc on this 2-core machine (page faults dominated).
#[global_allocator]
static ALLOC: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// `mi_option_purge_delay` in mimalloc.h (v2 and v3; libmimalloc-sys names no constant for
/// it): how long freed memory is kept before it is returned to the OS (default 1000 ms in
/// the bundled mimalloc v3, 10 ms in v2).
const MI_OPTION_PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;

/// Never return freed memory to the OS. A training step (~80 ms) frees and re-allocates
/// the same large tensors; with the default delay it still paid for page faults and the
/// kernel's zeroing of fresh pages (35,871 faults vs 1,106 and 17 % less CPU time in
/// `fipt bench --suite train --quick`). Peak memory is unchanged: it is the same buffers.
///
/// The delay is a billion ms (11 days), not −1 ("never"): freed pages are then scheduled for a
/// purge that never comes due by itself, and the release between stages forces it.
fn keep_freed_memory() {
    // SAFETY: sets a documented mimalloc option; any value is valid for it.
    unsafe { libmimalloc_sys::mi_option_set(MI_OPTION_PURGE_DELAY, KEEP_MS) }
}

/// [`keep_freed_memory`]'s purge delay.
const KEEP_MS: std::ffi::c_long = 1_000_000_000;

/// Between stages (`fipt_core::memory::release_free_memory`): forces the purges
/// [`keep_freed_memory`] put off, returning mimalloc's free pages to the OS. The next stage's
/// peak then starts from what is live, not from the largest stage before it.
fn release_freed_memory() {
    // SAFETY: a documented mimalloc call; it only frees what the heaps no longer use.
    unsafe { libmimalloc_sys::mi_collect(true) }
}

fn main() {
    keep_freed_memory();
    fipt_core::memory::set_release_hook(release_freed_memory);
    // Rust ignores SIGPIPE, so printing into a closed pipe (`fipt info | head -1`) panicked
    // with exit 101; the default action ends the process quietly, as other tools do.
    // SAFETY: sets a signal disposition to its default before any thread is started.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    std::process::exit(fipt_cli::main_with(fipt_cli::components()));
}

#[cfg(test)]
mod tests {
    /// The option index names `purge_delay`: it reads its default (1000 ms in v3, 10 in v2)
    /// or the value `main` sets.
    #[test]
    fn purge_delay_option_index_is_right() {
        // SAFETY: reads a mimalloc option.
        let v = unsafe { libmimalloc_sys::mi_option_get(super::MI_OPTION_PURGE_DELAY) };
        assert!(
            v == 1000 || v == 10 || v == super::KEEP_MS,
            "option 15 reads {v}: not purge_delay?"
        );
    }

    /// With freed memory kept (as `main` sets it), memory freed by a stage stays resident
    /// until the release between stages returns it.
    #[test]
    fn the_release_between_stages_returns_what_mimalloc_kept() {
        let rss = || fipt_core::memory::rss_mib().expect("Linux /proc");
        super::keep_freed_memory();
        let blocks: Vec<Vec<u8>> = (0..64).map(|_| vec![1u8; 4 << 20]).collect();
        std::hint::black_box(&blocks);
        let held = rss();
        drop(blocks);
        let kept = rss();
        super::release_freed_memory();
        let after = rss();
        assert!(kept > held - 64.0, "{held:.0} MiB held, {kept:.0} kept");
        assert!(after < kept - 128.0, "{kept:.0} MiB kept, {after:.0} after");
        // SAFETY: reads a mimalloc option.
        let v = unsafe { libmimalloc_sys::mi_option_get(super::MI_OPTION_PURGE_DELAY) };
        assert_eq!(v, super::KEEP_MS);
    }
}
