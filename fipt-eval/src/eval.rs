//! `fipt eval <scene> OUT`: the evaluation protocol of method §6 against the ground-truth
//! folders, per view and averaged per split; `OUT/metrics.json`, error maps in `OUT/eval/`.
//!
//! kd PSNR over GT-diffuse (metallic < 0.5) non-emitter pixels, a′ and σ PSNR over non-emitter
//! surface pixels, ground truth quantised to 8 bits, σ of both clamped to [0.2, 1]; metallic
//! pooled over the split: the share of metal pixels predicted ≥ 0.8 and of dielectric ones
//! predicted > 0.1; emitter IoU (Emit summed over channels > 0) and log-L2 =
//! MSE(log(1 + E_pred), log(1 + E_gt)) over all pixels.
use crate::error::{Context, Result};
use crate::eval_parts::{PartScores, ViewMaps};
use fipt_core::dataset::{Dataset, GtKind};
use fipt_core::fsutil::write_json_atomic;
use fipt_core::image::Image;
use fipt_core::metrics::psnr;
use glam::Vec3;
use rayon::prelude::*;
use std::path::Path;

/// A pixel is *observed* when at least this many training pixels fall in its surface cell.
const OBSERVED_MIN: f32 = 8.0;

fn q8(v: Vec3) -> Vec3 {
    (v.clamp(Vec3::ZERO, Vec3::ONE) * 255.0).round() / 255.0
}

/// The views' finite values (a view without the quantity, or with an undefined PSNR, counts
/// for neither the mean nor the median).
fn finite(v: &[Option<f64>]) -> Vec<f64> {
    v.iter()
        .flatten()
        .copied()
        .filter(|x| x.is_finite())
        .collect()
}

fn mean(v: &[Option<f64>]) -> Option<f64> {
    let x = finite(v);
    (!x.is_empty()).then(|| x.iter().sum::<f64>() / x.len() as f64)
}

/// Median of the finite values: next to the protocol's mean, which one near-exact view (a
/// PSNR of 60–100 dB, e.g. a view of walls whose σ = 1 is met exactly) can carry.
fn median(v: &[Option<f64>]) -> Option<f64> {
    let mut x = finite(v);
    x.sort_by(f64::total_cmp);
    let n = x.len();
    (n > 0).then(|| {
        if n % 2 == 1 {
            x[n / 2]
        } else {
            0.5 * (x[n / 2 - 1] + x[n / 2])
        }
    })
}

/// Why a view cannot score a re-render: all black, or saturated at the working exposure (a
/// PSNR there would compare nothing with nothing and read ~100 dB).
fn degenerate(img: &Image) -> Option<&'static str> {
    if img.data.iter().all(|p| p.max_element() <= 0.0) {
        Some("black view")
    } else if img.data.iter().all(|p| p.min_element() >= 1.0) {
        Some("saturated view")
    } else {
        None
    }
}

/// The scale re-renders and views are divided by before the sRGB PSNR: 1 (the protocol: the
/// values as given) unless the run's exposure scale is more than 16× from 1, where the views
/// as given would clamp to white or black: then the working exposure.
pub fn display_scale(exposure: f32) -> f32 {
    if (1.0 / 16.0..=16.0).contains(&exposure) {
        1.0
    } else {
        exposure
    }
}

/// Emitter IoU (None when neither map emits anywhere) and the summed squared log difference
/// of the emission maps.
fn emission_scores(emis: &Image, emit_gt: Option<&Image>) -> (Option<f64>, f64) {
    let (mut inter, mut uni, mut log2) = (0usize, 0usize, 0f64);
    for (i, &p) in emis.data.iter().enumerate() {
        let g = emit_gt.map_or(Vec3::ZERO, |e| e.data[i]);
        let (a, b) = (p.element_sum() > 0.0, g.element_sum() > 0.0);
        inter += (a && b) as usize;
        uni += (a || b) as usize;
        for c in 0..3 {
            let d = (1.0 + p[c].max(0.0) as f64).ln() - (1.0 + g[c].max(0.0) as f64).ln();
            log2 += d * d;
        }
    }
    ((uni > 0).then(|| inter as f64 / uni as f64), log2)
}

