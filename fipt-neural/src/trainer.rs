//! The built-in [`FieldTrainer`] (`hash-grid`): the hash-grid + MLP field of method §4.3,
//! trained with the fused loss, sized for each set, checkpointed in the round's folder and
//! resumed from it, warm-started from a previous round's field of its own kind.
use crate::error::NeuralError;
use crate::field::NeuralField;
use crate::train::{load_field, StepLosses, TrainConfig, TrainTimings, Trainer};
use fipt_core::field::MaterialField;
use fipt_core::trainer::{FieldTrainer, Note, StepProgress, TrainRound, Trained};
use fipt_core::training_set::TrainingSet;
use fipt_core::CoreError;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The file a round's field (and its checkpoint) is written to, in the round's folder.
pub const FIELD_FILE: &str = "field.safetensors";

/// Trains a [`NeuralField`] with [`Trainer`] under one [`TrainConfig`].
pub struct HashGridTrainer {
    pub config: TrainConfig,
}

impl HashGridTrainer {
    /// A trainer of these settings (checked).
    pub fn new(config: TrainConfig) -> crate::Result<Self> {
        config.validate()?;
        Ok(HashGridTrainer { config })
    }

    /// The settings sized for `set`: the grid's finest level from the footprint, the steps
    /// capped for a warm start.
    pub fn sized(&self, set: &TrainingSet, warm: bool, note: Note) -> TrainConfig {
        let cfg = &self.config;
        let n = set.len();
        let mut sized = cfg.sized_for(n, set.footprint, &set.bounds);
        sized.steps = cfg.capped_steps(n, warm);
        if sized.steps < cfg.steps {
            note(&format!(
                "training for {} steps instead of {}: at most {} passes over {} pixels from the previous round's field, at least {} steps (train.max_passes, min_steps)",
                sized.steps, cfg.steps, cfg.max_passes, n, cfg.min_steps
            ));
        }
        sized
    }

    /// The round's optimiser: resumed from its checkpoint, or new (warm-started from the
    /// previous round's field when there is one).
    fn start(
        &self,
        cfg: &TrainConfig,
        set: &TrainingSet,
        round: &TrainRound,
    ) -> crate::Result<Trainer> {
        if round.resume {
            match Trainer::resume(cfg, set.bounds, set.levels, round.inputs, round.dir)? {
                Ok(t) => {
                    (round.note)(&format!(
                        "resuming from step {} in {}",
                        t.step_count(),
                        round.dir.display()
                    ));
                    return Ok(t);
                }
                Err(why) if why != "no checkpoint" => {
                    (round.note)(&format!("training afresh: {why}"))
                }
                Err(_) => {}
            }
        }
        let mut t = Trainer::new(cfg.clone(), set.bounds, set.levels)?;
        t.inputs = round.inputs.to_string();
        if let Some(warm) = round.warm {
            let Some(field) = warm.as_any().and_then(|a| a.downcast_ref::<NeuralField>()) else {
                return Err(NeuralError::config(
                    "warm start",
                    format!(
                        "the hash-grid trainer starts only from a field of its own, not from `{}`",
                        warm.name()
                    ),
                ));
            };
            t.warm_start(field)?;
            (round.note)("warm start from the previous round's field");
        }
        Ok(t)
    }
}

impl FieldTrainer for HashGridTrainer {
    fn name(&self) -> &str {
        "hash-grid"
    }

    fn train(
        &self,
        set: &TrainingSet,
        round: &TrainRound,
        progress: StepProgress,
    ) -> fipt_core::Result<Trained> {
        let cfg = self.sized(set, round.warm.is_some(), round.note);
        let mut trainer = self.start(&cfg, set, round)?;
        let (pg, pm) = trainer.field.num_params();
        (round.note)(&format!(
            "training on {} pixels of {} views: {pg} hash-table + {pm} MLP parameters, {} steps of {}",
            set.len(),
            set.views,
            cfg.steps,
            cfg.batch
        ));
        let first = trainer.step_count();
        let start = Instant::now();
        trainer.run(set, Some(round.dir), &mut |l| {
            progress(l.step, cfg.steps, l.total)
        })?;
        let secs = start.elapsed().as_secs_f64();
        let done = (trainer.step_count() - first).max(1);
        let sps = done as f64 / secs.max(1e-9);
        note_training(round.note, &trainer.timings, &trainer.last, done, sps);
        let report = serde_json::json!({
            "params_grid": pg,
            "params_mlp": pm,
            "steps_now": trainer.step_count() - first,
            "steps_per_second": sps,
            "timings": trainer.timings,
            "last": trainer.last,
        });
        let settings =
            serde_json::to_value(&cfg).map_err(|e| CoreError::config("train", e.to_string()))?;
        Ok(Trained {
            field: Box::new(trainer.field),
            settings,
            report,
            files: vec![PathBuf::from(FIELD_FILE)],
        })
    }

    fn load(&self, dir: &Path) -> fipt_core::Result<Box<dyn MaterialField>> {
        let (field, _) = load_field(dir)?;
        Ok(Box::new(field))
    }
}

/// Per-step timings and the final losses of a training, as notes.
fn note_training(note: Note, t: &TrainTimings, l: &StepLosses, done: usize, sps: f64) {
    let ms = |x: f64| x / done as f64 * 1e3;
    note(&format!(
        "{sps:.1} steps/s; per step: batch {:.1} ms, forward {:.1} ms (hash grid {:.1}), backward {:.1} ms (hash grid {:.1}, with its Adam update {:.1}), MLP optimiser {:.1} ms",
        ms(t.batch),
        ms(t.forward),
        ms(t.grid_forward),
        ms(t.backward),
        ms(t.grid_backward + t.grid_optimizer),
        ms(t.grid_optimizer),
        ms(t.optimizer),
    ));
    note(&format!(
        "final losses: total {:.5}, image {:.5}, mask {:.5}, prior {:.5}",
        l.total, l.image, l.mask, l.prior
    ));
}
