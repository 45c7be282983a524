//! Scoring a `fipt run` against its scene's ground truth, usable without a run:
//!
//! * [`eval::evaluate`] / [`eval::evaluate_run`]: `metrics.json` (kd, ks, σ, metallic and
//!   emission PSNRs per view and split, per part, the metal and emitter scores, the re-renders'
//!   PSNRs, kd error maps), checked against the scene's fingerprint;
//! * [`eval::evaluate_scaled`]: the same after fitted kd and radiance scales (LDR views);
//! * [`eval::closure_psnr`]: how well the shadings with the true materials reproduce the views;
//! * [`sweep_plot`]: a sweep's rows, table and speed–accuracy plot.
pub mod eval;
mod eval_parts;
pub mod sweep_plot;

pub use eval::{closure_psnr, evaluate, evaluate_run, evaluate_scaled, Scales};

use fipt_capture::scene;
use fipt_run::{bail, error, note};
