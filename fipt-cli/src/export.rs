//! `fipt export OUT --format glb|mitsuba|obj --out DIR`: a run's recovered scene for other tools.
use crate::progress::Stage;
use anyhow::Result;
use fipt_export::{export, ExportOptions, Format};
use fipt_pipeline::recovered::RunOutput;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// A `fipt run` output folder.
    run: PathBuf,
    /// glb (glTF 2.0 binary), mitsuba (Mitsuba 3 XML + OBJ + PNG) or obj (OBJ + MTL + PNG).
    #[arg(long)]
    format: Format,
    /// Output folder.
    #[arg(long)]
    out: PathBuf,
    /// The scene folder, when the path in the run's report.json does not resolve from here.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// World size of a texel (default: the re-render's material cache cell, 2 pixel footprints).
    #[arg(long)]
    texel: Option<f32>,
    /// Largest atlas edge in texels (the texel grows until the atlas fits).
    #[arg(long, default_value_t = 4096)]
    max_atlas: u32,
    /// Per-vertex materials instead of a texture atlas (glb only).
    #[arg(long)]
    per_vertex: bool,
}

pub fn run(a: Args) -> Result<()> {
    let st = Stage::start("load");
    let run = RunOutput::open(&a.run, a.scene.as_deref())?;
    let (ds, geometry) = run.open_scene()?;
    let field = run.field()?;
    let views: Vec<_> = ds.splits.iter().flat_map(|s| s.views.clone()).collect();
    let surfaces = fipt_pipeline::recovered::surfaces(
        &geometry,
        &views,
        field.as_ref(),
        &run.emitters,
        run.model,
    )?;
    st.done();
    let opts = ExportOptions {
        texel_size: a.texel.unwrap_or(surfaces.cell()),
        max_atlas: a.max_atlas,
        per_vertex: a.per_vertex,
    };
    let st = Stage::start("export");
    let sum = export(
        &geometry.mesh,
        &surfaces,
        &run.emitters,
        a.format,
        &a.out,
        &opts,
    )?;
    st.done();
    match sum.atlas {
        Some((w, h, charts, s)) => println!(
            "atlas {w}×{h} texels, {charts} charts, texel {:.1} mm",
            s * 1000.0
        ),
        None => println!("per-vertex materials (no atlas)"),
    }
    let total: u64 = sum.files.iter().map(|f| f.1).sum();
    for (f, n) in &sum.files {
        println!("  {:>10} B  {}", n, f.display());
    }
    println!(
        "wrote {} files, {:.1} MiB, {} triangles and {} emitters ({:?}) to {}",
        sum.files.len(),
        total as f64 / (1 << 20) as f64,
        sum.triangles,
        sum.emitters,
        a.format,
        a.out.display()
    );
    Ok(())
}
