//! The host's settings of a run (`RunConfig`: `[render]`, `[model]`, `[pipeline]`,
//! `[capture]`), typed with `deny_unknown_fields`, and the presets' values; the components'
//! tables (`[bake]`, `[train]`, `[search]`, `[plugins.<name>]`, …) kept as written, each typed
//! by the factory of the component that reads it ([`crate::Components::settings_of`]).
use crate::error::Result;
use fipt_core::reflectance::ReflectanceModel;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// All settings of a run: the host's sections typed, the components' tables as the file gave
/// them (a table no registered component reads is refused by [`crate::run::check`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunConfig {
    pub render: ReRenderConfig,
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
    pub plugins: BTreeMap<String, serde_json::Value>,
    /// The components' own tables as written (`[bake]`, `[train]`, `[search]`, …; absent:
    /// the preset's values, which the component that reads the table gives).
    #[serde(flatten)]
    pub tables: BTreeMap<String, serde_json::Value>,
}

/// `[pipeline]`: the components `fipt run` composes, by registered name
/// ([`crate::Components`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PipelineConfig {
    /// The method: a registered fitter's name (`fipt`, the default, registered by crate
    /// fipt-method with its tables `[search]`, `[rounds]`, `[train]`, `[refine]`; `ipt`;
    /// another's settings `[plugins.<name>]`).
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
    /// The host's own tables (typed here); every other table belongs to a component.
    pub const HOST_TABLES: &'static [&'static str] =
        &["render", "model", "pipeline", "capture", "plugins"];

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

/// Bounces of every preset's re-render, of `fipt render` and of the renders `fipt eval` scores
/// (a run's own setting where it has one). Russian roulette ends most paths long before, so
/// the cap costs little: a capture holds every bounce, and at 7 (the cut of the Mitsuba rooms'
/// `max_depth` 8) `kitchen` rendered with every bounce re-rendered 1.4 dB lower
/// (`docs/kd-bias.md`). At 5, `fipt eval --cameras-from` rendered `kitchen`'s recovered scene
/// 13 % too dark.
pub const DEFAULT_MAX_BOUNCES: u32 = 24;

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
    /// At most this many training-view pixels are re-rendered and mapped (views evenly spaced
    /// in index order, the first always among them; the same views for both, listed in
    /// `views/train/maps.json` where some are left out); 0: every training view. The training
    /// views' re-renders and maps show the fit to the photographs; the novel (val) views are
    /// always all re-rendered and mapped. 2 M: `studio-mitsuba`, `room` and `cornell` keep
    /// every view; 200 views of 640 × 480 keep 6, which made 90 % of the re-render's time
    /// (`docs/scaling.md`).
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
    /// The host's sections of preset `name` (the components' tables empty: each component
    /// gives its own preset values); None for an unknown name.
    pub fn preset(name: &str) -> Option<Self> {
        if !fipt_core::presets::is_known(name) {
            return None;
        }
        Some(RunConfig {
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
                max_bounces: DEFAULT_MAX_BOUNCES,
                seed: 0,
                train_pixels: default_train_pixels(),
                denoise: name != "reference",
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
            tables: Default::default(),
        })
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
