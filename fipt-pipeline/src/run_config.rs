//! The settings of a run (`RunConfig`: every stage's section, the components, the model, the
//! capture handling), typed once with `deny_unknown_fields`, and the presets' values.
use crate::error::Result;
use fipt_bake::bake::BakeConfig;
use fipt_bake::refine::RefineConfig;
use fipt_core::presets::Presets;
use fipt_core::reflectance::ReflectanceModel;
use fipt_emitter::MaskExtractorConfig;
use fipt_neural::TrainConfig;
use fipt_search::SearchConfig;
use serde::{Deserialize, Serialize};

/// All settings of a run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunConfig {
    pub bake: BakeConfig,
    pub train: TrainConfig,
    pub emitters: MaskExtractorConfig,
    pub refine: RefineConfig,
    pub rounds: RoundsConfig,
    pub render: ReRenderConfig,
    /// The material search before each training round (absent: as the preset).
    #[serde(default)]
    pub search: SearchConfig,
    /// The reflectance model fitted (absent: as the preset).
    #[serde(default)]
    pub model: ModelConfig,
    /// Which registered components run (absent: the built-in ones).
    #[serde(default)]
    pub pipeline: PipelineConfig,
    /// What the run does with views that are captures (`[capture]`).
    #[serde(default)]
    pub capture: crate::capture::CaptureConfig,
    /// Settings of registered plug-in components, by name (`[plugins.<name>]`).
    #[serde(default)]
    pub plugins: std::collections::BTreeMap<String, serde_json::Value>,
}

/// `[pipeline]`: the components `fipt run` composes, by registered name
/// ([`crate::Components`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PipelineConfig {
    /// The method: `fipt` (built in: bake, search, train, emitters, refinement rounds) or a
    /// registered fitter's name (settings `[plugins.<name>]`).
    pub method: String,
    /// The shading baker: `slf` (built in, settings `[bake]`) or a plug-in's name.
    pub baker: String,
    /// The shading refiner of `fipt`'s rounds: `path-grown` (built in, settings `[refine]`) or
    /// a plug-in's name.
    pub refiner: String,
    /// The emitter extractor: `mask` (built in, settings `[emitters]`) or a plug-in's name
    /// (settings `[plugins.<name>]`).
    pub extractor: String,
    /// The field trainer of `fipt`'s rounds: `hash-grid` (built in, settings `[train]`) or a
    /// plug-in's name (settings `[plugins.<name>]`; `[train]` still chooses the training
    /// set's pixels, segments and targets).
    pub trainer: String,
}

impl Default for PipelineConfig {
    fn default() -> Self {
        PipelineConfig {
            method: crate::names::FIPT_METHOD.to_string(),
            baker: crate::names::SLF_BAKER.to_string(),
            refiner: crate::names::PATH_GROWN_REFINER.to_string(),
            extractor: crate::names::MASK_EXTRACTOR.to_string(),
            trainer: crate::names::HASH_GRID_TRAINER.to_string(),
        }
    }
}

impl RunConfig {
    /// The tables `names` of the config (`bake`, `train`, …) as JSON, by name, for the
    /// component whose settings they hold (the config serialised once).
    pub(crate) fn sections(
        &self,
        names: &[&str],
    ) -> Result<serde_json::Map<String, serde_json::Value>> {
        let mut all = serde_json::to_value(self)?;
        names
            .iter()
            .map(|&name| match all.get_mut(name) {
                Some(v) => Ok((name.to_string(), v.take())),
                None => crate::bail!("the run config has no [{name}] table"),
            })
            .collect()
    }

    /// `[plugins.<name>]` (an empty table when absent).
    pub(crate) fn plugin_settings(&self, name: &str) -> serde_json::Value {
        self.plugins
            .get(name)
            .cloned()
            .unwrap_or_else(|| serde_json::json!({}))
    }
}

/// `[model]`: the reflectance model the shadings are baked for and the field is fitted in.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ModelConfig {
    /// `principled` (Burley + GGX: Mitsuba 3's `principled`, Blender's and glTF's
    /// metallic-roughness model; every preset but `reference`) or `fipt` (Lambert + GGX, the
    /// method's; `reference`).
    pub brdf: ReflectanceModel,
}

/// Path-traced re-renders of every view from the recovered scene (`_render.exr`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReRenderConfig {
    /// Samples per pixel of the training views' re-renders; 0 disables the stage.
    pub spp: u32,
    /// Samples per pixel of the other splits' views (val: the novel views that are scored);
    /// 0: as `spp`. Raw, the re-render metric is bound by Monte Carlo noise (caustics through
    /// metals: on `studio-mitsuba` val 30.8 dB at 256 spp, 34.0 at 1024); denoised, 64 spp
    /// reads 34.9 (`docs/denoise.md`).
    #[serde(default)]
    pub val_spp: u32,
    pub max_bounces: u32,
    pub seed: u64,
    /// At most this many training-view pixels are re-rendered (views evenly spaced in index
    /// order, the first always among them); 0: every training view. The training views'
    /// re-renders show the fit to the photographs; the novel (val) views are always all
    /// re-rendered. 2 M: `studio-mitsuba`, `room` and `cornell` keep every view; 200 views of
    /// 640 × 480 keep 6, which made 90 % of the re-render's time (`docs/scaling.md`).
    #[serde(default = "default_train_pixels")]
    pub train_pixels: u64,
    /// Denoise the re-renders (`_render.exr`), keeping the raw ones beside them
    /// (`_render_raw.exr`); off: `_render.exr` is the raw render.
    #[serde(default = "default_denoise")]
    pub denoise: bool,
}

