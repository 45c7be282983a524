//! `fipt run <scene> --out OUT`: load → (a bake, if the method asks for one) → the registered
//! method's fit (FIPT's: bake → train → emitters → (refine → train) × rounds) → emitters →
//! per-view maps → re-render → eval (with ground truth and an evaluator registered) → report. Every stage writes
//! its results atomically and a manifest last; re-running skips finished stages and resumes an
//! interrupted training.
pub use crate::check::{check, Checked};
use crate::error::Result;
pub use crate::outputs::{RunOutcome, RunSummary};
pub use crate::request::{lock, RunRequest};
pub use crate::run_config::{ModelConfig, PipelineConfig, ReRenderConfig, RunConfig};
pub use fipt_run::config::PRESETS;

/// `fipt run`: the configured method's stages, each reused when done, into `a.out`.
pub fn run(a: &RunRequest, components: &crate::Components) -> Result<RunOutcome> {
    crate::parent::die_with_parent();
    let mut cfg: RunConfig = crate::check::load(&a.preset, a.config.as_deref(), components)?;
    if let Some(m) = &a.method {
        cfg.pipeline.method = m.clone();
    }
    if let Some(n) = a.downscale {
        cfg.capture.downscale = n;
    }
    if cfg.capture.downscale == 0 {
        crate::bail!("[capture] downscale = 0: give a factor of 1 (as stored) or more");
    }
    let checked =
        check(&cfg, &a.preset, components).map_err(crate::check::in_file(a.config.as_deref()))?;
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
    // A mistyped scene path leaves no output folder behind.
    if !a.scene.exists() {
        return Err(fipt_core::CoreError::invalid(
            &a.scene,
            "no such folder: check the scene path",
        )
        .into());
    }
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
    // A panic (a bug) marks the folder failed as an error does, instead of leaving it
    // "running".
    let res = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        components
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
            })
    }))
    .unwrap_or_else(|p| Err(crate::RunError::from_panic(p)));
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