/// The sRGB PSNR of view `v`'s re-render in `dir` (× `radiance`) against its input, both
/// divided by `display` (None without a re-render, or for a black or saturated view).
fn render_score(
    ds: &Dataset,
    v: &fipt_core::dataset::View,
    dir: &Path,
    [display, radiance]: [f32; 2],
    split: &str,
    suffix: &str,
) -> Result<Option<f64>> {
    let k = v.index;
    let path = dir.join(format!("{k:03}_{suffix}.exr"));
    if !path.is_file() {
        return Ok(None);
    }
    let r = Image::read_exr(&path).with_context(|| format!("reading {}", path.display()))?;
    let mut r = same_size(r, ds, &path)?;
    let mut img = ds.load_image(v, fipt_core::image::BadPixelPolicy::Clamp)?.0;
    for p in r.data.iter_mut() {
        *p *= radiance / display;
    }
    for p in img.data.iter_mut() {
        *p /= display;
    }
    if let Some(why) = degenerate(&img) {
        crate::note!("note: {split} view {k}: re-render not scored ({why})");
        return Ok(None);
    }
    Ok(fipt_core::metrics::srgb_psnr(&r.data, &img.data, None))
}

/// `img` (a run's map read from `path`) when every value is finite; otherwise an error with
/// the counts: a score of such a map would be a number about nothing (an all-NaN kd map
/// scored 20.8 dB before this check).
fn finite_map(img: Image, path: &Path) -> Result<Image> {
    let bad = img.count_bad();
    if bad.nan + bad.inf > 0 {
        crate::bail!(
            "{}: {} NaN and {} infinite values in a map the run wrote: the run went wrong; run `fipt run` again into a new folder, and report it if it repeats",
            path.display(),
            bad.nan,
            bad.inf
        );
    }
    Ok(img)
}

/// `img` (read from `path`) when it has the scene's view size; otherwise an error naming both
/// sizes (a map of another scene's run, or one replaced by hand).
fn same_size(img: Image, ds: &Dataset, path: &Path) -> Result<Image> {
    if (img.width, img.height) != (ds.width, ds.height) {
        crate::bail!(
            "{}: {}×{} pixels but the scene's views are {}×{}: it is not of this scene (run `fipt run` again to redo it, or evaluate against the scene it came from)",
            path.display(),
            img.width,
            img.height,
            ds.width,
            ds.height
        );
    }
    Ok(img)
}

/// Evaluates the maps in `out/views/<split>/` of every split with ground truth; `exposure` is
/// the run's exposure scale (see [`display_scale`]).
pub fn evaluate(ds: &Dataset, out: &Path, exposure: f32) -> Result<serde_json::Value> {
    evaluate_scaled(ds, out, exposure, Scales::ONE)
}

/// Global factors applied to the predicted kd and to the re-renders before scoring: what a run
/// of LDR views cannot identify (the absolute scale of radiance, and with it of kd), fitted
/// against the ground truth by `fipt eval --cameras-from` and reported beside the scores.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Scales {
    pub kd: f32,
    pub radiance: f32,
}

impl Scales {
    pub const ONE: Scales = Scales {
        kd: 1.0,
        radiance: 1.0,
    };
}

