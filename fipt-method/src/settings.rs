//! FIPT's settings, as its factory reads them from the run config.
use crate::run_config::{ModelConfig, RoundsConfig, RunConfig};
use fipt_bake::refine::RefineConfig;
use fipt_neural::TrainConfig;
use fipt_search::SearchConfig;
use serde::{Deserialize, Serialize};

/// FIPT's settings: the run config's tables [`crate::FIPT_TABLES`], read by its
/// factory. The baker, refiner, trainer and extractor read their own ([`FitParts`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FiptSettings {
    pub search: SearchConfig,
    pub rounds: RoundsConfig,
    /// The training set's share, seed and targets, the steps asked (whichever trainer runs).
    pub train: TrainConfig,
    /// `rough_threshold`: whether the refinement rounds run (whichever refiner runs).
    pub refine: RefineConfig,
    pub model: ModelConfig,
}

impl FiptSettings {
    /// FIPT's tables of a run config.
    pub fn of(cfg: &RunConfig) -> Self {
        FiptSettings {
            search: cfg.search.clone(),
            rounds: cfg.rounds.clone(),
            train: cfg.train.clone(),
            refine: cfg.refine.clone(),
            model: cfg.model.clone(),
        }
    }
}
