//! FIPT (method §4) as the method `fipt` (registered by `fipt_method::register`), a
//! [`MaterialFitter`] like any other: the bake
//! (through the run's baker), the material search on its shadings and the first training; the
//! emitters (through the run's extractor); then the refine → search → train rounds (through the
//! run's refiner) that the scene needs. Its stages reuse what an earlier run of the folder
//! computed (`OUT/bake`, `OUT/train*`, `OUT/refine*`) and report their times one by one.
use crate::error::{Result, RunError};
use crate::outputs::{extract_emitters, has_ground_truth};
use crate::rounds::{planned_rounds, Rounds, RoundsContext};
use crate::scene::SceneRef;
use crate::settings::FiptSettings;
use crate::shard::Sharding;
use fipt_core::fit::{FitInputs, FitParts, Fitted, MaterialFitter, PartsUsed};
use fipt_core::shading::{PixelDraw, Progress, Scope};
use fipt_shading::records::{hit_points_and_footprint, HitPoint};
use std::time::Instant;

/// FIPT's rounds, on what [`FitInputs`] holds (its scene, [`FitInputs::scene`], included).
pub struct Fipt {
    settings: FiptSettings,
}

impl Fipt {
    pub fn new(settings: FiptSettings) -> Self {
        Fipt { settings }
    }
}

/// What FIPT's stages read of the run around them: its folder, `--force`, the shard.
pub(crate) struct Run<'a> {
    pub out: &'a std::path::Path,
    pub force: bool,
    pub sharding: Sharding,
}

impl MaterialFitter for Fipt {
    fn name(&self) -> &str {
        crate::names::FIPT_METHOD
    }

    /// FIPT bakes through the run's baker itself, and reads the shadings a view at a time.
    fn needs_shadings(&self) -> bool {
        false
    }

    /// FIPT composes the run's baker, refiner, trainer and extractor.
    fn parts_used(&self) -> PartsUsed {
        PartsUsed::ALL
    }

    fn fit(&self, inputs: &FitInputs, _progress: Progress) -> fipt_core::Result<Fitted> {
        let method = || {
            let scene = SceneRef::of(inputs).ok_or_else(|| {
                crate::err!(
                    "method `fipt` needs the scene around the views (`FitInputs::scene`: the dataset, the cache key, the exposure)"
                )
            })?;
            let parts = inputs.parts.ok_or_else(|| {
                crate::err!("method `fipt` needs the run's baker, refiner and extractor")
            })?;
            let mark = |stage: &'static str, t: Instant| {
                if let Some(done) = inputs.run.stage_done {
                    done(stage, t)
                }
            };
            let run = Run {
                out: inputs.run.out,
                force: inputs.run.force,
                sharding: Sharding {
                    shard: inputs.run.shard,
                    stop_before_refine: inputs.run.stop_before == Some("refine"),
                },
            };
            let (records, footprint) = hit_points_and_footprint(scene.geometry, inputs.views);
            let hits = (records, footprint.unwrap_or(0.01));
            let on = On {
                cfg: &self.settings,
                run: &run,
                scene: &scene,
                hits: &hits,
                model: inputs.model,
            };
            fit_rounds(&on, parts, &mark)
        };
        method().map_err(|e| fipt_core::CoreError::Component(Box::new(e)))
    }
}

/// The bake, the first round, the emitters and the refinement rounds.
/// What FIPT's fit works on: its settings, the run, the scene and its training views'
/// primary hits with their median footprint.
struct On<'a> {
    cfg: &'a FiptSettings,
    run: &'a Run<'a>,
    scene: &'a SceneRef<'a>,
    hits: &'a (Vec<Vec<Option<HitPoint>>>, f32),
    /// The run's reflectance model.
    model: fipt_core::reflectance::ReflectanceModel,
}

