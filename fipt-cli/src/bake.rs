//! `fipt bake <scene> --out DIR`: the initial shading bake alone.
use crate::info::Policy;
use anyhow::Result;
use fipt_core::reflectance::ReflectanceModel;
use fipt_core::shading::Shard;
use fipt_pipeline::bake::{BakeOutcome, BakeRequest};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scene folder.
    scene: PathBuf,
    /// Output folder; the shadings go to OUT/bake/.
    #[arg(long)]
    out: PathBuf,
    /// Settings preset: paper or balanced (the reference's sample counts), fast, reference (its estimators too).
    #[arg(long, default_value = "balanced")]
    preset: String,
    /// A TOML or JSON file of bake settings laid over the preset, or a run config: then its
    /// `[pipeline] baker` bakes, with that baker's section (as `fipt run` would).
    #[arg(long)]
    config: Option<PathBuf>,
    /// What to do with NaN/Inf/negative pixels.
    #[arg(long, value_enum, default_value = "reject")]
    bad_pixels: Policy,
    /// Bake again even if a finished bake with the same inputs and settings exists.
    #[arg(long)]
    force: bool,
    /// The reflectance model whose shadings are baked: principled (as `fipt run`'s presets) or
    /// fipt (as `--preset reference`), or one the binary registers.
    #[arg(long, default_value = "principled")]
    brdf: ReflectanceModel,
    /// Bake only the views k with k mod N = K (a task of a job array); the shard that finds
    /// all others done merges them.
    #[arg(long, value_name = "K/N")]
    shard: Option<Shard>,
}

pub fn run(a: Args, components: &fipt_pipeline::Components) -> Result<()> {
    let request = BakeRequest {
        scene: a.scene,
        out: a.out,
        preset: a.preset,
        config: a.config,
        bad_pixels: a.bad_pixels.into(),
        force: a.force,
        brdf: a.brdf,
        shard: a.shard.unwrap_or(Shard::ALL),
    };
    match fipt_pipeline::bake::bake_only(request, components)? {
        BakeOutcome::Stopped(why) => println!("{why}"),
        BakeOutcome::Wrote(dir) => println!("wrote {}", dir.display()),
    }
    Ok(())
}
