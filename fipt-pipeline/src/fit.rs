//! `fipt run`'s one path, for every method (`[pipeline] method`, a [`MaterialFitter`]; FIPT's
//! rounds are `fipt`, registered by crate fipt-method): load → (bake, when the fitter asks for it) → fit →
//! emitters (the fitter's, or the run's extractor on the fitted field) → maps → re-renders →
//! report (→ eval), with the outputs of every method in the same places.
use crate::error::{Result, RunError};
use crate::outputs::{
    emitters_summary, evaluate_if_gt, extend, extract_emitters, report_header, write_emitters_obj,
    write_views, RunOutcome, RunSummary, StageReport,
};
use crate::request::RunRequest;
use crate::run_config::RunConfig;
use crate::scene::LoadedScene;
use crate::Components;
use fipt_core::dataset::GtKind;
use fipt_core::emitter::{Emitter, EmitterExtractor};
use fipt_core::fit::{FitInputs, FitParts, FitRun, FitScene, Fitted, MaterialFitter};
use fipt_core::fsutil::write_json_atomic;
use fipt_shading::records::{hit_points_and_footprint, HitPoint};
use std::sync::{Mutex, OnceLock};
use std::time::Instant;

/// The components a run uses.
pub struct Parts<'a> {
    pub fitter: &'a dyn MaterialFitter,
    /// The baker, refiner and extractor (with their settings), handed to the fitter.
    pub parts: FitParts<'a>,
}

/// The training views' primary hits and their median pixel footprint.
pub type TrainHits = (Vec<Vec<Option<HitPoint>>>, f32);

/// What `fipt run` holds while it runs: the loaded scene, the run's config and request, and the
/// training views' primary hits, computed when first needed (the run's extractor, the
/// `observed` maps). A method sees none of it: it gets `FitInputs`.
pub struct Host {
    pub scene: LoadedScene,
    pub cfg: RunConfig,
    pub request: RunRequest,
    hits: OnceLock<TrainHits>,
}

impl Host {
    /// The training views' primary hits and their median pixel footprint.
    pub fn hits(&self) -> &TrainHits {
        self.hits.get_or_init(|| {
            let views = &self.scene.ds.train().views;
            let geometry = &self.scene.geometry;
            let (records, footprint) = hit_points_and_footprint(geometry, views);
            (records, footprint.unwrap_or(0.01))
        })
    }
}

/// A method's error back as the run's own (FIPT's stops and settings errors stay what they are).
fn from_method(e: fipt_core::CoreError) -> RunError {
    match e {
        fipt_core::CoreError::Component(b) => match b.downcast::<RunError>() {
            Ok(p) => *p,
            Err(b) => RunError::Component(b),
        },
        e => e.into(),
    }
}

/// The part (else semantic) ids of the training views, for a fitter that wants them.
fn segments_for(scene: &LoadedScene, fitter: &dyn MaterialFitter) -> Result<Option<Vec<Vec<i64>>>> {
    if !fitter.wants_segments() {
        return Ok(None);
    }
    let split = scene.ds.train();
    [GtKind::IndexMA, GtKind::Segmentation]
        .into_iter()
        .find(|&k| split.has_gt(k))
        .map(|k| crate::segments::split_ids(&crate::scene::SceneRef::loaded(scene), k))
        .transpose()
}

/// The stages reported so far, shared with the fitter's [`FitRun::stage_done`].
struct Stages(Mutex<Vec<StageReport>>);

impl Stages {
    fn mark(&self, stage: &'static str, t: Instant) {
        let mut s = self.0.lock().unwrap_or_else(|e| e.into_inner());
        s.push(StageReport::since(stage, t));
    }
    fn take(&self) -> Vec<StageReport> {
        std::mem::take(&mut *self.0.lock().unwrap_or_else(|e| e.into_inner()))
    }
    fn has(&self, stage: &str) -> bool {
        let s = self.0.lock().unwrap_or_else(|e| e.into_inner());
        s.iter().any(|r| r.stage == stage)
    }
    fn len(&self) -> usize {
        self.0.lock().unwrap_or_else(|e| e.into_inner()).len()
    }
}

