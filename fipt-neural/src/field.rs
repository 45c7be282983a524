//! The neural material field: hash grid + MLP → (albedo, roughness, metallic), and the
//! emission mask: positional encoding + MLP → α = 1 − exp(−relu(m)).
use crate::error::{CandleContext, NeuralError, Result};
use crate::hashgrid::{AdamConfig, HashGrid, HashGridConfig, HashGridOp};
use crate::head::{self, head_candle, FieldHead, HeadConfig};
use crate::mlp::Mlp;
use crate::ops::positional_encoding;
use candle_core::{DType, Device, Module, Tensor, Var};
use candle_nn::{VarBuilder, VarMap};
use fipt_core::field::{Material, MaterialField};
use fipt_core::materials::MIN_ROUGHNESS;
use fipt_core::rng::Pcg32;
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Sizes of the material field and the emission mask.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FieldConfig {
    pub grid: HashGridConfig,
    /// Width of the material MLP's hidden layers.
    pub mlp_width: usize,
    /// Number of hidden layers of the material MLP.
    pub mlp_hidden: usize,
    /// Frequencies of the mask's positional encoding.
    pub mask_frequencies: usize,
    pub mask_width: usize,
    pub mask_hidden: usize,
    /// Initial bias of the mask's output, so that every point starts with α > 0 and a live
    /// gradient (with α = 1 − exp(−relu(m)), a point whose m starts below 0 could never learn to
    /// emit). Sparsity then drives non-emitters to α = 0.
    pub mask_init_bias: f32,
    /// Initial bias of the metallic output's logit (0: m starts at 0.5). −2 would start at m ≈ 0.12, so
    /// metallic grows only where the data asks for it (a metal) instead of settling wherever
    /// kd and a·m trade off freely on rough surfaces.
    pub metallic_init_bias: f32,
    /// σ = 0.02 + 0.98·sigmoid(gain·h) for the material MLP's σ output h (1: the reference).
    /// σ changes the views only through ks·Ls(σ) (ks ≈ 0.04 on dielectrics), so its gradient
    /// is small and noisy while Adam moves each weight by at most about lr a step: with gain 1
    /// a glossy block (σ = 0.25) on cornell with exact shadings was still at 0.3–0.5 after
    /// 1500 steps (15 dB); with gain 10 and the segment prior it reached 0.25 (42.6 dB).
    #[serde(default = "unit_gain")]
    pub roughness_gain: f32,
    /// σ where training starts (through the bias of σ's output). The reference starts at
    /// 0.51 and pulls every point towards σ = 1 with its prior; `balanced` starts at 0.98
    /// without the pull instead, so σ stays rough where the views say nothing about it (rough
    /// walls) and drops only where highlights ask for it.
    #[serde(default = "default_roughness_init")]
    pub roughness_init: f32,
    /// A floor on σ's sigmoid slope in the backward (the forward is unchanged) at the points
    /// with a σ target of the material search: the gradient of σ's logit is
    /// `gain·(s(1 − s) + leak)` there. Elsewhere σ keeps the plain sigmoid (with the leak
    /// everywhere, the rough walls of a cornell trained with semantic classes drifted from
    /// σ = 1: 13.8 dB where 17 is asked). Where the first round's pull saturated σ at 1
    /// (s(1 − s) ≈ 1e-4), a later pull towards the search's target (the glossy box of
    /// `studio-mitsuba`: 0.48) could not move it, at any `target_weight`. 0: the plain sigmoid
    /// (`reference`); the other presets 0.02.
    #[serde(default)]
    pub roughness_leak: f32,
    /// `relu`: α = 1 − exp(−relu(m)) (the reference); `softplus`: α = 1 − exp(−softplus(m)).
    /// With relu, a point whose m falls below 0 has no gradient left: on `room` the 5 cm bulb
    /// (a few pixels per view) was switched off by the sparsity term early in training and
    /// never came back. softplus keeps a gradient everywhere; non-emitters settle at α ≈ 0.
    pub mask_activation: MaskActivation,
}

