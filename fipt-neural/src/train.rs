//! Fitting the field to the training pixels through the factorised image model (method §4.3).
//!
//! Prediction per pixel: `(1 − α)·(kd·Ld + ks·Ls0(σ) + Ls1(σ)) + α·GT`. Loss:
//! `MSE(oetf(pred), oetf(GT)) + mask_weight·mean(α) + prior_weight·(roughness_prior·mean|σ − 1|
//! + mean(m))
//! + segment_weight·mean(|σ − σ̄_seg| + |m − m̄_seg|)`, with the sRGB OETF unclamped and the
//! segment means weighted by specular shading (when the scene has segment ids). Batches are drawn uniformly from all valid training pixels by
//! a generator keyed on (seed, step), so a resumed run draws exactly the batches the
//! uninterrupted one would have.
use crate::adam::Adam;
use crate::error::{CandleContext, NeuralError, Result};
use crate::field::{Bounds, FieldConfig, NeuralField};
use crate::hashgrid::{AdamConfig, HashGridConfig};
use crate::ops::{
    srgb_oetf, FactorizedLoss, LevelWeights, LossBatch, SemanticPartners, SrgbOetf, NO_SEGMENT,
    SEGMENT_WEIGHT_FLOOR,
};
use candle_core::{Tensor, Var, D};
use fipt_core::fsutil::{read_json, write_atomic, write_json_atomic};
use fipt_core::rng::Pcg32;
use fipt_core::shading::{ViewShadings, NUM_LEVELS};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::Path;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::Instant;

mod candle_loss;
mod config;
pub use crate::image_loss::ImageLoss;
use candle_loss::reflected;
pub use candle_loss::{candle_ops_loss, LossWeights};
pub use config::{LrDecay, PriorNorm, SegmentSource, SemanticPrior, TrainConfig};
pub use fipt_core::training_set::TrainingSet;

/// Losses of one step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StepLosses {
    pub step: usize,
    pub total: f32,
    pub image: f32,
    pub mask: f32,
    pub prior: f32,
    /// The segment prior (0 without segments).
    #[serde(default)]
    pub segment: f32,
}

/// Where training time went (seconds, cumulative).
#[derive(Clone, Copy, Debug, Default, Serialize, Deserialize)]
pub struct TrainTimings {
    pub steps: usize,
    pub batch: f64,
    pub forward: f64,
    /// The whole backward, the hash tables' Adam update included (it runs inside it).
    pub backward: f64,
    /// The MLPs' optimiser.
    pub optimizer: f64,
    pub grid_forward: f64,
    /// The tables' gradient scatter (part of `backward`).
    pub grid_backward: f64,
    /// The tables' Adam update (part of `backward`).
    pub grid_optimizer: f64,
}

impl TrainTimings {
    pub fn total(&self) -> f64 {
        self.batch + self.forward + self.backward + self.optimizer
    }
}

/// The name of the tensor (u8, JSON) that carries a checkpoint's [`CheckpointMeta`] inside
/// `field.safetensors`.
pub const META_TENSOR: &str = "checkpoint.meta";

/// Checkpoint metadata, written after the tensors.
#[derive(Clone, Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckpointMeta {
    pub version: u32,
    pub step: usize,
    pub grid_steps: u64,
    pub adam_steps: u64,
    pub config: TrainConfig,
    pub bounds: Bounds,
    pub levels: [f32; NUM_LEVELS],
    pub last: StepLosses,
    /// What the data came from (e.g. fingerprints of the scene and the bake), set by the
    /// caller; a checkpoint of other data is not resumed.
    pub inputs: String,
}

/// 2: each MLP is one packed `<name>.params` tensor (was one tensor per layer weight and bias).
const CHECKPOINT_VERSION: u32 = 2;

/// Runs the optimisation.
pub struct Trainer {
    pub config: TrainConfig,
    pub field: NeuralField,
    adam: Adam,
    step: usize,
    pub last: StepLosses,
    pub timings: TrainTimings,
    level_weights: LevelWeights,
    /// Stored in checkpoints and compared on resume (see [`CheckpointMeta::inputs`]).
    pub inputs: String,
}

