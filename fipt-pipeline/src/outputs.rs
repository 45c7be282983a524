//! What every method's run writes: the stage records, the report's shared parts, the emitters
//! (JSON, OBJ), per-view maps and path-traced re-renders.
use crate::error::Result;
use crate::observe::Stage;
use crate::request::RunRequest;
use crate::run_config::RunConfig;
use fipt_core::emitter::{Emitter, EmitterExtractor, EmitterInputs, PixelHit, PixelHits};
use fipt_core::fsutil::{read_json, write_bytes_atomic, write_json_atomic};
use fipt_core::image::ExrPrecision;
use fipt_core::shading::PixelDraw;
use fipt_shading::records::HitPoint;
use fipt_shading::render::RenderConfig;
use fipt_shading::scene::Scene as RenderScene;
use glam::Vec3;
use serde::Serialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

impl StageReport {
    /// The stage `stage` that started at `t`, ending now; the heap's free pages go back to the
    /// system (glibc's malloc) and the peak restarts here, so that the next stage's peak is
    /// its own.
    pub fn since(stage: &'static str, t: std::time::Instant) -> Self {
        let peak_rss_mib = fipt_core::memory::peak_rss_mib();
        fipt_core::memory::release_free_memory();
        fipt_core::memory::reset_peak_rss();
        let seconds = t.elapsed().as_secs_f64();
        let reused = crate::observe::take_reused();
        StageReport {
            stage,
            seconds,
            peak_rss_mib,
            reused: reused.is_some(),
            computed_seconds: reused.map_or(Some(seconds), |s| s.is_finite().then_some(s)),
        }
    }

    /// The run's peak RSS: the largest of its stages' (`report.json`'s `peak_rss_mib`). Each
    /// stage resets the kernel's high-water mark, so `/usr/bin/time` shows only the last
    /// stage's.
    pub fn run_peak(stages: &[StageReport]) -> Option<f64> {
        stages
            .iter()
            .filter_map(|s| s.peak_rss_mib)
            .reduce(f64::max)
    }
}

/// A stage's wall time and the process's peak memory while it ran (since the stage before it
/// ended: the largest over the stages is the run's peak). An allocator that keeps freed
/// memory for reuse (the `fipt` binary's mimalloc does) keeps the resident size from falling,
/// so a stage's figure is then at least the resident size it started from.
#[derive(Clone, Debug, Serialize)]
pub struct StageReport {
    pub stage: &'static str,
    /// This invocation's time (a fraction of a second for a reused stage).
    pub seconds: f64,
    pub peak_rss_mib: Option<f64>,
    /// Whether the stage's result came from an earlier run of the folder.
    pub reused: bool,
    /// The time the result took to compute: `seconds`, or for a reused stage the earlier
    /// run's (null when not recorded).
    pub computed_seconds: Option<f64>,
}

/// The time all `stages` took to compute, reused ones at their earlier run's time (None when
/// one of those was not recorded).
pub(crate) fn computed_total(stages: &[StageReport]) -> Option<f64> {
    stages.iter().map(|s| s.computed_seconds).sum()
}

/// Whether the scene has ground truth to evaluate against (`DiffCol/` in a split).
pub fn has_ground_truth(ds: &fipt_core::dataset::Dataset) -> bool {
    ds.splits
        .iter()
        .any(|s| s.has_gt(fipt_core::dataset::GtKind::DiffCol))
}

/// The scene's capture warnings, and a loud one when no emitter was found in views that have
/// clipped or very bright regions.
pub(crate) fn run_warnings(scene: &crate::scene::LoadedScene, emitters: &[Emitter]) -> Vec<String> {
    let mut warnings = scene.capture.warnings.clone();
    if let Some(w) = no_light_warning(scene, emitters) {
        crate::note!("WARNING: {w}");
        warnings.push(w);
    }
    warnings
}