fn default_denoise() -> bool {
    true
}

fn default_train_pixels() -> u64 {
    2_000_000
}

impl ReRenderConfig {
    /// Which of `views` training views of `pixels` pixels each are re-rendered
    /// (`train_pixels`): all, or as many as fit, evenly spaced from the first.
    pub fn train_views(&self, views: usize, pixels: usize) -> Vec<bool> {
        let fit = match self.train_pixels {
            0 => views,
            cap => ((cap / pixels.max(1) as u64) as usize).clamp(1, views.max(1)),
        };
        let mut chosen = vec![false; views];
        for j in 0..fit.min(views) {
            chosen[j * views / fit] = true;
        }
        chosen
    }
}

impl ReRenderConfig {
    /// Refuses samples beyond `fipt render`'s range and more than 64 bounces, naming the key.
    pub fn validate(&self) -> Result<(), String> {
        let most = MAX_SPP;
        fipt_core::range::check("render.spp", self.spp, 0, most)?;
        fipt_core::range::check("render.val_spp", self.val_spp, 0, most)?;
        fipt_core::range::check("render.max_bounces", self.max_bounces, 0, 64)
    }
}

impl RunConfig {
    pub fn preset(name: &str) -> Option<Self> {
        Some(RunConfig {
            bake: BakeConfig::preset(name)?,
            train: TrainConfig::preset(name)?,
            emitters: MaskExtractorConfig::default(),
            refine: RefineConfig::preset(name)?,
            rounds: RoundsConfig {
                refinements: if matches!(name, "paper" | "reference") {
                    2
                } else {
                    1
                },
                // Fresh networks after 10,000-step rounds: on `room`, `paper` warm-started
                // (30,000 steps on one field) scored val kd 25.1 dB, afresh 27.7 dB.
                warm_start: !matches!(name, "paper" | "reference"),
                roughness_prior: (name != "reference").then_some(0.0),
                settle_share: 0.15,
                settle_rounds: u32::from(matches!(name, "balanced" | "fast")),
            },
            render: ReRenderConfig {
                // Denoised (`docs/denoise.md`): on `studio-mitsuba`'s val views 16 spp read
                // 33.6 dB and 64 spp 34.9, against 30.8 for the raw 256 spp of before and 34.0
                // for raw 1024. `reference` keeps the method's raw 64-spp renders.
                spp: match name {
                    "reference" => 64,
                    "fast" => 8,
                    _ => 16,
                },
                val_spp: match name {
                    "fast" => 16,
                    "reference" => 0,
                    _ => 64,
                },
                max_bounces: 7,
                seed: 0,
                train_pixels: default_train_pixels(),
                denoise: name != "reference",
            },
            search: if name == "reference" {
                SearchConfig::off()
            } else {
                SearchConfig::default()
            },
            // The renderer's model of the data we did not make: on `studio-mitsuba` (Mitsuba's
            // `principled`) val kd 29.6 dB against 26.8 under FIPT's model (`room`, rendered with
            // FIPT's model: 27.4 against 29.8). `reference` keeps the method's model.
            model: ModelConfig {
                brdf: if name == "reference" {
                    ReflectanceModel::Fipt
                } else {
                    ReflectanceModel::Principled
                },
            },
            pipeline: PipelineConfig::default(),
            capture: Default::default(),
            plugins: Default::default(),
        })
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

/// The most samples per pixel of a render (and of `[render] spp`).
pub const MAX_SPP: u32 = 65_536;

#[cfg(test)]
mod tests {
    use super::*;

    /// The training views re-rendered: every one without a budget or under it; else as many
    /// as the budget holds, evenly spaced from the first, and never none.
    #[test]
    fn the_training_re_render_budget_picks_evenly_spaced_views() {
        let with = |train_pixels| ReRenderConfig {
            train_pixels,
            ..RunConfig::preset("fast").unwrap().render
        };
        let picked = |cap, views, pixels| -> Vec<usize> {
            let chosen = with(cap).train_views(views, pixels);
            assert_eq!(chosen.len(), views);
            (0..views).filter(|&k| chosen[k]).collect()
        };
        assert_eq!(picked(0, 5, 100), [0, 1, 2, 3, 4]);
        assert_eq!(picked(500, 5, 100), [0, 1, 2, 3, 4]);
        assert_eq!(picked(10_000, 5, 100), [0, 1, 2, 3, 4]);
        assert_eq!(picked(350, 10, 100), [0, 3, 6]);
        assert_eq!(picked(50, 10, 100), [0]);
        assert_eq!(picked(2_000_000, 200, 640 * 480).len(), 6);
        assert!(picked(350, 0, 100).is_empty());
    }
}
