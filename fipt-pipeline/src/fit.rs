//! `fipt run` with a registered method (`[pipeline] method`, a [`MaterialFitter`]) in place of
//! FIPT's rounds: (bake, when the fitter asks for it) → fit → emitters (the fitter's, or the
//! run's extractor on the fitted field) → maps → re-renders → report (→ eval), with the outputs
//! of every method in the same places.
use crate::error::Result;
use crate::outputs::RunSummary;
use crate::outputs::{
    emitters_summary, evaluate_if_gt, extend, extract_emitters, report_header, write_emitters_obj,
    write_views, StageReport,
};
use crate::request::RunRequest;
use crate::run_config::RunConfig;
use crate::Components;
use fipt_core::dataset::GtKind;
use fipt_core::emitter::EmitterExtractor;
use fipt_core::fit::{FitInputs, MaterialFitter};
use fipt_core::fsutil::write_json_atomic;
use fipt_core::shading::ShadingBaker;
use fipt_shading::records::hit_points;
use std::time::Instant;

/// The components a fitted run uses.
pub struct Parts<'a> {
    pub fitter: &'a dyn MaterialFitter,
    /// The baker (and its settings) for a fitter that needs shadings.
    pub baker: &'a dyn ShadingBaker,
    pub bake_settings: &'a serde_json::Value,
    /// The emitter extractor, for a fitter that returns no emitters.
    pub extractor: &'a dyn EmitterExtractor,
}

/// The part (else semantic) ids of the training views, for a fitter that wants them.
fn segments_for(
    scene: &crate::scene::LoadedScene,
    fitter: &dyn MaterialFitter,
) -> Result<Option<Vec<Vec<i64>>>> {
    if !fitter.wants_segments() {
        return Ok(None);
    }
    let split = scene.ds.train();
    [GtKind::IndexMA, GtKind::Segmentation]
        .into_iter()
        .find(|&k| split.has_gt(k))
        .map(|k| crate::regions::split_ids(scene, k))
        .transpose()
}

/// The fitter on the training views (its checkpoints in `OUT/fit/`, cleared by `--force`).
fn fit_views(
    a: &RunRequest,
    cfg: &RunConfig,
    scene: &crate::scene::LoadedScene,
    fitter: &dyn MaterialFitter,
    shadings: Option<&fipt_shading::bake_store::StoredShadings>,
    segments: Option<&[Vec<i64>]>,
) -> Result<fipt_core::fit::Fitted> {
    let (split, mesh) = (scene.ds.train(), &scene.geometry.mesh);
    let dir = a.out.join("fit");
    if a.force && dir.exists() {
        // The fitter's checkpoints: `--force` starts it afresh.
        std::fs::remove_dir_all(&dir)?;
    }
    std::fs::create_dir_all(&dir)?;
    let st = crate::observe::Stage::start("fit");
    let pb = crate::observe::bar(1, fitter.name());
    // A fitter that asks for the shadings gets every view's at once.
    let all = shadings.map(|s| s.load_all()).transpose()?;
    let fitted = fitter.fit(
        &FitInputs {
            geometry: &scene.geometry,
            positions: &mesh.positions,
            triangles: &mesh.triangles,
            views: &split.views,
            images: &scene.images,
            shadings: all.as_deref(),
            segments,
            model: cfg.model.brdf,
            dir: &dir,
        },
        &|d, n| {
            pb.set_length(n as u64);
            pb.set_position(d as u64);
        },
    )?;
    drop(all);
    pb.finish_and_clear();
    st.done();
    Ok(fitted)
}