/// `fipt eval` of the outputs in `out` (the `eval` stage) when the scene has ground truth.
pub(crate) fn evaluate_if_gt(
    scene: &crate::scene::LoadedScene,
    out: &Path,
    evaluator: Option<&crate::components::Evaluator>,
    mark: &mut dyn FnMut(&'static str, std::time::Instant),
) -> Result<Option<serde_json::Value>> {
    if !has_ground_truth(&scene.ds) {
        return Ok(None);
    }
    let Some(evaluate) = evaluator else {
        crate::note!(
            "warning: the scene has ground truth but no evaluator is registered (`fipt_eval::register`): metrics.json not written"
        );
        return Ok(None);
    };
    let t = crate::observe::begin("eval");
    let m = evaluate(&scene.ds, out, scene.exposure)?;
    mark("eval", t);
    Ok(Some(m))
}

/// Writes `report.json` as a run's status while it has none to give (`running`, or `failed`
/// with the error): a finished run's report replaces it (`status: complete`).
pub(crate) fn mark_status(
    out: &Path,
    scene: &Path,
    status: &str,
    error: Option<String>,
) -> Result<()> {
    mark_status_after(out, scene, status, error, &[])
}

/// [`mark_status`] with the stages done so far (a run stopped where asked keeps their times
/// and peak memory).
pub(crate) fn mark_status_after(
    out: &Path,
    scene: &Path,
    status: &str,
    error: Option<String>,
    stages: &[StageReport],
) -> Result<()> {
    let mut r = serde_json::json!({
        "fipt_version": env!("CARGO_PKG_VERSION"),
        "status": status,
        "scene": scene,
    });
    if let Some(e) = error {
        r["error"] = serde_json::json!(e);
    }
    if !stages.is_empty() {
        r["stages"] = serde_json::json!(stages);
        r["peak_rss_mib"] = serde_json::json!(StageReport::run_peak(stages));
    }
    fipt_core::fsutil::write_json_atomic(&out.join("report.json"), &r)?;
    Ok(())
}

/// The part of `report.json` every method writes: version, scene, preset, settings (the host's
/// and those of the components the run used), the size of the inputs, the stages' times and
/// the whole run's, and the run's peak RSS ([`StageReport::run_peak`]).
pub(crate) fn report_header(
    a: &RunRequest,
    scene: &crate::scene::LoadedScene,
    settings: serde_json::Value,
    stages: &[StageReport],
    t_all: std::time::Instant,
) -> serde_json::Value {
    serde_json::json!({
        "stages": stages,
        "seconds_total": t_all.elapsed().as_secs_f64(),
        "stages_reused": stages.iter().filter(|s| s.reused).count(),
        "seconds_computed_total": computed_total(stages),
        "peak_rss_mib": StageReport::run_peak(stages),
        "fipt_version": env!("CARGO_PKG_VERSION"),
        "status": "complete",
        "scene": a.scene,
        "inputs_hash": scene.inputs_hash,
        "preset": a.preset,
        "settings": settings,
        "inputs": {
            "train_views": scene.ds.train().views.len(),
            "width": scene.ds.width,
            "height": scene.ds.height,
            "triangles": scene.geometry.mesh.triangles.len(),
        },
        "capture": scene.capture,
    })
}

/// The loud warning of a run that found no light while its views have clipped or very bright
/// pixels: its re-renders will be black and its materials wrong, and the report must say why.
pub(crate) fn no_light_warning(
    scene: &crate::scene::LoadedScene,
    emitters: &[Emitter],
) -> Option<String> {
    if !emitters.is_empty() {
        return None;
    }
    let c = &scene.capture.check;
    let mut lum: Vec<f32> = scene
        .images
        .iter()
        .flat_map(|i| i.data.iter().step_by(3))
        .map(|&p| fipt_core::color::luminance(p))
        .collect();
    let median = fipt_core::image::median(&mut lum);
    let k = (lum.len() as f64 * 0.999) as usize;
    let top = if k < lum.len() {
        *lum.select_nth_unstable_by(k, f32::total_cmp).1
    } else {
        0.0
    };
    let bright = median > 0.0 && top > 20.0 * median;
    if c.clipped_share == 0.0 && !bright {
        return None;
    }
    Some(format!(
        "NO LIGHT FOUND, yet {:.2} % of the training pixels are at the clip level ({} views clip{}) and the brightest 0.1 % are {:.1}× the median: \
         the lights are probably there but clipped or unexplained; the re-renders will be dark and the materials too bright. \
         Give HDR views (EXR) or photos at a shorter exposure where the lights do not clip, or check the emitter settings ([emitters])",
        100.0 * c.clipped_share,
        c.clipped_views.len(),
        if c.ldr { ", the views are LDR" } else { "" },
        if median > 0.0 { top / median } else { 0.0 }
    ))
}

/// Adds the keys of the object `more` to the object `report`.
pub(crate) fn extend(report: &mut serde_json::Value, more: serde_json::Value) {
    if let (Some(r), serde_json::Value::Object(m)) = (report.as_object_mut(), more) {
        r.extend(m);
    }
}

/// A light no brighter than 4× the views' median (at the working exposure) is as bright as a
/// lit wall: it may be a surface explaining light from an emitter no view sees.
pub(crate) const DOUBTFUL_LUMINANCE: f32 = 4.0 * fipt_core::image::CANONICAL_MEDIAN;

/// The ids and radiance of the lights (at the working exposure) that are doubtful.
pub(crate) fn doubtful_emitters(emitters: &[Emitter]) -> Vec<serde_json::Value> {
    emitters
        .iter()
        .enumerate()
        .filter_map(|(i, e)| {
            let l = fipt_core::color::luminance(glam::Vec3::from(e.mean_radiance));
            (l < DOUBTFUL_LUMINANCE).then(|| {
                crate::note!(
                    "warning: light {i} is no brighter than a lit surface ({l:.2} at the working exposure, where the views' median is {}): it may be a surface explaining light from an emitter no view sees",
                    fipt_core::image::CANONICAL_MEDIAN
                );
                serde_json::json!({"id": i, "luminance": l, "why": "no brighter than 4× the views' median luminance: possibly a lit surface explaining an emitter no view sees"})
            })
        })
        .collect()
}

/// One summary per light, as `report.json` lists them.
pub(crate) fn emitters_summary(emitters: &[Emitter]) -> Vec<serde_json::Value> {
    emitters
        .iter()
        .map(|e| {
            serde_json::json!({
                "triangles": e.triangles.len(), "area": e.area, "mean_radiance": e.mean_radiance,
                "power": e.power, "centroid": e.centroid, "pixels": e.pixels,
            })
        })
        .collect()
}

/// The recovered scene the maps and re-renders come from.
pub(crate) struct Recovered<'a> {
    pub field: &'a dyn fipt_core::field::MaterialField,
    pub emitters: &'a [Emitter],
    /// What identifies the field (its training's fingerprint); None: unknown or `--force`,
    /// every view is re-rendered.
    pub id: Option<String>,
}