impl Trainer {
    /// A fresh field over `bounds` for data with roughness `levels`.
    pub fn new(config: TrainConfig, bounds: Bounds, levels: [f32; NUM_LEVELS]) -> Result<Self> {
        config.validate()?;
        let field = NeuralField::new(config.field.clone(), bounds, config.seed)?;
        let adam = Adam::new(field.vars(), config.adam)?;
        Ok(Trainer {
            config,
            field,
            adam,
            step: 0,
            last: StepLosses::default(),
            timings: TrainTimings::default(),
            level_weights: LevelWeights(levels),
            inputs: String::new(),
        })
    }

    /// Starts from the parameters of a trained field (a warm start): the field's weights are
    /// copied, the optimiser state starts afresh. The fields must have the same sizes and
    /// bounds.
    pub fn warm_start(&mut self, from: &NeuralField) -> Result<()> {
        if from.config() != self.field.config() || from.bounds() != self.field.bounds() {
            return Err(NeuralError::config(
                "warm start",
                "the previous round's field has other sizes or bounds",
            ));
        }
        let src: HashMap<String, Var> = from.vars().into_iter().collect();
        for (name, var) in self.field.vars() {
            let t = src.get(&name).ok_or_else(|| {
                NeuralError::config("warm start", format!("the previous field lacks `{name}`"))
            })?;
            var.set(t.as_tensor()).ctx("warm start")?;
        }
        let params = from.grid().params();
        let n = params.len();
        self.field
            .grid()
            .set_state(params, vec![0.0; n], vec![0.0; n], 0)
    }

    /// The prior's ramp factor at the current step.
    fn prior_ramp(&self) -> f32 {
        let [a, b] = self.config.prior_ramp;
        let x = self.step as f32 / self.config.steps.max(1) as f32;
        if x >= b {
            1.0
        } else if x < a {
            0.0
        } else {
            (x - a) / (b - a)
        }
    }

    /// The semantic prior's partners for the batch rows `idx` (rows of the training set, at
    /// the batch's positions `unit`): `k` rows of the same class per row, drawn with a
    /// generator keyed on (seed, step).
    fn partners(&self, data: &TrainingSet, idx: &[usize], unit: &[[f32; 3]]) -> SemanticPartners {
        let sp = self.config.semantic;
        let k = sp.partners;
        let mut members: Vec<Vec<u32>> = vec![vec![]; data.segments];
        for (row, &i) in idx.iter().enumerate() {
            let s = data.segment.get(i).copied().unwrap_or(NO_SEGMENT);
            if s != NO_SEGMENT {
                members[s as usize].push(row as u32);
            }
        }
        let inv2 = 1.0 / (2.0 * sp.sigma_position * sp.sigma_position);
        let mut index = vec![0u32; idx.len() * k];
        let mut pos_w = vec![0f32; idx.len() * k];
        // One generator per row keyed on (seed, step, row): parallel and deterministic.
        use rayon::prelude::*;
        index
            .par_chunks_mut(k)
            .zip(pos_w.par_chunks_mut(k))
            .enumerate()
            .for_each(|(row, (ix, pw))| {
                let i = idx[row];
                let s = data.segment.get(i).copied().unwrap_or(NO_SEGMENT);
                let m = (s != NO_SEGMENT).then(|| &members[s as usize]);
                let mut rng =
                    Pcg32::from_keys(&[self.config.seed, self.step as u64, 0x5E3A, row as u64]);
                for q in 0..k {
                    let j = match m {
                        Some(m) => m[((rng.next_u32() as u64 * m.len() as u64) >> 32) as usize],
                        None => row as u32,
                    };
                    let (a, b) = (unit[row], unit[j as usize]);
                    // Unit-cube distance × 2: the reference's [−1, 1] coordinates.
                    let d2: f32 = (0..3).map(|c| (2.0 * (a[c] - b[c])).powi(2)).sum();
                    ix[q] = j;
                    pw[q] = (-d2 * inv2).exp();
                }
            });
        SemanticPartners {
            k,
            index,
            pos_w,
            sigma_albedo: sp.sigma_albedo,
        }
    }

