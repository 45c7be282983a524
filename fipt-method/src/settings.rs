//! FIPT's settings, as its factory reads them from the run config: its own `[search]` and
//! `[rounds]`, and what it reads of `[train]` and `[refine]`.
use fipt_bake::refine::RefineConfig;
use fipt_core::presets::Presets;
use fipt_neural::TrainConfig;
use fipt_search::SearchConfig;
use serde::{Deserialize, Serialize};

/// FIPT's settings: the run config's tables [`crate::FIPT_TABLES`], typed by its factory. The
/// baker, refiner, trainer and extractor read their own.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FiptSettings {
    pub search: SearchConfig,
    pub rounds: RoundsConfig,
    /// The training set's share, seed and targets, the steps asked (whichever trainer runs).
    pub train: TrainConfig,
    /// `rough_threshold`: whether the refinement rounds run (whichever refiner runs).
    pub refine: RefineConfig,
}

impl FiptSettings {
    /// The settings of preset `name`; None for an unknown name.
    pub fn preset(name: &str) -> Option<Self> {
        Some(FiptSettings {
            search: SearchConfig::preset(name)?,
            rounds: RoundsConfig::preset(name)?,
            train: TrainConfig::preset(name)?,
            refine: RefineConfig::preset(name)?,
        })
    }

    /// Range checks of FIPT's own tables and of the training set's settings, naming the key.
    pub fn validate(&self) -> crate::error::Result<()> {
        let invalid = crate::error::RunError::invalid;
        self.train.validate()?;
        self.search.validate().map_err(invalid)?;
        self.rounds.validate().map_err(invalid)
    }
}

/// The refine → train rounds after the first training round.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoundsConfig {
    /// Number of refine → train rounds (the reference: 2; 0 = the initial bake only).
    pub refinements: u32,
    /// Start each later training round from the previous round's field (the reference
    /// starts afresh).
    pub warm_start: bool,
    /// `train.roughness_prior` (the σ pull) in the training rounds after a refinement; absent:
    /// as in `[train]`. 0 in `balanced` and `fast`: the first round needs the pull (σ would
    /// absorb the one-bounce bake's noise and make most of the room "glossy", so that path
    /// growing costs 8×), the refined shadings are clean enough for σ to follow the
    /// highlights, from a warm start at σ ≈ 1.
    #[serde(default)]
    pub roughness_prior: Option<f32>,
    /// Up to `settle_rounds` further rounds after the planned ones, each while more than
    /// `settle_share` of the last refinement's secondary rays met surfaces whose light the
    /// field's materials decide (paths grown through glossy surfaces or rough ones no view
    /// saw). There the refined Ld carries the last round's albedo error back into the next
    /// round: on the default `cornell` (12 views of 64×48) 35 % of the rays, and one round
    /// leaves kd 10 % low; `room` and `studio-mitsuba` have 5–7 %. 0 rounds: off.
    #[serde(default)]
    pub settle_share: f32,
    #[serde(default)]
    pub settle_rounds: u32,
}

impl RoundsConfig {
    /// Range checks, with the key and the allowed range in the message.
    pub fn validate(&self) -> Result<(), String> {
        if !(0.0..=1.0).contains(&self.settle_share) {
            return Err(format!(
                "rounds.settle_share = {} (use [0, 1])",
                self.settle_share
            ));
        }
        if self.settle_rounds > 4 || self.refinements > 16 {
            return Err(format!(
                "rounds.refinements = {}, rounds.settle_rounds = {} (use at most 16 and 4)",
                self.refinements, self.settle_rounds
            ));
        }
        Ok(())
    }
}

impl RoundsConfig {
    /// The rounds of `paper` (two refinements, fresh networks each round, the σ pull off after
    /// a refinement, no settling round), of `reference` (the same, `[train]`'s σ pull kept in
    /// every round) or of `balanced` and `fast` (one refinement, warm-started, the σ pull off
    /// after it, up to one settling round).
    fn of(paper: bool, reference: bool) -> Self {
        RoundsConfig {
            refinements: if paper { 2 } else { 1 },
            // Fresh networks after 10,000-step rounds: on `room`, `paper` warm-started
            // (30,000 steps on one field) scored val kd 25.1 dB, afresh 27.7 dB.
            warm_start: !paper,
            roughness_prior: (!reference).then_some(0.0),
            settle_share: 0.15,
            settle_rounds: u32::from(!paper),
        }
    }
}

impl Presets for RoundsConfig {
    fn paper() -> Self {
        Self::of(true, false)
    }
    fn balanced() -> Self {
        Self::of(false, false)
    }
    fn fast() -> Self {
        Self::of(false, false)
    }
    fn reference() -> Self {
        Self::of(true, true)
    }
}