/// What the re-renders of a run folder are a function of, and which views are done
/// (`views/render.json`, rewritten after each view: a killed run re-renders only the rest).
#[derive(Serialize, serde::Deserialize)]
struct RenderProgress {
    key: String,
    done: Vec<(String, usize)>,
    /// Each done view's `_render.exr` content hash by "split/k": a file changed since is
    /// rendered again (absent in files written before it existed: not checked).
    #[serde(default)]
    hashes: std::collections::BTreeMap<String, String>,
    /// Seconds each done view took to render, by "split/k" (absent in files written before
    /// it existed).
    #[serde(default)]
    seconds: std::collections::BTreeMap<String, f64>,
}

impl RenderProgress {
    /// Whether view `k` of `split` is done and its file `exr` is the one written.
    fn has(&self, split: &str, k: usize, exr: &Path) -> bool {
        if !(self.done.iter().any(|d| d.0 == split && d.1 == k) && exr.is_file()) {
            return false;
        }
        let Some(h) = self.hashes.get(&format!("{split}/{k}")) else {
            return true;
        };
        let now = fipt_core::fsutil::hash_files(&[exr.to_path_buf()]).unwrap_or_default();
        if &now != h {
            crate::note!(
                "warning: {} was changed after it was rendered (content hash {now}, recorded {h}): rendering it again",
                exr.display()
            );
        }
        &now == h
    }
}

