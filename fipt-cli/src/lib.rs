//! The `fipt` command-line tool as a library: argument parsing, printing, and the registry of
//! components (`Components`) that `fipt run` composes by name. The `fipt` binary is
//! `main_with(Components::builtin())`; a crate that brings its own component (an emitter
//! extractor, …) builds its own binary the same way with the component registered, and every
//! subcommand, preset and file layout stays as it is (see `examples/brightest-emitters`).
mod bake;
mod bench;
mod bench_bake;
mod bench_train;
mod config;
mod demo;
mod eval;
mod eval_parts;
mod export;
mod fit;
mod info;
mod memory;
mod outputs;
mod progress;
mod recovered;
mod refine;
mod regions;
mod render;
mod report;
mod rounds;
mod run;
mod scene;
mod search;
mod shard;
mod sweep;
mod sweep_plot;
mod synth;
mod table;
mod train;

pub mod components;

use clap::{Parser, Subcommand};
pub use components::Components;

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
            eprintln!("error: {}", describe(&e));
            1
        }
    }
}

/// An error and its causes on one line, each cause said once (an I/O error's message is often
/// part of its context's already).
pub fn describe(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let s = cause.to_string();
        if out.contains(&s) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&s);
    }
    out
}

fn dispatch(cli: Cli, components: &Components) -> anyhow::Result<()> {
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
        Command::Render(a) => render::run(a),
        Command::Export(a) => export::run(a),
        Command::Report(a) => report::run(a),
        Command::Sweep(a) => sweep::run(a, components),
        Command::Bake(a) => bake::run(a, components),
        Command::Train(a) => train::run(a),
        Command::Run(a) => run::run(a, components),
        Command::Eval(a) => eval::run(a),
        Command::Demo(a) => demo::run(a, components),
        Command::Bench(a) => bench::run(a),
        Command::Profile(a) => search::run(a),
        Command::Table(a) => table::run(a),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn an_error_chain_says_each_cause_once() {
        let io = std::io::Error::new(std::io::ErrorKind::NotFound, "No such file or directory");
        let e = anyhow::Error::new(fipt_core::CoreError::io(std::path::Path::new("/x/out"), io))
            .context("creating the output folder");
        assert_eq!(
            super::describe(&e),
            "creating the output folder: /x/out: No such file or directory"
        );
    }
}