/// The fitter on the training views (its own folder `OUT/fit/`, cleared by `--force`).
fn fit_views(
    host: &Host,
    parts: &Parts,
    shadings: Option<&fipt_bake::bake_store::StoredShadings>,
    segments: Option<&[Vec<i64>]>,
    stages: &Stages,
) -> Result<Fitted> {
    let (a, cfg, scene) = (&host.request, &host.cfg, &host.scene);
    let (split, mesh) = (scene.ds.train(), &scene.geometry.mesh);
    let dir = a.out.join("fit");
    if a.force && dir.exists() {
        std::fs::remove_dir_all(&dir)?;
    }
    std::fs::create_dir_all(&dir)?;
    // A fitter that asks for the shadings gets every view's at once.
    let all = shadings.map(|s| s.load_all()).transpose()?;
    let (pb, name) = (OnceLock::new(), parts.fitter.name().to_string());
    let mark = |stage: &'static str, t: Instant| stages.mark(stage, t);
    let fitted = parts.fitter.fit(
        &FitInputs {
            geometry: &scene.geometry,
            positions: &mesh.positions,
            triangles: &mesh.triangles,
            views: &split.views,
            images: &scene.images,
            shadings: all.as_deref(),
            segments,
            model: cfg.model.brdf,
            scene: Some(FitScene {
                dataset: &scene.ds,
                cache_key: &scene.cache_key,
                exposure: scene.exposure,
                left_out: &scene.capture.left_out,
                masked: &scene.capture.masked,
            }),
            dir: &dir,
            parts: Some(parts.parts),
            run: FitRun {
                out: &a.out,
                force: a.force,
                shard: a.sharding().shard,
                stage_done: Some(&mark),
                stop_before: a.stop_before_refine.then_some("refine"),
            },
        },
        // The bar appears with the fitter's first progress (FIPT's stages have bars of their own).
        &|d, n| {
            let bar = pb.get_or_init(|| crate::observe::bar(n as u64, &name));
            bar.set_length(n as u64);
            bar.set_position(d as u64);
        },
    );
    if let Some(bar) = pb.get() {
        bar.finish_and_clear();
    }
    // A method that kept nothing there (FIPT keeps its stages at the top of OUT) leaves no
    // empty folder behind.
    let _ = std::fs::remove_dir(&dir);
    fitted.map_err(from_method)
}

/// The scene, checked for coverage and for the extractor's bounds on its mesh.
fn load_checked(
    a: &RunRequest,
    cfg: &RunConfig,
    extractor: &dyn fipt_core::emitter::EmitterExtractor,
) -> Result<LoadedScene> {
    let scene = crate::scene::load(&a.scene, a.bad_pixels, &cfg.capture)?;
    crate::scene::check_coverage(&scene)?;
    (extractor.check(scene.geometry.mesh.triangles.len())).map_err(RunError::invalid)?;
    Ok(scene)
}

/// The caveats of the components whose work a run uses, without repeats, as one sentence.
pub fn caveats(lists: impl IntoIterator<Item = Vec<String>>) -> Option<String> {
    let mut all: Vec<String> = vec![];
    for c in lists.into_iter().flatten() {
        if !all.contains(&c) {
            all.push(c);
        }
    }
    (!all.is_empty()).then(|| all.join("; "))
}

/// Runs `parts.fitter` on the scene of `a` and writes the output contract into `a.out`.
pub fn run(
    a: &RunRequest,
    cfg: &RunConfig,
    components: &Components,
    parts: Parts,
    checked: &crate::check::Checked,
) -> Result<RunOutcome> {
    let t_all = Instant::now();
    let stages = Stages(Mutex::new(vec![]));
    if a.sharding().shard.is_all() {
        // Only a plain run (never beside a shard: the locks) may take other processes'
        // temporaries for a killed run's.
        fipt_core::fsutil::remove_stale_temporaries(&a.out);
    }
    let t = crate::observe::begin("load");
    let host = Host {
        scene: load_checked(a, cfg, parts.parts.extractor)?,
        cfg: cfg.clone(),
        request: a.clone(),
        hits: OnceLock::new(),
    };
    stages.mark("load", t);
    let (scene, p) = (&host.scene, &parts.parts);
    let shadings = bake_for(&host, &parts, &stages)?;
    let fitted = match fit_stage(&host, &parts, shadings.as_ref(), &stages)? {
        Ok(f) => f,
        Err(why) => return Ok(RunOutcome::Stopped(why)),
    };
    let Fitted {
        field,
        emitters,
        report: fit_report,
        modeled,
        id,
        field_file,
    } = fitted;
    let field = field.as_ref();
    let shadings_for = shadings.as_ref().map(|s| s as _);
    let mut used = parts.fitter.parts_used();
    used.baker |= shadings.is_some();
    used.extractor |= emitters.is_none();
    let (emitters, user_emitters) =
        emitters_stage(&host, p.extractor, field, emitters, shadings_for, &stages)?;
    let warnings = crate::outputs::run_warnings(scene, &emitters);
    let seen = crate::seen::SeenField::new(
        field,
        &scene.geometry.mesh,
        &host.hits().0,
        observed_cells(&host),
    )?;
    seen.note();
    let mut mark = |stage: &'static str, t: Instant| stages.mark(stage, t);
    let recovered = crate::outputs::Recovered {
        field: &seen,
        emitters: &emitters,
        // The fill is part of what the re-renders are a function of.
        id: id.map(|i| format!("{i}|{}", crate::seen::VERSION)),
    };
    write_views(
        scene,
        cfg,
        &a.out,
        recovered,
        Some(seen.counts()),
        &mut mark,
    )?;
    let metrics = evaluate_if_gt(scene, &a.out, components.evaluator(), &mut mark)?;
    let stages = stages.take();
    let settings = checked.report(cfg, components, used);
    let mut report = report_header(a, scene, settings, &stages, t_all);
    let what = Ran {
        cfg,
        components,
        fitter: parts.fitter,
        extractor: p.extractor,
        field,
        baked: shadings.is_some(),
        caveats: caveats(shadings.is_some().then(|| p.baker.caveats())),
        exposure: scene.exposure,
    };
    // Where the field is stored, for `fipt render` and `export` to load it back through the
    // trainer its folder's manifest names.
    let stored = field_file.as_deref().and_then(|f| f.parent());
    if let Some(dir) = stored.filter(|d| d.join("manifest.json").is_file()) {
        let rel = dir.strip_prefix(&a.out).unwrap_or(dir);
        report["field_dir"] = rel.to_string_lossy().into();
    }
    let lights = emitters.len();
    let own = [fit_report, modeled.unwrap_or_else(|| what.modeled())];
    extend(
        &mut report,
        what.report(own, &emitters, &user_emitters, metrics, warnings),
    );
    RunSummary::write(a, cfg, scene, &report, stages, lights, field_file).map(RunOutcome::Finished)
}