/// The stages every method ends with: per-view maps of every split (`maps`) and path-traced
/// re-renders of every view from the recovered scene (`re-render`), skipping the views a
/// previous run rendered from the same field, lights and settings.
pub(crate) fn write_views(
    scene: &crate::scene::LoadedScene,
    cfg: &RunConfig,
    out: &Path,
    recovered: Recovered,
    observed: Option<&fipt_search::CellCounts>,
    mark: &mut dyn FnMut(&'static str, std::time::Instant),
) -> Result<()> {
    let Recovered {
        field, emitters, ..
    } = recovered;
    let t = crate::observe::begin("maps");
    let st = Stage::start("maps");
    let mut emission_of: HashMap<u32, Vec3> = HashMap::new();
    for e in emitters {
        for (t, l) in e.triangles.iter().zip(&e.radiance) {
            emission_of.insert(*t, Vec3::from(*l));
        }
    }
    for s in &scene.ds.splits {
        let dir = out.join("views").join(&s.name);
        let views = crate::maps::mapped_views(scene, &cfg.render, s, &dir)?;
        crate::maps::export_views(
            field,
            &scene.geometry,
            &views,
            None,
            Some(&emission_of),
            observed,
            scene.exposure,
            &dir,
        )?;
    }
    st.done();
    mark("maps", t);

    if cfg.render.spp > 0 {
        let t = crate::observe::begin("re-render");
        let st = Stage::start("re-render");
        re_render(scene, cfg, out, &recovered)?;
        st.done();
        mark("re-render", t);
    }
    let t = crate::observe::begin("light ends");
    let n = crate::light_ends::write(scene, out, crate::report::VIEWS)?;
    if n > 0 {
        crate::note!("kd at the ends of the unpinned lights' ranges: {n} maps");
        mark("light ends", t);
    }
    Ok(())
}

impl RenderProgress {
    /// The views already re-rendered in `out` from the same recovered scene and settings
    /// (none when the field is not identified).
    fn open(
        scene: &crate::scene::LoadedScene,
        cfg: &RunConfig,
        out: &Path,
        recovered: &Recovered,
    ) -> Option<RenderProgress> {
        let id = recovered.id.as_ref()?;
        let what = serde_json::json!({ "render": cfg.render, "model": cfg.model.brdf });
        let lights = serde_json::to_vec(recovered.emitters).unwrap_or_default();
        let key = format!(
            "{}|{id}|{}|{}",
            scene.cache_key,
            fipt_core::fsutil::hash_json(&what),
            fipt_core::fsutil::hash_bytes(&lights)
        );
        let done = read_json::<RenderProgress>(&out.join("views").join("render.json"))
            .ok()
            .filter(|p| p.key == key)
            .map_or(Default::default(), |p| (p.done, p.hashes, p.seconds));
        Some(RenderProgress {
            key,
            done: done.0,
            hashes: done.1,
            seconds: done.2,
        })
    }
}

/// Path-traces every view not already rendered (`progress`) from the recovered scene.
fn re_render(
    scene: &crate::scene::LoadedScene,
    cfg: &RunConfig,
    out: &Path,
    recovered: &Recovered,
) -> Result<()> {
    let chosen = rendered_views(scene, cfg, out)?;
    let total = chosen.len();
    let progress_path = out.join("views").join("render.json");
    let mut progress = RenderProgress::open(scene, cfg, out, recovered);
    let is_done = |p: &Option<RenderProgress>, split: &str, k: usize, exr: &Path| {
        p.as_ref().is_some_and(|p| p.has(split, k, exr))
    };
    let exr_of = |split: &str, k: usize| {
        out.join("views")
            .join(split)
            .join(format!("{k:03}_render.exr"))
    };
    let done: std::collections::HashSet<(String, usize)> = (chosen.iter())
        .filter(|(s, k)| is_done(&progress, s, *k, &exr_of(s, *k)))
        .cloned()
        .collect();
    let reused = done.len();
    if reused > 0 {
        crate::note!(
            "reusing {reused} of {total} re-rendered views (same field, lights and settings); --force to redo them"
        );
    }
    if reused == total {
        // The render time of every view, when each was recorded.
        let seconds = progress
            .as_ref()
            .and_then(|p| (p.seconds.len() == total).then(|| p.seconds.values().sum::<f64>()));
        crate::observe::reused(seconds);
        return Ok(());
    }
    let views: Vec<_> = scene
        .ds
        .splits
        .iter()
        .flat_map(|s| s.views.clone())
        .collect();
    let surfaces = crate::recovered::surfaces(
        &scene.geometry,
        &views,
        recovered.field,
        recovered.emitters,
        cfg.model.brdf,
    )?;
    let rscene = RenderScene::new(scene.geometry.mesh.clone(), surfaces);
    let pb = crate::observe::bar(total as u64, "re-render");
    let (mut rays, mut traced, mut stage) = (0u64, 0f64, 0f64);
    for (si, s) in scene.ds.splits.iter().enumerate() {
        let dir = out.join("views").join(&s.name);
        let rc = RenderConfig {
            spp: if s.name == scene.ds.train().name || cfg.render.val_spp == 0 {
                cfg.render.spp
            } else {
                cfg.render.val_spp
            },
            max_bounces: cfg.render.max_bounces,
            seed: cfg.render.seed,
            ..Default::default()
        };
        let at = ReRenderAt {
            rscene: &rscene,
            rc: &rc,
            denoise: cfg.render.denoise,
            exposure: scene.exposure,
            dir: &dir,
        };
        for v in &s.views {
            let k = v.index;
            let exr = exr_of(&s.name, k);
            if !chosen.contains(&(s.name.clone(), k)) {
                continue;
            }
            pb.inc(1);
            if done.contains(&(s.name.clone(), k)) {
                continue;
            }
            let key = ((si as u64) << 32) + v.index as u64;
            let t_view = std::time::Instant::now();
            let stats = re_render_view(&at, v, key, &exr)?;
            (rays, traced) = (rays + stats.rays, traced + stats.seconds);
            stage += t_view.elapsed().as_secs_f64();
            if let Some(p) = &mut progress {
                p.done.retain(|d| !(d.0 == s.name && d.1 == k));
                p.done.push((s.name.clone(), k));
                let h = fipt_core::fsutil::hash_files(std::slice::from_ref(&exr))?;
                p.hashes.insert(format!("{}/{k}", s.name), h);
                (p.seconds).insert(format!("{}/{k}", s.name), t_view.elapsed().as_secs_f64());
                write_json_atomic(&progress_path, p)?;
            }
        }
    }
    pb.finish_and_clear();
    if rays > 0 {
        crate::note!(
            "re-render: {:.2} Mrays/s traced ({rays} closest-hit and shadow rays in {traced:.1} s of path tracing; {:.2} Mrays/s over the {stage:.1} s of its views with denoising and writing); `fipt bench --suite bake --scene SCENE` gives the BVH's raw incoherent rate",
            rays as f64 / traced.max(1e-9) / 1e6,
            rays as f64 / stage.max(1e-9) / 1e6
        );
    }
    Ok(())
}

/// The (split, view) pairs the re-render covers: every view but the training views beyond
/// `render.train_pixels` ([`crate::run_config::ReRenderConfig::train_views`]), said so; the
/// re-renders a previous run left of the others are removed (they would be another field's).
fn rendered_views(
    scene: &crate::scene::LoadedScene,
    cfg: &RunConfig,
    out: &Path,
) -> Result<std::collections::HashSet<(String, usize)>> {
    let mut chosen = std::collections::HashSet::new();
    for s in &scene.ds.splits {
        let keep = crate::maps::kept_views(scene, &cfg.render, s);
        for (v, keep) in s.views.iter().zip(&keep) {
            if *keep {
                chosen.insert((s.name.clone(), v.index));
                continue;
            }
            let dir = out.join("views").join(&s.name);
            for suffix in ["render", "render_raw"] {
                for p in [
                    dir.join(format!("{:03}_{suffix}.exr", v.index)),
                    dir.join("preview")
                        .join(format!("{:03}_{suffix}.png", v.index)),
                ] {
                    if p.is_file() {
                        std::fs::remove_file(&p).map_err(|e| fipt_core::CoreError::io(&p, e))?;
                    }
                }
            }
        }
        let n = keep.iter().filter(|k| **k).count();
        if n < s.views.len() {
            crate::note!(
                "re-render: {n} of {} {} views, evenly spaced (render.train_pixels = {}; 0 for every one)",
                s.views.len(),
                s.name,
                cfg.render.train_pixels
            );
        }
    }
    Ok(chosen)
}

/// Where and how a run's views are re-rendered.
struct ReRenderAt<'a, S: fipt_shading::scene::SurfaceModel> {
    rscene: &'a RenderScene<S>,
    rc: &'a RenderConfig,
    denoise: bool,
    exposure: f32,
    dir: &'a Path,
}

