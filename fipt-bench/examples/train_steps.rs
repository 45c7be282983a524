//! Training steps alone, for a profiler: `train_steps [preset] [batch] [steps]`
//! (default `balanced 65536 40`), in the global pool (`RAYON_NUM_THREADS` sets its size).

/// The `fipt` binary's allocator and setting (freed memory kept: see fipt-cli's main.rs).
#[global_allocator]
static ALLOC: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() {
    // SAFETY: sets a documented mimalloc option (15: purge delay; -1: never return memory).
    unsafe { libmimalloc_sys::mi_option_set(15, -1) }
    let args: Vec<String> = std::env::args().skip(1).collect();
    let preset = args.first().map_or("balanced", |s| s.as_str());
    let batch = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(65_536);
    let steps = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(40);
    match fipt_bench::profile_steps(preset, batch, steps) {
        Ok((ms, split)) => println!(
            "{preset} batch {batch}, {} threads: median step {ms:.2} ms; mean split {split}",
            rayon::current_num_threads()
        ),
        Err(e) => {
            eprintln!("error: {e}");
            std::process::exit(1);
        }
    }
}
