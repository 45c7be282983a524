//! The training settings: presets, the learning-rate schedule, priors and segment sources.
use super::*;

/// Training settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainConfig {
    pub field: FieldConfig,
    pub steps: usize,
    /// Pixels per batch.
    pub batch: usize,
    /// At most this many passes over the training pixels in a round warm-started from the
    /// previous round's field: where `steps` batches would draw each pixel more often, the
    /// steps fall to ⌈max_passes · pixels / batch⌉ (at least `min_steps`); 0: no cap
    /// ([`TrainConfig::capped_steps`]). On a small scene the field otherwise fits the noise of
    /// the views and the shadings: on the default cornell (36,000 pixels) 1,000 steps are 225
    /// passes, and val kd rose as the steps fell. A round from a fresh field keeps its steps:
    /// its emission mask starts at α ≈ 0.5 and needs them to fall (capped at 25 passes, with
    /// 249 steps of 2,048 a 12-view cornell at 48×36 kept a floor triangle as a light; 400
    /// were enough there but not on a 4-spp cornell at 40×30).
    #[serde(default)]
    pub max_passes: f32,
    /// The fewest steps the `max_passes` cap leaves. A round after a search moves σ and
    /// metallic to its targets from a trained field: with 150 steps `balanced` left
    /// `cornell-metal`'s gold block dielectric (metal recall 0.99 → 0.17), with 400 it did not.
    #[serde(default)]
    pub min_steps: usize,
    /// The training set keeps at most `set_cap · steps · batch` pixels (a uniform random
    /// subset, drawn from the seed): a round never draws more, so a scene of more pixels
    /// than that gains little from holding them all (232 bytes each with `principled`).
    /// 0: every pixel.
    #[serde(default)]
    pub set_cap: f32,
    pub adam: AdamConfig,
    /// The hash tables' learning rate as a multiple of `adam.lr`.
    pub grid_lr_factor: f32,
    /// Learning-rate decay within a training round (the reference: none).
    #[serde(default)]
    pub lr_decay: LrDecay,
    /// Weight of mean(α) (mask sparsity).
    pub mask_weight: f32,
    /// Weight of the roughness/metallic prior. The reference's 5e-4 (`reference`) leaves metallic
    /// flipping between neighbouring points; 0.02 (`balanced`) measured +2.5 dB kd and +4 dB σ
    /// on `room` (val: kd 15.7 → 18.2 dB), and 0 loses 1 dB more.
    pub prior_weight: f32,
    /// `l1`: mean|σ − 1| + mean(m) (the reference). `l2`: mean((σ − 1)²) + mean(m²), whose pull
    /// vanishes at the target: with Adam, the L1 pull of every pixel on the MLP's shared output
    /// bias saturates the sigmoids (σ → 1, m → 0 everywhere) and drowns the few glossy or
    /// metallic pixels that observe them (measured on cornell with a gold block: glossy σ at
    /// 2.5 dB with L1). `l2_roughness`: L2 on σ, L1 on metallic (`balanced`, `fast`). On `room`
    /// an L1 σ pull saturated σ at 1 in the first round and the later, pull-free round could
    /// not bring it back (σ of the median val view 10.5 dB); with L2 it did (12.5 dB), and val
    /// kd rose 27.5 → 28.2 dB. L2 on metallic let small metallic values linger and cost 1.9 dB
    /// of val kd on a 12-view cornell (the e2e test).
    pub prior_norm: PriorNorm,
    /// The prior's weight ramps linearly from 0 at `prior_ramp[0]·steps` to full at
    /// `prior_ramp[1]·steps`. A prior active from the first step pulls every point to
    /// (σ = 1, m = 0), where a metal explained as a diffuse surface is a local minimum whose
    /// gradients in σ and m nearly vanish; letting the data shape the field first avoids it.
    /// `[0, 0]`: full weight from the start (the reference).
    pub prior_ramp: [f32; 2],
    /// Scale of the prior's σ part, |σ − 1| (1: the reference; the metallic part is always
    /// on). Under Adam, a small pull of the same sign at every pixel outweighs the weak
    /// gradient σ gets from the views, so any σ pull sends every surface to σ = 1 (on cornell
    /// with exact shadings the glossy block's σ went from 42.6 dB without it to 2.5 dB with the
    /// reference's 5e-4); without it, σ absorbs the noise of the shadings (on `room` after
    /// the initial bake, 88 % of the surface came out glossier than 0.6). `fipt run` keeps it
    /// for the first round and drops it after a refinement (`rounds.roughness_prior`); the
    /// segment prior carries σ from the highlights across each surface.
    #[serde(default = "unit_scale")]
    pub roughness_prior: f32,
    /// Which segment ids the segment-consistency prior uses (the caller loads them): `auto`
    /// takes the scene's part ids (`IndexMA/`) when it has them, `parts` requires them, `none`
    /// disables the prior.
    #[serde(default)]
    pub segments: SegmentSource,
    /// Weight of the segment-consistency prior (the reference's part prior, 5e-3): each pixel's
    /// σ and metallic are pulled towards its segment's means in the batch, weighted by the
    /// pixels' specular shading (see [`FactorizedLoss`]).
    #[serde(default = "default_segment_weight")]
    pub segment_weight: f32,
    /// The semantic prior, used instead when the ids are semantic classes (`segmentation/`).
    #[serde(default)]
    pub semantic: SemanticPrior,
    /// Weight of the pull towards the material search's (σ*, m*) at the pixels that have one
    /// (`[search]` in `fipt run`): `(σ − σ*)² + (m − m*)²`, from the first step and in every
    /// round; it replaces the roughness/metallic prior there. Ignored without targets.
    #[serde(default = "default_target_weight")]
    pub target_weight: f32,
    pub seed: u64,
    /// Shrink the hash tables to what the number of training pixels can fill
    /// ([`TrainConfig::sized_for`]). The reference always uses 2^19.
    pub table_from_data: bool,
    /// Set the finest level from the median pixel footprint ([`TrainConfig::sized_for`]).
    pub finest_from_data: bool,
    /// The finest cell's width in median pixel footprints (with `finest_from_data`). Default 4:
    /// wider cells pool more pixels (less noise from the views and the shadings) but blur
    /// texture edges; on `room` after one refinement, val kd measured 22.1 / 24.6 / 26.1 /
    /// 26.8 / 27.5 dB at 1 / 2 / 3 / 4 / 6 footprints, with the checker floor visibly blurred
    /// at 6.
    pub finest_cell_footprints: f32,
    /// Steps between checkpoints (0: only at the end).
    pub checkpoint_every: usize,
    /// Leave out of the training set the pixels within this many pixels of one at least
    /// `bleed_contrast` times brighter (0: keep every pixel, the presets). A camera's pixel
    /// filter spreads a light over its neighbours (Mitsuba's default Gaussian over about two
    /// pixels), while the model sees the surface at the pixel's centre. Radius 2 was the
    /// presets' answer to a bright kd ring around `studio-mitsuba`'s ceiling panel, which
    /// `emitter_material = false` now removes at its cause; left out, the pixels beside a light
    /// leave its neighbourhood to the light's own kd (a ring 4–5 pixels wide around
    /// `gallery-mitsuba`'s wall panel).
    #[serde(default)]
    pub bleed_radius: u32,
    /// See `bleed_radius`. Darker pixels than 1 % of the view's median luminance count as
    /// that floor (a noisy shadow is not a bright edge).
    #[serde(default = "default_bleed_contrast")]
    pub bleed_contrast: f32,
    /// How a pixel's error is measured: `srgb` compares sRGB-encoded values (the reference);
    /// `srgb_slope` weighs the linear error by the sRGB curve's slope at the prediction (the
    /// same emphasis on dark pixels, but the views' noise averages out instead of pulling kd
    /// down: the sRGB curve is concave, so the mean of a noisy pixel's encoded values lies
    /// below the encoded mean).
    #[serde(default)]
    pub image_loss: ImageLoss,
    /// Whether a light's pixels (over 4× brighter than any reflection their shadings allow:
    /// [`crate::ops::unreflectable`]) train the material too (the reference). Their loss term
    /// is (1 − α)·(kd·Ld + …) + α·I, so at α ≈ 0.7 a light 30× as bright as the wall behind it
    /// drives kd to 1 there, and the hash cells it shares with
    /// the wall 1 cm behind carry that albedo into the wall around the light (a white ring
    /// 4–5 pixels wide around `gallery-mitsuba`'s wall panel). Off: those pixels train the
    /// mask only (`docs/gallery-mitsuba.md`).
    #[serde(default = "default_true")]
    pub emitter_material: bool,
}

