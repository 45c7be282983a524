//! Small element-wise candle ops with hand-written CPU forward and backward.
//!
//! * [`SrgbOetf`]: the sRGB opto-electronic transfer function without clamping (the loss of
//!   method §4 compares sRGB-encoded HDR values): 12.92·x below 0.0031308, else
//!   1.055·x^(1/2.4) − 0.055; linear continuation for x < 0.
//! * [`LevelWeights`]: the hat-function weights of piecewise-linear interpolation over the
//!   roughness levels, so that `Σ_l w_l(σ)·Ls[l]` equals
//!   [`fipt_core::shading::lerp_levels`] and is differentiable in σ.
pub use crate::image_loss::SLOPE_LOSS_CLIP;
use crate::image_loss::{slope_term, srgb_term, ImageLoss};
use candle_core::{CpuStorage, CustomOp1, Layout, Shape, Tensor};
use fipt_core::reflectance::{
    image_linear_in_base_color, metallic_workflow_channel, metallic_workflow_channel_derivatives,
};
use fipt_core::shading::{level_segment, NUM_LEVELS};

/// The f32 values of a contiguous CPU tensor; `name` says which in errors.
pub(crate) fn contiguous<'a>(
    s: &'a CpuStorage,
    l: &Layout,
    name: &str,
) -> candle_core::Result<&'a [f32]> {
    let data = match s {
        CpuStorage::F32(v) => v,
        _ => candle_core::bail!("{name}: expects f32"),
    };
    match l.contiguous_offsets() {
        Some((a, b)) => Ok(&data[a..b]),
        None => candle_core::bail!("{name}: expects a contiguous tensor"),
    }
}

/// `len` zeros, written by the pool's threads. A per-step buffer from `vec![0.0; len]` is
/// zeroed by the calling thread alone (the allocator reuses memory, so calloc must clear
/// it): serial work in every training step.
pub fn zeros_par(len: usize) -> Vec<f32> {
    use rayon::prelude::*;
    if len < 1 << 16 {
        return vec![0.0; len];
    }
    let mut v = Vec::with_capacity(len);
    v.par_extend(rayon::iter::repeat_n(0f32, len));
    v
}

/// The f32 values of a contiguous tensor's storage (read in place, without the copy of
/// `to_vec1`); CPU only.
pub(crate) fn storage_f32<'a>(
    s: &'a candle_core::Storage,
    l: &Layout,
    name: &str,
) -> candle_core::Result<&'a [f32]> {
    match s {
        candle_core::Storage::Cpu(c) => contiguous(c, l, name),
        _ => candle_core::bail!("{name}: expects a CPU tensor"),
    }
}

/// Calls `f` with the f32 values of `tensors` (made contiguous, read in place; CPU only),
/// `names` saying which in errors.
pub(crate) fn with_cpu_f32<const N: usize, R>(
    tensors: [&candle_core::Tensor; N],
    names: [&str; N],
    f: impl FnOnce([&[f32]; N]) -> R,
) -> candle_core::Result<R> {
    let owned = tensors
        .iter()
        .map(|t| t.contiguous())
        .collect::<candle_core::Result<Vec<_>>>()?;
    let guards: Vec<_> = owned.iter().map(|t| t.storage_and_layout()).collect();
    let mut slices: [&[f32]; N] = [&[]; N];
    for ((slot, (storage, layout)), name) in slices.iter_mut().zip(&guards).zip(names) {
        *slot = storage_f32(storage, layout, name)?;
    }
    Ok(f(slices))
}

/// sRGB OETF of a linear value, continued linearly below 0 (no clamp).
pub use fipt_core::color::srgb_oetf_extended as srgb_oetf;
pub use fipt_core::color::srgb_oetf_grad;

/// The sRGB OETF as a differentiable op.
#[derive(Clone, Copy, Debug)]
pub struct SrgbOetf;

