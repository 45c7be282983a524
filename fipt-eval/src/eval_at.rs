//! `fipt eval SRC OUT --cameras-from SRC`: a run of one scene (a capture-like copy made by
//! `fipt degrade`, or the scene itself) scored against another folder's ground truth at that
//! folder's cameras. The recovered scene is path-traced there (`fipt render`: maps and
//! re-renders) into `OUT/eval/cameras-from/views/<split>/`, and scored with the protocol of
//! [`crate::eval`]. Where the run's views were LDR, one global kd scale and one radiance scale
//! are fitted to the ground truth first (what 8-bit views at an unknown exposure cannot
//! identify) and reported with the unscaled scores.
use crate::error::{Context, Result};
use crate::eval::{evaluate_scaled, Scales};
use crate::render::{render_unchecked, RenderRequest};
use fipt_core::color::luminance;
use fipt_core::dataset::{Dataset, GtKind, Split};
use fipt_core::image::{BadPixelPolicy, Image};
use fipt_pipeline::run_config::DEFAULT_MAX_BOUNCES;
use std::path::{Path, PathBuf};

/// Whether to fit the global scales before scoring.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FitScales {
    /// When the run's report says its views were LDR.
    Auto,
    On,
    Off,
}

/// What to score and how.
#[derive(Clone, Debug)]
pub struct EvalAtRequest {
    /// The scene folder whose ground truth and cameras score the run.
    pub truth: PathBuf,
    /// The `fipt run` output folder.
    pub out: PathBuf,
    /// The split of `truth` to score at (default: `val`, else the first with ground truth).
    pub split: Option<String>,
    pub spp: u32,
    pub seed: u64,
    pub fit: FitScales,
}

/// The folder the renders at the other cameras go to.
pub fn render_dir(out: &Path) -> PathBuf {
    out.join("eval").join("cameras-from")
}

/// Renders the run at `truth`'s cameras and scores it; returns (and writes into
/// [`render_dir`]) `metrics.json`.
pub fn evaluate_at(a: &EvalAtRequest, components: &crate::Components) -> Result<serde_json::Value> {
    let ds =
        Dataset::open(&a.truth).with_context(|| format!("opening scene {}", a.truth.display()))?;
    let split = pick_split(&ds, a.split.as_deref())?.clone();
    let dir = render_dir(&a.out);
    let views_dir = dir.join("views").join(&split.name);
    // Writes into the run folder: under its lock, as `fipt run` does.
    let _lock = fipt_core::lock::OutputLock::acquire(&a.out, "fipt eval --cameras-from")?;
    crate::render::check_spp(a.spp)?;
    let report: serde_json::Value =
        fipt_core::fsutil::read_json(&a.out.join("report.json")).unwrap_or_default();
    // The paths the run's own re-render traced (the ground truth's are as long).
    let max_bounces = report["settings"]["render"]["max_bounces"]
        .as_u64()
        .map_or(DEFAULT_MAX_BOUNCES, |b| b.min(64) as u32);
    render_unchecked(
        &RenderRequest {
            source: a.out.clone(),
            materials: None,
            scene: None,
            cameras: split.cameras_file.clone(),
            out: views_dir.clone(),
            size: Some((ds.width, ds.height)),
            spp: a.spp,
            max_bounces,
            seed: a.seed,
            views: None,
            brdf: None,
            lights: vec![],
            emitters: None,
            edits: None,
            reference: None,
            denoise: Some(true),
        },
        components,
    )?;
    let ldr = report["capture"]["ldr"].as_bool().unwrap_or(false);
    let fit = match a.fit {
        FitScales::Auto => ldr,
        FitScales::On => true,
        FitScales::Off => false,
    };
    let only = Dataset {
        splits: vec![split.clone()],
        ..ds.clone()
    };
    let unscaled = evaluate_scaled(&only, &dir, 1.0, Scales::ONE)?;
    let scales = if fit {
        fit_scales(&only, &split, &views_dir)?
    } else {
        Scales::ONE
    };
    let mut m = if fit {
        evaluate_scaled(&only, &dir, 1.0, scales)?
    } else {
        unscaled.clone()
    };
    m[&split.name]["cameras_from"] = serde_json::json!({
        "truth": a.truth,
        "split": split.name,
        "spp": a.spp,
        "scales_fitted": fit,
        "scales": scales,
        "why": if fit { "one global kd scale and one radiance scale, least squares against the ground truth (LDR views fix neither)" } else { "none fitted" },
        "unscaled": unscaled[&split.name]["mean"],
    });
    fipt_core::fsutil::write_json_atomic(&dir.join("metrics.json"), &m)?;
    Ok(m)
}

pub(crate) fn pick_split<'a>(ds: &'a Dataset, name: Option<&str>) -> Result<&'a Split> {
    let with_gt = |s: &&Split| s.has_gt(GtKind::DiffCol);
    let found = match name {
        Some(n) => ds.split(n).filter(with_gt),
        None => ds
            .split("val")
            .filter(with_gt)
            .or_else(|| ds.splits.iter().find(with_gt)),
    };
    found.with_context(|| {
        format!(
            "{}: no split {}with ground truth (DiffCol/) to score at",
            ds.root.display(),
            name.map(|n| format!("`{n}` ")).unwrap_or_default()
        )
    })
}

/// The kd scale (least squares over ground-truth diffuse, non-emitting pixels) and the
/// radiance scale (least squares of the re-renders' luminance against the views', off the
/// emitters and the clipped-free range) of the renders in `dir`.
fn fit_scales(ds: &Dataset, split: &Split, dir: &Path) -> Result<Scales> {
    let (mut kd_xy, mut kd_xx, mut l_xy, mut l_xx) = (0f64, 0f64, 0f64, 0f64);
    for v in &split.views {
        let k = v.index;
        let read = |name: &str| -> Result<Image> {
            let p = dir.join(format!("{k:03}_{name}.exr"));
            Image::read_exr(&p).with_context(|| format!("reading {}", p.display()))
        };
        let (kd, render) = (read("kd")?, read("render")?);
        let gt = |kind| ds.load_gt(split, kind, k).ok().flatten();
        let (Some(kd_gt), emit) = (gt(GtKind::DiffCol), gt(GtKind::Emit)) else {
            continue;
        };
        let metal = gt(GtKind::Metallic);
        let view = ds.load_image(v, BadPixelPolicy::Clamp)?.0;
        for i in 0..kd.data.len() {
            if emit.as_ref().is_some_and(|e| e.data[i].element_sum() > 0.0) {
                continue;
            }
            let (r, t) = (render.data[i], view.data[i]);
            l_xy += (luminance(r) * luminance(t)) as f64;
            l_xx += (luminance(r) * luminance(r)) as f64;
            if metal.as_ref().is_none_or(|m| m.data[i].x < 0.5) {
                kd_xy += kd.data[i].dot(kd_gt.data[i]) as f64;
                kd_xx += kd.data[i].length_squared() as f64;
            }
        }
    }
    let ratio = |xy: f64, xx: f64| if xx > 0.0 { (xy / xx) as f32 } else { 1.0 };
    Ok(Scales {
        kd: ratio(kd_xy, kd_xx),
        radiance: ratio(l_xy, l_xx),
    })
}
