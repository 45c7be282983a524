//! `fipt export OUT --format glb|mitsuba|obj --out DIR`: a run's recovered scene for other tools.
use anyhow::Result;
use fipt_export::Format;
use fipt_pipeline::recovered::{export_run, ExportRequest};
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

pub fn run(a: Args, components: &fipt_pipeline::Components) -> Result<()> {
    let sum = export_run(
        &ExportRequest {
            run: a.run,
            scene: a.scene,
            format: a.format,
            out: a.out.clone(),
            texel: a.texel,
            max_atlas: a.max_atlas,
            per_vertex: a.per_vertex,
        },
        components,
    )?;
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
        "wrote {} {} files, {:.1} MiB, to {}: {} surface triangles and {} lights of {} triangles",
        sum.files.len(),
        a.format,
        total as f64 / (1 << 20) as f64,
        a.out.display(),
        sum.triangles,
        sum.emitters,
        sum.emitter_triangles
    );
    Ok(())
}
