//! `fipt synth <name> --out DIR`.
use crate::progress::{bar, Stage};
use anyhow::{bail, Context, Result};
use fipt_synth::{build, write_dataset, SynthOptions, SCENES};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scene to generate: cornell (tiny, for tests), cornell-metal (cornell with a glossy floor and a gold block) or room (a furnished room).
    name: String,
    /// Output folder (must be empty or absent unless --force).
    #[arg(long)]
    out: PathBuf,
    /// Training views (default: 12 for cornell, 48 for room).
    #[arg(long)]
    views: Option<usize>,
    /// Validation views (default: 4 for cornell, 8 for room).
    #[arg(long)]
    val_views: Option<usize>,
    /// Image width in pixels (default: 64 for cornell, 240 for room).
    #[arg(long)]
    width: Option<usize>,
    /// Image height in pixels (default: 48 for cornell, 160 for room).
    #[arg(long)]
    height: Option<usize>,
    /// Samples per pixel of the input images (default: 64 for cornell, 128 for room).
    #[arg(long)]
    spp: Option<u32>,
    /// Seed of cameras and renders.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Write into a non-empty folder (files of the same name are replaced).
    #[arg(long)]
    force: bool,
    /// The reflectance model the views are rendered with: fipt, principled, or one the binary
    /// registers.
    #[arg(long, default_value = "fipt")]
    brdf: fipt_core::reflectance::ReflectanceModel,
    /// Split every triangle into four this many times (the same scene with 4^K times the
    /// triangles; for scaling measurements).
    #[arg(long, default_value_t = 0)]
    subdivide: u32,
    /// Render every view (and its maps) through this lens: `opencv:K1[,K2,P1,P2,K3]` or
    /// `fisheye:K1[,K2,K3,K4]`; `transforms.json` records it (`distortion`).
    #[arg(long, value_name = "MODEL:COEFFS")]
    lens: Option<fipt_core::distortion::Distortion>,
}

pub fn run(a: Args) -> Result<()> {
    if !SCENES.contains(&a.name.as_str()) {
        bail!(
            "unknown scene `{}`; available: {}",
            a.name,
            SCENES.join(", ")
        );
    }
    fipt_core::lock::output_folder(&a.out)?;
    if a.out.exists()
        && !a.force
        && std::fs::read_dir(&a.out)
            .map(|mut d| d.next().is_some())
            .unwrap_or(true)
    {
        bail!(
            "{} exists and is not empty; choose another --out or pass --force",
            a.out.display()
        );
    }
    let mut opts = SynthOptions::defaults(&a.name);
    opts.train_views = a.views.unwrap_or(opts.train_views);
    opts.val_views = a.val_views.unwrap_or(opts.val_views);
    opts.width = a.width.unwrap_or(opts.width);
    opts.height = a.height.unwrap_or(opts.height);
    opts.render.spp = a.spp.unwrap_or(opts.render.spp);
    opts.render.seed = a.seed;
    opts.model = a.brdf;
    opts.lens = a.lens.unwrap_or_default();
    if opts.train_views == 0 || opts.width == 0 || opts.height == 0 || opts.render.spp == 0 {
        bail!("--views, --width, --height and --spp must be positive");
    }
    if a.subdivide > 6 {
        bail!(
            "--subdivide {} would make 4^{} times the triangles: use 0 to 6",
            a.subdivide,
            a.subdivide
        );
    }
    let scene = build(&a.name)?.subdivided(a.subdivide);
    eprintln!(
        "synth {} ({} model): {} triangles, {} train + {} val views at {}x{}, {} spp → {}",
        a.name,
        a.brdf,
        scene.mesh.triangles.len(),
        opts.train_views,
        opts.val_views,
        opts.width,
        opts.height,
        opts.render.spp,
        a.out.display()
    );
    let total = ((opts.train_views + opts.val_views) * opts.width * opts.height) as u64;
    let pb = bar(total, "render");
    let stage = Stage::start("synth total");
    let summary = write_dataset(scene, &a.out, &opts, &|done, _| {
        pb.set_position(done as u64)
    })
    .with_context(|| format!("writing {}", a.out.display()))?;
    pb.finish_and_clear();
    let secs = stage.done();
    eprintln!(
        "{} views, {} emitter triangles, {:.2} Mrays/s, {:.0} paths/s{}",
        summary.views,
        summary.emitters,
        summary.stats.rays as f64 / secs / 1e6,
        summary.stats.paths as f64 / secs,
        if summary.stats.nonfinite > 0 {
            format!(", {} non-finite samples dropped", summary.stats.nonfinite)
        } else {
            String::new()
        }
    );
    println!(
        "wrote {} (previews in {}/train/preview)",
        a.out.display(),
        a.out.display()
    );
    Ok(())
}