/// Renders view `v` (stream `key`), denoised unless switched off, and writes `exr`, the raw
/// render beside it and their previews; returns the rays its paths cast.
fn re_render_view<S: fipt_shading::scene::SurfaceModel>(
    at: &ReRenderAt<S>,
    v: &fipt_core::dataset::View,
    key: u64,
    exr: &Path,
) -> Result<fipt_shading::render::RenderStats> {
    let (k, dir) = (v.index, at.dir);
    let dn = fipt_shading::denoise::DenoiseConfig {
        passes: if at.denoise { 5 } else { 0 },
        ..Default::default()
    };
    let (mut img, mut raw, stats) =
        fipt_shading::denoise::render_denoised(at.rscene, &v.camera, at.rc, key, &dn, &|_| {});
    img.write_png(&dir.join("preview").join(format!("{k:03}_render.png")), 1.0)?;
    for p in img.data.iter_mut().chain(raw.data.iter_mut()) {
        *p *= at.exposure;
    }
    let raw_exr = dir.join(format!("{k:03}_render_raw.exr"));
    if at.denoise {
        raw.write_exr(&raw_exr, ExrPrecision::F32)?;
        let png = dir.join("preview").join(format!("{k:03}_render_raw.png"));
        raw.write_png(&png, 1.0 / at.exposure)?;
    } else if raw_exr.is_file() {
        // Denoising turned off: `_render.exr` is the raw render, a raw file beside it would
        // be an older render's.
        std::fs::remove_file(&raw_exr).map_err(|e| fipt_core::CoreError::io(&raw_exr, e))?;
    }
    img.write_exr(exr, ExrPrecision::F32)?;
    Ok(stats)
}

