//! `fipt eval <scene> OUT`: the evaluation protocol of method §6 (fipt-pipeline's `eval`),
//! printed: the table per split, σ ≡ 1's score, and the per-part tables.
use anyhow::Result;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Scene folder with ground truth.
    scene: PathBuf,
    /// Output folder of `fipt run` (with --ceiling: a new folder for the ceiling's renders).
    out: PathBuf,
    /// Score the scene's true materials (its scene_parts.json or scene_gt.json) laid on this copy's mesh (a
    /// scan made by `fipt degrade --subdivide K --mesh-warp MM`) at the scene's cameras: the
    /// best a run of the copy can score with that geometry. Writes OUT/metrics.json.
    #[arg(long, value_name = "COPY", conflicts_with = "cameras_from")]
    ceiling: Option<PathBuf>,
    /// Score at this scene folder's cameras (the scene itself: a run of a copy made by
    /// `fipt degrade` is scored against its source): the recovered scene is rendered there
    /// into OUT/eval/cameras-from/ and scored.
    #[arg(long, value_name = "SCENE")]
    cameras_from: Option<PathBuf>,
    /// With --cameras-from or --ceiling: the split to score at (default val).
    #[arg(long)]
    split: Option<String>,
    /// With --cameras-from or --ceiling: samples per pixel of the renders.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// With --cameras-from or --ceiling: seed of the renders.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// With --cameras-from: fit one global kd scale and one radiance scale before scoring
    /// (auto: when the run's views were LDR).
    #[arg(long, value_enum, default_value = "auto")]
    fit_scales: Fit,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum Fit {
    Auto,
    On,
    Off,
}

pub fn run(a: Args, components: &fipt_pipeline::Components) -> Result<()> {
    if let Some(copy) = &a.ceiling {
        use fipt_eval::ceiling::{evaluate_ceiling, CeilingRequest};
        let m = evaluate_ceiling(
            &CeilingRequest {
                truth: a.scene.clone(),
                copy: copy.clone(),
                out: a.out.clone(),
                split: a.split,
                spp: a.spp,
                seed: a.seed,
            },
            components,
        )?;
        print_metrics(&m);
        println!(
            "the true materials on {}'s mesh; wrote {}",
            copy.display(),
            a.out.join("metrics.json").display()
        );
        return Ok(());
    }
    if let Some(cams) = &a.cameras_from {
        use fipt_eval::eval_at::{evaluate_at, render_dir, EvalAtRequest, FitScales};
        let same = |p: &PathBuf| p.canonicalize().ok();
        if same(cams) != same(&a.scene) {
            anyhow::bail!(
                "--cameras-from {}: the ground truth is scored at its own cameras; pass the scene folder {} itself",
                cams.display(),
                a.scene.display()
            );
        }
        let m = evaluate_at(
            &EvalAtRequest {
                truth: a.scene.clone(),
                out: a.out.clone(),
                split: a.split,
                spp: a.spp,
                seed: a.seed,
                fit: match a.fit_scales {
                    Fit::Auto => FitScales::Auto,
                    Fit::On => FitScales::On,
                    Fit::Off => FitScales::Off,
                },
            },
            components,
        )?;
        print_metrics(&m);
        for (name, v) in m.as_object().into_iter().flatten() {
            let c = &v["cameras_from"];
            if c["scales_fitted"].as_bool() == Some(true) {
                println!(
                    "{name}: scores after fitted scales kd × {:.4}, radiance × {:.4} (unscaled: kd {:.2} dB, re-render {:.2} dB)",
                    c["scales"]["kd"].as_f64().unwrap_or(1.0),
                    c["scales"]["radiance"].as_f64().unwrap_or(1.0),
                    c["unscaled"]["kd_psnr"].as_f64().unwrap_or(f64::NAN),
                    c["unscaled"]["render_psnr"].as_f64().unwrap_or(f64::NAN),
                );
            }
        }
        println!(
            "wrote {} (`fipt report {}` shows these scores in report.html)",
            render_dir(&a.out).join("metrics.json").display(),
            a.out.display()
        );
        return Ok(());
    }
    let m = fipt_eval::eval::evaluate_run(&a.scene, &a.out)?;
    print_metrics(&m);
    println!("wrote {}", a.out.join("metrics.json").display());
    Ok(())
}