    /// Steps taken so far.
    pub fn step_count(&self) -> usize {
        self.step
    }

    /// The step's batch: `batch` pixels drawn from `data` with the step's own stream, in
    /// Morton order of their points, and their unit positions.
    fn draw_batch(&self, data: &TrainingSet) -> (Vec<[f32; 3]>, Arc<LossBatch>) {
        use rayon::prelude::*;
        let b = self.config.batch;
        let mut rng = Pcg32::from_keys(&[self.config.seed, self.step as u64, 0xBA7C]);
        let idx: Vec<usize> = (0..b)
            .map(|_| ((rng.next_u32() as u64 * data.len() as u64) >> 32) as usize)
            .collect();
        // Sorted by (Morton code, row): the keys gathered first, so that the comparisons read
        // memory in order. Equal keys are the same row drawn twice.
        let mut keyed: Vec<(u64, usize)> = idx.par_iter().map(|&i| (data.morton[i], i)).collect();
        keyed.par_sort_unstable();
        let idx: Vec<usize> = keyed.par_iter().map(|k| k.1).collect();
        // The gathers in parallel (random reads: many in flight); collect keeps the order.
        fn gather<T: Copy + Send + Sync>(idx: &[usize], from: &[T]) -> Vec<T> {
            if from.is_empty() {
                return vec![];
            }
            idx.par_iter().map(|&i| from[i]).collect()
        }
        let unit = gather(&idx, &data.unit);
        let batch = Arc::new(LossBatch {
            ld: gather(&idx, &data.ld),
            ld_poly: gather(&idx, &data.ld_poly),
            ls0: gather(&idx, &data.ls0),
            ls1: gather(&idx, &data.ls1),
            gt: gather(&idx, &data.gt),
            segment: if self.config.segments == SegmentSource::None {
                vec![]
            } else {
                idx.iter()
                    .filter_map(|&i| data.segment.get(i).copied())
                    .collect()
            },
            segments: data.segments,
            semantic: (data.semantic && self.config.segments != SegmentSource::None)
                .then(|| self.partners(data, &idx, &unit)),
            target: gather(&idx, &data.target),
        });
        (unit, batch)
    }