impl CustomOp1 for SrgbOetf {
    fn name(&self) -> &'static str {
        "srgb-oetf"
    }
    fn cpu_fwd(&self, s: &CpuStorage, l: &Layout) -> candle_core::Result<(CpuStorage, Shape)> {
        let x = contiguous(s, l, "srgb-oetf")?;
        Ok((
            CpuStorage::F32(x.iter().map(|&v| srgb_oetf(v)).collect()),
            l.shape().clone(),
        ))
    }
    fn bwd(
        &self,
        arg: &Tensor,
        _res: &Tensor,
        grad: &Tensor,
    ) -> candle_core::Result<Option<Tensor>> {
        let x = arg.flatten_all()?.to_vec1::<f32>()?;
        let g = grad.flatten_all()?.to_vec1::<f32>()?;
        let out: Vec<f32> = x
            .iter()
            .zip(&g)
            .map(|(&x, &g)| g * srgb_oetf_grad(x))
            .collect();
        Ok(Some(Tensor::from_vec(out, arg.shape(), arg.device())?))
    }
}

/// Interpolation weights over roughness levels: input σ `[n, 1]`, output `[n, NUM_LEVELS]`.
#[derive(Clone, Copy, Debug)]
pub struct LevelWeights(pub [f32; NUM_LEVELS]);

impl LevelWeights {
    /// (lower level, t, dt/dσ) of σ; σ is clamped to the levels' range (zero slope outside).
    #[inline]
    fn locate(&self, sigma: f32) -> (usize, f32, f32) {
        let lv = &self.0;
        let (i, t) = level_segment(lv, sigma);
        let inside = sigma > lv[0] && sigma < lv[NUM_LEVELS - 1];
        let span = lv[i + 1] - lv[i];
        let dt = if inside && span > 0.0 {
            1.0 / span
        } else {
            0.0
        };
        (i, t, dt)
    }
}

impl CustomOp1 for LevelWeights {
    fn name(&self) -> &'static str {
        "level-weights"
    }
    fn cpu_fwd(&self, s: &CpuStorage, l: &Layout) -> candle_core::Result<(CpuStorage, Shape)> {
        let x = contiguous(s, l, "level-weights")?;
        let mut out = vec![0f32; x.len() * NUM_LEVELS];
        for (row, &sigma) in out.chunks_exact_mut(NUM_LEVELS).zip(x) {
            let (i, t, _) = self.locate(sigma);
            row[i] = 1.0 - t;
            row[i + 1] += t;
        }
        Ok((CpuStorage::F32(out), Shape::from((x.len(), NUM_LEVELS))))
    }
    fn bwd(
        &self,
        arg: &Tensor,
        _res: &Tensor,
        grad: &Tensor,
    ) -> candle_core::Result<Option<Tensor>> {
        let x = arg.flatten_all()?.to_vec1::<f32>()?;
        let g = grad.flatten_all()?.to_vec1::<f32>()?;
        let out: Vec<f32> = x
            .iter()
            .zip(g.chunks_exact(NUM_LEVELS))
            .map(|(&sigma, g)| {
                let (i, _, dt) = self.locate(sigma);
                (g[i + 1] - g[i]) * dt
            })
            .collect();
        Ok(Some(Tensor::from_vec(out, arg.shape(), arg.device())?))
    }
}

/// NeRF positional encoding of points in [-1, 1]³: `[p, sin(2^k π p), cos(2^k π p)]` for
/// k < `frequencies`, as rows of `3 + 6·frequencies` values.
pub fn positional_encoding(points: &[[f32; 3]], frequencies: usize) -> Vec<f32> {
    use rayon::prelude::*;
    let d = 3 + 6 * frequencies;
    let mut out = zeros_par(points.len() * d);
    // In parallel: 60 sin/cos per point are ~2.5 ms of a training step on one core.
    out.par_chunks_mut(d * 512)
        .zip(points.par_chunks(512))
        .for_each(|(rows, pts)| {
            for (row, p) in rows.chunks_exact_mut(d).zip(pts) {
                row[..3].copy_from_slice(p);
                for k in 0..frequencies {
                    let f = (1u32 << k) as f32 * std::f32::consts::PI;
                    let o = &mut row[3 + 6 * k..9 + 6 * k];
                    for a in 0..3 {
                        let (sin, cos) = (f * p[a]).sin_cos();
                        o[a] = sin;
                        o[3 + a] = cos;
                    }
                }
            }
        });
    out
}

