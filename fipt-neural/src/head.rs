//! The field's output head: from the material MLP's 5 raw outputs `h` and the mask MLP's raw
//! output `m` to the packed `[n, 6]` row (albedo, σ, metallic, α) that the loss reads.
//!
//! * albedo and metallic: `sigmoid(h)`;
//! * σ = `MIN_ROUGHNESS + (1 − MIN_ROUGHNESS)·sigmoid(gain·h₃)`, with a leak of slope `w` in the
//!   backward at the points that carry a weight `w` (see `FieldConfig::roughness_leak`);
//! * α = `1 − exp(−act(m))`, act = relu or softplus.
//!
//! [`FieldHead`] is one op, row-parallel, with its backward written out; [`head_candle`] is the
//! same head in candle's element-wise ops (devices other than the CPU, and the reference the op
//! is tested against). The op's arithmetic follows candle's ops expression by expression, so the
//! two give the same bits, forward and backward (tested). The candle ops run one after another,
//! each a serial pass on the CPU: at batch 65,536 (`balanced`) the MLPs-and-loss part of a step
//! took 106 ms on one thread and 88 ms on two with them, 60 ms on two with this op
//! (`docs/training-speed.md`).
use crate::ops::{contiguous, with_cpu_f32, zeros_par};
use candle_core::{CpuStorage, CustomOp2, Layout, Shape, Tensor};
use fipt_core::materials::MIN_ROUGHNESS;
use rayon::prelude::*;
use std::sync::Arc;

/// Columns of the material MLP's output: albedo (3), σ, metallic.
pub const MATERIAL_OUTPUTS: usize = 5;
/// Columns of the packed head: albedo (3), σ, metallic, α.
pub const PACKED: usize = 6;
/// Rows per task.
const ROWS: usize = 1024;

/// The head's settings.
#[derive(Clone, Debug)]
pub struct HeadConfig {
    /// σ's logit gain.
    pub gain: f32,
    /// Per row, the leak of σ's sigmoid in the backward (0: none); `None`: no leak anywhere.
    pub leak: Option<Arc<Vec<f32>>>,
    /// α = 1 − exp(−softplus(m)) (else relu).
    pub softplus: bool,
}

/// candle's sigmoid, `(exp(−v) + 1)⁻¹`.
#[inline]
fn sigmoid(v: f32) -> f32 {
    ((-v).exp() + 1.0).recip()
}

/// `(1 − s)·s`, the slope of the sigmoid at output `s`.
#[inline]
fn slope(s: f32) -> f32 {
    (1.0 - s) * s
}

/// σ's affine map from the sigmoid (`x·(1 − MIN) + MIN`, with candle's f64 → f32 constants).
fn sigma_scale() -> f32 {
    (1.0 - MIN_ROUGHNESS as f64) as f32
}

/// σ's logit and sigmoid at a row: (x, r).
#[inline]
fn sigma_logit(h3: f32, gain: f32) -> (f32, f32) {
    let x = h3 * gain + 0.0;
    (x, sigmoid(x))
}

/// The material columns of one row: `out[0..5]` from `h[0..5]`; `w`: the row's leak.
#[inline]
#[allow(clippy::eq_op)] // `l - l` is meant: the graph's leak term, NaN where l is not finite
fn material_row(h: &[f32], gain: f32, w: Option<f32>, out: &mut [f32]) {
    for c in [0, 1, 2, 4] {
        out[c] = sigmoid(h[c]);
    }
    let (x, r) = sigma_logit(h[3], gain);
    // + l − detach(l): 0 in the forward (kept for the same bits as candle's graph).
    let r = match w {
        Some(w) => {
            let l = x * w;
            r + (l - l)
        }
        None => r,
    };
    out[3] = r * sigma_scale() + MIN_ROUGHNESS;
}