/// What each pixel of one view could at most reflect under its shadings (a white surface,
/// kd = ks = 1, at the roughness level that reflects most): Ld + max Ls0 + max Ls1; None where
/// the shadings are not valid.
pub(crate) fn max_reflected_view(sh: &fipt_core::shading::ViewShadings) -> Vec<Option<Vec3>> {
    let m =
        |x: &[Vec3; fipt_core::shading::NUM_LEVELS]| x.iter().fold(Vec3::ZERO, |a, b| a.max(*b));
    (0..sh.ld.len())
        .map(|i| sh.valid[i].then(|| sh.ld[i] + m(&sh.ls0[i]) + m(&sh.ls1[i])))
        .collect()
}

/// Emitter extraction from the field's mask and the training pixels (with what the initial
/// shadings say each pixel could at most reflect, [`max_reflected_view`]). The pixels are built
/// one view at a time as the extractor visits them ([`TrainingHits`]).
pub fn extract_emitters(
    scene: &crate::scene::SceneRef,
    records: &[Vec<Option<HitPoint>>],
    field: &dyn fipt_core::field::MaterialField,
    shadings: Option<(&dyn fipt_bake::bake_store::ShadingViews, PixelDraw)>,
    extractor: &dyn EmitterExtractor,
) -> Result<Vec<Emitter>> {
    let hits = TrainingHits {
        scene: *scene,
        records,
        shadings,
    };
    let emitters = extractor.extract(&EmitterInputs {
        positions: scene.positions,
        triangles: scene.triangles,
        field,
        pixel_hits: &hits,
    })?;
    for n in extractor.notes() {
        crate::note!("emitters: {n}");
    }
    Ok(emitters)
}

/// The training pixels that hit the mesh, built view by view when visited: a scene's pixels
/// are never held all at once (52 bytes each: 3.2 GB for 200 views of 640×480).
struct TrainingHits<'a> {
    scene: crate::scene::SceneRef<'a>,
    records: &'a [Vec<Option<HitPoint>>],
    /// The initial shadings, for each pixel's bound on reflected light, at the pixels drawn
    /// (those the run reads: the bound is the same whether the bake holds more).
    shadings: Option<(&'a dyn fipt_bake::bake_store::ShadingViews, PixelDraw)>,
}

