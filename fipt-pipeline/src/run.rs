//! `fipt run <scene> --out OUT`: bake → train → extract emitters → (refine → train) × rounds →
//! per-view maps → re-render → report (→ eval when ground truth exists). Every stage writes
//! its results atomically and a manifest last; re-running skips finished stages and resumes an
//! interrupted training.
use crate::error::{PipelineError, Result};
use crate::observe::Stage;
use crate::outputs::{
    emitters_summary, evaluate_if_gt, extend, extract_emitters, has_ground_truth, report_header,
    write_emitters_obj, write_views, StageReport,
};
pub use crate::outputs::{RunOutcome, RunSummary};
pub use crate::request::{lock, RunRequest};
pub use crate::rounds::RoundsConfig;
use crate::rounds::{planned_rounds, Rounds, RoundsContext};
pub use crate::run_config::{ModelConfig, PipelineConfig, ReRenderConfig, RunConfig};
use fipt_core::emitter::Emitter;
use fipt_core::fsutil::write_json_atomic;
use fipt_shading::records::hit_points;
use std::path::Path;

/// `fipt run`: the configured method's stages, each reused when done, into `a.out`.
pub fn run(a: &RunRequest, components: &crate::Components) -> Result<RunOutcome> {
    crate::parent::die_with_parent();
    let mut cfg: RunConfig =
        crate::config::load_preset(&a.preset, RunConfig::preset, a.config.as_deref())?;
    if let Some(m) = &a.method {
        cfg.pipeline.method = m.clone();
    }
    let Checked {
        extractor,
        baker,
        refiner,
        bake_settings,
        refine_settings,
    } = check(&cfg, &a.preset, components)?;
    fipt_core::lock::refuse_nested_run(&a.out)?;
    // One run per output folder at a time (one per shard for shard runs).
    let _lock = lock(&a.out, a.sharding().shard, "fipt run")?;
    // Until it finishes, the folder says so (an older report must not pass for this run's).
    // Shard runs share the folder with other tasks and leave `report.json` to the plain runs.
    let status = |s: &str, e: Option<String>| -> Result<()> {
        if a.sharding().shard.is_all() {
            crate::outputs::mark_status(&a.out, &a.scene, s, e)?;
        }
        Ok(())
    };
    status("running", None)?;
    let method = &cfg.pipeline.method;
    let res = match components.fitter(method, &cfg.plugin_settings(method), &a.preset) {
        Err(e) => Err(e),
        Ok(Some(fitter)) => {
            let parts = crate::fit::Parts {
                fitter: fitter.as_ref(),
                baker: baker.as_ref(),
                bake_settings: &bake_settings,
                extractor: extractor.as_ref(),
            };
            crate::fit::run(a, &cfg, components, parts).map(RunOutcome::Finished)
        }
        Ok(None) => {
            let settings = [&bake_settings, &refine_settings];
            run_locked(a, &cfg, components, extractor, baker, refiner, settings)
        }
    };
    match res {
        Err(e) if e.is_stopped() => {
            status("stopped", Some(e.to_string()))?;
            Ok(RunOutcome::Stopped(e.to_string()))
        }
        Err(e) => {
            status("failed", Some(crate::describe(&e)))?;
            Err(e)
        }
        Ok(outcome) => Ok(outcome),
    }
}

/// A run's components built from its checked settings.
pub(crate) struct Checked {
    extractor: Box<dyn fipt_core::emitter::EmitterExtractor>,
    baker: Box<dyn fipt_core::shading::ShadingBaker>,
    refiner: Box<dyn fipt_core::shading::ShadingRefiner>,
    bake_settings: serde_json::Value,
    refine_settings: serde_json::Value,
}

/// Every setting of `cfg` in its range and every component it names built (a misspelt name or
/// bad plug-in settings fail here, before any work; `fipt sweep` checks each grid point so).
pub(crate) fn check(
    cfg: &RunConfig,
    preset: &str,
    components: &crate::Components,
) -> Result<Checked> {
    cfg.train.validate()?;
    cfg.search.validate().map_err(PipelineError::invalid)?;
    cfg.rounds.validate().map_err(PipelineError::invalid)?;
    cfg.render.validate().map_err(PipelineError::invalid)?;
    let extractor = components.extractor(&cfg.pipeline.extractor, &cfg.extractor_settings()?)?;
    let bake_settings = cfg.baker_settings()?;
    let baker = components.baker(&cfg.pipeline.baker, &bake_settings, cfg.model.brdf)?;
    let refine_settings = cfg.refiner_settings()?;
    let refiner = components.refiner(&cfg.pipeline.refiner, &refine_settings, cfg.model.brdf)?;
    let method = &cfg.pipeline.method;
    components.fitter(method, &cfg.plugin_settings(method), preset)?;
    Ok(Checked {
        extractor,
        baker,
        refiner,
        bake_settings,
        refine_settings,
    })
}