/// [`evaluate`] with the predicted kd and re-renders multiplied by `scales`.
pub fn evaluate_scaled(
    ds: &Dataset,
    out: &Path,
    exposure: f32,
    scales: Scales,
) -> Result<serde_json::Value> {
    let display = display_scale(exposure);
    let names = crate::eval_parts::part_names(&ds.root);
    let mut splits = serde_json::Map::new();
    for s in &ds.splits {
        if !s.has_gt(GtKind::DiffCol) {
            continue;
        }
        let dir = out.join("views").join(&s.name);
        let mut acc = SplitScores::default();
        let at = SplitAt {
            ds,
            split: s,
            dir: &dir,
            scales,
            display,
        };
        // Where the run mapped a share of the views (`maps.json`), those.
        let mapped = fipt_pipeline::maps::MapsManifest::read(&dir)?;
        let (views, unmapped): (Vec<&fipt_core::dataset::View>, Vec<_>) = (s.views.iter())
            .partition(|v| mapped.as_ref().is_none_or(|m| m.views.contains(&v.index)));
        // A previous evaluation's error maps of views without maps now are another field's.
        for v in unmapped {
            let p = error_map_path(out, &s.name, v.index);
            if p.is_file() {
                std::fs::remove_file(&p).map_err(|e| fipt_core::CoreError::io(&p, e))?;
            }
        }
        // The views are read and scored on every core, a few at a time, and added in view
        // order (the sums are those of one view after another).
        let chunk = 2 * rayon::current_num_threads().max(1);
        for views in views.chunks(chunk) {
            let scored = (views.par_iter())
                .map(|v| score_view(&at, v))
                .collect::<Result<Vec<_>>>()?;
            // Written in view order too (each write is a moment of `fipt_core::chaos`).
            for view in scored.into_iter().flatten() {
                let (k, kd, kd_gt, valid) = &view.kd_error;
                write_kd_error(out, &s.name, *k, kd, kd_gt, valid)?;
                view.add_to(&mut acc);
            }
        }
        splits.insert(s.name.clone(), acc.to_json(&names, display));
    }
    let m = serde_json::Value::Object(splits);
    write_json_atomic(&out.join("metrics.json"), &m)?;
    Ok(m)
}

/// One split's scores as its views add them.
#[derive(Default)]
struct SplitScores {
    rows: Vec<serde_json::Value>,
    kd: Vec<Option<f64>>,
    albedo: Vec<Option<f64>>,
    roughness: Vec<Option<f64>>,
    iou: Vec<Option<f64>>,
    log_l2: Vec<Option<f64>>,
    render: Vec<Option<f64>>,
    render_raw: Vec<Option<f64>>,
    /// Metallic, pooled over the split's pixels: [metal pixels, of them predicted ≥ 0.8,
    /// dielectric pixels, of them predicted > 0.1].
    metal: [usize; 4],
    /// The same kd and σ on observed pixels, and their share of the valid ones.
    kd_observed: Vec<Option<f64>>,
    roughness_observed: Vec<Option<f64>>,
    observed_share: Vec<Option<f64>>,
    /// σ ≡ 1 (no gloss anywhere) scored the same way: the floor a σ map must beat.
    roughness_constant: Vec<Option<f64>>,
    parts: PartScores,
}

impl SplitScores {
    fn to_json(&self, names: &[String], display: f32) -> serde_json::Value {
        let share = |a: usize, b: usize| (b > 0).then(|| a as f64 / b as f64);
        let metal = self.metal;
        let parts_json = (!self.parts.is_empty()).then(|| self.parts.to_json(names));
        serde_json::json!({
            "observed": {"min_count": OBSERVED_MIN, "kd_psnr": mean(&self.kd_observed), "kd_psnr_median": median(&self.kd_observed),
                         "roughness_psnr": mean(&self.roughness_observed), "roughness_psnr_median": median(&self.roughness_observed), "share": mean(&self.observed_share)},
            "metallic": {"metal_recall": share(metal[1], metal[0]), "false_metal": share(metal[3], metal[2]),
                         "metal_pixels": metal[0], "dielectric_pixels": metal[2]},
            "roughness_constant": {"value": 1.0, "roughness_psnr": mean(&self.roughness_constant), "roughness_psnr_median": median(&self.roughness_constant)},
            "mean": {"kd_psnr": mean(&self.kd), "albedo_psnr": mean(&self.albedo), "roughness_psnr": mean(&self.roughness),
                     "emission_iou": mean(&self.iou), "emission_log_l2": mean(&self.log_l2), "render_psnr": mean(&self.render),
                     "render_raw_psnr": mean(&self.render_raw)},
            "median": {"kd_psnr": median(&self.kd), "albedo_psnr": median(&self.albedo), "roughness_psnr": median(&self.roughness),
                       "emission_iou": median(&self.iou), "emission_log_l2": median(&self.log_l2), "render_psnr": median(&self.render)},
            "views": self.rows,
            "parts": parts_json,
            "render_display_scale": display,
        })
    }
}

