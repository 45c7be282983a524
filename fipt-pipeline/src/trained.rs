//! A training round's folder as later runs and commands read it back: its manifest (the
//! trainer, its settings, the field's files and their hash, what the field is a function of),
//! whether the field changed since, and the folder of round r (`train`, `train1`, …).
use fipt_core::fsutil::read_json;
use fipt_neural::TrainConfig;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// The folder of the training after `round` refinements: `train`, then `train1`, `train2`, …
pub fn train_dir(out: &Path, round: u32) -> PathBuf {
    match round {
        0 => out.join("train"),
        r => out.join(format!("train{r}")),
    }
}

/// What a finished training stage wrote, read back by later runs (written last).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TrainManifest {
    pub inputs: String,
    /// [`request_key`]: what decided this training before its set was built (empty in
    /// manifests written before it existed).
    #[serde(default)]
    pub request: String,
    /// The trainer (`[pipeline] trainer`; `hash-grid` in manifests written before trainers
    /// were chosen by name).
    #[serde(default = "hash_grid")]
    pub trainer: String,
    /// The settings the training ran with, as the trainer sized them for the set.
    pub config: serde_json::Value,
    /// [`TrainManifest::fingerprint`], computed when the training finished (a float read back
    /// from JSON may differ in its last bit, so it is not recomputed from `config`; empty in
    /// manifests written before 2026-11-28, whose fingerprint is recomputed as it was then).
    #[serde(default)]
    pub fingerprint: String,
    pub pixels: usize,
    /// Hit pixels that `train.set_cap` left out of the training set.
    #[serde(default)]
    pub pixels_left_out: usize,
    /// Training pixels over [`fipt_core::training_set::UNREFLECTABLE`]× brighter than any
    /// reflection their shadings allow (a light's); with `emitter_material = false` they train
    /// the emission mask only.
    #[serde(default)]
    pub pixels_lights: usize,
    pub seconds: f64,
    /// What the trainer said it did (the hash-grid trainer: parameters, steps/s, timings,
    /// last losses).
    #[serde(default)]
    pub report: serde_json::Value,
    /// The files of the round's folder that hold the field.
    #[serde(default = "field_files")]
    pub field_files: Vec<String>,
    /// The content hash of `field_files` when the training finished, checked before the field
    /// is reused or rendered (empty in manifests written before it existed: not checked).
    #[serde(default)]
    pub field_hash: String,
}

fn hash_grid() -> String {
    crate::names::HASH_GRID_TRAINER.to_string()
}

fn field_files() -> Vec<String> {
    vec![FIELD_FILE.to_string()]
}

/// Why the field in `dir` is not the one its training wrote (None when it is, or when its
/// manifest records no hash).
pub fn field_changed(dir: &Path) -> Option<String> {
    let m = read_json::<TrainManifest>(&dir.join("manifest.json")).ok()?;
    let files: Vec<PathBuf> = m.field_files.iter().map(|f| dir.join(f)).collect();
    if m.field_hash.is_empty() {
        return None;
    }
    if let Some(gone) = files.iter().find(|f| !f.is_file()) {
        return Some(format!(
            "{} is missing (its training wrote it)",
            gone.display()
        ));
    }
    let now = fipt_core::fsutil::hash_files(&files).unwrap_or_else(|e| e.to_string());
    (now != m.field_hash).then(|| {
        format!(
            "{} was changed after its training wrote it (content hash {now}, recorded {})",
            files.first().map_or(dir, |f| f.as_path()).display(),
            m.field_hash
        )
    })
}

/// The hash-grid trainer's field file in a training folder.
pub use fipt_neural::trainer::FIELD_FILE;

impl TrainManifest {
    /// What the trained field is a function of: its inputs, trainer and settings (training
    /// is deterministic). Later stages key on it.
    pub fn fingerprint(&self) -> String {
        if !self.fingerprint.is_empty() {
            return self.fingerprint.clone();
        }
        // Written before trainers were plug-ins: the hash-grid trainer's settings, hashed as
        // they were then (typed, in their fields' order), so that the stages after it are reused.
        let typed = serde_json::from_value::<TrainConfig>(self.config.clone());
        let cfg = typed.map_or_else(
            |_| self.config.to_string(),
            |c| serde_json::to_string(&c).unwrap_or_default(),
        );
        fipt_core::fsutil::hash_bytes(format!("{}|{cfg}", self.inputs).as_bytes())
    }
}
