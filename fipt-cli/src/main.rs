//! `fipt`: recover materials and emitters of indoor scenes by factorized inverse path tracing.
//!
//! A thin composition of the library crates; every subcommand lives in its own module.
mod bake;
mod bench;
mod bench_bake;
mod bench_train;
mod config;
mod demo;
mod eval;
mod info;
mod progress;
mod refine;
mod regions;
mod render;
mod run;
mod scene;
mod search;
mod synth;
mod table;
mod train;

use clap::{Parser, Subcommand};

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

#[derive(Parser)]
#[command(
    name = "fipt",
    version,
    about = "Factorized inverse path tracing: materials and emitters of indoor scenes from posed HDR views"
)]
struct Cli {
    /// Worker threads (default: all cores).
    #[arg(long, global = true)]
    threads: Option<usize>,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Summarise and validate a scene folder (views, mesh, HDR range, ground truth, warnings).
    Info(info::Args),
    /// Generate a procedural scene with exact ground truth in the reference layout.
    Synth(synth::Args),
    /// Bake the diffuse and specular shadings of the training views (the first FIPT stage).
    Bake(bake::Args),
    /// The whole pipeline: bake → train → emitters → maps → report (→ eval with ground truth).
    Run(run::Args),
    /// Evaluate the maps of a run against the scene's ground truth (method §6).
    Eval(eval::Args),
    /// Generate the `room` scene, run the pipeline on it and evaluate it.
    Demo(demo::Args),
    /// Fit the material field and emission mask to the baked shadings (the second FIPT stage).
    Train(train::Args),
    /// Path-trace views of a mesh with given materials and cameras (the forward renderer alone).
    Render(render::Args),
    /// The material search's cost curves per region over roughness and metallic (a diagnostic of
    /// the shadings; with ground truth, also at the true base colour).
    Profile(search::Args),
    /// The accuracy table (Markdown) of finished runs: kd, σ, metallic, IoU, re-render, wall time.
    Table(table::Args),
    /// Measure BVH build, ray throughput and path-tracing speed; writes JSON.
    Bench(bench::Args),
}

fn main() {
    keep_freed_memory();
    let cli = Cli::parse();
    if let Some(n) = cli.threads {
        if let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
        {
            eprintln!("warning: could not set {n} threads: {e}");
        }
    }
    let result = match cli.command {
        Command::Info(a) => info::run(a),
        Command::Synth(a) => synth::run(a),
        Command::Render(a) => render::run(a),
        Command::Bake(a) => bake::run(a),
        Command::Train(a) => train::run(a),
        Command::Run(a) => run::run(a),
        Command::Eval(a) => eval::run(a),
        Command::Demo(a) => demo::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Profile(a) => search::run(a),
        Command::Table(a) => table::run(a),
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
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
