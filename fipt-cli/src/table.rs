//! `fipt table OUT...`: the accuracy table of finished runs (one row per run and split), as
//! Markdown, from each run's `report.json` and `metrics.json`.
use anyhow::{Context, Result};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Output folders of `fipt run` (with metrics.json: scenes with ground truth).
    #[arg(required = true)]
    runs: Vec<PathBuf>,
    /// Split to tabulate (`val`: novel views; `train`).
    #[arg(long, default_value = "val")]
    split: String,
}

/// The run's time: every stage's computed time (a resumed run's reused stages count what they
/// took when computed), and how many stages this invocation reused.
fn wall(report: &serde_json::Value) -> String {
    let s = report["seconds_computed_total"]
        .as_f64()
        .or(report["seconds_total"].as_f64())
        .unwrap_or(f64::NAN);
    match report["stages_reused"].as_u64() {
        Some(n) if n > 0 => format!("{:.1} min ({n} stages reused)", s / 60.0),
        _ => format!("{:.1} min", s / 60.0),
    }
}

fn read(p: &std::path::Path) -> Result<serde_json::Value> {
    let text = std::fs::read_to_string(p)
        .with_context(|| format!("reading {} (run `fipt run` to the end first)", p.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}: invalid JSON", p.display()))
}

pub fn run(a: Args) -> Result<()> {
    println!(
        "| run | scene | preset | wall | kd mean / median | σ mean / median | metal recall (false) | IoU | re-render | observed: kd / σ (share) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for out in &a.runs {
        let report = read(&out.join("report.json"))?;
        let metrics = read(&out.join("metrics.json"))?;
        let m = &metrics[&a.split];
        let f = |v: &serde_json::Value, p: usize| {
            v.as_f64().map_or("–".into(), |x| format!("{x:.p$}"))
        };
        let pair = |k: &str| format!("{} / {}", f(&m["mean"][k], 2), f(&m["median"][k], 2));
        let scene = report["scene"].as_str().map_or("?".into(), |s| {
            std::path::Path::new(s)
                .file_name()
                .map_or(s.to_string(), |n| n.to_string_lossy().into_owned())
        });
        println!(
            "| {} | {} | {} | {} | {} | {} | {} ({}) | {} | {} | {} / {} ({}) |",
            out.display(),
            scene,
            report["preset"].as_str().unwrap_or("?"),
            wall(&report),
            pair("kd_psnr"),
            pair("roughness_psnr"),
            f(&m["metallic"]["metal_recall"], 2),
            f(&m["metallic"]["false_metal"], 3),
            f(&m["mean"]["emission_iou"], 2),
            f(&m["mean"]["render_psnr"], 2),
            f(&m["observed"]["kd_psnr"], 2),
            f(&m["observed"]["roughness_psnr"], 2),
            f(&m["observed"]["share"], 2),
        );
    }
    Ok(())
}