/// The batch a [`FactorizedLoss`] compares against, row per pixel.
#[derive(Clone, Debug, Default)]
pub struct LossBatch {
    pub ld: Vec<[f32; 3]>,
    /// [Ld1, Ld2] per pixel when the diffuse shading depends on σ (`principled`: Ld(σ) =
    /// Ld + σ·Ld1 + σ²·Ld2), else empty.
    pub ld_poly: Vec<[[f32; 3]; 2]>,
    pub ls0: Vec<[[f32; 3]; NUM_LEVELS]>,
    pub ls1: Vec<[[f32; 3]; NUM_LEVELS]>,
    pub gt: Vec<[f32; 3]>,
    /// Dense segment id of each pixel (`< segments`, or [`NO_SEGMENT`]: the prior skips it), for
    /// the segment-consistency prior; empty when the scene has no segmentation.
    pub segment: Vec<u32>,
    /// Number of segment ids.
    pub segments: usize,
    /// With semantic classes as segment ids: each pixel's partners for the bilateral prior
    /// (instead of the part prior's segment means).
    pub semantic: Option<SemanticPartners>,
    /// Per pixel the material search's (σ*, m*), which the prior pulls towards (L2, weight
    /// [`FactorizedLoss::target_weight`]) instead of (1, 0); a NaN part has no target (the
    /// default prior applies to it).
    /// Empty when the run has no search.
    pub target: Vec<[f32; 2]>,
}

/// The partners of the semantic prior (the reference's prior for `segmentation/` classes):
/// `k` pixels of the same class per pixel, drawn by the trainer, and the position part of
/// their weights.
///
/// Each pixel i is compared with the weighted mean of its partners j:
/// `w_ij = pos_w_ij · exp(−|a_i − a_j|² / (2 sigma_albedo²))` (albedo not differentiated), so
/// a class (e.g. "furniture") is not one surface: only nearby pixels of similar albedo pull
/// each other's σ and metallic. The term is `Σ_classes mean_{i ∈ class} |σ̄_i − σ_i| +
/// |m̄_i − m_i|` (the reference sums over classes). The means include the pixel itself with the
/// weight floor 1e-4, so a pixel with no partner of similar albedo is not pulled (in the
/// reference the floor only divides, pulling such a pixel's σ and m towards 0: on cornell
/// with 64 partners that took kd from 42 to 22 dB).
#[derive(Clone, Debug, Default)]
pub struct SemanticPartners {
    pub k: usize,
    /// `k` batch rows per pixel (pixels of no class: any rows, ignored).
    pub index: Vec<u32>,
    /// `exp(−|x_i − x_j|² / (2 sigma_position²))` per partner.
    pub pos_w: Vec<f32>,
    pub sigma_albedo: f32,
}

/// The specular weight of a pixel in its segment's mean (method §4.3, the reference's
/// part prior): the mean over channels of its specular shading ks·Ls0(σ) + Ls1(σ), plus 1e-4,
/// so that the pixels whose σ and m the views observe (highlights) decide the segment's
/// values. Not differentiated (a constant of each step).
pub const SEGMENT_WEIGHT_FLOOR: f32 = 1e-4;

pub use fipt_core::training_set::NO_SEGMENT;

