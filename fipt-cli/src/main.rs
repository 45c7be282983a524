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
mod render;
mod run;
mod scene;
mod synth;
mod train;

use clap::{Parser, Subcommand};

/// candle allocates a fresh tensor per op; mimalloc made training steps 1.7–2× faster than
/// glibc malloc on this 2-core machine (page faults dominated).
#[global_allocator]
static ALLOC: mimalloc::MiMalloc = mimalloc::MiMalloc;

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
    /// Measure BVH build, ray throughput and path-tracing speed; writes JSON.
    Bench(bench::Args),
}

fn main() {
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
    };
    if let Err(e) = result {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}