/// Activation of the emission mask's output.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MaskActivation {
    Relu,
    Softplus,
}

impl Default for FieldConfig {
    fn default() -> Self {
        FieldConfig {
            grid: HashGridConfig::default(),
            mlp_width: 64,
            mlp_hidden: 2,
            mask_frequencies: 10,
            mask_width: 64,
            mask_hidden: 2,
            mask_init_bias: 0.1,
            metallic_init_bias: 0.0,
            mask_activation: MaskActivation::Softplus,
            roughness_gain: 10.0,
            roughness_init: 0.98,
            roughness_leak: 0.02,
        }
    }
}

fn unit_gain() -> f32 {
    1.0
}

/// σ at a zero logit (the reference's start).
fn default_roughness_init() -> f32 {
    MIN_ROUGHNESS + (1.0 - MIN_ROUGHNESS) * 0.5
}

impl FieldConfig {
    /// The bias of σ's output that starts σ at `roughness_init`.
    fn roughness_bias(&self) -> f32 {
        let s =
            ((self.roughness_init - MIN_ROUGHNESS) / (1.0 - MIN_ROUGHNESS)).clamp(1e-4, 1.0 - 1e-4);
        (s / (1.0 - s)).ln() / self.roughness_gain.max(1e-6)
    }
}

/// The cube the grid covers (`unit = (p − min) / size`): fipt-core's [`Cube`], under the
/// name the field's API uses.
pub use fipt_core::cube::Cube as Bounds;

/// Outputs of a forward pass: one packed `[n, 6]` tensor (albedo, σ, metallic, α), and its
/// columns as contiguous `[n, k]` copies on demand.
pub struct FieldOutput {
    packed: Tensor,
}

impl FieldOutput {
    /// From the packed `[n, 6]` head (albedo, σ, metallic, α).
    pub fn from_packed(packed: Tensor) -> Self {
        FieldOutput { packed }
    }
    fn columns(&self, start: usize, len: usize) -> candle_core::Result<Tensor> {
        self.packed.narrow(1, start, len)?.contiguous()
    }
    pub fn device(&self) -> &Device {
        self.packed.device()
    }
    /// `[n, 3]`.
    pub fn albedo(&self) -> candle_core::Result<Tensor> {
        self.columns(0, 3)
    }
    /// σ = 0.02 + 0.98·s, `[n, 1]`.
    pub fn roughness(&self) -> candle_core::Result<Tensor> {
        self.columns(3, 1)
    }
    /// `[n, 1]`.
    pub fn metallic(&self) -> candle_core::Result<Tensor> {
        self.columns(4, 1)
    }
    /// α ∈ [0, 1), `[n, 1]`.
    pub fn alpha(&self) -> candle_core::Result<Tensor> {
        self.columns(5, 1)
    }
    /// From the four parts (`[n, 3]`, `[n, 1]` × 3), packed by a concatenation.
    pub fn new(
        albedo: &Tensor,
        roughness: &Tensor,
        metallic: &Tensor,
        alpha: &Tensor,
    ) -> candle_core::Result<Self> {
        Ok(Self::from_packed(Tensor::cat(
            &[albedo, roughness, metallic, alpha],
            1,
        )?))
    }
    /// `[n, 6]`: albedo, σ, metallic, α (the input of [`crate::ops::FactorizedLoss`]).
    pub fn packed(&self) -> candle_core::Result<Tensor> {
        Ok(self.packed.clone())
    }
    /// kd = a·(1 − m).
    pub fn kd(&self) -> candle_core::Result<Tensor> {
        self.albedo()?
            .broadcast_mul(&self.metallic()?.affine(-1.0, 1.0)?)
    }
    /// ks = 0.04·(1 − m) + a·m ([`fipt_core::reflectance::metallic_workflow`]).
    pub fn ks(&self) -> candle_core::Result<Tensor> {
        let f0 = fipt_core::reflectance::DIELECTRIC_F0 as f64;
        let metallic = self.metallic()?;
        self.albedo()?
            .broadcast_mul(&metallic)?
            .broadcast_add(&metallic.affine(-f0, f0)?)
    }
}