    /// One optimisation step on a batch drawn from `data`.
    pub fn step(&mut self, data: &TrainingSet) -> Result<StepLosses> {
        if data.is_empty() {
            return Err(NeuralError::config(
                "training set",
                "no valid pixels to train on",
            ));
        }
        let t0 = Instant::now();
        let (unit, batch) = self.draw_batch(data);
        let t1 = Instant::now();
        let cfg = &self.config;
        // The tables' Adam step is taken inside the backward (see `forward_step`).
        let lr = cfg.adam.lr * cfg.lr_decay.scale(self.step, cfg.steps);
        let grid_adam = AdamConfig {
            lr: lr * cfg.grid_lr_factor,
            ..cfg.adam
        };
        // σ's leak where the search set a σ target (see `FieldConfig::roughness_leak`).
        let leak: Vec<bool> = batch.target.iter().map(|t| t[0].is_finite()).collect();
        let out = if leak.is_empty() {
            self.field.forward_step(&unit, grid_adam)?
        } else {
            self.field.forward_step_leaky(&unit, grid_adam, &leak)?
        };
        let loss = FactorizedLoss {
            batch,
            levels: self.level_weights.0,
            mask_weight: cfg.mask_weight,
            prior_weight: cfg.prior_weight * self.prior_ramp(),
            prior_l1: cfg.prior_norm == PriorNorm::L1,
            metallic_l1: cfg.prior_norm != PriorNorm::L2,
            segment_weight: if data.semantic {
                cfg.semantic.weight
            } else {
                cfg.segment_weight
            },
            roughness_prior_scale: cfg.roughness_prior,
            target_weight: cfg.target_weight,
            image_loss: cfg.image_loss,
            emitter_material: cfg.emitter_material,
            cache: Default::default(),
        };
        let terms = out.packed().and_then(|p| p.apply_op1(loss)).ctx("loss")?;
        let total = terms
            .narrow(0, 0, 1)
            .and_then(|t| t.sum_all())
            .ctx("loss")?;
        let t2 = Instant::now();
        let grads = total.backward().ctx("backward")?;
        let t3 = Instant::now();
        self.adam.set_lr(lr);
        self.adam.step(&grads)?;
        let t4 = Instant::now();
        let v = terms.to_vec1::<f32>().ctx("loss value")?;
        self.step += 1;
        self.last = StepLosses {
            step: self.step,
            total: v[0],
            image: v[1],
            mask: v[2],
            prior: v[3],
            segment: v[4],
        };
        let tm = &mut self.timings;
        tm.steps += 1;
        tm.batch += (t1 - t0).as_secs_f64();
        tm.forward += (t2 - t1).as_secs_f64();
        tm.backward += (t3 - t2).as_secs_f64();
        tm.optimizer += (t4 - t3).as_secs_f64();
        let timers = &self.field.grid().timers;
        let secs = |a: &std::sync::atomic::AtomicU64| a.load(Ordering::Relaxed) as f64 * 1e-9;
        tm.grid_forward = secs(&timers.forward_ns);
        tm.grid_backward = secs(&timers.backward_ns);
        tm.grid_optimizer = secs(&timers.adam_ns);
        if !self.last.total.is_finite() {
            return Err(NeuralError::config(
                "training",
                format!(
                    "loss became {} at step {} (lower the learning rate?)",
                    self.last.total, self.step
                ),
            ));
        }
        Ok(self.last)
    }

    /// Steps until `config.steps`, writing a checkpoint to `dir` every `checkpoint_every`
    /// steps and at the end; `progress` sees every step's losses.
    pub fn run(
        &mut self,
        data: &TrainingSet,
        dir: Option<&Path>,
        progress: &mut dyn FnMut(&StepLosses),
    ) -> Result<()> {
        self.run_until(data, self.config.steps, dir, progress)
    }

    /// [`Trainer::run`] stopping after step `stop` (≤ `config.steps`), as an interrupted run
    /// would; settings that depend on the step (the prior's ramp) follow `config.steps`.
    pub fn run_until(
        &mut self,
        data: &TrainingSet,
        stop: usize,
        dir: Option<&Path>,
        progress: &mut dyn FnMut(&StepLosses),
    ) -> Result<()> {
        while self.step < stop.min(self.config.steps) {
            let l = self.step(data)?;
            progress(&l);
            let every = self.config.checkpoint_every;
            if let Some(dir) = dir {
                if self.step == self.config.steps || (every > 0 && self.step % every == 0) {
                    self.save(dir)?;
                }
            }
        }
        Ok(())
    }

    /// Writes `dir/field.safetensors` (parameters, optimiser state and, as the tensor
    /// [`META_TENSOR`], this checkpoint's metadata) then `dir/checkpoint.json` (the same
    /// metadata, readable), each atomically. A process killed between the two leaves a newer
    /// tensor file than `checkpoint.json`; [`Trainer::resume`] trusts the metadata inside the
    /// tensor file, so the pair can never be mixed.
    pub fn save(&self, dir: &Path) -> Result<()> {
        let dev = self.field.device();
        let mut map: HashMap<String, Tensor> = HashMap::new();
        for (name, var) in self.field.vars() {
            map.insert(name, var.as_tensor().clone());
        }
        for (name, t) in self.adam.state() {
            map.insert(name, t);
        }
        let (p, m, v, grid_steps) = self.field.grid().state();
        let n = p.len();
        for (name, x) in [("grid.params", p), ("grid.adam.m", m), ("grid.adam.v", v)] {
            map.insert(name.into(), Tensor::from_vec(x, n, dev).ctx("checkpoint")?);
        }
        let meta = self.meta(grid_steps);
        let bytes =
            serde_json::to_vec(&meta).map_err(|e| NeuralError::invalid(dir, e.to_string()))?;
        let nb = bytes.len();
        map.insert(
            META_TENSOR.into(),
            Tensor::from_vec(bytes, nb, dev).ctx("checkpoint")?,
        );
        let path = dir.join("field.safetensors");
        write_atomic(&path, |tmp| {
            candle_core::safetensors::save(&map, tmp)
                .map_err(|e| fipt_core::CoreError::invalid(tmp, e.to_string()))
        })?;
        write_json_atomic(&dir.join("checkpoint.json"), &meta)?;
        Ok(())
    }