impl Default for TrainConfig {
    /// The `balanced` preset.
    fn default() -> Self {
        TrainConfig {
            field: FieldConfig::default(),
            // On `room` 1000 steps beat 3000 (val kd 18.2 vs 17.2 dB, σ 14.2 vs 13.0 dB,
            // re-render 22.0 vs 21.5 dB): longer training fits the shadings' noise.
            steps: 1000,
            batch: 8192,
            max_passes: MAX_PASSES,
            min_steps: MIN_STEPS,
            set_cap: 1.0,
            adam: AdamConfig::default(),
            grid_lr_factor: 1.0,
            // On `room` (whole run): val kd 27.99 → 28.39 dB, σ 22.98 → 23.07 dB, median view
            // σ 12.00 → 12.50 dB against a constant rate.
            lr_decay: LrDecay {
                start: 0.5,
                factor: 0.1,
            },
            mask_weight: 1.0,
            prior_weight: 0.02,
            prior_norm: PriorNorm::L2Roughness,
            prior_ramp: [0.3, 0.6],
            roughness_prior: 1.0,
            segments: SegmentSource::Auto,
            segment_weight: default_segment_weight(),
            semantic: SemanticPrior::default(),
            target_weight: default_target_weight(),
            table_from_data: true,
            finest_from_data: true,
            finest_cell_footprints: 4.0,
            seed: 9,
            checkpoint_every: 500,
            // With `emitter_material` off, leaving out the pixels beside the lights only
            // opened a gap the lights' undefined kd filled (`docs/gallery-mitsuba.md`).
            bleed_radius: 0,
            bleed_contrast: default_bleed_contrast(),
            image_loss: ImageLoss::Srgb,
            emitter_material: false,
        }
    }
}