/// What the hash grid's backward does in a forward pass.
#[derive(Clone, Copy)]
enum GridGrad {
    /// No backward (queries).
    None,
    /// Accumulate the tables' gradient.
    Accumulate,
    /// Accumulate and take the tables' Adam step.
    Step(AdamConfig),
}

impl GridGrad {
    /// Whether the pass is recorded for a backward (the MLPs then keep their activations).
    fn records(self) -> bool {
        !matches!(self, GridGrad::None)
    }
}

/// The trainable field.
pub struct NeuralField {
    config: FieldConfig,
    bounds: Bounds,
    grid: Arc<HashGrid>,
    varmap: VarMap,
    mlp: Mlp,
    mask: Mlp,
    device: Device,
}

/// Names of the candle parameters, sorted (checkpoint order).
fn sorted_vars(varmap: &VarMap) -> Vec<(String, Var)> {
    let data = varmap.data().lock().unwrap();
    let mut v: Vec<(String, Var)> = data.iter().map(|(k, v)| (k.clone(), v.clone())).collect();
    v.sort_by(|a, b| a.0.cmp(&b.0));
    v
}

impl NeuralField {
    /// A freshly initialised field over `bounds`, deterministic in `seed`.
    pub fn new(config: FieldConfig, bounds: Bounds, seed: u64) -> Result<Self> {
        for (k, v) in [
            ("mlp_width", config.mlp_width),
            ("mask_width", config.mask_width),
        ] {
            if v == 0 || v > 1024 {
                return Err(NeuralError::config(
                    "field",
                    format!("{k} = {v} (use 1..=1024)"),
                ));
            }
        }
        if config.mask_frequencies > 16 {
            return Err(NeuralError::config(
                "field",
                format!(
                    "mask_frequencies = {} (use 0..=16)",
                    config.mask_frequencies
                ),
            ));
        }
        if !(bounds.size > 0.0 && bounds.size.is_finite()) {
            return Err(NeuralError::config(
                "field",
                "empty or infinite scene bounds",
            ));
        }
        let device = Device::Cpu;
        let grid = Arc::new(HashGrid::new(config.grid.clone(), seed)?);
        let varmap = VarMap::new();
        let vb = VarBuilder::from_varmap(&varmap, DType::F32, &device);
        let mlp = Mlp::new(
            vb.pp("material"),
            grid.output_dim(),
            config.mlp_width,
            config.mlp_hidden,
            5,
        )?;
        let mask = Mlp::new(
            vb.pp("mask"),
            3 + 6 * config.mask_frequencies,
            config.mask_width,
            config.mask_hidden,
            1,
        )?;
        // Deterministic initialisation (candle's CPU RNG cannot be seeded), layer by layer,
        // mask first: biases uniform in ±0.1/√out, then He-uniform weights (±√(6/in)); the
        // last layers' biases are the configured starting points.
        let mut rng = Pcg32::new(seed, 0x3C1D);
        for (net, last_bias) in [
            (&mask, vec![config.mask_init_bias]),
            (
                &mlp,
                vec![
                    0.0,
                    0.0,
                    0.0,
                    config.roughness_bias(),
                    config.metallic_init_bias,
                ],
            ),
        ] {
            let layers = net.layers();
            let mut values = vec![0f32; layers.last().map_or(0, |l| l.bias.end)];
            for (i, l) in layers.iter().enumerate() {
                if i + 1 == layers.len() {
                    values[l.bias.clone()].copy_from_slice(&last_bias);
                } else {
                    let b = 0.1 / (l.output as f32).sqrt();
                    for v in &mut values[l.bias.clone()] {
                        *v = (rng.next_f32() * 2.0 - 1.0) * b;
                    }
                }
                let b = (6.0 / l.input as f32).sqrt();
                for v in &mut values[l.weight.clone()] {
                    *v = (rng.next_f32() * 2.0 - 1.0) * b;
                }
            }
            net.set_params(values)?;
        }
        Ok(NeuralField {
            config,
            bounds,
            grid,
            varmap,
            mlp,
            mask,
            device,
        })
    }