    fn meta(&self, grid_steps: u64) -> CheckpointMeta {
        CheckpointMeta {
            version: CHECKPOINT_VERSION,
            step: self.step,
            grid_steps,
            adam_steps: self.adam.steps(),
            config: self.config.clone(),
            bounds: self.field.bounds(),
            levels: self.level_weights.0,
            last: self.last,
            inputs: self.inputs.clone(),
        }
    }

    /// Restores a checkpoint written by [`Trainer::save`] in `dir`, if it was made with the same
    /// settings; `Ok(None)` when there is none or it does not match (the reason is returned).
    pub fn resume(
        config: &TrainConfig,
        bounds: Bounds,
        levels: [f32; NUM_LEVELS],
        inputs: &str,
        dir: &Path,
    ) -> Result<Result<Trainer, String>> {
        let meta_path = dir.join("checkpoint.json");
        if !meta_path.is_file() {
            return Ok(Err("no checkpoint".into()));
        }
        let meta: CheckpointMeta = match read_json(&meta_path) {
            Ok(m) => m,
            Err(e) => return Ok(Err(format!("unreadable checkpoint ({e})"))),
        };
        // The tensors' own metadata wins: `checkpoint.json` may be one checkpoint behind.
        let tensors = dir.join("field.safetensors");
        let map = match candle_core::safetensors::load(&tensors, &candle_core::Device::Cpu) {
            Ok(m) => m,
            Err(e) => return Ok(Err(format!("unreadable checkpoint tensors ({e})"))),
        };
        let meta = match map.get(META_TENSOR).map(|t| t.to_vec1::<u8>()) {
            None => meta,
            Some(Ok(b)) => match serde_json::from_slice::<CheckpointMeta>(&b) {
                Ok(m) => m,
                Err(e) => return Ok(Err(format!("unreadable checkpoint metadata ({e})"))),
            },
            Some(Err(e)) => return Ok(Err(format!("unreadable checkpoint metadata ({e})"))),
        };
        if meta.version != CHECKPOINT_VERSION {
            return Ok(Err(format!("checkpoint version {}", meta.version)));
        }
        let mut same_cfg = meta.config.clone();
        same_cfg.steps = config.steps;
        same_cfg.checkpoint_every = config.checkpoint_every;
        if &same_cfg != config {
            return Ok(Err("settings changed".into()));
        }
        if meta.inputs != inputs {
            return Ok(Err("the scene or the bake changed".into()));
        }
        if meta.bounds != bounds || meta.levels != levels {
            return Ok(Err("scene bounds or roughness levels changed".into()));
        }
        if meta.step > config.steps {
            return Ok(Err(format!(
                "checkpoint is at step {} > {} steps asked",
                meta.step, config.steps
            )));
        }
        let mut t = Trainer::new(config.clone(), bounds, levels)?;
        load_field_tensors(&t.field, &map, &tensors, Some(meta.grid_steps))?;
        t.adam.load_state(&map, meta.adam_steps, &tensors)?;
        t.step = meta.step;
        t.last = meta.last;
        t.inputs = meta.inputs.clone();
        Ok(Ok(t))
    }
}