impl TrainConfig {
    /// The reference's sizes and steps (32 levels × 2 features × 2^19, base 16; 10k steps of
    /// 8192 pixels, lr 1e-3, seed 9) with this crate's losses and sizing: the finest level
    /// from the pixel footprint (the reference's scale 1.3 makes cells far below a pixel),
    /// the learning rate decayed over the second half of the steps (as `balanced`).
    pub fn paper() -> Self {
        TrainConfig {
            field: FieldConfig {
                grid: HashGridConfig::reference(),
                ..FieldConfig::default()
            },
            steps: 10_000,
            // The reference's steps on every scene.
            max_passes: 0.0,
            table_from_data: false,
            ..Self::default()
        }
    }
    /// The reference as it is: its sizes and steps, and its mask activation (relu), σ
    /// parametrisation (gain 1 from 0.51), prior (5e-4·(mean|σ − 1| + mean(m)) from the first
    /// step), constant learning rate and fixed per-level scale.
    pub fn reference() -> Self {
        TrainConfig {
            field: FieldConfig {
                grid: HashGridConfig::reference(),
                mask_activation: crate::field::MaskActivation::Relu,
                roughness_gain: 1.0,
                roughness_init: 0.51,
                roughness_leak: 0.0,
                ..FieldConfig::default()
            },
            steps: 10_000,
            max_passes: 0.0,
            set_cap: 0.0,
            prior_weight: 5e-4,
            prior_norm: PriorNorm::L1,
            prior_ramp: [0.0, 0.0],
            roughness_prior: 1.0,
            table_from_data: false,
            finest_from_data: false,
            lr_decay: LrDecay::default(),
            bleed_radius: 0,
            emitter_material: true,
            ..Self::default()
        }
    }
    /// Fewer, smaller levels and steps.
    pub fn fast() -> Self {
        TrainConfig {
            field: FieldConfig {
                grid: HashGridConfig {
                    levels: 12,
                    log2_table: 17,
                    per_level_scale: 1.5,
                    ..HashGridConfig::default()
                },
                mask_width: 32,
                ..FieldConfig::default()
            },
            steps: 1000,
            ..Self::default()
        }
    }
    /// These settings with the hash tables no larger than the data can fill: per level at
    /// most `2^ceil(log2(4·pixels))` entries (at least 2^14), when `table_from_data` is set.
    ///
    /// With `finest_from_data` and a `footprint` (median world-space size of a training pixel,
    /// same units as `bounds`), `per_level_scale` is set so that the finest level's cells are
    /// about one pixel footprint wide: finer cells are each seen by a single pixel and fit its
    /// noise (measured on cornell at 64×48: kd of unseen views 10 dB with 1.6 mm cells for
    /// 4 cm pixels).
    pub fn sized_for(&self, pixels: usize, footprint: Option<f32>, bounds: &Bounds) -> TrainConfig {
        let mut c = self.clone();
        if c.table_from_data {
            let need = (4 * pixels.max(1))
                .next_power_of_two()
                .trailing_zeros()
                .max(14);
            c.field.grid.log2_table = c.field.grid.log2_table.min(need);
        }
        if let (true, Some(f)) = (c.finest_from_data, footprint) {
            let g = &mut c.field.grid;
            if f > 0.0 && f.is_finite() && g.levels > 1 {
                let cell = f * c.finest_cell_footprints.max(1e-3);
                let finest = (bounds.size / cell).max(g.base_resolution as f32);
                let scale = (finest / g.base_resolution as f32).powf(1.0 / (g.levels - 1) as f32);
                // Rounded so that the value survives a JSON round trip unchanged.
                g.per_level_scale = ((scale * 1e4).round() / 1e4).clamp(1.0, 4.0);
            }
        }
        c
    }