/// Where a split's views are scored.
struct SplitAt<'a> {
    ds: &'a Dataset,
    split: &'a fipt_core::dataset::Split,
    dir: &'a Path,
    scales: Scales,
    display: f32,
}

/// One view's scores, and the per-pixel maps its parts are scored on, to add to its split's.
struct ViewScore {
    row: serde_json::Value,
    kd: Option<f64>,
    albedo: Option<f64>,
    roughness: Option<f64>,
    roughness_constant: Option<f64>,
    iou: Option<f64>,
    log_l2: f64,
    render: Option<f64>,
    render_raw: Option<f64>,
    /// kd and σ PSNR on observed pixels and their share, when the run wrote `_observed.exr`.
    observed: Option<[Option<f64>; 3]>,
    metal: [usize; 4],
    /// Part ids (IndexMA), valid, diffuse, kd, true kd, σ, true σ, metallic (predicted, true).
    parts: Option<PartMaps>,
    /// What the kd error map is drawn from: the view, kd, true kd, the valid pixels.
    kd_error: (usize, Image, Image, Vec<bool>),
}

type PartMaps = (
    Vec<i64>,
    Vec<bool>,
    Vec<bool>,
    [Vec<Vec3>; 4],
    Option<(Vec<Vec3>, Vec<Vec3>)>,
);

impl ViewScore {
    /// Adds this view's scores to its split's, after the views before it.
    fn add_to(self, acc: &mut SplitScores) {
        for (a, b) in acc.metal.iter_mut().zip(self.metal) {
            *a += b;
        }
        acc.roughness_constant.push(self.roughness_constant);
        if let Some((ids, valid, diffuse, [kd, kd_gt, sigma, sigma_gt], m)) = &self.parts {
            acc.parts.add(&ViewMaps {
                ids,
                valid,
                diffuse,
                kd,
                kd_gt,
                sigma,
                sigma_gt,
                metallic: m.as_ref().map(|(p, g)| (&p[..], &g[..])),
            });
        }
        if let Some([kd, sigma, share]) = self.observed {
            acc.kd_observed.push(kd);
            acc.roughness_observed.push(sigma);
            acc.observed_share.push(share);
        }
        acc.render.push(self.render);
        acc.render_raw.push(self.render_raw);
        acc.kd.push(self.kd);
        acc.albedo.push(self.albedo);
        acc.roughness.push(self.roughness);
        acc.iou.push(self.iou);
        acc.log_l2.push(Some(self.log_l2));
        acc.rows.push(self.row);
    }
}