/// Loads the parameters (and the grid's optimiser state when `grid_steps` is given).
fn load_field_tensors(
    field: &NeuralField,
    map: &HashMap<String, Tensor>,
    path: &Path,
    grid_steps: Option<u64>,
) -> Result<()> {
    let get = |k: &str| {
        map.get(k)
            .ok_or_else(|| NeuralError::invalid(path, format!("checkpoint lacks `{k}`")))
    };
    for (name, var) in field.vars() {
        let t = get(&name)?;
        if t.dims() != var.dims() {
            return Err(NeuralError::invalid(
                path,
                format!(
                    "`{name}` has shape {:?}, expected {:?} (other sizes?)",
                    t.dims(),
                    var.dims()
                ),
            ));
        }
        var.set(t).ctx("loading a checkpoint")?;
    }
    let vec =
        |k: &str| -> Result<Vec<f32>> { get(k)?.to_vec1::<f32>().ctx("loading a checkpoint") };
    let params = vec("grid.params")?;
    let (m, v, steps) = match grid_steps {
        Some(s) => (vec("grid.adam.m")?, vec("grid.adam.v")?, s),
        None => (vec![0.0; params.len()], vec![0.0; params.len()], 0),
    };
    field.grid().set_state(params, m, v, steps)
}

/// Loads a trained field for queries from a training folder (`field.safetensors` +
/// `checkpoint.json`).
pub fn load_field(dir: &Path) -> Result<(NeuralField, CheckpointMeta)> {
    let meta_path = dir.join("checkpoint.json");
    let meta: CheckpointMeta = read_json(&meta_path)?;
    let field = NeuralField::new(meta.config.field.clone(), meta.bounds, meta.config.seed)?;
    let path = dir.join("field.safetensors");
    let map = candle_core::safetensors::load(&path, field.device())
        .map_err(|e| NeuralError::invalid(&path, format!("cannot read the field: {e}")))?;
    load_field_tensors(&field, &map, &path, None)?;
    Ok((field, meta))
}

/// The factorised image of pixels `idx` of one view's shadings `sh` with the field's current
/// materials at `unit` (one per index), for reports: (reflected radiance `[n]`, mask α `[n]`).
pub fn render_factorized(
    field: &NeuralField,
    unit: &[[f32; 3]],
    sh: &ViewShadings,
    idx: &[usize],
) -> Result<(Vec<[f32; 3]>, Vec<f32>)> {
    let n = unit.len();
    let dev = field.device();
    let out = field.forward(unit, false)?;
    let r: candle_core::Result<_> = (|| {
        let rgb = |f: &dyn Fn(usize) -> Vec3| {
            let v: Vec<f32> = idx.iter().flat_map(|&i| f(i).to_array()).collect();
            Tensor::from_vec(v, (n, 3), dev)
        };
        let ld = rgb(&|i| sh.ld[i])?;
        let poly = match sh.ld_poly.is_empty() {
            true => None,
            false => Some((rgb(&|i| sh.ld_poly[i][0])?, rgb(&|i| sh.ld_poly[i][1])?)),
        };
        let levels = |x: &[[Vec3; NUM_LEVELS]]| {
            let v: Vec<f32> = idx
                .iter()
                .flat_map(|&i| x[i].iter().flat_map(|c| c.to_array()))
                .collect();
            Tensor::from_vec(v, (n, NUM_LEVELS, 3), dev)
        };
        let (ls0, ls1) = (levels(&sh.ls0)?, levels(&sh.ls1)?);
        let render = reflected(
            &out,
            &ld,
            poly.as_ref().map(|(a, b)| (a, b)),
            &ls0,
            &ls1,
            sh.levels,
        )?;
        Ok((
            render.to_vec2::<f32>()?,
            out.alpha()?.squeeze(D::Minus1)?.to_vec1::<f32>()?,
        ))
    })();
    let (render, alpha) = r.ctx("re-rendering")?;
    Ok((
        render.into_iter().map(|v| [v[0], v[1], v[2]]).collect(),
        alpha,
    ))
}