/// The whole training loss of method §4.3 fused into one op (the per-pixel shading
/// composition, sRGB OETF, MSE, mask sparsity and the roughness/metallic prior), instead of
/// ~30 small candle ops and their backward.
///
/// The prior of a pixel is `prior_weight·(roughness_prior_scale·|σ − 1| + m)` (L1), or the
/// square of either part; a part with a search target is `target_weight·(σ − σ*)²` or
/// `target_weight·(m − m*)²` instead.
///
/// Input `[n, 6]`: albedo (3), σ, metallic, α per pixel (after their activations). Output `[5]`:
/// total, image MSE, mean α, weighted prior (its weights inside), segment prior; the backward
/// honours gradients on all five.
///
/// The segment prior (the reference's part prior, used when the batch has segment ids):
/// `mean_j |σ_j − σ̄_s(j)| + |m_j − m̄_s(j)|`, where σ̄_s and m̄_s are the means over the batch's
/// pixels of segment s weighted by each pixel's specular shading ([`SEGMENT_WEIGHT_FLOOR`]).
/// σ and m are only observable where a surface shows a highlight; this carries them across
/// the rest of the surface, where the roughness prior alone pulls σ to 1.
#[derive(Clone, Debug)]
pub struct FactorizedLoss {
    pub batch: std::sync::Arc<LossBatch>,
    pub levels: [f32; NUM_LEVELS],
    pub mask_weight: f32,
    pub prior_weight: f32,
    /// L1 (the reference) or L2 prior on σ.
    pub prior_l1: bool,
    /// L1 (the reference) or L2 prior on metallic.
    pub metallic_l1: bool,
    /// Weight of the segment prior (ignored when the batch has no segment ids).
    pub segment_weight: f32,
    /// Scale of the prior's roughness part (1: the reference's mean|σ − 1| + mean(m)).
    pub roughness_prior_scale: f32,
    /// Weight of the pull towards the search's targets (pixels with one; no ramp, whatever
    /// `roughness_prior_scale`): (σ − σ*)² + (m − m*)².
    pub target_weight: f32,
    /// How a pixel's error is measured.
    pub image_loss: ImageLoss,
    /// Whether a light's pixels ([`unreflectable`]) pass gradient to the material
    /// ([`crate::train::TrainConfig::emitter_material`]).
    pub emitter_material: bool,
    /// The segment prior's terms of the forward, for the backward (leave it `Default`).
    pub cache: PriorCache,
}

/// The segment prior's per-batch terms that the forward computes and the backward needs (for
/// the semantic prior, 0.5 M bilateral weights a step), kept with the input they came from.
#[derive(Debug, Default)]
pub struct PriorCache(std::sync::Mutex<Option<(Vec<f32>, PriorTerms)>>);

/// A cache is not shared by a clone.
impl Clone for PriorCache {
    fn clone(&self) -> Self {
        PriorCache::default()
    }
}

#[derive(Debug)]
enum PriorTerms {
    Parts(SegmentSums),
    Semantic(SemanticTerms),
}

/// Per-segment sums of one batch: Σw, Σw·σ, Σw·m, then Σsign(σ − σ̄), Σsign(m − m̄).
#[derive(Clone, Debug, Default)]
struct SegmentSums {
    w: Vec<f64>,
    /// Each pixel's weight.
    pixel_w: Vec<f32>,
    mean_sigma: Vec<f32>,
    mean_m: Vec<f32>,
    sign_sigma: Vec<f32>,
    sign_m: Vec<f32>,
}

#[inline]
fn sign(x: f32) -> f32 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

pub use fipt_core::training_set::{unreflectable, UNREFLECTABLE};

/// Per-pixel terms: (Σ_c e_c², α, prior) and the gradient of each term w.r.t. the 6 inputs.
struct PixelTerms {
    sq: f32,
    prior: f32,
    d_image: [f32; 6],
    d_prior: [f32; 6],
}

