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
fn keep_freed_memory() {
    // SAFETY: sets a documented mimalloc option; any value is valid for it.
    unsafe { libmimalloc_sys::mi_option_set(MI_OPTION_PURGE_DELAY, -1) }
}

fn main() {
    keep_freed_memory();
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
            v == 1000 || v == 10 || v == -1,
            "option 15 reads {v}: not purge_delay?"
        );
    }
}
