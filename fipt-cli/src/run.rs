//! `fipt run <scene> --out OUT`: the arguments into a [`RunRequest`], the pipeline
//! (fipt-pipeline's `run`), and what it did, printed.
use crate::info::Policy;
use anyhow::Result;
use fipt_core::shading::Shard;
use fipt_pipeline::outputs::StageReport;
use fipt_pipeline::run::{RunOutcome, RunRequest, RunSummary};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scene folder (either layout).
    pub scene: PathBuf,
    /// Output folder (created; finished stages inside are reused).
    #[arg(long)]
    pub out: PathBuf,
    /// Settings preset: paper (the reference's sample counts, sizes and steps), balanced, fast, reference (its behaviour too).
    #[arg(long, default_value = "balanced")]
    pub preset: String,
    /// A TOML or JSON file with `[model]`, `[pipeline]`, `[bake]`, `[train]`, `[emitters]`,
    /// `[refine]`, `[rounds]`, `[render]`, `[search]` and `[plugins.<name>]` sections laid over
    /// the preset. Methods (`[pipeline] method = "…"`): fipt (built in) and those the binary
    /// registers; emitter extractors (`[pipeline] extractor = "…"`): mask (built in) and those
    /// the binary registers (report.json lists them). Reflectance models
    /// (`[model] brdf = "…"`): principled (Burley + GGX: Mitsuba 3's `principled`, Blender, glTF;
    /// every preset but reference), fipt (Lambert + GGX, the method's; reference), or one the
    /// binary registers (`examples/oren-nayar`).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// The method, over `[pipeline] method`: fipt (built in), ipt (inverse path tracing, the
    /// baseline; settings `[plugins.ipt]`), or one the binary registers.
    #[arg(long)]
    pub method: Option<String>,
    /// What to do with NaN/Inf/negative pixels.
    #[arg(long, value_enum, default_value = "reject")]
    pub bad_pixels: Policy,
    /// Redo every stage.
    #[arg(long)]
    pub force: bool,
    /// Compute only the views k with k mod N = K of the next sharded stage that is not done
    /// (the bake, then each refinement), into OUT, and stop: one task of a job array. The
    /// stages before it must be done (training runs without --shard); the next `fipt run`
    /// merges the shards. `scripts/slurm/fipt-sharded.sh` drives it.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<Shard>,
    /// Stop before the named stage when it is not done (`refine`: so that a job array computes
    /// the refinement's shards).
    #[arg(long, value_enum)]
    pub stop_before: Option<StopBefore>,
    /// Shrink every view (its mask and intrinsics with it) by this factor on read, over
    /// `[capture] downscale`: photos larger than the method needs (a 4032×3024 capture with
    /// 8 runs at 504×378). Later commands on OUT read the scene the same way.
    #[arg(long, value_name = "N")]
    pub downscale: Option<usize>,
}

/// Where `--stop-before` stops.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum StopBefore {
    Refine,
}

impl Args {
    /// The pipeline's request.
    pub fn request(&self) -> RunRequest {
        RunRequest {
            scene: self.scene.clone(),
            out: self.out.clone(),
            preset: self.preset.clone(),
            config: self.config.clone(),
            method: self.method.clone(),
            bad_pixels: self.bad_pixels.into(),
            force: self.force,
            shard: self.shard.unwrap_or(Shard::ALL),
            stop_before_refine: self.stop_before == Some(StopBefore::Refine),
            downscale: self.downscale,
        }
    }
}

pub fn run(a: Args, components: &fipt_pipeline::Components) -> Result<()> {
    match fipt_pipeline::run::run(&a.request(), components)? {
        RunOutcome::Stopped(why) => println!("{why}"),
        RunOutcome::Finished(summary) => print_summary(&summary),
    }
    Ok(())
}

/// The metrics (with ground truth), the stage table and where the outputs are.
pub fn print_summary(s: &RunSummary) {
    if let Some(m) = &s.metrics {
        crate::eval::print_metrics(m);
    }
    print_stages(&s.stages);
    println!("\nfipt run ({}) finished in {:.1} s", s.method, s.seconds);
    println!("  maps:     {}", s.out.join("views").display());
    println!(
        "  emitters: {} ({} lights)",
        s.out.join("emitters.json").display(),
        s.lights
    );
    if let Some(field) = &s.field {
        println!("  field:    {}", field.display());
    }
    println!("  report:   {}", s.out.join("report.json").display());
    if let Some(html) = &s.pictures {
        println!("  pictures: {}", html.display());
    }
    if !s.warnings.is_empty() {
        println!("\n{} WARNING(S) (also in report.json):", s.warnings.len());
        for w in &s.warnings {
            println!("  - {w}");
        }
    }
}

fn print_stages(stages: &[StageReport]) {
    println!("\n{:<10} {:>9} {:>14}", "stage", "seconds", "peak RSS MiB");
    for st in stages {
        println!(
            "{:<10} {:>9.1} {:>14}",
            st.stage,
            st.seconds,
            st.peak_rss_mib
                .map_or("–".to_string(), |m| format!("{m:.0}"))
        );
    }
    if let Some(most) = StageReport::run_peak(stages) {
        println!("{:<10} {:>9} {:>14.0}", "peak", "", most);
    }
}