/// α from the mask MLP's output `m`, and what its backward needs: (α, exp(−|m|), exp(−act)).
#[inline]
fn mask_row(m: f32, softplus: bool) -> (f32, f32, f32) {
    let (e, act) = if softplus {
        // softplus(m) = ln(1 + exp(−|m|)) + relu(m).
        let e = (-m.abs()).exp();
        (e, (e * 1.0 + 1.0).ln() + m.max(0.0))
    } else {
        (0.0, m.max(0.0))
    };
    let e2 = (-act).exp();
    (e2 * -1.0 + 1.0, e, e2)
}

/// d loss / d m of one row from d loss / d α.
#[inline]
fn mask_grad(m: f32, g: f32, softplus: bool) -> f32 {
    let (_, e, e2) = mask_row(m, softplus);
    let g_act = -((g * -1.0 + 0.0) * e2);
    let relu = if m >= 0.0 { 1.0 } else { 0.0 };
    if !softplus {
        return g_act * relu;
    }
    let g_e = (g_act / (e * 1.0 + 1.0)) * 1.0 + 0.0;
    let abs = if m >= 0.0 { 1.0 } else { -1.0 };
    g_act * relu + (-(g_e * e)) * abs
}

/// d loss / d h of one row's material columns from d loss / d out (`g[0..5]`); `out` is the
/// row the forward gave (albedo and metallic are the sigmoids themselves, as candle's sigmoid
/// reads its output in the backward; σ's sigmoid is recomputed from `h`).
#[inline]
fn material_grad(h: &[f32], out: &[f32], g: &[f32], gain: f32, w: Option<f32>, dh: &mut [f32]) {
    for c in [0, 1, 2, 4] {
        dh[c] = g[c] * slope(out[c]);
    }
    let (_, r) = sigma_logit(h[3], gain);
    let g_r = g[3] * sigma_scale() + 0.0;
    let g_x = g_r * slope(r);
    let g_x = match w {
        Some(w) => g_x + g_r * w,
        None => g_x,
    };
    dh[3] = g_x * gain + 0.0;
}

/// The head as one candle op: `(h [n, 5], m [n, 1]) → [n, 6]`.
#[derive(Clone, Debug)]
pub struct FieldHead(pub HeadConfig);

impl FieldHead {
    fn leak_at(&self, row: usize) -> Option<f32> {
        self.0.leak.as_ref().map(|w| w[row])
    }
}

impl CustomOp2 for FieldHead {
    fn name(&self) -> &'static str {
        "field-head"
    }

    fn cpu_fwd(
        &self,
        s1: &CpuStorage,
        l1: &Layout,
        s2: &CpuStorage,
        l2: &Layout,
    ) -> candle_core::Result<(CpuStorage, Shape)> {
        let h = contiguous(s1, l1, "field head (material)")?;
        let m = contiguous(s2, l2, "field head (mask)")?;
        let n = m.len();
        if h.len() != n * MATERIAL_OUTPUTS {
            candle_core::bail!("field head: {} material values for {n} rows", h.len());
        }
        let cfg = &self.0;
        let mut out = zeros_par(n * PACKED);
        out.par_chunks_mut(ROWS * PACKED)
            .enumerate()
            .for_each(|(k, block)| {
                for (i, o) in block.chunks_exact_mut(PACKED).enumerate() {
                    let j = k * ROWS + i;
                    let hj = &h[j * MATERIAL_OUTPUTS..(j + 1) * MATERIAL_OUTPUTS];
                    material_row(hj, cfg.gain, self.leak_at(j), o);
                    o[5] = mask_row(m[j], cfg.softplus).0;
                }
            });
        Ok((CpuStorage::F32(out), Shape::from((n, PACKED))))
    }

    fn bwd(
        &self,
        arg1: &Tensor,
        arg2: &Tensor,
        res: &Tensor,
        grad: &Tensor,
    ) -> candle_core::Result<(Option<Tensor>, Option<Tensor>)> {
        let names = [
            "field head (material)",
            "field head (mask)",
            "field head (output)",
            "field head (gradient)",
        ];
        let tensors = [arg1, arg2, res, grad];
        let (dh, dm) = with_cpu_f32(tensors, names, |[h_v, m_v, o_v, g_v]| {
            let n = m_v.len();
            let cfg = &self.0;
            let mut dh = zeros_par(n * MATERIAL_OUTPUTS);
            let mut dm = zeros_par(n);
            dh.par_chunks_mut(ROWS * MATERIAL_OUTPUTS)
                .zip(dm.par_chunks_mut(ROWS))
                .enumerate()
                .for_each(|(k, (dh, dm))| {
                    let rows = dh.chunks_exact_mut(MATERIAL_OUTPUTS).zip(dm).enumerate();
                    for (i, (d, dmi)) in rows {
                        let j = k * ROWS + i;
                        let hj = &h_v[j * MATERIAL_OUTPUTS..(j + 1) * MATERIAL_OUTPUTS];
                        let (oj, gj) = (&o_v[j * PACKED..], &g_v[j * PACKED..(j + 1) * PACKED]);
                        material_grad(hj, oj, gj, cfg.gain, self.leak_at(j), d);
                        *dmi = mask_grad(m_v[j], gj[5], cfg.softplus);
                    }
                });
            (dh, dm)
        })?;
        let dh = Tensor::from_vec(dh, arg1.shape(), arg1.device())?;
        let dm = Tensor::from_vec(dm, arg2.shape(), arg2.device())?;
        Ok((Some(dh), Some(dm)))
    }
}

