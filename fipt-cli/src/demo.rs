//! `fipt demo`: the main job on a fresh machine with nothing at hand: generate `room` (in the
//! preset's reflectance model), run the pipeline on it with the `balanced` preset, evaluate,
//! and say where everything is.
use crate::progress::bar;
use anyhow::Result;
use fipt_pipeline::run::{RunOutcome, RunRequest};
use fipt_synth::{build, write_dataset, SynthOptions};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Working folder: the scene goes to DIR/room, the results to DIR/out.
    #[arg(long, default_value = "fipt-demo")]
    dir: PathBuf,
    /// Preset of the run.
    #[arg(long, default_value = "balanced")]
    preset: String,
}

pub fn run(a: Args, components: &fipt_pipeline::Components) -> Result<()> {
    // Before minutes of rendering: a mistyped preset is refused at once.
    let Some(preset) = fipt_pipeline::run::RunConfig::preset(&a.preset) else {
        anyhow::bail!(
            "unknown preset `{}` (use one of {})",
            a.preset,
            fipt_pipeline::run::PRESETS
        );
    };
    fipt_core::lock::output_folder(&a.dir)?;
    let scene = a.dir.join("room");
    if !scene.join("val").join("transforms.json").is_file() {
        eprintln!(
            "generating the `room` scene in {} (a few minutes on 2 cores)",
            scene.display()
        );
        let pb = bar(1, "synth");
        // Rendered in the reflectance model the preset fits (`principled`; `reference`:
        // FIPT's): fitting one model to views of another biases kd and σ by itself
        // (docs/kd-bias.md).
        let mut opts = SynthOptions::defaults("room");
        opts.model = preset.model.brdf;
        write_dataset(build("room")?, &scene, &opts, &|d, t| {
            pb.set_length(t as u64);
            pb.set_position(d as u64);
        })?;
        pb.finish_and_clear();
    } else {
        eprintln!("using the scene already in {}", scene.display());
    }
    let request = RunRequest::new(&scene, a.dir.join("out"), &a.preset);
    match fipt_pipeline::run::run(&request, components)? {
        RunOutcome::Finished(summary) => crate::run::print_summary(&summary),
        RunOutcome::Stopped(why) => println!("{why}"),
    }
    println!(
        "  previews: {}/views/*/preview/",
        a.dir.join("out").display()
    );
    println!("  metrics:  {}", a.dir.join("out/metrics.json").display());
    Ok(())
}