    pub fn config(&self) -> &FieldConfig {
        &self.config
    }
    pub fn bounds(&self) -> Bounds {
        self.bounds
    }
    pub fn grid(&self) -> &Arc<HashGrid> {
        &self.grid
    }
    pub fn device(&self) -> &Device {
        &self.device
    }
    /// The candle parameters (MLPs), sorted by name.
    pub fn vars(&self) -> Vec<(String, Var)> {
        sorted_vars(&self.varmap)
    }
    /// Trainable values: (hash tables, MLPs).
    pub fn num_params(&self) -> (usize, usize) {
        let mlp = self.vars().iter().map(|(_, v)| v.elem_count()).sum();
        (self.grid.num_params(), mlp)
    }

    /// Points mapped into the unit cube.
    pub fn to_unit(&self, points: &[Vec3]) -> Vec<[f32; 3]> {
        points.iter().map(|&p| self.bounds.unit(p)).collect()
    }

    /// Forward pass at unit-cube points. With `train`, the hash grid's backward is recorded
    /// (call `backward` on a loss built from the output, then step the optimisers).
    pub fn forward(&self, unit: &[[f32; 3]], train: bool) -> Result<FieldOutput> {
        let grid = if train {
            GridGrad::Accumulate
        } else {
            GridGrad::None
        };
        self.forward_with(unit, grid, None)
    }

    /// [`NeuralField::forward`] for training whose backward also takes the hash tables' Adam
    /// step with `grid_adam` (level by level, while the touched entries are in cache): the
    /// caller then steps only the MLPs' optimiser.
    pub fn forward_step(&self, unit: &[[f32; 3]], grid_adam: AdamConfig) -> Result<FieldOutput> {
        self.forward_with(unit, GridGrad::Step(grid_adam), None)
    }

    /// [`NeuralField::forward_step`] with σ's [`FieldConfig::roughness_leak`] at the points
    /// where `leak[i]` (those with a σ target of the material search); elsewhere σ is the plain
    /// sigmoid, so a σ pinned at 1 where nothing asks it to move stays there.
    pub fn forward_step_leaky(
        &self,
        unit: &[[f32; 3]],
        grid_adam: AdamConfig,
        leak: &[bool],
    ) -> Result<FieldOutput> {
        self.forward_with(unit, GridGrad::Step(grid_adam), Some(leak))
    }

    fn forward_with(
        &self,
        unit: &[[f32; 3]],
        grid: GridGrad,
        leak_at: Option<&[bool]>,
    ) -> Result<FieldOutput> {
        let h = self.material_forward(unit, grid)?;
        let m = self.mask_forward(unit, grid.records())?;
        let leak = self.config.roughness_leak;
        let leak = leak_at
            .filter(|l| grid.records() && leak > 0.0 && l.iter().any(|&b| b))
            .map(|at| Arc::new(at.iter().map(|&b| if b { leak } else { 0.0 }).collect()));
        let cfg = HeadConfig {
            gain: self.config.roughness_gain,
            leak,
            softplus: self.config.mask_activation == MaskActivation::Softplus,
        };
        let packed = if self.device.is_cpu() {
            h.apply_op2(&m, FieldHead(cfg))
        } else {
            head_candle(&h, &m, &cfg)
        };
        packed.map(FieldOutput::from_packed).ctx("field head")
    }

