//! Scoring a `fipt run` against its scene's ground truth, usable without a run:
//!
//! * [`eval::evaluate`] / [`eval::evaluate_run`]: `metrics.json` (kd, ks, σ, metallic and
//!   emission PSNRs per view and split, per part, the metal and emitter scores, the re-renders'
//!   PSNRs, kd error maps), checked against the scene's fingerprint;
//! * [`eval::evaluate_scaled`]: the same after fitted kd and radiance scales (LDR views);
//! * [`eval::closure_psnr`]: how well the shadings with the true materials reproduce the views;
//! * [`eval_at`]: a run rendered at another scene's cameras and scored there (`fipt eval
//!   --cameras-from`);
//! * [`ceiling`]: a scene's true materials on a copy's mesh (a scan), scored at the scene's
//!   cameras: what that geometry allows (`fipt eval --ceiling`);
//! * [`sweep`]: runs over presets and settings, their table and speed–accuracy plot
//!   ([`sweep_plot`]).
//!
//! The host scores a run only with an evaluator registered ([`register`]; the `fipt` binary's
//! `fipt_cli::components()` does).
pub mod ceiling;
pub mod eval;
pub mod eval_at;
mod eval_parts;
pub mod sweep;
pub mod sweep_plot;

pub use eval::{closure_psnr, evaluate, evaluate_run, evaluate_scaled, Scales};

use fipt_capture::scene;
use fipt_pipeline::{config, parent, render, run, Components};
use fipt_run::{bail, error, note};

/// `components` with the scoring of `metrics.json` registered as the run's evaluator.
pub fn register(components: Components) -> Components {
    components.with_evaluator(Box::new(|ds, out, exposure| evaluate(ds, out, exposure)))
}