/// The bake, for a fitter that asks for the shadings.
fn bake_for(
    host: &Host,
    parts: &Parts,
    stages: &Stages,
) -> Result<Option<fipt_bake::bake_store::StoredShadings>> {
    if !parts.fitter.needs_shadings() {
        return Ok(None);
    }
    let (a, p) = (&host.request, &parts.parts);
    if let Some(c) = caveats([p.baker.caveats()]) {
        crate::note!("{c}");
    }
    let t = crate::observe::begin("bake");
    let bake = &a.out.join("bake");
    let sh = crate::bake::stage(
        &crate::scene::SceneRef::loaded(&host.scene),
        p.baker,
        p.bake_settings,
        bake,
        a.force,
        a.shard.into(),
    )?;
    stages.mark("bake", t);
    Ok(Some(sh.1))
}

/// The fit, one stage or the fitter's own; Ok(Err(why)) when it stopped where asked
/// (`--stop-before refine`: report.json then keeps the stages done, their times and peaks).
fn fit_stage(
    host: &Host,
    parts: &Parts,
    shadings: Option<&fipt_bake::bake_store::StoredShadings>,
    stages: &Stages,
) -> Result<std::result::Result<Fitted, String>> {
    let a = &host.request;
    let segments = segments_for(&host.scene, parts.fitter)?;
    let (t, before) = (crate::observe::begin("fit"), stages.len());
    let st = crate::observe::Stage::start("fit");
    let fitted = match fit_views(host, parts, shadings, segments.as_deref(), stages) {
        Err(e) if e.is_stopped() && a.sharding().shard.is_all() => {
            let why = e.to_string();
            let done = stages.take();
            let status = Some(why.clone());
            crate::outputs::mark_status_after(&a.out, &a.scene, "stopped", status, &done)?;
            return Ok(Err(why));
        }
        f => f?,
    };
    // A fitter that reports no stages of its own is one stage.
    if stages.len() == before {
        st.done();
        stages.mark("fit", t);
    }
    Ok(Ok(fitted))
}

/// The fitter's emitters, or the run's extractor on the fitted field; `emitters.json` and
/// `.obj` written. The emitters at the normalised scale and at the views' own.
fn emitters_stage(
    host: &Host,
    extractor: &dyn EmitterExtractor,
    field: &dyn fipt_core::field::MaterialField,
    emitters: Option<Vec<Emitter>>,
    shadings: Option<&dyn fipt_bake::bake_store::ShadingViews>,
    stages: &Stages,
) -> Result<(Vec<Emitter>, Vec<Emitter>)> {
    let (a, scene) = (&host.request, &host.scene);
    let t = crate::observe::begin("emitters");
    let emitters = match emitters {
        Some(e) => e,
        None => extract_emitters(
            &crate::scene::SceneRef::loaded(scene),
            &host.hits().0,
            field,
            shadings.map(|s| (s, fipt_core::shading::PixelDraw::ALL)),
            extractor,
        )?,
    };
    let user_emitters = write_emitters(a, scene, &emitters)?;
    // FIPT extracts its emitters inside its fit, and reports that stage itself.
    if !stages.has("emitters") {
        stages.mark("emitters", t);
    }
    Ok((emitters, user_emitters))
}

