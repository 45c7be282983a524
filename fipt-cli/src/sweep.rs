//! `fipt sweep <scene> --out DIR [--grid sweep.toml] [--quick]`: arguments and the printed
//! table; the grid, the runs and the CSV and plot are `fipt_eval::sweep`.
use anyhow::{Context, Result};
use fipt_eval::sweep::{sweep, SweepRequest};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scene folder.
    scene: PathBuf,
    /// Output folder (one sub-folder per point).
    #[arg(long)]
    out: PathBuf,
    /// The grid (TOML): `presets = [...]` and `[axes]` of dotted run-config keys → values;
    /// default: the presets fast, balanced and paper, for every method the binary has
    /// (`pipeline.method`: fipt, ipt, and those it registers).
    #[arg(long)]
    grid: Option<PathBuf>,
    /// A tiny grid for smoke tests: `fast` at two training lengths.
    #[arg(long)]
    quick: bool,
}

pub fn run(a: Args, components: &fipt_pipeline::Components) -> Result<()> {
    let request = SweepRequest {
        scene: a.scene,
        out: a.out,
        grid: a.grid,
        quick: a.quick,
        exe: std::env::current_exe().context("finding the fipt binary")?,
    };
    let s = sweep(&request, components)?;
    println!(
        "{:<28} {:>8} {:>8} {:>8} {:>8} {:>9}",
        "point", "seconds", "kd dB", "σ dB", "render", "peak MiB"
    );
    let f = |v: Option<f64>| v.map_or("–".to_string(), |x| format!("{x:.2}"));
    for r in &s.rows {
        println!(
            "{:<28} {:>8.1} {:>8} {:>8} {:>8} {:>9.0}",
            r.name,
            r.seconds,
            f(r.kd),
            f(r.sigma),
            f(r.render),
            r.peak_mib
        );
    }
    println!("wrote {} and {}", s.csv.display(), s.svg.display());
    Ok(())
}
