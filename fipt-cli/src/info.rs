//! `fipt info <scene>`: fipt-pipeline's `inspect` of a scene folder, printed (or as JSON).
use anyhow::Result;
use fipt_core::dataset::Layout;
use fipt_core::image::BadPixelPolicy;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scene folder (synthetic layout with train/transforms.json, or real layout with cam.txt).
    scene: PathBuf,
    /// What to do with NaN/Inf/negative pixels: reject (error) or clamp.
    #[arg(long, value_enum, default_value = "reject")]
    bad_pixels: Policy,
    /// Also print the summary as JSON on stdout.
    #[arg(long)]
    json: bool,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum Policy {
    Reject,
    Clamp,
}

impl From<Policy> for BadPixelPolicy {
    fn from(p: Policy) -> Self {
        match p {
            Policy::Reject => BadPixelPolicy::Reject,
            Policy::Clamp => BadPixelPolicy::Clamp,
        }
    }
}

pub fn run(a: Args) -> Result<()> {
    let sum = fipt_pipeline::inspect::inspect(&a.scene, a.bad_pixels.into())?;
    // With --json, stdout holds the JSON alone; the human summary goes to stderr.
    let json = a.json;
    macro_rules! say {
        ($($t:tt)*) => {
            if json {
                eprintln!($($t)*)
            } else {
                println!($($t)*)
            }
        };
    }
    let layout = match sum.layout {
        Layout::Synthetic => "synthetic",
        _ => "real",
    };
    say!("scene        {} ({layout} layout)", sum.scene.display());
    say!(
        "mesh         {}: {} triangles, {} vertices, vertex normals: {}",
        sum.mesh.display(),
        sum.triangles,
        sum.vertices,
        if sum.vertex_normals { "yes" } else { "no" }
    );
    let [lo, hi] = sum.bounds;
    say!(
        "bounds       [{:.3}, {:.3}, {:.3}] – [{:.3}, {:.3}, {:.3}] (extent {:.3})",
        lo[0],
        lo[1],
        lo[2],
        hi[0],
        hi[1],
        hi[2],
        sum.extent()
    );
    for s in &sum.splits {
        say!(
            "{:<12} {} views at {}x{}, fov_x {:.1}°",
            s.name,
            s.views,
            sum.width,
            sum.height,
            s.fov_x_deg
        );
        say!(
            "  {}        min {:.3e}, max {:.3e}, mean luminance {:.4}, median {:.4} (exposure scale {})",
            if s.hdr.ldr.ldr { "LDR" } else { "HDR" },
            s.hdr.min,
            s.hdr.max,
            s.hdr.mean_luminance,
            s.hdr.median_luminance,
            fipt_core::image::exposure_scale(s.hdr.median_luminance)
        );
        say!(
            "  coverage   mean {:.1} % of pixel-centre rays hit the mesh; lowest {:.1} % (view {})",
            100.0 * s.coverage_mean,
            100.0 * s.coverage_min,
            s.coverage_min_view
        );
        say!(
            "  ground truth {}",
            if s.ground_truth.is_empty() {
                "none".to_string()
            } else {
                s.ground_truth.join(", ")
            }
        );
    }
    if let Some(f) = &sum.exposure_fit {
        let lo = f.gains.iter().cloned().fold(f32::INFINITY, f32::min);
        let hi = f.gains.iter().cloned().fold(0.0f32, f32::max);
        say!(
            "exposures   fitted on {} shared surface cells: gains {lo:.3} … {hi:.3} (×{:.3}), log residual {:.3}",
            f.cells,
            f.spread,
            f.residual_log_rms
        );
    }
    say!(
        "edges       the views' edges lie a median {:.2} px from the mesh's ({} of {} views {} px or more)",
        sum.edges.median_px,
        sum.edges.views_off.len(),
        sum.edges.shifts.len(),
        fipt_pipeline::capture::EDGE_OFF_PX
    );
    if sum.warnings.is_empty() {
        say!("warnings     none");
    } else {
        say!("warnings     {}", sum.warnings.len());
        for w in &sum.warnings {
            say!("  - {w}");
        }
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&sum)?);
    }
    Ok(())
}