/// Scores view `v` of a split (None for a view without kd and σ ground truth).
fn score_view(at: &SplitAt, v: &fipt_core::dataset::View) -> Result<Option<ViewScore>> {
    let (ds, s, dir) = (at.ds, at.split, at.dir);
    let k = v.index;
    let pred = |name: &str| -> Result<Image> {
        let p = dir.join(format!("{k:03}_{name}.exr"));
        let img = Image::read_exr(&p)
            .with_context(|| format!("reading {} (run `fipt run` first)", p.display()))?;
        finite_map(same_size(img, ds, &p)?, &p)
    };
    // A ground-truth folder with files missing was left out when the scene was opened (with
    // a warning); a file present but unreadable, of another size or with NaN is an error here,
    // not a view silently left unscored.
    let gt = |kind: GtKind| -> Result<Option<Image>> {
        let path = s.gt_path(kind, k);
        let read = ds.load_gt(s, kind, k).with_context(|| {
            format!(
                "reading the ground truth {} (fix the file, or remove its folder {} to score without it)",
                path.display(),
                kind.folder()
            )
        })?;
        let Some(img) = read else {
            return Ok(None);
        };
        same_size(img, ds, &path).map(Some)
    };
    let (Some(kd_gt), Some(r_gt)) = (gt(GtKind::DiffCol)?, gt(GtKind::Roughness)?) else {
        return Ok(None);
    };
    let emit_gt = gt(GtKind::Emit)?;
    let mut kd = pred("kd")?;
    for p in &mut kd.data {
        *p *= at.scales.kd;
    }
    let ks = pred("ks")?;
    let rough = pred("roughness")?;
    let emis = pred("emission")?;
    let n = kd.data.len();
    let is_emit = |i: usize| {
        emit_gt
            .as_ref()
            .is_some_and(|e| e.data[i].element_sum() > 0.0)
    };
    let valid: Vec<bool> = (0..n)
        .map(|i| !is_emit(i) && r_gt.data[i].x > 0.0)
        .collect();
    // kd over GT-diffuse pixels (method §6): metals' kd is 0 by definition.
    let m_gt = gt(GtKind::Metallic)?;
    let diffuse: Vec<bool> = (0..n)
        .map(|i| valid[i] && m_gt.as_ref().is_none_or(|m| m.data[i].x < 0.5))
        .collect();
    let kd_clamped: Vec<Vec3> = kd
        .data
        .iter()
        .map(|v| v.clamp(Vec3::ZERO, Vec3::ONE))
        .collect();
    let kd_q8: Vec<Vec3> = kd_gt.data.iter().map(|&v| q8(v)).collect();
    let kd_p = psnr(&kd_clamped, &kd_q8, Some(&diffuse), 1.0);
    let alb_p = gt(GtKind::Albedo)?.and_then(|a| albedo_psnr(&kd, &ks, &a, &valid));
    let m = m_gt.as_ref().map(|_| pred("metallic")).transpose()?;
    let metallic = m_gt
        .as_ref()
        .zip(m.as_ref())
        .map(|(g, p)| (&p.data[..], &g.data[..]));
    let mut metal = [0; 4];
    if let Some((p, g)) = metallic {
        count_metal(&mut metal, &valid, p, g);
    }
    let cl = |v: Vec3| Vec3::splat(v.x.clamp(0.2, 1.0));
    let r_pred: Vec<Vec3> = rough.data.iter().map(|&v| cl(v)).collect();
    let r_true: Vec<Vec3> = r_gt.data.iter().map(|&v| cl(q8(v))).collect();
    let r_p = psnr(&r_pred, &r_true, Some(&valid), 1.0);
    let r_const = psnr(&[Vec3::ONE].repeat(n), &r_true, Some(&valid), 1.0);
    let maps = ViewMaps {
        ids: &[],
        valid: &valid,
        diffuse: &diffuse,
        kd: &kd_clamped,
        kd_gt: &kd_q8,
        sigma: &r_pred,
        sigma_gt: &r_true,
        metallic,
    };
    let observed = score_observed(at, k, &maps)?;
    let ids = ds.load_ids(s, GtKind::IndexMA, k)?;
    let (iou, log2) = emission_scores(&emis, emit_gt.as_ref());
    let scale = [at.display, at.scales.radiance];
    let render_p = render_score(ds, v, dir, scale, &s.name, "render")?;
    // The re-render before denoising, where it was kept.
    let raw_p = render_score(ds, v, dir, scale, &s.name, "render_raw")?;
    let log_l2 = log2 / (3 * n) as f64;
    let kd_error = (k, kd, kd_gt, valid.clone());
    let metallic = m_gt.zip(m).map(|(g, p)| (p.data, g.data));
    let parts = ids.map(|ids| {
        (
            ids,
            valid,
            diffuse,
            [kd_clamped, kd_q8, r_pred, r_true],
            metallic,
        )
    });
    Ok(Some(ViewScore {
        row: serde_json::json!({"view": k, "kd_psnr": kd_p, "albedo_psnr": alb_p, "roughness_psnr": r_p, "emission_iou": iou, "emission_log_l2": log_l2, "render_psnr": render_p, "render_raw_psnr": raw_p}),
        kd: kd_p,
        albedo: alb_p,
        roughness: r_p,
        roughness_constant: r_const,
        iou,
        log_l2,
        render: render_p,
        render_raw: raw_p,
        observed,
        metal,
        parts,
        kd_error,
    }))
}