impl FactorizedLoss {
    #[inline]
    fn pixel(&self, j: usize, x: &[f32]) -> PixelTerms {
        let b = &*self.batch;
        let (a, sigma, m, alpha) = ([x[0], x[1], x[2]], x[3], x[4], x[5]);
        let lw = LevelWeights(self.levels);
        let (i, t, dt) = lw.locate(sigma);
        let (ld0, s0l, s1l, g) = (b.ld[j], &b.ls0[j], &b.ls1[j], b.gt[j]);
        // Ld(σ) and dLd/dσ (the diffuse σ polynomial of `principled`; constant otherwise).
        let (ld, dld) = match b.ld_poly.get(j) {
            None => (ld0, [0.0; 3]),
            Some([p1, p2]) => (
                std::array::from_fn(|c| ld0[c] + sigma * (p1[c] + sigma * p2[c])),
                std::array::from_fn(|c| p1[c] + 2.0 * sigma * p2[c]),
            ),
        };
        let mut sq = 0.0;
        let mut d = [0f32; 6];
        // The material's share of the image term (none at an emitter, unless asked).
        let material = if self.emitter_material || !unreflectable(ld0, s0l, s1l, g) {
            1.0 - alpha
        } else {
            0.0
        };
        for c in 0..3 {
            let s0 = s0l[i][c] * (1.0 - t) + s0l[i + 1][c] * t;
            let s1 = s1l[i][c] * (1.0 - t) + s1l[i + 1][c] * t;
            let (kd, ks) = metallic_workflow_channel(a[c], m);
            let r = kd * ld[c] + ks * s0 + s1;
            let p = (1.0 - alpha) * r + alpha * g[c];
            // The pixel's term and its derivative in P, then the chain to the inputs.
            let (term, dp) = match self.image_loss {
                ImageLoss::Srgb => srgb_term(p, g[c]),
                ImageLoss::SrgbSlope => slope_term(p, g[c]),
            };
            sq += term;
            let dr = dp * material;
            // ∂I/∂a (the image is linear in a), then ∂I/∂σ, ∂I/∂m.
            d[c] += dr * image_linear_in_base_color(ld[c], s0, s1, m).0;
            d[3] += dr * (ks * (s0l[i + 1][c] - s0l[i][c]) + (s1l[i + 1][c] - s1l[i][c])) * dt
                + dr * kd * dld[c];
            let (_, (dkd_dm, dks_dm)) = metallic_workflow_channel_derivatives(a[c], m);
            d[4] += dr * (dkd_dm * ld[c] + dks_dm * s0);
            d[5] += dp * (g[c] - r);
        }
        // Each part: the search's target pull where it has one, the default prior elsewhere.
        let [ts, tm] = b.target.get(j).copied().unwrap_or([f32::NAN; 2]);
        let (pw, tw, k) = (
            self.prior_weight,
            self.target_weight,
            self.roughness_prior_scale,
        );
        let (prior_s, dps) = if ts.is_finite() {
            (tw * (sigma - ts).powi(2), tw * 2.0 * (sigma - ts))
        } else if self.prior_l1 {
            (
                pw * k * (sigma - 1.0).abs(),
                pw * if sigma < 1.0 { -k } else { k },
            )
        } else {
            (pw * k * (sigma - 1.0).powi(2), pw * k * 2.0 * (sigma - 1.0))
        };
        let (prior_m, dpm) = if tm.is_finite() {
            (tw * (m - tm).powi(2), tw * 2.0 * (m - tm))
        } else if self.metallic_l1 {
            (pw * m, pw)
        } else {
            (pw * m * m, pw * 2.0 * m)
        };
        let prior = prior_s + prior_m;
        let mut d_prior = [0f32; 6];
        d_prior[3] = dps;
        d_prior[4] = dpm;
        PixelTerms {
            sq,
            prior,
            d_image: d,
            d_prior,
        }
    }
}

impl FactorizedLoss {
    fn has_segments(&self) -> bool {
        !self.batch.segment.is_empty()
    }

    /// The specular shading weight of pixel `j` in its segment's means.
    #[inline]
    fn segment_weight_of(&self, j: usize, x: &[f32]) -> f32 {
        let b = &*self.batch;
        let (sigma, m) = (x[3], x[4]);
        let (i, t, _) = LevelWeights(self.levels).locate(sigma);
        let mut sum = 0.0;
        for c in 0..3 {
            let s0 = b.ls0[j][i][c] * (1.0 - t) + b.ls0[j][i + 1][c] * t;
            let s1 = b.ls1[j][i][c] * (1.0 - t) + b.ls1[j][i + 1][c] * t;
            let (_, ks) = metallic_workflow_channel(x[c], m);
            sum += ks * s0 + s1;
        }
        let w = sum / 3.0;
        // Shadings are non-negative; a NaN or negative weight must not reach the means.
        (if w.is_finite() { w.max(0.0) } else { 0.0 }) + SEGMENT_WEIGHT_FLOOR
    }