/// The scene, checked for coverage and for the run's memory (the estimate in bytes).
fn load_checked(a: &RunRequest, cfg: &RunConfig) -> Result<(crate::scene::LoadedScene, u64)> {
    let scene = crate::scene::load(&a.scene, a.bad_pixels, cfg.capture.align_views)?;
    crate::scene::check_coverage(&scene)?;
    let pixels = scene.images.iter().map(|i| i.data.len() as u64).sum();
    let memory = crate::memory::check(pixels, cfg)?;
    if cfg.pipeline.extractor == crate::components::MASK_EXTRACTOR {
        // The emission mask is queried at every sample of every triangle: about 10 M queries
        // a second on 2 cores.
        let triangles = scene.geometry.mesh.triangles.len() as f64;
        let factors = [
            (
                "emitters.samples_per_triangle",
                cfg.emitters.samples_per_triangle as f64,
            ),
            ("triangles", triangles),
        ];
        fipt_core::range::product("the emission mask's queries", &factors, 1e10, "queries")
            .map_err(PipelineError::invalid)?;
    }
    Ok((scene, memory))
}

/// A shard run stops once the sharded stages are behind it.
fn past_sharded_stages(a: &RunRequest) -> Result<()> {
    let shard = a.sharding().shard;
    if shard.is_all() {
        return Ok(());
    }
    Err(PipelineError::Stopped(format!(
        "shard {shard}: every sharded stage in {} is done; the rest (maps, re-renders) runs without --shard",
        a.out.display()
    ))
    .into())
}

/// FIPT's rounds once the settings and components are checked and the folder is held.
fn run_locked(
    a: &RunRequest,
    cfg: &RunConfig,
    components: &crate::Components,
    extractor: Box<dyn fipt_core::emitter::EmitterExtractor>,
    baker: Box<dyn fipt_core::shading::ShadingBaker>,
    refiner: Box<dyn fipt_core::shading::ShadingRefiner>,
    [bake_settings, refine_settings]: [&serde_json::Value; 2],
) -> Result<RunOutcome> {
    let t_all = std::time::Instant::now();
    let mut stages = vec![];
    let mut mark =
        |stage: &'static str, t: std::time::Instant| stages.push(StageReport::since(stage, t));
    if a.sharding().shard.is_all() {
        // Only a plain run (never beside a shard: the locks) may take other processes'
        // temporaries for a killed run's.
        fipt_core::fsutil::remove_stale_temporaries(&a.out);
    }
    let t = crate::observe::begin("load");
    let (scene, memory) = load_checked(a, cfg)?;
    mark("load", t);
    let mut first = first_round(a, cfg, &scene, baker.as_ref(), bake_settings, &mut mark)?;
    let (records, footprint, field) = (&first.records, first.footprint, first.field);
    let t = crate::observe::begin("emitters");
    let emitters = extract_emitters(
        &scene,
        records,
        &field,
        Some(&first.shadings),
        extractor.as_ref(),
    )?;
    let user_emitters = write_emitters(&a.out, &scene, &emitters)?;
    mark("emitters", t);
    let warnings = crate::outputs::run_warnings(&scene, &emitters);

    // Refine → train rounds, unless nothing in the scene needs them.
    let mut rounds = vec![];
    let mut state = Rounds {
        field,
        train: first.train,
        searched: first.searched,
        searches: &mut first.searches,
        closure: &mut first.closure,
        reports: &mut rounds,
    };
    let ctx = RoundsContext {
        scene: &scene,
        cfg,
        out: &a.out,
        force: a.force,
        records,
        footprint,
        emitters: &emitters,
        has_gt: first.has_gt,
        refiner: refiner.as_ref(),
        refine_settings,
        sharding: a.sharding(),
    };
    let planned =
        planned_rounds(&ctx, &mut state, &mut mark).and_then(|p| past_sharded_stages(a).map(|_| p));
    let (refine_plan, done_rounds) = match planned {
        // `--stop-before refine`: report.json keeps the stages done (their times and peaks).
        Err(e) if e.is_stopped() && a.sharding().shard.is_all() => {
            let why = e.to_string();
            crate::outputs::mark_status_after(
                &a.out,
                &a.scene,
                "stopped",
                Some(why.clone()),
                &stages,
            )?;
            return Ok(RunOutcome::Stopped(why));
        }
        p => p?,
    };
    let (field, train) = (state.field, state.train);

    // Observation counts per surface cell (the search's cells: 4 footprints).
    let points = first.records.iter().flatten().flatten().map(|r| r.p);
    let observed =
        fipt_shading::search::CellCounts::new(points, cfg.search.cell_footprints * footprint);
    let recovered = crate::outputs::Recovered {
        field: &field,
        emitters: &emitters,
        id: (!a.force).then(|| train.fingerprint()),
    };
    write_views(&scene, cfg, &a.out, recovered, Some(&observed), &mut mark)?;

    let metrics = evaluate_if_gt(&scene, &a.out, &mut mark)?;
    let mut report = report_header(a, &scene, cfg, &stages, t_all);
    extend(
        &mut report,
        serde_json::json!({
            "bake": { "stats": first.bake.stats, "seconds": first.bake.seconds_total },
            "train": train,
            "rounds": rounds,
            "shading_closure": first.closure,
            "search": first.searches,
            "emitters": emitters_summary(&user_emitters),
            "exposure_scale": scene.exposure,
            "memory_estimate_gib": fipt_core::memory::gib(memory),
            "components": components_report(cfg, components, extractor.name(), &field),
            "modeled": modeled(cfg, &emitters, &refine_plan, &train),
            "metrics": metrics,
            "warnings": warnings,
        }),
    );
    let field = crate::rounds::train_dir(&a.out, done_rounds).join("field.safetensors");
    RunSummary::write(a, cfg, &scene, &report, stages, emitters.len(), Some(field))
        .map(RunOutcome::Finished)
}