/// The side of the `observed` maps' cells, in the training views' median pixel footprints (the
/// size of FIPT's search cells in every preset).
pub const OBSERVED_CELL_FOOTPRINTS: f32 = 4.0;

/// Observation counts per surface cell ([`OBSERVED_CELL_FOOTPRINTS`] footprints), over the
/// training views' hits: the `observed` maps.
fn observed_cells(host: &Host) -> fipt_search::CellCounts {
    let (records, footprint) = host.hits();
    let points = records.iter().flatten().flatten().map(|r| r.p);
    fipt_search::CellCounts::new(points, OBSERVED_CELL_FOOTPRINTS * footprint)
}

/// Writes `emitters.json` (at the views' own scale; the stages work at the normalised one) and
/// `emitters.obj`, prints the lights; returns them at the views' scale.
fn write_emitters(
    a: &RunRequest,
    scene: &LoadedScene,
    emitters: &[Emitter],
) -> Result<Vec<Emitter>> {
    let st = crate::observe::Stage::start("emitters");
    let user: Vec<Emitter> = emitters.iter().map(|e| e.scaled(scene.exposure)).collect();
    write_json_atomic(&a.out.join("emitters.json"), &user)?;
    write_emitters_obj(&a.out.join("emitters.obj"), &scene.geometry.mesh, &user)?;
    st.done();
    for (i, e) in user.iter().enumerate() {
        crate::note!(
            "light {i}: {} triangles, area {:.4} m², radiance {:.2?}, power {:.1?} W, {} pixels",
            e.triangles.len(),
            e.area,
            e.mean_radiance,
            e.power,
            e.pixels
        );
    }
    Ok(user)
}

/// What a run reports beyond the common header.
struct Ran<'a> {
    cfg: &'a RunConfig,
    components: &'a Components,
    fitter: &'a dyn MaterialFitter,
    extractor: &'a dyn EmitterExtractor,
    field: &'a dyn fipt_core::field::MaterialField,
    baked: bool,
    /// The baker's caveats, when the run baked for the method.
    caveats: Option<String>,
    exposure: f32,
}

impl Ran<'_> {
    /// What `modeled` says of a method that says nothing of its own.
    fn modeled(&self) -> serde_json::Value {
        serde_json::json!({
            "material_field": format!("fitted by method `{}`", self.cfg.pipeline.method),
            "initial_bake": if self.baked { "baked for the fitter" } else { "skipped (the fitter does not use shadings)" },
            "search_and_refinement": "skipped (FIPT's rounds; this run's method replaces them)",
        })
    }

    /// `report.json`'s fit, emitters, components, modeled, metrics and warnings, with the
    /// method's own report and `modeled`.
    fn report(
        &self,
        [fit, own]: [serde_json::Value; 2],
        emitters: &[Emitter],
        user_emitters: &[Emitter],
        metrics: Option<serde_json::Value>,
        warnings: Vec<String>,
    ) -> serde_json::Value {
        let cfg = self.cfg;
        let (fitter, extractor, field) = (self.fitter, self.extractor, self.field);
        let mut modeled = serde_json::json!({
            "reflectance_model": cfg.model.brdf,
            "emitters": emitters.len(),
            "emitters_doubtful": crate::outputs::doubtful_emitters(emitters),
            "re_render": self.re_render(),
        });
        extend(&mut modeled, own);
        if let Some(off) = self.caveats.as_ref() {
            modeled["diffuse_cache"] = off.as_str().into();
        }
        serde_json::json!({
            "fit": fit,
            "emitters": emitters_summary(user_emitters),
            "exposure_scale": self.exposure,
            "components": {
                "reflectance_model": cfg.model.brdf,
                "method": { "name": cfg.pipeline.method, "implementation": fitter.name() },
                "extractor": { "name": cfg.pipeline.extractor, "implementation": extractor.name() },
                "material_field": field.name(),
                "registered": self.components.describe(),
            },
            "modeled": modeled,
            "metrics": metrics,
            "warnings": warnings,
        })
    }

    /// How the views are re-rendered.
    fn re_render(&self) -> String {
        let r = &self.cfg.render;
        if r.spp == 0 {
            return "skipped (render.spp = 0)".to_string();
        }
        let other = if r.val_spp > 0 { r.val_spp } else { r.spp };
        format!(
            "path traced at {} spp (other splits: {other}) from the field (voxel cache) and the extracted emitters",
            r.spp
        )
    }
}
