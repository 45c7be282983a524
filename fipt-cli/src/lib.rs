//! The `fipt` command-line tool as a library: argument parsing and printing over fipt-pipeline
//! (the host: stage order, caching and the registry of components, `Components`, that
//! `fipt run` composes by name), fipt-method, fipt-eval and fipt-capture. The `fipt` binary is
//! `main_with(components())`: the pipeline's built-ins (`slf`, `path-grown`, `hash-grid`,
//! `mask`) with FIPT (`fipt_method::register`), the IPT baseline (`fipt_ipt::register`) and
//! the scoring (`fipt_eval::register`) registered by their crates; a crate that brings its own component (an emitter
//! extractor, …) builds its own binary the same way with the component registered, and every
//! subcommand, preset and file layout stays as it is (see `examples/brightest-emitters`).
mod bake;
mod bench;
mod degrade;
mod demo;
mod eval;
mod export;
mod info;
mod progress;
mod render;
mod report;
mod run;
mod search;
mod sweep;
mod synth;
mod table;
mod train;

pub use clap::{Parser, Subcommand};
pub use fipt_pipeline::{describe, Components};

/// The `fipt` binary's components: the pipeline's built-ins (`slf`, `path-grown`, `hash-grid`,
/// `mask`), FIPT's method `fipt` (registered by `fipt-method`), the inverse-path-tracing
/// baseline `ipt` (registered by `fipt-ipt`) and the scoring of runs against ground truth
/// (registered by `fipt-eval`), each registered as a plug-in from outside registers its own.
pub fn components() -> Components {
    let methods = fipt_ipt::register(fipt_method::register(Components::builtin()));
    fipt_eval::register(methods)
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
    /// A capture-like copy of a scene: real layout, pose and pixel noise, 8-bit photos at one
    /// or each view's exposure, JPEG, a denser mesh warped by millimetres.
    Degrade(degrade::Args),
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
    /// Path-trace a recovered scene (a run's output folder) or a mesh with given materials from
    /// any cameras, optionally relit (--lights, --emitters).
    Render(render::Args),
    /// Contact sheets and a static HTML report (report.html) of a finished run.
    Report(report::Args),
    /// Export a run's recovered scene: glTF binary with textures, Mitsuba 3 scene, or OBJ + MTL.
    Export(export::Args),
    /// The material search's cost curves per region over roughness and metallic (a diagnostic of
    /// the shadings; with ground truth, also at the true base colour).
    Profile(search::Args),
    /// The speed/accuracy trade: a grid of runs (presets × settings), sweep.csv and sweep.svg
    /// with the Pareto front; resumable.
    Sweep(sweep::Args),
    /// The accuracy table (Markdown) of finished runs: kd, σ, metallic, IoU, re-render, wall time.
    Table(table::Args),
    /// Measure BVH build, ray throughput and path-tracing speed; writes JSON.
    Bench(bench::Args),
}

/// Parses `args` (the program name first) and runs the subcommand with `components`.
pub fn run_args<I, T>(args: I, components: &Components) -> anyhow::Result<()>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let cli = Cli::try_parse_from(args)?;
    dispatch(cli, components)
}

/// The whole program: parses the process arguments, runs, prints errors; returns the exit code.
pub fn main_with(components: Components) -> i32 {
    let cli = Cli::parse();
    match dispatch(cli, &components) {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("error: {}", describe(&*e));
            1
        }
    }
}

fn dispatch(cli: Cli, components: &Components) -> anyhow::Result<()> {
    // What the pipeline says goes to the terminal (a second call keeps the first observer).
    fipt_pipeline::observe::set_observer(Box::new(progress::Terminal));
    if let Some(n) = cli.threads {
        if let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
        {
            eprintln!("warning: could not set {n} threads: {e}");
        }
    }
    match cli.command {
        Command::Info(a) => info::run(a),
        Command::Synth(a) => synth::run(a),
        Command::Degrade(a) => degrade::run(a),
        Command::Render(a) => render::run(a, components),
        Command::Export(a) => export::run(a, components),
        Command::Report(a) => report::run(a),
        Command::Sweep(a) => sweep::run(a, components),
        Command::Bake(a) => bake::run(a, components),
        Command::Train(a) => train::run(a, components),
        Command::Run(a) => run::run(a, components),
        Command::Eval(a) => eval::run(a, components),
        Command::Demo(a) => demo::run(a, components),
        Command::Bench(a) => bench::run(a),
        Command::Profile(a) => search::run(a),
        Command::Table(a) => table::run(a),
    }
}