    /// Hash grid + material MLP: the MLP's raw outputs `[n, 5]` (see [`crate::head`]).
    fn material_forward(&self, unit: &[[f32; 3]], grid: GridGrad) -> Result<Tensor> {
        let n = unit.len();
        let op = match grid {
            GridGrad::None => None,
            GridGrad::Accumulate => Some(HashGridOp::new(self.grid.clone())),
            GridGrad::Step(cfg) => Some(HashGridOp::stepping(self.grid.clone(), cfg)),
        };
        let enc = if let Some(op) = op {
            let flat: Vec<f32> = unit.iter().flatten().copied().collect();
            let pts = Tensor::from_vec(flat, (n, 3), &self.device).ctx("points")?;
            // A Var input makes candle record the op, so that its backward is called.
            let v = Var::from_tensor(&pts).ctx("points")?;
            v.as_tensor().apply_op1(op).ctx("hash grid")?
        } else {
            Tensor::from_vec(
                self.grid.encode(unit),
                (n, self.grid.output_dim()),
                &self.device,
            )
            .ctx("hash grid")?
        };
        if grid.records() {
            self.mlp.forward(&enc)
        } else {
            self.mlp.forward_inference(&enc)
        }
        .ctx("material MLP")
    }

    /// Positional encoding + mask MLP: its raw output m `[n, 1]`; `record`: for a backward.
    fn mask_forward(&self, unit: &[[f32; 3]], record: bool) -> Result<Tensor> {
        let n = unit.len();
        let signed: Vec<[f32; 3]> = unit
            .iter()
            .map(|p| [p[0] * 2.0 - 1.0, p[1] * 2.0 - 1.0, p[2] * 2.0 - 1.0])
            .collect();
        let pe = positional_encoding(&signed, self.config.mask_frequencies);
        let pe = Tensor::from_vec(pe, (n, 3 + 6 * self.config.mask_frequencies), &self.device)
            .ctx("positional encoding")?;
        if record {
            self.mask.forward(&pe)
        } else {
            self.mask.forward_inference(&pe)
        }
        .ctx("mask MLP")
    }

    /// Materials at world points, in chunks, without recording gradients (the mask MLP is not
    /// run).
    pub fn query_materials(&self, points: &[Vec3]) -> Result<Vec<Material>> {
        let mut mats = Vec::with_capacity(points.len());
        for chunk in points.chunks(65_536) {
            let h = self.material_forward(&self.to_unit(chunk), GridGrad::None)?;
            let h = h.flatten_all().and_then(|t| t.to_vec1::<f32>());
            let out = head::materials(&h.ctx("material MLP")?, self.config.roughness_gain);
            mats.extend(out.chunks_exact(head::MATERIAL_OUTPUTS).map(|o| Material {
                albedo: Vec3::new(o[0], o[1], o[2]),
                roughness: o[3],
                metallic: o[4],
            }));
        }
        Ok(mats)
    }

    /// Emission mask α at world points, in chunks (the hash grid and material MLP are not run).
    pub fn query_mask(&self, points: &[Vec3]) -> Result<Vec<f32>> {
        let mut alphas = Vec::with_capacity(points.len());
        for chunk in points.chunks(65_536) {
            let m = self.mask_forward(&self.to_unit(chunk), false)?;
            let m = m.flatten_all().and_then(|t| t.to_vec1::<f32>());
            let softplus = self.config.mask_activation == MaskActivation::Softplus;
            alphas.extend(head::alphas(&m.ctx("mask MLP")?, softplus));
        }
        Ok(alphas)
    }

    /// Both [`NeuralField::query_materials`] and [`NeuralField::query_mask`].
    pub fn query(&self, points: &[Vec3]) -> Result<(Vec<Material>, Vec<f32>)> {
        Ok((self.query_materials(points)?, self.query_mask(points)?))
    }
}

impl MaterialField for NeuralField {
    fn name(&self) -> &str {
        "fipt-hashgrid-mlp"
    }
    fn materials(&self, points: &[Vec3]) -> fipt_core::Result<Vec<Material>> {
        Ok(self.query_materials(points)?)
    }
    fn emission_mask(&self, points: &[Vec3]) -> fipt_core::Result<Vec<f32>> {
        Ok(self.query_mask(points)?)
    }
    fn as_any(&self) -> Option<&dyn std::any::Any> {
        Some(self)
    }
}