    /// `steps`, lowered so that a round `warm`-started from the previous one passes over
    /// `pixels` at most `max_passes` times (never below `min_steps`, never above `steps`); a
    /// round from a fresh field keeps `steps`.
    pub fn capped_steps(&self, pixels: usize, warm: bool) -> usize {
        if !warm || self.max_passes <= 0.0 || self.batch == 0 {
            return self.steps;
        }
        let cap = (self.max_passes as f64 * pixels as f64 / self.batch as f64).ceil() as usize;
        self.steps.min(cap.max(self.min_steps))
    }

    /// How many training pixels the set keeps at most (`set_cap · steps · batch`; `None`:
    /// every pixel).
    pub fn set_limit(&self) -> Option<usize> {
        (self.set_cap > 0.0)
            .then(|| (self.set_cap as f64 * self.steps as f64 * self.batch as f64).ceil() as usize)
    }

    pub fn validate(&self) -> Result<()> {
        use fipt_core::range::check;
        let sizes = [
            check("steps", self.steps, 1, 10_000_000),
            check("min_steps", self.min_steps, 0, 10_000_000),
            check("checkpoint_every", self.checkpoint_every, 0, 10_000_000),
            check("grid_lr_factor", self.grid_lr_factor, 0.0, 1e6),
            check(
                "finest_cell_footprints",
                self.finest_cell_footprints,
                0.0,
                1e6,
            ),
        ];
        for r in sizes {
            r.map_err(|e| NeuralError::config("train", e))?;
        }
        for (key, v) in [("max_passes", self.max_passes), ("set_cap", self.set_cap)] {
            if !(v >= 0.0 && v <= 1e6) {
                return Err(NeuralError::config(
                    "train",
                    format!("{key} = {v} (use a value in [0, 1000000]; 0 turns it off)"),
                ));
            }
        }
        self.field.grid.validate("train.field.grid")?;
        if self.batch == 0 || self.batch > 1 << 22 {
            return Err(NeuralError::config(
                "train",
                format!("batch = {} (use 1..=4194304)", self.batch),
            ));
        }
        let f = &self.field;
        if !(f.roughness_gain > 0.0 && f.roughness_gain <= 100.0) {
            return Err(NeuralError::config(
                "train.field",
                format!("roughness_gain = {} (use (0, 100])", f.roughness_gain),
            ));
        }
        let lo = fipt_core::reflectance::MIN_ROUGHNESS;
        if !(f.roughness_init >= lo && f.roughness_init <= 1.0) {
            return Err(NeuralError::config(
                "train.field",
                format!("roughness_init = {} (use [{lo}, 1])", f.roughness_init),
            ));
        }
        let d = self.lr_decay;
        if !((0.0..=1.0).contains(&d.start) && d.factor > 0.0 && d.factor <= 1.0) {
            return Err(NeuralError::config(
                "train.lr_decay",
                format!(
                    "start = {}, factor = {} (use start in [0, 1] and factor in (0, 1])",
                    d.start, d.factor
                ),
            ));
        }
        if self.bleed_radius > 16 || !(self.bleed_contrast >= 1.0 && self.bleed_contrast <= 1e6) {
            return Err(NeuralError::config(
                "train",
                format!(
                    "bleed_radius = {}, bleed_contrast = {} (use a radius of at most 16 pixels and a contrast in [1, 1000000])",
                    self.bleed_radius, self.bleed_contrast
                ),
            ));
        }
        self.validate_weights()
    }