    /// The weighted means and sign sums of every segment (sequential: a fixed order of
    /// summation, and only a few flops per pixel).
    fn segment_sums(&self, x: &[f32]) -> SegmentSums {
        let b = &*self.batch;
        let k = b.segments;
        let n = b.segment.len();
        // The per-pixel weights in parallel, the sums in pixel order (deterministic).
        let pixel_w: Vec<f32> = {
            use rayon::prelude::*;
            (0..n)
                .into_par_iter()
                .with_min_len(1024)
                .map(|j| self.segment_weight_of(j, &x[6 * j..6 * j + 6]))
                .collect()
        };
        let (mut w, mut ws, mut wm) = (vec![0f64; k], vec![0f64; k], vec![0f64; k]);
        for j in 0..n {
            if b.segment[j] == NO_SEGMENT {
                continue;
            }
            let r = &x[6 * j..6 * j + 6];
            let s = b.segment[j] as usize;
            let wj = pixel_w[j] as f64;
            w[s] += wj;
            ws[s] += wj * r[3] as f64;
            wm[s] += wj * r[4] as f64;
        }
        let mean = |a: &[f64]| -> Vec<f32> {
            a.iter()
                .zip(&w)
                .map(|(a, w)| if *w > 0.0 { (a / w) as f32 } else { 0.0 })
                .collect()
        };
        let (mean_sigma, mean_m) = (mean(&ws), mean(&wm));
        let (mut sign_sigma, mut sign_m) = (vec![0f32; k], vec![0f32; k]);
        for j in 0..n {
            if b.segment[j] == NO_SEGMENT {
                continue;
            }
            let s = b.segment[j] as usize;
            sign_sigma[s] += sign(x[6 * j + 3] - mean_sigma[s]);
            sign_m[s] += sign(x[6 * j + 4] - mean_m[s]);
        }
        SegmentSums {
            w,
            pixel_w,
            mean_sigma,
            mean_m,
            sign_sigma,
            sign_m,
        }
    }
}

/// The semantic prior of one batch: per pixel its partners' normalised weights, the weighted
/// means of (σ, m), the class normalisation 1/n_c, and the loss.
#[derive(Debug)]
struct SemanticTerms {
    /// `k` weights w_ij / W_i per pixel.
    w: Vec<f32>,
    mean: Vec<[f32; 2]>,
    inv_count: Vec<f32>,
    loss: f64,
}

impl FactorizedLoss {
    fn semantic_terms(&self, x: &[f32]) -> SemanticTerms {
        use rayon::prelude::*;
        let b = &*self.batch;
        let sem = b.semantic.as_ref().expect("semantic partners");
        let (n, k) = (b.segment.len(), sem.k);
        let mut count = vec![0u32; b.segments];
        for &s in &b.segment {
            if s != NO_SEGMENT {
                count[s as usize] += 1;
            }
        }
        let inv_count: Vec<f32> = b
            .segment
            .iter()
            .map(|&s| {
                if s == NO_SEGMENT {
                    0.0
                } else {
                    1.0 / count[s as usize] as f32
                }
            })
            .collect();
        let inv2 = 1.0 / (2.0 * sem.sigma_albedo * sem.sigma_albedo);
        let mut w = vec![0f32; n * k];
        let mut mean = vec![[0f32; 2]; n];
        if k > 0 {
            w.par_chunks_mut(k)
                .zip(mean.par_iter_mut())
                .enumerate()
                .for_each(|(i, (wi, mi))| {
                    if b.segment[i] == NO_SEGMENT {
                        return;
                    }
                    let ai = &x[6 * i..6 * i + 3];
                    let mut total = SEGMENT_WEIGHT_FLOOR as f64;
                    for q in 0..k {
                        let j = sem.index[i * k + q] as usize;
                        let aj = &x[6 * j..6 * j + 3];
                        let d2: f32 = (0..3).map(|c| (ai[c] - aj[c]).powi(2)).sum();
                        let v = sem.pos_w[i * k + q] * (-d2 * inv2).exp();
                        wi[q] = if v.is_finite() { v } else { 0.0 };
                        total += wi[q] as f64;
                    }
                    // The floor is the pixel's own weight: without a similar partner it is
                    // pulled towards itself (not towards 0).
                    let own = SEGMENT_WEIGHT_FLOOR as f64 / total;
                    let (mut ms, mut mm) = (own * x[6 * i + 3] as f64, own * x[6 * i + 4] as f64);
                    for q in 0..k {
                        wi[q] = (wi[q] as f64 / total) as f32;
                        let j = sem.index[i * k + q] as usize;
                        ms += (wi[q] * x[6 * j + 3]) as f64;
                        mm += (wi[q] * x[6 * j + 4]) as f64;
                    }
                    *mi = [ms as f32, mm as f32];
                });
        }
        let mut loss = 0f64;
        for i in 0..n {
            loss += (inv_count[i]
                * ((mean[i][0] - x[6 * i + 3]).abs() + (mean[i][1] - x[6 * i + 4]).abs()))
                as f64;
        }
        SemanticTerms {
            w,
            mean,
            inv_count,
            loss,
        }
    }