fn fit_rounds(on: &On, parts: FitParts, mark: &dyn Fn(&'static str, Instant)) -> Result<Fitted> {
    let (a, cfg, scene) = (on.run, on.cfg, on.scene);
    let pixels = scene.images.iter().map(|i| i.data.len() as u64).sum();
    let memory = crate::memory::check(pixels, cfg, on.model)?;
    let caveats = crate::fit::caveats([parts.baker.caveats(), parts.refiner.caveats()]);
    if let Some(c) = &caveats {
        crate::note!("{c}");
    }
    let mut first = first_round(on, parts, mark)?;
    let (records, footprint) = on.hits;
    let t = crate::observe::begin("emitters");
    let emitters = extract_emitters(
        scene,
        records,
        first.field.as_ref(),
        Some((&first.shadings, first.draw)),
        parts.extractor,
    )?;
    mark("emitters", t);

    // Refine → train rounds, unless nothing in the scene needs them.
    let mut rounds = vec![];
    let mut state = Rounds {
        field: first.field,
        train: first.train,
        searched: first.searched,
        searches: &mut first.searches,
        closure: &mut first.closure,
        reports: &mut rounds,
    };
    let ctx = RoundsContext {
        scene,
        cfg,
        out: a.out,
        force: a.force,
        records,
        footprint: *footprint,
        emitters: &emitters,
        draw: first.draw,
        has_gt: first.has_gt,
        refiner: parts.refiner,
        refine_settings: parts.refine_settings,
        trainer: parts.trainer,
        train_settings: parts.train_settings,
        sharding: a.sharding,
    };
    let mut mark_mut = |stage: &'static str, t: Instant| mark(stage, t);
    let (refine_plan, done_rounds) = planned_rounds(&ctx, &mut state, &mut mark_mut)?;
    past_sharded_stages(a)?;
    let (field, train) = (state.field, state.train);
    let report = serde_json::json!({
        "bake": { "stats": first.bake.stats, "seconds": first.bake.seconds_total },
        "train": train,
        "rounds": rounds,
        "shading_closure": first.closure,
        "search": first.searches,
        "memory_estimate_gib": fipt_core::memory::gib(memory),
    });
    let mut fitted = Fitted::new(field, Some(emitters), report);
    let mut modeled = modeled(cfg, &refine_plan, &train);
    if let Some(c) = caveats {
        modeled["diffuse_cache"] = c.into();
    }
    fitted.modeled = Some(modeled);
    fitted.id = (!a.force).then(|| train.fingerprint());
    let dir = crate::rounds::train_dir(a.out, done_rounds);
    fitted.field_file = train.field_files.first().map(|f| dir.join(f));
    Ok(fitted)
}

/// A shard run stops once the sharded stages are behind it.
fn past_sharded_stages(a: &Run) -> Result<()> {
    let shard = a.sharding.shard;
    if shard.is_all() {
        return Ok(());
    }
    Err(RunError::Stopped(format!(
        "shard {shard}: every sharded stage in {} is done; the rest (maps, re-renders) runs without --shard",
        a.out.display()
    )))
}

/// What the first round leaves for the rest of a FIPT run.
struct FirstRound {
    bake: fipt_bake::bake_store::BakeManifest,
    /// The hit pixels the run reads of its shadings.
    draw: PixelDraw,
    has_gt: bool,
    searched: Option<crate::search::Searched>,
    searches: Vec<serde_json::Value>,
    closure: Vec<serde_json::Value>,
    /// The initial shadings on disk, for the extraction's bound on reflected light.
    shadings: fipt_bake::bake_store::StoredShadings,
    field: Box<dyn fipt_core::field::MaterialField>,
    train: crate::train::TrainManifest,
}

/// FIPT's first round: the bake, the search on its shadings and the first training.
fn first_round(
    on: &On,
    parts: FitParts,
    mark: &dyn Fn(&'static str, Instant),
) -> Result<FirstRound> {
    let (a, cfg, scene) = (on.run, on.cfg, on.scene);
    let t = crate::observe::begin("bake");
    let (records, footprint) = on.hits;
    let draw = crate::draw::plan(scene, records, cfg)?;
    let scope = Scope {
        shard: a.sharding.shard,
        pixels: draw,
    };
    let (bake, shadings) = crate::bake::stage(
        scene,
        parts.baker,
        parts.bake_settings,
        &a.out.join("bake"),
        a.force,
        scope,
    )?;
    mark("bake", t);
    let has_gt = has_ground_truth(scene.ds);
    let mut searches = vec![];
    let t = crate::observe::begin("search");
    let bake_id = fipt_bake::bake_store::fingerprint(&bake);
    let on = crate::search::SearchOn {
        shadings: &shadings,
        id: &bake_id,
        force: a.force,
        seed: cfg.train.seed,
    };
    let searched = crate::search::on_bake(scene, records, on, &cfg.search, *footprint)?;
    if searched.is_some() {
        mark("search", t);
    }
    // The closure of the shadings with the true materials (with ground truth).
    let closure = bake_closure(scene, &shadings, &draw, has_gt)?;
    let t = crate::observe::begin("train");
    let trainer = (parts.trainer)(parts.train_settings)?;
    let on = crate::train::TrainOn {
        scene,
        shadings: &shadings,
        shadings_id: &bake_id,
        set: &cfg.train,
        trainer: trainer.as_ref(),
        settings: parts.train_settings,
        search: searched.as_ref(),
    };
    let must_reuse = !a.sharding.shard.is_all();
    let (field, train, _) =
        crate::train::stage(&on, &a.out.join("train"), a.force, None, must_reuse)?;
    mark("train", t);
    if cfg.search.on_bake {
        searches.push(serde_json::json!({ "shadings": "bake", "search": &searched }));
    }
    Ok(FirstRound {
        bake,
        draw,
        has_gt,
        searched,
        searches,
        closure,
        shadings,
        field,
        train,
    })
}

/// The closure of the bake's shadings with the true materials (empty without ground truth).
fn bake_closure(
    scene: &crate::scene::SceneRef,
    shadings: &fipt_bake::bake_store::StoredShadings,
    draw: &PixelDraw,
    has_gt: bool,
) -> Result<Vec<serde_json::Value>> {
    Ok(if has_gt {
        vec![serde_json::json!({
            "shadings": "bake",
            "psnr_db": crate::eval::closure_psnr(scene, shadings, draw)?,
        })]
    } else {
        vec![]
    })
}

/// What `report.json`'s `modeled` says of FIPT's parts, and why.
fn modeled(
    cfg: &FiptSettings,
    refine_plan: &Result<String, String>,
    train: &crate::train::TrainManifest,
) -> serde_json::Value {
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
    serde_json::json!({
        "material_field": true,
        "material_search": search,
        "emission_mask": true,
        "path_grown_refinement": match refine_plan { Ok(p) => p.clone(), Err(why) => why.clone() },
        "training": training(cfg, train),
        "hash_table_log2": train.config.pointer("/field/grid/log2_table"),
    })
}

/// What the last training round did, against what was asked (the trainer's `steps`, `batch`,
/// `max_passes`, `min_steps` and `emitter_material` settings, where it has them).
fn training(cfg: &FiptSettings, train: &crate::train::TrainManifest) -> String {
    let t = &train.config;
    let num = |k: &str| t.get(k).and_then(|v| v.as_f64());
    let mut training = match (num("steps"), num("batch")) {
        (Some(steps), Some(batch)) => format!(
            "the last round: {steps} steps of {batch} pixels over {} training pixels ({:.1} passes)",
            train.pixels,
            steps * batch / train.pixels.max(1) as f64
        ),
        _ => format!(
            "the last round: trainer `{}` over {} training pixels",
            train.trainer, train.pixels
        ),
    };
    if num("steps").is_some_and(|s| s < cfg.train.steps as f64) {
        training += &format!(
            "; {} steps asked, capped at {} passes and at least {} steps in the rounds from a previous round's field (train.max_passes, min_steps)",
            cfg.train.steps,
            num("max_passes").unwrap_or(0.0) as f32,
            num("min_steps").unwrap_or(0.0)
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
        let trains = match t.get("emitter_material").and_then(|v| v.as_bool()) {
            Some(true) => " train the material and the emission mask (train.emitter_material)",
            Some(false) => " train the emission mask only (train.emitter_material)",
            None => "",
        };
        training += &format!(
            "; {} pixels ({:.2} %) over {}× brighter than any reflection their shadings allow (a light's){trains}",
            train.pixels_lights,
            100.0 * train.pixels_lights as f64 / train.pixels.max(1) as f64,
            fipt_core::training_set::UNREFLECTABLE,
        );
    }
    training
}