    /// The segment prior's and the loss's weights and widths, and the learning rate.
    fn validate_weights(&self) -> Result<()> {
        let sp = &self.semantic;
        if sp.partners == 0 || sp.partners > 4096 {
            return Err(NeuralError::config(
                "train.semantic",
                format!("partners = {} (use 1..=4096)", sp.partners),
            ));
        }
        for (key, v) in [
            ("sigma_albedo", sp.sigma_albedo),
            ("sigma_position", sp.sigma_position),
        ] {
            if !(v > 0.0 && v.is_finite()) {
                return Err(NeuralError::config(
                    "train.semantic",
                    format!("{key} = {v} (use a width > 0)"),
                ));
            }
        }
        for (key, v) in [
            ("semantic.weight", sp.weight),
            ("segment_weight", self.segment_weight),
            ("target_weight", self.target_weight),
            ("roughness_prior", self.roughness_prior),
            ("prior_weight", self.prior_weight),
            ("mask_weight", self.mask_weight),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(NeuralError::config(
                    "train",
                    format!("{key} = {v} (use a finite weight ≥ 0)"),
                ));
            }
        }
        if !(self.adam.lr > 0.0 && self.adam.lr.is_finite()) {
            return Err(NeuralError::config(
                "train.adam",
                format!("lr = {}", self.adam.lr),
            ));
        }
        Ok(())
    }
}

/// `balanced`'s and `fast`'s cap on passes over the training pixels (`max_passes`).
pub const MAX_PASSES: f32 = 25.0;
/// `balanced`'s and `fast`'s fewest steps under that cap (`min_steps`).
pub const MIN_STEPS: usize = 400;

fn unit_scale() -> f32 {
    1.0
}

fn default_target_weight() -> f32 {
    0.02
}

fn default_bleed_contrast() -> f32 {
    fipt_core::image::BLEED_CONTRAST
}

fn default_segment_weight() -> f32 {
    5e-3
}

/// Settings written before `emitter_material` existed trained the material at emitters.
fn default_true() -> bool {
    true
}

/// Geometric learning-rate decay: `adam.lr` until `start·steps`, then down to
/// `factor·adam.lr` at the last step (`lr·factor^((x − start)/(1 − start))` at the fraction x
/// of the steps). At a constant rate Adam's iterate keeps jumping around the optimum by the
/// batch noise; a decay lets the last steps average it out. `start = 1` or `factor = 1`: none.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LrDecay {
    /// Fraction of the steps at which the decay begins, in [0, 1].
    pub start: f32,
    /// The rate at the last step as a multiple of `adam.lr`, in (0, 1].
    pub factor: f32,
}

impl Default for LrDecay {
    fn default() -> Self {
        LrDecay {
            start: 1.0,
            factor: 1.0,
        }
    }
}

