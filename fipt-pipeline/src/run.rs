//! `fipt run <scene> --out OUT`: load → (a bake, if the method asks for one) → the registered
//! method's fit (FIPT's: bake → train → emitters → (refine → train) × rounds) → emitters →
//! per-view maps → re-render → eval (with ground truth and an evaluator registered) → report. Every stage writes
//! its results atomically and a manifest last; re-running skips finished stages and resumes an
//! interrupted training.
use crate::error::{Result, RunError};
use crate::names::Kind;
pub use crate::outputs::{RunOutcome, RunSummary};
pub use crate::request::{lock, RunRequest};
pub use crate::run_config::{ModelConfig, PipelineConfig, ReRenderConfig, RunConfig};

/// `fipt run`: the configured method's stages, each reused when done, into `a.out`.
pub fn run(a: &RunRequest, components: &crate::Components) -> Result<RunOutcome> {
    crate::parent::die_with_parent();
    let mut cfg: RunConfig =
        crate::config::load_preset(&a.preset, RunConfig::preset, a.config.as_deref())?;
    if let Some(m) = &a.method {
        cfg.pipeline.method = m.clone();
    }
    if let Some(n) = a.downscale {
        cfg.capture.downscale = n;
    }
    if cfg.capture.downscale == 0 {
        crate::bail!("[capture] downscale = 0: give a factor of 1 (as stored) or more");
    }
    let checked = check(&cfg, &a.preset, components).map_err(|e| match &a.config {
        Some(file) => crate::err!("{}: {e:#}", file.display()),
        None => e,
    })?;
    let Checked {
        extractor,
        baker,
        refiner,
        bake_settings,
        refine_settings,
        train_settings,
        ..
    } = &checked;
    let make_trainer = |v: &serde_json::Value| {
        (components.trainer(&cfg.pipeline.trainer, v))
            .map_err(|e| fipt_core::CoreError::Component(Box::new(e)))
    };
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
    let res = components
        .fitter(method, &checked.method_settings, &a.preset)
        .and_then(|fitter| {
            let parts = crate::fit::Parts {
                fitter: fitter.as_ref(),
                parts: fipt_core::fit::FitParts {
                    baker: baker.as_ref(),
                    bake_settings,
                    refiner: refiner.as_ref(),
                    refine_settings,
                    extractor: extractor.as_ref(),
                    trainer: &make_trainer,
                    train_settings,
                },
            };
            crate::fit::run(a, &cfg, components, parts, &checked)
        });
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

/// A run's components built from its checked settings, and the settings of each.
pub struct Checked {
    extractor: Box<dyn fipt_core::emitter::EmitterExtractor>,
    baker: Box<dyn fipt_core::shading::ShadingBaker>,
    refiner: Box<dyn fipt_core::shading::ShadingRefiner>,
    bake_settings: serde_json::Value,
    refine_settings: serde_json::Value,
    train_settings: serde_json::Value,
    extractor_settings: serde_json::Value,
    method_settings: serde_json::Value,
}

impl Checked {
    /// `report.json`'s `settings`: the host's sections of `cfg` and the settings of the
    /// components the run used (the method's, and each part's that `used` says), as their
    /// factories took them.
    pub(crate) fn report(
        &self,
        cfg: &RunConfig,
        components: &crate::Components,
        used: fipt_core::fit::PartsUsed,
    ) -> serde_json::Value {
        let mut host = cfg.clone();
        host.tables.clear();
        host.plugins.clear();
        let mut out = match serde_json::to_value(&host) {
            Ok(serde_json::Value::Object(o)) => o,
            _ => Default::default(),
        };
        out.insert("plugins".into(), serde_json::json!({}));
        let p = &cfg.pipeline;
        let parts = [
            (used.baker, Kind::Baker, &p.baker, &self.bake_settings),
            (
                used.refiner,
                Kind::Refiner,
                &p.refiner,
                &self.refine_settings,
            ),
            (
                used.trainer,
                Kind::Trainer,
                &p.trainer,
                &self.train_settings,
            ),
            (
                used.extractor,
                Kind::Extractor,
                &p.extractor,
                &self.extractor_settings,
            ),
        ];
        for (_, kind, name, settings) in parts.into_iter().filter(|u| u.0) {
            components.report_settings(kind, name, settings, &mut out);
        }
        components.report_settings(Kind::Method, &p.method, &self.method_settings, &mut out);
        serde_json::Value::Object(out)
    }
}

/// Every setting of `cfg` in its range and every component it names built (a misspelt name or
/// bad plug-in settings fail here, before any work; `fipt sweep` checks each grid point so);
/// a table that no registered component reads is refused, naming the ones they read.
pub fn check(cfg: &RunConfig, preset: &str, components: &crate::Components) -> Result<Checked> {
    cfg.render.validate().map_err(RunError::invalid)?;
    check_tables(cfg, components)?;
    let p = &cfg.pipeline;
    let settings = |kind, name: &str| components.settings_of(kind, name, cfg, preset);
    let extractor_settings = settings(Kind::Extractor, &p.extractor)?;
    let extractor = components.extractor(&p.extractor, &extractor_settings)?;
    let bake_settings = settings(Kind::Baker, &p.baker)?;
    let baker = components.baker(&p.baker, &bake_settings, cfg.model.brdf)?;
    let refine_settings = settings(Kind::Refiner, &p.refiner)?;
    let refiner = components.refiner(&p.refiner, &refine_settings, cfg.model.brdf)?;
    let train_settings = settings(Kind::Trainer, &p.trainer)?;
    components.trainer(&p.trainer, &train_settings)?;
    let method_settings = settings(Kind::Method, &p.method)?;
    components.fitter(&p.method, &method_settings, preset)?;
    Ok(Checked {
        extractor,
        baker,
        refiner,
        bake_settings,
        refine_settings,
        train_settings,
        extractor_settings,
        method_settings,
    })
}

/// Refuses a table of `cfg` that neither the host nor any registered component reads.
fn check_tables(cfg: &RunConfig, components: &crate::Components) -> Result<()> {
    let known = components.table_names();
    let Some(unknown) = cfg.tables.keys().find(|k| !known.contains(k.as_str())) else {
        return Ok(());
    };
    let list = |names: &mut dyn Iterator<Item = &str>| -> String {
        names
            .map(|t| format!("[{t}]"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let what = if cfg.tables[unknown].is_object() {
        "table"
    } else {
        "key"
    };
    crate::bail!(
        "unknown {what} `{unknown}`: the run reads {}, its components {} (a plug-in's settings go in [plugins.<name>])",
        list(&mut RunConfig::HOST_TABLES.iter().copied()),
        list(&mut known.into_iter())
    )
}
