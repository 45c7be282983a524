//! The voxel table as a field trainer: FIPT's rounds hand it their training set (the pixels,
//! their shadings, the positions in the set's unit cube) and it fits the table in closed form.
//! It keeps no checkpoint (the fit takes a moment) and needs no warm start (it ignores one);
//! the table goes to `voxels.json` in the round's folder, from which [`VoxelTrainer::load`]
//! reads it back for `fipt render` and `fipt export`.
use crate::{key_of, Key, Sums, VoxelField, VoxelLambertConfig};
use fipt_core::color::{luminance, Rgb};
use fipt_core::field::MaterialField;
use fipt_core::reflectance::diffuse_at;
use fipt_core::shading::NUM_LEVELS;
use fipt_core::trainer::{FieldTrainer, StepProgress, TrainRound, Trained};
use fipt_core::training_set::TrainingSet;
use glam::Vec3;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The trainer's registered name.
pub const NAME: &str = "voxel-table";

/// The file the table is written to in the round's folder.
pub const TABLE_FILE: &str = "voxels.json";

/// Fits a [`VoxelField`] to a training set.
pub struct VoxelTrainer {
    pub config: VoxelLambertConfig,
}

impl FieldTrainer for VoxelTrainer {
    fn name(&self) -> &str {
        NAME
    }

    fn train(
        &self,
        set: &TrainingSet,
        round: &TrainRound,
        progress: StepProgress,
    ) -> fipt_core::Result<Trained> {
        if set.is_empty() {
            return Err(fipt_core::CoreError::config(
                NAME,
                "the training set is empty",
            ));
        }
        // The voxel edge in the set's unit cube: `cell_footprints` pixel footprints.
        let footprint = set.footprint.unwrap_or(set.bounds.size / 256.0);
        let cell = (footprint * self.config.cell_footprints / set.bounds.size).max(1e-6);
        let max =
            |x: &[[f32; 3]; NUM_LEVELS]| x.iter().fold(Vec3::ZERO, |a, b| a.max(Vec3::from(*b)));
        let mut sums: HashMap<Key, Sums> = HashMap::new();
        for j in 0..set.len() {
            let poly = set.ld_poly.get(j).map(|p| p.map(Rgb::from));
            let ld = diffuse_at(Vec3::from(set.ld[j]), poly.as_ref(), 1.0).0;
            let reflectable = luminance(ld + max(&set.ls0[j]) + max(&set.ls1[j]));
            let s = sums
                .entry(key_of(Vec3::from(set.unit[j]), cell))
                .or_default();
            s.add(
                Vec3::from(set.gt[j]),
                ld,
                reflectable,
                self.config.emit_ratio,
            );
        }
        progress(1, 1, 0.0);
        let field = VoxelField::from_sums(cell, Some(set.bounds), &sums);
        if round.warm.is_some() {
            (round.note)(
                "voxel-table: fitted in closed form; the previous round's field is not needed",
            );
        }
        fipt_core::fsutil::write_json_atomic(&round.dir.join(TABLE_FILE), &field)?;
        Ok(Trained {
            settings: serde_json::json!({
                "cell_footprints": self.config.cell_footprints,
                "emit_ratio": self.config.emit_ratio,
            }),
            report: serde_json::json!({ "voxels": field.voxels.len(), "cell_unit": cell }),
            field: Box::new(field),
            files: vec![PathBuf::from(TABLE_FILE)],
        })
    }

    fn load(&self, dir: &Path) -> fipt_core::Result<Box<dyn MaterialField>> {
        let field: VoxelField = fipt_core::fsutil::read_json(&dir.join(TABLE_FILE))?;
        Ok(Box::new(field))
    }
}