/// What the first round leaves for the rest of a FIPT run.
struct FirstRound {
    bake: fipt_shading::bake_store::BakeManifest,
    records: Vec<Vec<Option<fipt_shading::records::HitPoint>>>,
    footprint: f32,
    has_gt: bool,
    searched: Option<crate::search::Searched>,
    searches: Vec<serde_json::Value>,
    closure: Vec<serde_json::Value>,
    /// The initial shadings on disk, for the extraction's bound on reflected light.
    shadings: fipt_shading::bake_store::StoredShadings,
    field: fipt_neural::field::NeuralField,
    train: crate::train::TrainManifest,
}

/// FIPT's first round: the bake, the search on its shadings and the first training.
fn first_round(
    a: &RunRequest,
    cfg: &RunConfig,
    scene: &crate::scene::LoadedScene,
    baker: &dyn fipt_core::shading::ShadingBaker,
    bake_settings: &serde_json::Value,
    mark: &mut dyn FnMut(&'static str, std::time::Instant),
) -> Result<FirstRound> {
    let t = crate::observe::begin("bake");
    let (bake, shadings) = crate::bake::stage(
        scene,
        baker,
        bake_settings,
        &a.out.join("bake"),
        a.force,
        a.sharding().shard,
    )?;
    mark("bake", t);
    let has_gt = has_ground_truth(scene);
    let (records, footprint) = train_hits(scene);
    let mut searches = vec![];
    let t = crate::observe::begin("search");
    let bake_id = fipt_shading::bake_store::fingerprint(&bake);
    let on = crate::search::SearchOn {
        shadings: &shadings,
        id: &bake_id,
        force: a.force,
    };
    let searched = crate::search::on_bake(scene, &records, on, &cfg.search, footprint)?;
    if searched.is_some() {
        mark("search", t);
    }
    // The closure of the shadings with the true materials (with ground truth).
    let closure = bake_closure(scene, &shadings, has_gt)?;
    let t = crate::observe::begin("train");
    let (field, train, _) = crate::train::stage(
        scene,
        &bake_id,
        &shadings,
        &cfg.train,
        &a.out.join("train"),
        a.force,
        None,
        searched.as_ref(),
        !a.sharding().shard.is_all(),
    )?;
    mark("train", t);
    if cfg.search.on_bake {
        searches.push(serde_json::json!({ "shadings": "bake", "search": &searched }));
    }
    Ok(FirstRound {
        bake,
        records,
        footprint,
        has_gt,
        searched,
        searches,
        closure,
        shadings,
        field,
        train,
    })
}

/// `report.json`'s `components`: what ran, by name and implementation, and what was registered.
fn components_report(
    cfg: &RunConfig,
    components: &crate::Components,
    extractor: &str,
    field: &dyn fipt_core::field::MaterialField,
) -> serde_json::Value {
    serde_json::json!({
        "reflectance_model": cfg.model.brdf,
        "method": cfg.pipeline.method,
        "extractor": { "name": cfg.pipeline.extractor, "implementation": extractor },
        "material_field": field.name(),
        "registered": components.describe(),
    })
}

/// The closure of the bake's shadings with the true materials (empty without ground truth).
fn bake_closure(
    scene: &crate::scene::LoadedScene,
    shadings: &fipt_shading::bake_store::StoredShadings,
    has_gt: bool,
) -> Result<Vec<serde_json::Value>> {
    Ok(if has_gt {
        vec![serde_json::json!({
            "shadings": "bake",
            "psnr_db": crate::eval::closure_psnr(scene, shadings)?,
        })]
    } else {
        vec![]
    })
}

/// Primary hits of the training views (shared by the search, the emitter extraction and the
/// glossiness check) and their median pixel footprint.
fn train_hits(
    scene: &crate::scene::LoadedScene,
) -> (Vec<Vec<Option<fipt_shading::records::HitPoint>>>, f32) {
    let views = &scene.ds.train().views;
    let records = views
        .iter()
        .map(|v| hit_points(&scene.geometry, v))
        .collect();
    let footprint = fipt_shading::records::view_footprint(&scene.geometry, views).unwrap_or(0.01);
    (records, footprint)
}

/// Writes `emitters.json` (at the views' own scale; the stages work at the normalised one) and
/// `emitters.obj`, prints the lights; returns them at the views' scale.
fn write_emitters(
    out: &Path,
    scene: &crate::scene::LoadedScene,
    emitters: &[Emitter],
) -> Result<Vec<Emitter>> {
    let st = Stage::start("emitters");
    let user: Vec<Emitter> = emitters.iter().map(|e| e.scaled(scene.exposure)).collect();
    write_json_atomic(&out.join("emitters.json"), &user)?;
    write_emitters_obj(&out.join("emitters.obj"), &scene.geometry.mesh, emitters)?;
    st.done();
    note_lights(&user);
    Ok(user)
}

/// What `report.json` says was modelled and skipped, and why.
fn modeled(
    cfg: &RunConfig,
    emitters: &[Emitter],
    refine_plan: &Result<String, String>,
    train: &crate::train::TrainManifest,
) -> serde_json::Value {
    let t = &train.config;
    let passes = (t.steps * t.batch) as f64 / train.pixels.max(1) as f64;
    let mut training = format!(
        "the last round: {} steps of {} pixels over {} training pixels ({passes:.1} passes)",
        t.steps, t.batch, train.pixels
    );
    if t.steps < cfg.train.steps {
        training += &format!(
            "; {} steps asked, capped at {} passes and at least {} steps in the rounds from a previous round's field (train.max_passes, min_steps)",
            cfg.train.steps, t.max_passes, t.min_steps
        );
    }
    if train.pixels_left_out > 0 {
        training += &format!(
            "; {} more hit pixels left out at random: a round draws no more than {} (train.set_cap)",
            train.pixels_left_out,
            cfg.train.set_limit().unwrap_or(0)
        );
    }
    if train.pixels_lights > 0 {
        training += &format!(
            "; {} pixels ({:.2} %) over {}× brighter than any reflection their shadings allow (a light's) train {} (train.emitter_material)",
            train.pixels_lights,
            100.0 * train.pixels_lights as f64 / train.pixels.max(1) as f64,
            fipt_neural::ops::UNREFLECTABLE,
            if t.emitter_material { "the material and the emission mask" } else { "the emission mask only" }
        );
    }
    let search = if cfg.search.enabled {
        format!(
            "per region ({:?}) on {}: σ over {} values, metallic over {:?}, pulled towards with weight {}",
            cfg.search.regions,
            if cfg.search.on_bake { "the bake and each refinement" } else { "each refinement (none without one)" },
            cfg.search.roughness_steps,
            cfg.search.metallic,
            cfg.train.target_weight
        )
    } else {
        "skipped (search.enabled = false)".to_string()
    };
    let re_render = if cfg.render.spp > 0 {
        let other = if cfg.render.val_spp > 0 {
            cfg.render.val_spp
        } else {
            cfg.render.spp
        };
        format!("path traced at {} spp (other splits: {other}) from the field (voxel cache) and the extracted emitters", cfg.render.spp)
    } else {
        "skipped (render.spp = 0)".to_string()
    };
    serde_json::json!({
        "reflectance_model": cfg.model.brdf,
        "material_field": true,
        "material_search": search,
        "emission_mask": true,
        "emitters": emitters.len(),
        "emitters_doubtful": crate::outputs::doubtful_emitters(emitters),
        "path_grown_refinement": match refine_plan { Ok(p) => p.clone(), Err(why) => why.clone() },
        "re_render": re_render,
        "training": training,
        "hash_table_log2": t.field.grid.log2_table,
    })
}

/// One line per extracted light.
fn note_lights(emitters: &[Emitter]) {
    for (i, e) in emitters.iter().enumerate() {
        crate::note!(
            "light {i}: {} triangles, area {:.4} m², radiance {:.2?}, power {:.1?} W, {} pixels",
            e.triangles.len(),
            e.area,
            e.mean_radiance,
            e.power,
            e.pixels
        );
    }
}