/// PSNR of kd + ks (clamped to [0, 1]) against the albedo ground truth on the valid pixels.
fn albedo_psnr(kd: &Image, ks: &Image, truth: &Image, valid: &[bool]) -> Option<f64> {
    let pa: Vec<Vec3> = kd
        .data
        .iter()
        .zip(&ks.data)
        .map(|(a, b)| (*a + *b).clamp(Vec3::ZERO, Vec3::ONE))
        .collect();
    let q: Vec<Vec3> = truth.data.iter().map(|&v| q8(v)).collect();
    psnr(&pa, &q, Some(valid), 1.0)
}

/// kd and σ on observed pixels: surface cells that at least OBSERVED_MIN training pixels saw
/// (`_observed.exr` of `fipt run`), where the run wrote one.
fn score_observed(at: &SplitAt, k: usize, maps: &ViewMaps) -> Result<Option<[Option<f64>; 3]>> {
    let obs_path = at.dir.join(format!("{k:03}_observed.exr"));
    if !obs_path.is_file() {
        return Ok(None);
    }
    let o =
        Image::read_exr(&obs_path).with_context(|| format!("reading {}", obs_path.display()))?;
    let o = same_size(o, at.ds, &obs_path)?;
    let n = maps.valid.len();
    let seen = |i: usize| o.data[i].x >= OBSERVED_MIN;
    let od: Vec<bool> = (0..n).map(|i| maps.diffuse[i] && seen(i)).collect();
    let ov: Vec<bool> = (0..n).map(|i| maps.valid[i] && seen(i)).collect();
    let nv = maps.valid.iter().filter(|&&v| v).count();
    Ok(Some([
        psnr(maps.kd, maps.kd_gt, Some(&od), 1.0),
        psnr(maps.sigma, maps.sigma_gt, Some(&ov), 1.0),
        (nv > 0).then(|| ov.iter().filter(|&&v| v).count() as f64 / nv as f64),
    ]))
}

/// Adds a view's metal pixels (true metallic ≥ 0.5) and those predicted ≥ 0.8, and its
/// dielectric pixels and those predicted > 0.1, to `metal`, over the `valid` pixels.
fn count_metal(metal: &mut [usize; 4], valid: &[bool], pred: &[Vec3], truth: &[Vec3]) {
    for i in (0..valid.len()).filter(|&i| valid[i]) {
        let (g, p) = (truth[i].x, pred[i].x);
        if g >= 0.5 {
            metal[0] += 1;
            metal[1] += usize::from(p >= 0.8);
        } else {
            metal[2] += 1;
            metal[3] += usize::from(p > 0.1);
        }
    }
}

/// Where [`write_kd_error`] writes view `k`'s map.
fn error_map_path(out: &Path, split: &str, k: usize) -> std::path::PathBuf {
    out.join("eval")
        .join(split)
        .join(format!("{k:03}_kd_error_x4.png"))
}

/// Writes `OUT/eval/<split>/{k:03}_kd_error_x4.png`: |kd − kd_gt|·4 on the scored pixels.
fn write_kd_error(
    out: &Path,
    split: &str,
    k: usize,
    kd: &Image,
    kd_gt: &Image,
    valid: &[bool],
) -> Result<()> {
    let data = (0..kd.data.len())
        .map(|i| {
            if valid[i] {
                (kd.data[i] - kd_gt.data[i]).abs() * 4.0
            } else {
                Vec3::ZERO
            }
        })
        .collect();
    let err = Image {
        width: kd.width,
        height: kd.height,
        data,
    };
    err.write_png(&error_map_path(out, split, k), 1.0)?;
    Ok(())
}

