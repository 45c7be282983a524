//! The field-trainer contract: fit a [`MaterialField`] to a [`TrainingSet`] (method §4.3).
//!
//! A method builds the set (which pixels, their shadings, segments and the search's targets)
//! and hands it to a trainer with the round it is in: the folder the trainer keeps its
//! checkpoints and its field in, whether to resume, and the previous round's field to start
//! from. The trainer returns the field and says what it did; it loads a finished round's field
//! from its folder again (`fipt render`, `fipt export`). The hash-grid trainer of
//! `fipt-neural` (`hash-grid`) is the built-in one; a trainer from a crate of its own is
//! registered by name and chosen by `[pipeline] trainer`.
use crate::error::Result;
use crate::field::MaterialField;
use crate::training_set::TrainingSet;
use std::path::{Path, PathBuf};

/// A message for the user (a line of the run's log).
pub type Note<'a> = &'a (dyn Fn(&str) + Sync);

/// Progress of a training: (steps done, steps in all, the last step's loss).
pub type StepProgress<'a> = &'a mut dyn FnMut(usize, usize, f32);

/// The round a training is in.
pub struct TrainRound<'a> {
    /// The round's own folder (it exists): the trainer writes its checkpoints and its field
    /// here, and [`FieldTrainer::load`] reads the field back from it.
    pub dir: &'a Path,
    /// What the set is a function of (scene, shadings, targets): a checkpoint written for
    /// other inputs must not be resumed.
    pub inputs: &'a str,
    /// Resume an interrupted training of the same inputs and settings found in `dir`. When
    /// false (`--force`, or the field in `dir` was changed after it was written) the trainer
    /// must not read what an earlier training left there.
    pub resume: bool,
    /// The previous round's field to start from (a warm start), when the method asks for one.
    /// A trainer that needs none may ignore it; one that cannot start from this kind of field
    /// says so with an error.
    pub warm: Option<&'a dyn MaterialField>,
    /// Where the trainer's messages go (resumed, warm-started, steps capped, final losses).
    pub note: Note<'a>,
}

/// A finished training.
pub struct Trained {
    pub field: Box<dyn MaterialField>,
    /// The settings the training ran with, as the trainer sized them for the set (written
    /// to the round's manifest; later stages key on them). The trainer's factory must accept
    /// them: a finished round's field is loaded by a trainer built from them.
    pub settings: serde_json::Value,
    /// What the training did, in the trainer's words (steps, losses, timings):
    /// `report.json`'s rounds carry it.
    pub report: serde_json::Value,
    /// The files in [`TrainRound::dir`] that hold the field, relative to it (at least one, no
    /// `..`): their content hash is recorded, so that a field changed afterwards is not taken
    /// for this one.
    pub files: Vec<PathBuf>,
}

/// Fits a material field to a training set.
pub trait FieldTrainer: Send + Sync {
    /// A short name for reports (`[pipeline] trainer`).
    fn name(&self) -> &str;
    /// Trains on `set` (resuming or warm-starting as `round` says); `progress` sees each step.
    fn train(
        &self,
        set: &TrainingSet,
        round: &TrainRound,
        progress: StepProgress,
    ) -> Result<Trained>;
    /// The field a finished [`FieldTrainer::train`] left in `dir`.
    fn load(&self, dir: &Path) -> Result<Box<dyn MaterialField>>;
}