/// The tables of `metrics.json`: per split, then per part.
pub fn print_metrics(m: &serde_json::Value) {
    print_table(m);
    for (name, v) in m.as_object().into_iter().flatten() {
        print_parts(name, &v["parts"]);
    }
}

fn print_table(m: &serde_json::Value) {
    let f = |v: &serde_json::Value, k: &str, p: usize| {
        v.get(k)
            .and_then(|x| x.as_f64())
            .map_or("–".to_string(), |x| format!("{x:.p$}"))
    };
    println!(
        "{:<13} {:>9} {:>12} {:>11} {:>11} {:>12} {:>11} {:>13}",
        "split",
        "kd dB",
        "albedo dB",
        "rough. dB",
        "light IoU",
        "light err",
        "render dB",
        "metal recall"
    );
    if let Some(o) = m.as_object() {
        for (name, v) in o {
            for (stat, label) in [("mean", name.clone()), ("median", format!("{name} median"))] {
                let x = &v[stat];
                let metal = if stat == "mean" {
                    let r = &v["metallic"];
                    format!(
                        "{} ({} false)",
                        f(r, "metal_recall", 2),
                        f(r, "false_metal", 3)
                    )
                } else {
                    String::new()
                };
                println!(
                    "{:<13} {:>9} {:>12} {:>11} {:>11} {:>12} {:>11} {:>13}",
                    label,
                    f(x, "kd_psnr", 2),
                    f(x, "albedo_psnr", 2),
                    f(x, "roughness_psnr", 2),
                    f(x, "emission_iou", 3),
                    f(x, "emission_log_l2", 5),
                    f(x, "render_psnr", 2),
                    metal
                );
            }
        }
        println!(
            "albedo: kd + specular reflectance; rough.: roughness σ; light IoU: overlap of the \
             emitting pixels with the true ones; light err: mean over pixels of (ln(1 + emitted) \
             − ln(1 + true emitted))²; metal recall: share of true metal pixels found metallic (≥ 0.8), \
             and of the others wrongly so."
        );
        for (name, v) in o {
            let c = &v["roughness_constant"];
            if c["roughness_psnr"].is_number() {
                println!(
                    "{name}: a roughness map of 1 everywhere would score {} / {} dB (mean / median view): the floor a roughness map must beat",
                    f(c, "roughness_psnr", 2),
                    f(c, "roughness_psnr_median", 2)
                );
            }
        }
    }
}

/// Prints a split's per-part table (from [`PartScores::to_json`]).
fn print_parts(split: &str, rows: &serde_json::Value) {
    let Some(rows) = rows.as_array().filter(|r| !r.is_empty()) else {
        return;
    };
    let f =
        |v: &serde_json::Value, p: usize| v.as_f64().map_or("–".into(), |x| format!("{x:.p$}"));
    println!("\n{split}, per part (mean predicted / true):");
    println!(
        "{:<16} {:>6} {:>7} {:>13} {:>7} {:>11} {:>11}",
        "part", "share", "kd dB", "kd pred/true", "σ dB", "σ", "metallic"
    );
    for r in rows {
        let name = r["name"]
            .as_str()
            .map_or_else(|| format!("#{}", r["id"]), str::to_string);
        let pair = |a: &str, b: &str| format!("{}/{}", f(&r[a], 2), f(&r[b], 2));
        println!(
            "{:<16} {:>6} {:>7} {:>13} {:>7} {:>11} {:>11}",
            name,
            f(&r["share"], 3),
            f(&r["kd_psnr"], 2),
            pair("kd_mean", "kd_true"),
            f(&r["roughness_psnr"], 2),
            format!(
                "{}/{}",
                f(&r["roughness_mean"], 2),
                f(&r["roughness_true"], 2)
            ),
            format!(
                "{}/{}",
                f(&r["metallic_mean"], 2),
                f(&r["metallic_true"], 2)
            ),
        );
    }
}