impl LrDecay {
    /// The multiple of the learning rate at step `step` (0-based) of `steps`.
    pub fn scale(&self, step: usize, steps: usize) -> f32 {
        let x = step as f32 / steps.saturating_sub(1).max(1) as f32;
        if x <= self.start {
            1.0
        } else {
            self.factor
                .powf(((x - self.start) / (1.0 - self.start)).min(1.0))
        }
    }
}

/// The reference's prior for semantic classes (see [`SemanticPartners`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SemanticPrior {
    /// Weight (the reference: 1e-3).
    pub weight: f32,
    /// Partners drawn per pixel among the batch's pixels of its class (the reference: 1024).
    pub partners: usize,
    /// Albedo kernel width (the reference: 0.05/3).
    pub sigma_albedo: f32,
    /// Position kernel width, in the scene cube's [−1, 1] coordinates (the reference: 0.1).
    pub sigma_position: f32,
}

impl Default for SemanticPrior {
    fn default() -> Self {
        SemanticPrior {
            weight: 1e-3,
            partners: 64,
            sigma_albedo: 0.05 / 3.0,
            sigma_position: 0.1,
        }
    }
}

/// Where the ids of the segment-consistency prior come from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SegmentSource {
    /// Part ids when the scene has them, else semantic classes when it has them, else smooth
    /// patches of the mesh (a capture: on `studio-mitsuba`'s capture-like copy `cap-hdr`, val
    /// σ 30.24 → 30.76 dB against none, the metal sphere's 22.3 → 24.9; `docs/captures.md`).
    #[default]
    Auto,
    /// Part ids (`IndexMA/`), required.
    Parts,
    /// Semantic classes (`segmentation/`), required.
    Semantic,
    /// Smooth connected patches of the mesh (a dihedral angle under 30° joins two triangles):
    /// for captures, which have no part ids.
    Mesh,
    /// No segment prior.
    None,
}

/// Norm of the roughness/metallic prior.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PriorNorm {
    L1,
    L2,
    /// L2 on σ, L1 on metallic.
    L2Roughness,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cap lowers a warm-started round's steps to ⌈passes · pixels / batch⌉, never below
    /// the floor nor above the steps asked; a fresh round keeps its steps; 0 turns it off; the
    /// set's limit is one round's draws.
    #[test]
    fn steps_are_capped_in_passes_over_the_pixels() {
        let c = TrainConfig::fast();
        assert_eq!((c.steps, c.batch, c.min_steps), (1000, 8192, 400));
        // 36,000 pixels at 25 passes: 110 steps, raised to the floor; a fresh round: all.
        assert_eq!(c.capped_steps(36_000, true), 400);
        assert_eq!(c.capped_steps(36_000, false), 1000);
        // 200,000 pixels: 611 steps; 1.6 M pixels (5 passes): untouched.
        assert_eq!(c.capped_steps(200_000, true), 611);
        assert_eq!(c.capped_steps(1_600_000, true), 1000);
        let off = TrainConfig {
            max_passes: 0.0,
            ..c.clone()
        };
        assert_eq!(off.capped_steps(100, true), 1000);
        assert_eq!(TrainConfig::paper().capped_steps(36_000, true), 10_000);
        let floor_above = TrainConfig {
            min_steps: 5000,
            ..c.clone()
        };
        assert_eq!(floor_above.capped_steps(100, true), 1000);
        assert_eq!(c.set_limit(), Some(8_192_000));
        assert_eq!(TrainConfig::reference().set_limit(), None);
        for bad in [-1.0, f32::NAN, f32::INFINITY] {
            assert!(TrainConfig {
                max_passes: bad,
                ..c.clone()
            }
            .validate()
            .is_err());
            assert!(TrainConfig {
                set_cap: bad,
                ..c.clone()
            }
            .validate()
            .is_err());
        }
    }
}

impl fipt_core::presets::Presets for TrainConfig {
    fn paper() -> Self {
        TrainConfig::paper()
    }
    fn reference() -> Self {
        TrainConfig::reference()
    }
    fn balanced() -> Self {
        TrainConfig::default()
    }
    fn fast() -> Self {
        TrainConfig::fast()
    }
}