impl PixelHits for TrainingHits<'_> {
    fn visit(&self, f: &mut dyn FnMut(&PixelHit)) -> fipt_core::Result<()> {
        let (positions, triangles) = (self.scene.positions, self.scene.triangles);
        let views = &self.scene.ds.train().views;
        for (v, (recs, img)) in self.records.iter().zip(self.scene.images).enumerate() {
            let (most, draw) = match self.shadings {
                Some((s, draw)) => (Some(max_reflected_view(&*s.get(v)?)), draw),
                None => (None, PixelDraw::ALL),
            };
            let eye = views.get(v).map(|view| view.camera.origin);
            let w = img.width.max(1);
            for (i, (r, l)) in recs.iter().zip(&img.data).enumerate() {
                let Some(r) = r else {
                    continue;
                };
                // The winding normal against the direction to the camera: the side seen.
                let front = eye.and_then(|eye| {
                    let [a, b, c] = triangles
                        .get(r.tri() as usize)?
                        .map(|k| positions[k as usize]);
                    let d = (b - a).cross(c - a).dot(eye - r.p);
                    (d != 0.0).then_some(d > 0.0)
                });
                f(&PixelHit {
                    triangle: r.tri(),
                    radiance: *l,
                    max_reflected: (most.as_ref())
                        .filter(|_| draw.keeps(v, i))
                        .and_then(|m| m.get(i).copied().flatten()),
                    at: Some([v as u32, (i % w) as u32, (i / w) as u32]),
                    front,
                });
            }
        }
        Ok(())
    }
}

/// Writes the emitter triangles as OBJ, one group per light.
pub(crate) fn write_emitters_obj(
    path: &Path,
    mesh: &fipt_geom::Mesh,
    emitters: &[Emitter],
) -> Result<()> {
    let mut s = String::from("# fipt emitters: one group per light, world space\n");
    let mut n = 0;
    for (i, e) in emitters.iter().enumerate() {
        s.push_str(&format!(
            "g light_{i}\n# mean radiance {:?}\n",
            e.mean_radiance
        ));
        for &t in &e.triangles {
            for v in mesh.triangles[t as usize] {
                let p = mesh.positions[v as usize];
                s.push_str(&format!("v {} {} {}\n", p.x, p.y, p.z));
            }
            s.push_str(&format!("f {} {} {}\n", n + 1, n + 2, n + 3));
            n += 3;
        }
    }
    write_bytes_atomic(path, s.as_bytes())?;
    Ok(())
}

/// How a run ended without an error.
pub enum RunOutcome {
    /// Every stage is done.
    Finished(RunSummary),
    /// A shard run (or `stop_before_refine`) stopped where asked; the message says what is left.
    Stopped(String),
}

/// What a finished run wrote and how long each stage took.
pub struct RunSummary {
    pub method: String,
    pub stages: Vec<StageReport>,
    pub seconds: f64,
    pub out: PathBuf,
    /// The lights extracted.
    pub lights: usize,
    /// The final material field's checkpoint (FIPT's rounds).
    pub field: Option<PathBuf>,
    /// `metrics.json` when the scene has ground truth.
    pub metrics: Option<serde_json::Value>,
    /// `report.html`, when it was written.
    pub pictures: Option<PathBuf>,
    /// `report.json`'s warnings (the capture's, a run that found no light).
    pub warnings: Vec<String>,
}

impl RunSummary {
    /// Writes `report` as `report.json`, then the pictures, and sums the run up.
    pub(crate) fn write(
        a: &RunRequest,
        cfg: &RunConfig,
        scene: &crate::scene::LoadedScene,
        report: &serde_json::Value,
        stages: Vec<StageReport>,
        lights: usize,
        field: Option<PathBuf>,
    ) -> Result<Self> {
        write_json_atomic(&a.out.join("report.json"), report)?;
        Ok(RunSummary {
            method: cfg.pipeline.method.clone(),
            seconds: report["seconds_total"].as_f64().unwrap_or(0.0),
            stages,
            out: a.out.clone(),
            lights,
            field,
            pictures: crate::report::write_or_warn(&a.out, &scene.ds),
            metrics: Some(report["metrics"].clone()).filter(|m| !m.is_null()),
            warnings: report["warnings"]
                .as_array()
                .into_iter()
                .flatten()
                .filter_map(|w| w.as_str().map(str::to_string))
                .collect(),
        })
    }
}
