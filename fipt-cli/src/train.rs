//! `fipt train <scene> --out OUT`: fit the material field to the bake in OUT/bake, write the
//! checkpoint to OUT/train/ and per-view maps to OUT/train/views/<split>/.
use crate::info::Policy;
use anyhow::Result;
use fipt_method::train::TrainRequest;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scene folder.
    scene: PathBuf,
    /// Output folder holding OUT/bake/ (from `fipt bake`); results go to OUT/train/.
    #[arg(long)]
    out: PathBuf,
    /// Settings preset: paper (the reference's sizes and 10k steps), balanced, fast, reference.
    #[arg(long, default_value = "balanced")]
    preset: String,
    /// A TOML or JSON file of training settings laid over the preset: a training config, or a
    /// run config (its `[train]`; with a `[pipeline]` table, OUT/bake must be the bake of its
    /// `baker` and settings, and its `method` FIPT's).
    #[arg(long)]
    config: Option<PathBuf>,
    /// Override the number of steps.
    #[arg(long)]
    steps: Option<usize>,
    /// What to do with NaN/Inf/negative pixels.
    #[arg(long, value_enum, default_value = "reject")]
    bad_pixels: Policy,
    /// Train afresh even if a finished or resumable run exists.
    #[arg(long)]
    force: bool,
}

pub fn run(a: Args, components: &fipt_pipeline::Components) -> Result<()> {
    let dir = fipt_method::train::train_only(
        TrainRequest {
            scene: a.scene,
            out: a.out,
            preset: a.preset,
            config: a.config,
            steps: a.steps,
            bad_pixels: a.bad_pixels.into(),
            force: a.force,
        },
        components,
    )?;
    println!("wrote {}", dir.display());
    Ok(())
}
