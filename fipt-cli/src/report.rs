//! `fipt report OUT`: contact sheets and `report.html` of a finished run.
use anyhow::Result;
use std::path::PathBuf;

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

pub fn run(a: Args) -> Result<()> {
    if let Some(html) = fipt_pipeline::report::rewrite(&a.run, a.scene.as_deref(), a.views)? {
        println!("  pictures: {}", html.display());
    }
    Ok(())
}