/// `fipt eval`: evaluates the outputs in `out` against `scene`'s ground truth, after checking
/// that they are of this scene; writes and returns `metrics.json`.
pub fn evaluate_run(scene: &Path, out: &Path) -> Result<serde_json::Value> {
    let ds = Dataset::open_with(scene, fipt_capture::scene::run_open_options(out))
        .with_context(|| format!("opening scene {}", scene.display()))?;
    if !ds.splits.iter().any(|s| s.has_gt(GtKind::DiffCol)) {
        crate::bail!(
            "{}: no ground truth (DiffCol/) to evaluate against",
            scene.display()
        );
    }
    // The outputs must be of this scene: `report.json` holds the inputs' fingerprint. Without
    // it nothing says where the maps came from: refused, never scored blind.
    let report = out.join("report.json");
    let r: serde_json::Value = fipt_core::fsutil::read_json(&report).with_context(|| {
        format!(
            "{} cannot be checked against {}: a finished `fipt run` writes it with the scene's fingerprint (run `fipt run {} --out {}` again to restore it; finished stages are reused)",
            report.display(),
            scene.display(),
            scene.display(),
            out.display()
        )
    })?;
    let here = crate::scene::inputs_hash(&ds)?;
    match r["inputs_hash"].as_str() {
        Some(there) if there != here => crate::bail!(
            "{} was made from another scene (inputs fingerprint {there}, {} has {here}): evaluate it against the scene it came from",
            out.display(),
            scene.display()
        ),
        Some(_) => {}
        None => crate::bail!(
            "{}: the run is not finished (status {}): run `fipt run` to the end first",
            report.display(),
            r["status"].as_str().unwrap_or("unknown")
        ),
    }
    let exposure = r["exposure_scale"].as_f64().unwrap_or(1.0) as f32;
    evaluate(&ds, out, exposure)
}

/// The closure of shadings against the training views: mean over views of the sRGB PSNR of
/// kd·Ld + ks·Ls0(σ) + Ls1(σ) with the ground-truth materials, off the emitters (None without
/// ground truth). It measures the shadings alone: exact shadings reproduce the views but for
/// the renderer's noise. Over the hit pixels `draw` draws (those the run reads).
pub fn closure_psnr(
    scene: &crate::scene::SceneRef,
    sh: &dyn fipt_bake::bake_store::ShadingViews,
    draw: &fipt_core::shading::PixelDraw,
) -> Result<Option<f64>> {
    let ds = &scene.ds;
    let split = ds.train();
    if ![
        GtKind::DiffCol,
        GtKind::Specular,
        GtKind::Roughness,
        GtKind::Emit,
    ]
    .iter()
    .all(|&k| split.has_gt(k))
    {
        return Ok(None);
    }
    let mut sum = 0.0;
    for k in 0..sh.count() {
        let s = sh.get(k)?;
        let v = &split.views[k];
        let g = |kind| {
            ds.load_gt(split, kind, v.index)
                .map(|x| x.expect("present"))
        };
        let (kd, ks, ro, le) = (
            g(GtKind::DiffCol)?,
            g(GtKind::Specular)?,
            g(GtKind::Roughness)?,
            g(GtKind::Emit)?,
        );
        let pred: Vec<Vec3> = (0..kd.data.len())
            .map(|i| s.reflected(i, kd.data[i], ks.data[i], ro.data[i].x))
            .collect();
        let mask: Vec<bool> = (0..kd.data.len())
            .map(|i| s.valid[i] && le.data[i].max_element() <= 0.0 && draw.keeps(k, i))
            .collect();
        sum +=
            fipt_core::metrics::srgb_psnr(&pred, &scene.images[k].data, Some(&mask)).unwrap_or(0.0);
    }
    Ok(Some(sum / sh.count() as f64))
}

#[cfg(test)]
mod tests {
    use super::{mean, median};

    #[test]
    fn median_ignores_missing_and_non_finite_views_and_resists_an_outlier() {
        let v = [Some(10.0), None, Some(12.0), Some(f64::NAN), Some(98.0)];
        assert_eq!(median(&v), Some(12.0));
        assert_eq!(mean(&v), Some(40.0));
        assert_eq!(median(&[Some(10.0), Some(11.0)]), Some(10.5));
        assert_eq!(median(&[None, Some(f64::INFINITY)]), None);
    }
}
