//! `fipt info <scene>`.
use anyhow::{bail, Context, Result};
use fipt_core::dataset::{hdr_stats, Dataset, Layout};
use fipt_core::image::BadPixelPolicy;
use fipt_geom::{view_coverage, BuildQuality, Bvh, Mesh};
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
    let ds =
        Dataset::open(&a.scene).with_context(|| format!("opening scene {}", a.scene.display()))?;
    let mut warnings = ds.warnings.clone();
    let mesh = Mesh::load(&ds.mesh).with_context(|| "loading the scene mesh")?;
    if mesh.dropped_degenerate > 0 {
        warnings.push(format!(
            "{}: {} degenerate triangles dropped (zero area, repeated or invalid vertices)",
            ds.mesh.display(),
            mesh.dropped_degenerate
        ));
    }
    let b = mesh.bounds();
    let bvh = Bvh::build(&mesh, BuildQuality::Medium);
    say!(
        "scene        {} ({} layout)",
        ds.root.display(),
        if ds.layout == Layout::Synthetic {
            "synthetic"
        } else {
            "real"
        }
    );
    say!(
        "mesh         {}: {} triangles, {} vertices, vertex normals: {}",
        ds.mesh.display(),
        mesh.triangles.len(),
        mesh.positions.len(),
        if mesh.normals.is_some() { "yes" } else { "no" }
    );
    say!(
        "bounds       [{:.3}, {:.3}, {:.3}] – [{:.3}, {:.3}, {:.3}] (extent {:.3})",
        b.min.x,
        b.min.y,
        b.min.z,
        b.max.x,
        b.max.y,
        b.max.z,
        (b.max - b.min).length()
    );
    let mut json_splits = Vec::new();
    let mut any_hit = false;
    for s in &ds.splits {
        let stats = hdr_stats(&ds, s, a.bad_pixels.into())
            .with_context(|| format!("reading the {} images", s.name))?;
        let cover: Vec<f32> = s
            .views
            .iter()
            .map(|v| view_coverage(&bvh, &v.camera, 4))
            .collect();
        let (worst, wv) =
            cover.iter().enumerate().fold(
                (1.0f32, 0usize),
                |acc, (k, &c)| if c < acc.0 { (c, k) } else { acc },
            );
        let mean = cover.iter().sum::<f32>() / cover.len().max(1) as f32;
        any_hit |= cover.iter().any(|&c| c > 0.0);
        for (k, &c) in cover.iter().enumerate() {
            if c == 0.0 {
                warnings.push(format!("{} view {k}: no pixel-centre ray hits the mesh (wrong pose convention, or a camera outside the scene?)", s.name));
            } else if c < 0.5 {
                warnings.push(format!("{} view {k}: only {:.0} % of pixel-centre rays hit the mesh (open scene? rays that escape see no light)", s.name, 100.0 * c));
            }
        }
        if stats.bad > 0 {
            warnings.push(format!(
                "{}: {} bad pixel values clamped in views {:?}",
                s.name, stats.bad, stats.bad_views
            ));
        }
        if !stats.black_views.is_empty() {
            warnings.push(format!(
                "{}: black views {:?} (every pixel 0): they constrain nothing but emitters' absence",
                s.name, stats.black_views
            ));
        }
        if !stats.saturated_views.is_empty() {
            warnings.push(format!(
                "{}: views {:?} have ≥ 99 % of their pixels at their maximum (clipped exposure?)",
                s.name, stats.saturated_views
            ));
        }
        let gt: Vec<&str> = s.gt.iter().map(|g| g.folder()).collect();
        say!(
            "{:<12} {} views at {}x{}, fov_x {:.1}°",
            s.name,
            s.views.len(),
            ds.width,
            ds.height,
            s.views[0].camera.fov_x().to_degrees()
        );
        say!(
            "  HDR        min {:.3e}, max {:.3e}, mean luminance {:.4}, median {:.4} (exposure scale {})",
            stats.min,
            stats.max,
            stats.mean_luminance,
            stats.median_luminance,
            fipt_core::image::exposure_scale(stats.median_luminance)
        );
        say!("  coverage   mean {:.1} % of pixel-centre rays hit the mesh; lowest {:.1} % (view {wv})", 100.0 * mean, 100.0 * worst);
        say!(
            "  ground truth {}",
            if gt.is_empty() {
                "none".to_string()
            } else {
                gt.join(", ")
            }
        );
        json_splits.push(serde_json::json!({
            "name": s.name, "views": s.views.len(), "hdr": stats, "coverage_mean": mean, "coverage_min": worst, "ground_truth": gt,
        }));
    }
    if !any_hit {
        bail!(
            "no camera ray of any view hits the mesh {}: the poses are probably in another convention \
             (transforms.json expects camera-to-world with +X left, +Y up, +Z forward) or the mesh is not the scene's",
            ds.mesh.display()
        );
    }
    if warnings.is_empty() {
        say!("warnings     none");
    } else {
        say!("warnings     {}", warnings.len());
        for w in &warnings {
            say!("  - {w}");
        }
    }
    if a.json {
        let v = serde_json::json!({
            "scene": ds.root, "layout": ds.layout, "mesh": ds.mesh, "triangles": mesh.triangles.len(),
            "degenerate_dropped": mesh.dropped_degenerate, "bounds": [b.min.to_array(), b.max.to_array()],
            "width": ds.width, "height": ds.height, "splits": json_splits, "warnings": warnings,
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
    }
    Ok(())
}
