//! `fipt info <scene>`: fipt-pipeline's `inspect` of a scene folder, printed (or as JSON).
use anyhow::Result;
use fipt_capture::inspect::SceneSummary as Summary;
use fipt_core::dataset::Layout;
use fipt_core::image::BadPixelPolicy;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scene folder: FIPT's synthetic (train/transforms.json) or real (cam.txt + K_list.txt)
    /// layout, a COLMAP model (sparse/0/ with images/), or a nerfstudio transforms.json.
    scene: PathBuf,
    /// Shrink every view by this factor on read, as `fipt run --downscale N` would.
    #[arg(long, value_name = "N", default_value_t = 1)]
    downscale: usize,
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
    if a.downscale == 0 {
        anyhow::bail!("--downscale 0: give a factor of 1 (as stored) or more");
    }
    let opts = fipt_core::capture_layout::OpenOptions {
        downscale: a.downscale,
    };
    let sum = fipt_capture::inspect::inspect(&a.scene, a.bad_pixels.into(), opts)?;
    // With --json, stdout holds the JSON alone; the human summary goes to stderr.
    let mut lines = vec![];
    inputs_lines(&sum, &mut lines);
    splits_lines(&sum, &mut lines);
    findings_lines(&sum, &mut lines);
    for l in &lines {
        if a.json {
            eprintln!("{l}");
        } else {
            println!("{l}");
        }
    }
    if a.json {
        println!("{}", serde_json::to_string_pretty(&sum)?);
    }
    Ok(())
}

/// The scene, its cameras, lenses, pose convention, downscale, masks, EXIF, mesh and bounds.
fn inputs_lines(sum: &Summary, out: &mut Vec<String>) {
    let layout = match sum.layout {
        Layout::Synthetic => "FIPT synthetic",
        Layout::Real => "FIPT real",
        Layout::Colmap => "COLMAP",
        Layout::Nerfstudio => "nerfstudio",
    };
    out.push(format!(
        "scene        {} ({layout} layout)",
        sum.scene.display()
    ));
    if let Some(c) = &sum.cameras {
        out.push(format!("cameras      {c}"));
    }
    let lenses: Vec<String> = sum
        .lenses
        .iter()
        .map(|(l, n)| format!("{l} ({n} views)"))
        .collect();
    out.push(format!("lenses       {}", lenses.join("; ")));
    if let Some(c) = &sum.convention {
        let scores: Vec<String> = c
            .contrast
            .iter()
            .map(|(k, s)| format!("{k} {s:.2}"))
            .collect();
        out.push(format!(
            "convention   poses read as {}; edge contrast per reading (median of {} views): {}",
            c.read_as,
            c.views_tested,
            scores.join(", ")
        ));
    }
    if sum.downscale > 1 {
        out.push(format!(
            "downscale    every view read at 1/{} of its stored size",
            sum.downscale
        ));
    }
    if sum.masked_views > 0 {
        out.push(format!(
            "masks        {} training views have a mask of pixels to leave out",
            sum.masked_views
        ));
    }
    if !sum.exif.is_empty() {
        let e = &sum.exif;
        out.push(format!(
            "EXIF         {} of {} views carry an exposure time{}{}{}",
            e.views_with_exposure,
            e.views,
            e.camera
                .as_ref()
                .map_or(String::new(), |c| format!(" ({c})")),
            e.spread.map_or(String::new(), |s| format!(
                "; relative exposures spread ×{s:.2}{}",
                if e.used { ", used" } else { "" }
            )),
            e.fitted_spread_after.map_or(String::new(), |s| format!(
                "; the views' fitted gains after them spread ×{s:.2}"
            ))
        ));
    }
    out.push(format!(
        "mesh         {}: {} triangles, {} vertices, vertex normals: {}",
        sum.mesh.display(),
        sum.triangles,
        sum.vertices,
        if sum.vertex_normals { "yes" } else { "no" }
    ));
    let [lo, hi] = sum.bounds;
    out.push(format!(
        "bounds       [{:.3}, {:.3}, {:.3}] – [{:.3}, {:.3}, {:.3}] (extent {:.3})",
        lo[0],
        lo[1],
        lo[2],
        hi[0],
        hi[1],
        hi[2],
        sum.extent()
    ));
}

/// Per split: views, size and field of view; the pixels' range; coverage; ground truth.
fn splits_lines(sum: &Summary, out: &mut Vec<String>) {
    for s in &sum.splits {
        out.push(format!(
            "{:<12} {} views at {}x{}, fov_x {:.1}°",
            s.name, s.views, sum.width, sum.height, s.fov_x_deg
        ));
        out.push(format!(
            "  {}        min {:.3e}, max {:.3e}, mean luminance {:.4}, median {:.4} (exposure scale {})",
            if s.hdr.ldr.ldr { "LDR" } else { "HDR" },
            s.hdr.min,
            s.hdr.max,
            s.hdr.mean_luminance,
            s.hdr.median_luminance,
            fipt_core::image::exposure_scale(s.hdr.median_luminance)
        ));
        out.push(format!(
            "  coverage   mean {:.1} % of pixel-centre rays hit the mesh; lowest {:.1} % (view {})",
            100.0 * s.coverage_mean,
            100.0 * s.coverage_min,
            s.coverage_min_view
        ));
        out.push(format!(
            "  ground truth {}",
            if s.ground_truth.is_empty() {
                "none".to_string()
            } else {
                s.ground_truth.join(", ")
            }
        ));
    }
}

/// The camera's response, the fitted exposures, the edges against the mesh, the warnings.
fn findings_lines(sum: &Summary, out: &mut Vec<String>) {
    out.extend(response_line(sum.response.as_ref()));
    if let Some(f) = &sum.exposure_fit {
        let lo = f.gains.iter().cloned().fold(f32::INFINITY, f32::min);
        let hi = f.gains.iter().cloned().fold(0.0f32, f32::max);
        out.push(format!(
            "exposures   fitted on {} shared surface cells: gains {lo:.3} … {hi:.3} (×{:.3}), log residual {:.3}",
            f.cells,
            f.spread,
            f.residual_log_rms
        ));
    }
    out.push(format!(
        "edges       the views' edges lie a median {:.2} px from the mesh's ({} of {} views {} px or more)",
        sum.edges.median_px,
        sum.edges.views_off.len(),
        sum.edges.shifts.len(),
        fipt_capture::capture::EDGE_OFF_PX
    ));
    if sum.warnings.is_empty() {
        out.push("warnings     none".to_string());
    } else {
        out.push(format!("warnings     {}", sum.warnings.len()));
        out.extend(sum.warnings.iter().map(|w| format!("  - {w}")));
    }
}

/// The line on the camera's response, where one was fitted.
fn response_line(r: Option<&fipt_capture::capture::ResponseFit>) -> Option<String> {
    r.map(|r| format!(
        "response     {} (fitted on {} surface series, gains {}; departs from sRGB by {:.3} RMS; views disagree by {:.2} 8-bit steps RMS under sRGB, {:.2} under the fit)",
        r.outcome, r.series, r.gains, r.departure, r.residual_srgb, r.residual_fitted
    ))
}
