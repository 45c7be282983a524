//! `fipt report OUT`: contact sheets and `report.html` of a finished run.
use crate::recovered::RunOutput;
use anyhow::{Context, Result};
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct Args {
    /// A `fipt run` output folder.
    run: PathBuf,
    /// The scene folder, when the path in the run's report.json does not resolve from here.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Views per split shown.
    #[arg(long, default_value_t = 4)]
    views: usize,
}

/// Writes the report of run folder `out` of scene `ds`; prints where it is.
pub fn write(out: &Path, ds: &fipt_core::dataset::Dataset, views: usize) -> Result<()> {
    let opts = fipt_report::Options { views };
    let files = fipt_report::write_report(out, ds, &opts).context("writing the report")?;
    if let Some(html) = files.last() {
        println!("  pictures: {}", html.display());
    }
    Ok(())
}

/// The report at the end of `fipt run`: its failure does not fail the run (every result is
/// already written), it is reported.
pub fn write_or_warn(out: &Path, ds: &fipt_core::dataset::Dataset) {
    if let Err(e) = write(out, ds, 4) {
        eprintln!("warning: the pictures of the report were not written: {e:#}");
    }
}

pub fn run(a: Args) -> Result<()> {
    let run = RunOutput::open(&a.run, a.scene.as_deref())?;
    let (ds, _) = run.open_scene()?;
    write(&a.run, &ds, a.views)
}