    /// The segment prior's terms of input `x`: the forward's when it had the same input.
    fn prior_terms(&self, x: &[f32]) -> PriorTerms {
        let cached = self.cache.0.lock().ok().and_then(|mut c| c.take());
        match cached {
            Some((input, terms)) if input == x => terms,
            _ if self.batch.semantic.is_some() => PriorTerms::Semantic(self.semantic_terms(x)),
            _ => PriorTerms::Parts(self.segment_sums(x)),
        }
    }

    /// d(semantic prior)/d(σ, m) per pixel.
    fn semantic_grad(&self, x: &[f32], t: &SemanticTerms) -> Vec<[f32; 2]> {
        let b = &*self.batch;
        let sem = b.semantic.as_ref().expect("semantic partners");
        let (n, k) = (b.segment.len(), sem.k);
        let mut g = vec![[0f32; 2]; n];
        for i in 0..n {
            if b.segment[i] == NO_SEGMENT {
                continue;
            }
            // |σ̄_i − σ_i|: sign·(own − 1) on σ_i, +sign·w_ij on each partner's σ_j (same for m).
            let own = 1.0 - t.w[i * k..(i + 1) * k].iter().sum::<f32>();
            for c in 0..2 {
                let sg = t.inv_count[i] * sign(t.mean[i][c] - x[6 * i + 3 + c]);
                g[i][c] -= sg * (1.0 - own);
                for q in 0..k {
                    let j = sem.index[i * k + q] as usize;
                    g[j][c] += sg * t.w[i * k + q];
                }
            }
        }
        g
    }
}

