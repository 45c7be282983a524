//! `fipt bench`: arguments for the benchmarks of crate `fipt-bench`, which write the JSON.
use anyhow::Result;
use fipt_bench::{bench, BenchRequest, Suite};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Where to write the JSON report.
    #[arg(long, default_value = "bench.json")]
    out: PathBuf,
    /// Smaller workloads (for a smoke test).
    #[arg(long)]
    quick: bool,
    /// Repetitions of each timed measurement (the best is reported).
    #[arg(long, default_value_t = 3)]
    reps: usize,
    /// What to measure: rays (BVH and path tracer), bake (the shading bake on --scene), train
    /// (material-field training steps per preset, custom op vs plain candle) or render (the
    /// re-render of the finished run --scene beside the BVH's raw rate on the same scene).
    #[arg(long, value_enum, default_value = "rays")]
    suite: SuiteArg,
    /// Scene folder for `--suite bake` (e.g. the output of `fipt synth room`); a finished run
    /// folder for `--suite render`.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Training views used by `--suite bake` (the first N; default all); val views rendered by
    /// `--suite render` (default 2).
    #[arg(long)]
    views: Option<usize>,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum SuiteArg {
    Rays,
    Bake,
    Train,
    Render,
}

pub fn run(a: Args) -> Result<()> {
    let suite = match a.suite {
        SuiteArg::Rays => Suite::Rays,
        SuiteArg::Bake => Suite::Bake,
        SuiteArg::Train => Suite::Train,
        SuiteArg::Render => Suite::Render,
    };
    let request = BenchRequest {
        suite,
        out: a.out,
        quick: a.quick,
        reps: a.reps,
        scene: a.scene,
        views: a.views,
    };
    bench(&request)?;
    println!("wrote {}", request.out.display());
    Ok(())
}
