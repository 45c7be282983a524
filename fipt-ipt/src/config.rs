//! `[plugins.ipt]`: the settings of the joint optimisation, laid over a named preset.
use serde::{Deserialize, Serialize};

/// What the material unknowns are attached to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Segments {
    /// One material per scene part (`IndexMA/`, else per class of `segmentation/`) when the
    /// scene has them, else one per triangle.
    Auto,
    /// One material per triangle.
    None,
}

/// The settings of `--method ipt`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IptConfig {
    /// Gradient steps.
    pub iterations: u32,
    /// Training pixels per step (each traced twice: one path for the residual, an independent
    /// one for the gradient, so the squared loss's gradient is unbiased).
    pub batch: u32,
    /// Reflections along a path at most (1: direct light only).
    pub max_bounces: u32,
    /// Reflections before Russian roulette ends paths by their throughput.
    pub rr_start: u32,
    /// Adam's rate at the first step; it decays exponentially to `learning_rate ·
    /// final_rate_ratio` at the last (a constant rate keeps joint optimisation wandering).
    pub learning_rate: f32,
    pub final_rate_ratio: f32,
    /// The rate of the log-radiances relative to `learning_rate` (a step of the log is a
    /// relative change of the radiance; emitters start decades below their value).
    pub emission_rate_scale: f32,
    /// The largest relative residual |L − I| / (I + ε) a pixel contributes, per channel: one
    /// firefly of the residual path must not steer a step (at the price of a bias where the
    /// residual path is that noisy).
    pub max_relative_residual: f32,
    /// The material unknowns: per part (`auto`) or per triangle (`none`).
    pub segments: Segments,
    /// One emitted radiance for both sides of a triangle (FIPT's assumption) instead of one
    /// per side (lights are mostly one-sided panels; a side no view sees stays black either
    /// way).
    pub two_sided_emission: bool,
    /// Weight of the L1 prior on emitted radiance (area-weighted, relative to the radiance
    /// observed on each triangle): it decides between a surface that reflects and one that
    /// emits.
    pub emission_prior: f32,
    /// Weight of the L1 prior on metallic (each group's m weighted by its share of the training
    /// pixels, so the prior is on the loss's per-pixel scale): where the views cannot tell a
    /// rough metal of base colour a from a rough dielectric (σ near 1: both lobes are broad),
    /// nothing else holds m, and the fit wandered to m ≈ 0.25 on rough walls; a metal the
    /// highlights demand outweighs it. 0: off.
    pub metallic_prior: f32,
    /// Rebuild the emitter sampler from the current emission every this many steps.
    pub light_update_every: u32,
    /// Save the state every this many steps (and at the end); a rerun resumes from it.
    pub checkpoint_every: u32,
    /// A seen triangle is an emitter when its fitted radiance is at least this share of the
    /// radiance observed on it.
    pub emitter_share: f32,
    /// A group of emitting triangles is a light only when the radiance observed on it is at
    /// least this many times the training views' median luminance (0: every group). Lights
    /// outshine what they light; a bright wall beside one that the fit made emit does not.
    pub emitter_contrast: f32,
    /// Initial base colour, roughness, and emitted radiance of each seen triangle relative to
    /// the radiance observed on it.
    pub init_albedo: f32,
    pub init_roughness: f32,
    pub init_emission: f32,
    pub seed: u64,
}

impl Default for IptConfig {
    fn default() -> Self {
        IptConfig::balanced()
    }
}

impl IptConfig {
    /// About 5 min on `studio-mitsuba` (40 views of 320×240) on 2 cores.
    pub fn balanced() -> Self {
        IptConfig {
            iterations: 10_000,
            batch: 16_384,
            max_bounces: 6,
            rr_start: 2,
            learning_rate: 0.03,
            final_rate_ratio: 0.05,
            emission_rate_scale: 4.0,
            max_relative_residual: 50.0,
            segments: Segments::Auto,
            two_sided_emission: false,
            emission_prior: 0.1,
            metallic_prior: 0.05,
            light_update_every: 10,
            checkpoint_every: 50,
            emitter_share: 0.5,
            emitter_contrast: 10.0,
            init_albedo: 0.5,
            init_roughness: 0.5,
            init_emission: 0.01,
            seed: 0,
        }
    }

    /// About 1 min on `studio-mitsuba`.
    pub fn fast() -> Self {
        IptConfig {
            iterations: 3000,
            batch: 8192,
            max_bounces: 4,
            ..Self::balanced()
        }
    }

    /// About 20 min on `studio-mitsuba`.
    pub fn paper() -> Self {
        IptConfig {
            iterations: 30_000,
            batch: 16_384,
            max_bounces: 8,
            ..Self::balanced()
        }
    }

    /// Range checks, naming the key.
    pub fn validate(&self) -> Result<(), String> {
        let bad = |k: &str, why: &str| Err(format!("[plugins.ipt] {k}: {why}"));
        if self.iterations == 0 || self.iterations > 10_000_000 {
            return bad("iterations", "must be in 1..=10000000");
        }
        if self.batch == 0 || self.batch > 1 << 22 {
            return bad("batch", "must be in 1..=4194304");
        }
        if self.max_bounces == 0 || self.max_bounces > 32 {
            return bad("max_bounces", "must be in 1..=32");
        }
        if !(self.learning_rate > 0.0 && self.learning_rate <= 1.0) {
            return bad("learning_rate", "must be in (0, 1]");
        }
        if !(self.final_rate_ratio > 0.0 && self.final_rate_ratio <= 1.0) {
            return bad("final_rate_ratio", "must be in (0, 1]");
        }
        if !(self.max_relative_residual > 0.0) {
            return bad("max_relative_residual", "must be > 0");
        }
        if !(self.emission_rate_scale > 0.0 && self.emission_rate_scale <= 100.0) {
            return bad("emission_rate_scale", "must be in (0, 100]");
        }
        if !(self.emission_prior >= 0.0 && self.emission_prior.is_finite()) {
            return bad("emission_prior", "must be ≥ 0");
        }
        if !(self.metallic_prior >= 0.0 && self.metallic_prior <= 100.0) {
            return bad("metallic_prior", "must be in [0, 100]");
        }
        if self.light_update_every == 0 || self.checkpoint_every % self.light_update_every != 0 {
            return bad(
                "light_update_every / checkpoint_every",
                "must be ≥ 1, checkpoint_every a multiple of light_update_every",
            );
        }
        if !(self.emitter_share > 0.0 && self.emitter_share <= 1.0) {
            return bad("emitter_share", "must be in (0, 1]");
        }
        if !(self.emitter_contrast >= 0.0 && self.emitter_contrast <= 1e6) {
            return bad("emitter_contrast", "must be in [0, 1000000]");
        }
        if !(0.0..=1.0).contains(&self.init_albedo)
            || !(0.02..=1.0).contains(&self.init_roughness)
            || !(self.init_emission > 0.0 && self.init_emission.is_finite())
        {
            return bad(
                "init_*",
                "init_albedo in [0, 1], init_roughness in [0.02, 1], init_emission > 0",
            );
        }
        Ok(())
    }
}

/// `reference` is `paper`: the reference never had an IPT.
impl fipt_core::presets::Presets for IptConfig {
    fn paper() -> Self {
        IptConfig::paper()
    }
    fn balanced() -> Self {
        IptConfig::balanced()
    }
    fn fast() -> Self {
        IptConfig::fast()
    }
}