impl CustomOp1 for FactorizedLoss {
    fn name(&self) -> &'static str {
        "factorized-loss"
    }
    fn cpu_fwd(&self, s: &CpuStorage, l: &Layout) -> candle_core::Result<(CpuStorage, Shape)> {
        use rayon::prelude::*;
        let x = contiguous(s, l, "factorized-loss")?;
        let n = x.len() / 6;
        let nseg = self.batch.segment.len();
        if n != self.batch.gt.len()
            || l.shape().dims() != [n, 6]
            || (nseg != 0 && nseg != n)
            || self
                .batch
                .segment
                .iter()
                .any(|&s| s != NO_SEGMENT && s as usize >= self.batch.segments)
            || self.batch.semantic.as_ref().is_some_and(|p| {
                p.index.len() != n * p.k
                    || p.pos_w.len() != n * p.k
                    || p.index.iter().any(|&j| j as usize >= n)
            })
        {
            candle_core::bail!(
                "factorized-loss: input {:?} for a batch of {}",
                l.shape(),
                self.batch.gt.len()
            );
        }
        // Fixed chunks summed in order: deterministic whatever the thread count.
        let parts: Vec<[f64; 3]> = (0..n)
            .collect::<Vec<_>>()
            .par_chunks(1024)
            .map(|js| {
                let mut acc = [0f64; 3];
                for &j in js {
                    let p = self.pixel(j, &x[6 * j..6 * j + 6]);
                    acc[0] += p.sq as f64;
                    acc[1] += x[6 * j + 5] as f64;
                    acc[2] += p.prior as f64;
                }
                acc
            })
            .collect();
        let mut sum = [0f64; 3];
        for p in parts {
            for k in 0..3 {
                sum[k] += p[k];
            }
        }
        let image = sum[0] / (3 * n) as f64;
        let mask = sum[1] / n as f64;
        let prior = sum[2] / n as f64;
        let (segment, terms) = if self.batch.semantic.is_some() && self.has_segments() {
            let t = self.semantic_terms(x);
            (t.loss, Some(PriorTerms::Semantic(t)))
        } else if self.has_segments() {
            let seg = self.segment_sums(x);
            let b = &*self.batch;
            let mut acc = 0f64;
            for j in 0..n {
                if b.segment[j] == NO_SEGMENT {
                    continue;
                }
                let s = b.segment[j] as usize;
                acc += ((x[6 * j + 3] - seg.mean_sigma[s]).abs()
                    + (x[6 * j + 4] - seg.mean_m[s]).abs()) as f64;
            }
            (acc / n as f64, Some(PriorTerms::Parts(seg)))
        } else {
            (0.0, None)
        };
        if let (Some(t), Ok(mut c)) = (terms, self.cache.0.lock()) {
            *c = Some((x.to_vec(), t));
        }
        let total =
            image + self.mask_weight as f64 * mask + prior + self.segment_weight as f64 * segment;
        Ok((
            CpuStorage::F32(vec![
                total as f32,
                image as f32,
                mask as f32,
                prior as f32,
                segment as f32,
            ]),
            Shape::from(5),
        ))
    }
    fn bwd(
        &self,
        arg: &Tensor,
        _res: &Tensor,
        grad: &Tensor,
    ) -> candle_core::Result<Option<Tensor>> {
        use rayon::prelude::*;
        let x = arg.flatten_all()?.to_vec1::<f32>()?;
        let g = grad.to_vec1::<f32>()?;
        let n = x.len() / 6;
        // d total = d image + w_m d mask + d prior (weighted per pixel), plus the outputs' own
        // gradients.
        let gi = (g[0] + g[1]) / (3 * n) as f32;
        let gm = (g[0] * self.mask_weight + g[2]) / n as f32;
        let gp = (g[0] + g[3]) / n as f32;
        let semantic = self.batch.semantic.is_some() && self.has_segments();
        // The part prior is a mean over pixels; the semantic one a sum of per-class means
        // (1/n_class is inside its gradient).
        let gs = (g[0] * self.segment_weight + g[4]) / if semantic { 1.0 } else { n as f32 };
        // d/dσ_j mean_i |σ_i − σ̄_s(i)| = (sign_j − w_j/W_s · Σ_{i∈s} sign_i) / n (w constant).
        let terms = (self.has_segments() && gs != 0.0).then(|| self.prior_terms(&x));
        // The semantic prior's gradient: its own term per pixel plus what it receives as a
        // partner of others (scattered in pixel order: deterministic).
        let (seg, sem_grad) = match &terms {
            Some(PriorTerms::Parts(s)) => (Some(s), None),
            Some(PriorTerms::Semantic(t)) => (None, Some(self.semantic_grad(&x, t))),
            None => (None, None),
        };
        let mut out = zeros_par(x.len());
        out.par_chunks_mut(6 * 256)
            .enumerate()
            .for_each(|(ci, rows)| {
                for (k, row) in rows.chunks_exact_mut(6).enumerate() {
                    let j = ci * 256 + k;
                    let p = self.pixel(j, &x[6 * j..6 * j + 6]);
                    for q in 0..6 {
                        row[q] = gi * p.d_image[q] + gp * p.d_prior[q];
                    }
                    row[5] += gm;
                    if let Some(g) = &sem_grad {
                        row[3] += gs * g[j][0];
                        row[4] += gs * g[j][1];
                    }
                    if let Some(seg) = seg.filter(|_| self.batch.segment[j] != NO_SEGMENT) {
                        let r = &x[6 * j..6 * j + 6];
                        let s = self.batch.segment[j] as usize;
                        let share = (seg.pixel_w[j] as f64 / seg.w[s]) as f32;
                        row[3] += gs * (sign(r[3] - seg.mean_sigma[s]) - share * seg.sign_sigma[s]);
                        row[4] += gs * (sign(r[4] - seg.mean_m[s]) - share * seg.sign_m[s]);
                    }
                }
            });
        Ok(Some(Tensor::from_vec(out, arg.shape(), arg.device())?))
    }
}