/// The head's material columns at query points, without a graph: `h` row-major `[n, 5]`.
pub fn materials(h: &[f32], gain: f32) -> Vec<f32> {
    let mut out = zeros_par(h.len());
    out.par_chunks_mut(ROWS * MATERIAL_OUTPUTS)
        .zip(h.par_chunks(ROWS * MATERIAL_OUTPUTS))
        .for_each(|(o, h)| {
            for (o, h) in o
                .chunks_exact_mut(MATERIAL_OUTPUTS)
                .zip(h.chunks_exact(MATERIAL_OUTPUTS))
            {
                material_row(h, gain, None, o);
            }
        });
    out
}

/// α at query points from the mask MLP's outputs, without a graph.
pub fn alphas(m: &[f32], softplus: bool) -> Vec<f32> {
    m.par_iter().map(|&m| mask_row(m, softplus).0).collect()
}

/// The same head in candle's element-wise ops: `[n, 6]`.
pub fn head_candle(h: &Tensor, m: &Tensor, cfg: &HeadConfig) -> candle_core::Result<Tensor> {
    let s = candle_nn::ops::sigmoid(h)?;
    let albedo = s.narrow(1, 0, 3)?;
    let x = h.narrow(1, 3, 1)?.affine(cfg.gain as f64, 0.0)?;
    let r = candle_nn::ops::sigmoid(&x)?;
    let r = match &cfg.leak {
        Some(w) => {
            // + leak·x − detach(leak·x): exactly 0 in the forward, slope `leak` in the backward.
            let w = Tensor::from_vec(w.to_vec(), (w.len(), 1), h.device())?;
            let l = (&x * &w)?;
            (r + (&l - l.detach())?)?
        }
        None => r,
    };
    let roughness = r.affine(1.0 - MIN_ROUGHNESS as f64, MIN_ROUGHNESS as f64)?;
    let metallic = s.narrow(1, 4, 1)?;
    let act = if cfg.softplus {
        // softplus(x) = relu(x) + ln(1 + exp(−|x|)), stable for any x.
        (m.abs()?.neg()?.exp()?.affine(1.0, 1.0)?.log()? + m.relu()?)?
    } else {
        m.relu()?
    };
    let alpha = act.neg()?.exp()?.affine(-1.0, 1.0)?;
    Tensor::cat(&[&albedo, &roughness, &metallic, &alpha], 1)
}