/// Runs `parts.fitter` on the scene of `a` and writes the output contract into `a.out`.
pub fn run(
    a: &RunRequest,
    cfg: &RunConfig,
    components: &Components,
    parts: Parts,
) -> Result<RunSummary> {
    let Parts {
        fitter,
        baker,
        bake_settings,
        extractor,
    } = parts;
    let t_all = Instant::now();
    let mut stages: Vec<StageReport> = vec![];
    if a.sharding().shard.is_all() {
        // Only a plain run (never beside a shard: the locks) may take other processes'
        // temporaries for a killed run's.
        fipt_core::fsutil::remove_stale_temporaries(&a.out);
    }
    let t = crate::observe::begin("load");
    let scene = crate::scene::load(&a.scene, a.bad_pixels, cfg.capture.align_views)?;
    stages.push(StageReport::since("load", t));
    let mesh = &scene.geometry.mesh;
    let shadings = if fitter.needs_shadings() {
        let t = crate::observe::begin("bake");
        let (_, sh) = crate::bake::stage(
            &scene,
            baker,
            bake_settings,
            &a.out.join("bake"),
            a.force,
            a.shard,
        )?;
        stages.push(StageReport::since("bake", t));
        Some(sh)
    } else {
        None
    };
    let segments = segments_for(&scene, fitter)?;
    let t = crate::observe::begin("fit");
    let fitted = fit_views(
        a,
        cfg,
        &scene,
        fitter,
        shadings.as_ref(),
        segments.as_deref(),
    )?;
    stages.push(StageReport::since("fit", t));
    let t = crate::observe::begin("emitters");
    let field = fitted.field.as_ref();
    let emitters = match fitted.emitters {
        Some(e) => e,
        None => extract_from_field(&scene, field, shadings.as_ref(), extractor)?,
    };
    let user_emitters: Vec<_> = emitters.iter().map(|e| e.scaled(scene.exposure)).collect();
    write_json_atomic(&a.out.join("emitters.json"), &user_emitters)?;
    write_emitters_obj(&a.out.join("emitters.obj"), mesh, &emitters)?;
    stages.push(StageReport::since("emitters", t));
    let warnings = crate::outputs::run_warnings(&scene, &emitters);
    let mut mark = |stage: &'static str, t: Instant| stages.push(StageReport::since(stage, t));
    let recovered = crate::outputs::Recovered {
        field,
        emitters: &emitters,
        id: None,
    };
    write_views(&scene, cfg, &a.out, recovered, None, &mut mark)?;
    let metrics = evaluate_if_gt(&scene, &a.out, &mut mark)?;
    let mut report = report_header(a, &scene, cfg, &stages, t_all);
    let what = FitRun {
        cfg,
        components,
        fitter,
        extractor,
        field,
        baked: shadings.is_some(),
        exposure: scene.exposure,
    };
    extend(
        &mut report,
        what.report(fitted.report, &emitters, &user_emitters, metrics, warnings),
    );
    RunSummary::write(a, cfg, &scene, &report, stages, emitters.len(), None)
}

/// The run's extractor on the fitted field's emission mask (for a fitter without emitters of its
/// own), with each pixel's bound on reflected light when the bake ran.
fn extract_from_field(
    scene: &crate::scene::LoadedScene,
    field: &dyn fipt_core::field::MaterialField,
    shadings: Option<&fipt_shading::bake_store::StoredShadings>,
    extractor: &dyn EmitterExtractor,
) -> Result<Vec<fipt_core::emitter::Emitter>> {
    let records: Vec<_> = (scene.ds.train().views.iter())
        .map(|v| hit_points(&scene.geometry, v))
        .collect();
    let shadings = shadings.map(|s| s as &dyn fipt_shading::bake_store::ShadingViews);
    extract_emitters(scene, &records, field, shadings, extractor)
}

/// What a fitter's run reports beyond the common header.
struct FitRun<'a> {
    cfg: &'a RunConfig,
    components: &'a Components,
    fitter: &'a dyn MaterialFitter,
    extractor: &'a dyn EmitterExtractor,
    field: &'a dyn fipt_core::field::MaterialField,
    baked: bool,
    exposure: f32,
}

impl FitRun<'_> {
    /// `report.json`'s fit, emitters, components, modeled, metrics and warnings.
    fn report(
        &self,
        fit: serde_json::Value,
        emitters: &[fipt_core::emitter::Emitter],
        user_emitters: &[fipt_core::emitter::Emitter],
        metrics: Option<serde_json::Value>,
        warnings: Vec<String>,
    ) -> serde_json::Value {
        let cfg = self.cfg;
        let (fitter, extractor, field) = (self.fitter, self.extractor, self.field);
        let components = self.components;
        serde_json::json!({
            "fit": fit,
            "emitters": emitters_summary(user_emitters),
            "exposure_scale": self.exposure,
            "components": {
                "reflectance_model": cfg.model.brdf,
                "method": { "name": cfg.pipeline.method, "implementation": fitter.name() },
                "extractor": { "name": cfg.pipeline.extractor, "implementation": extractor.name() },
                "material_field": field.name(),
                "registered": components.describe(),
            },
            "modeled": {
                "reflectance_model": cfg.model.brdf,
                "material_field": format!("fitted by method `{}`", cfg.pipeline.method),
                "emitters": emitters.len(),
                "emitters_doubtful": crate::outputs::doubtful_emitters(&emitters),
                "initial_bake": if self.baked { "baked for the fitter" } else { "skipped (the fitter does not use shadings)" },
                "search_and_refinement": "skipped (FIPT's rounds; this run's method replaces them)",
            },
            "metrics": metrics,
            "warnings": warnings,
        })
    }
}
