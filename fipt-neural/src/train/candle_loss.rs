//! The training loss written with plain candle ops: the reference the fused
//! [`FactorizedLoss`] is tested against.
use super::*;

/// Ls(σ) interpolated over the levels in candle ops (`ls` `[n, levels, 3]` → `[n, 3]`).
fn reflected_specular(
    out: &crate::field::FieldOutput,
    ls: &Tensor,
    levels: [f32; NUM_LEVELS],
) -> candle_core::Result<Tensor> {
    let w = out
        .roughness()?
        .apply_op1(LevelWeights(levels))?
        .unsqueeze(2)?;
    ls.broadcast_mul(&w)?.sum(1)
}

/// kd·Ld(σ) + ks·Ls0(σ) + Ls1(σ) in candle ops (`ld` `[n, 3]`, `ls0`/`ls1` `[n, levels, 3]`;
/// `poly` = (Ld1, Ld2) `[n, 3]` each when Ld(σ) = Ld + σ·Ld1 + σ²·Ld2).
pub(super) fn reflected(
    out: &crate::field::FieldOutput,
    ld: &Tensor,
    poly: Option<(&Tensor, &Tensor)>,
    ls0: &Tensor,
    ls1: &Tensor,
    levels: [f32; NUM_LEVELS],
) -> candle_core::Result<Tensor> {
    let s0 = reflected_specular(out, ls0, levels)?;
    let s1 = reflected_specular(out, ls1, levels)?;
    let ld = match poly {
        None => ld.clone(),
        Some((p1, p2)) => {
            let s = &out.roughness()?;
            (ld + p1.broadcast_mul(s)?)?.add(&p2.broadcast_mul(&s.sqr()?)?)?
        }
    };
    ((out.kd()? * ld)? + (out.ks()? * s0)?)?.add(&s1)
}

/// The weights of a [`candle_ops_loss`].
#[derive(Clone, Copy, Debug)]
pub struct LossWeights {
    pub mask: f32,
    pub prior: f32,
    pub prior_norm: PriorNorm,
    /// Scale of the prior's σ part ([`TrainConfig::roughness_prior`]).
    pub roughness_prior: f32,
    pub segment: f32,
    /// [`TrainConfig::target_weight`].
    pub target: f32,
    /// [`TrainConfig::image_loss`].
    pub image_loss: ImageLoss,
    /// [`TrainConfig::emitter_material`].
    pub emitter_material: bool,
}

/// The loss of [`Trainer::step`] written with plain candle ops (`[5]`: total, image, mask,
/// weighted prior, segment prior): the reference the fused [`FactorizedLoss`] is tested against.
pub fn candle_ops_loss(
    out: &crate::field::FieldOutput,
    batch: &LossBatch,
    levels: [f32; NUM_LEVELS],
    weights: LossWeights,
) -> Result<Tensor> {
    let LossWeights {
        mask: mask_weight,
        segment: segment_weight,
        image_loss,
        emitter_material,
        ..
    } = weights;
    let dev = out.device();
    let b = batch.gt.len();
    let r: candle_core::Result<Tensor> = (|| {
        let flat3 = |v: &[[f32; 3]]| v.iter().flatten().copied().collect::<Vec<_>>();
        let flat_l = |v: &[[[f32; 3]; NUM_LEVELS]]| {
            v.iter().flatten().flatten().copied().collect::<Vec<_>>()
        };
        let ld = Tensor::from_vec(flat3(&batch.ld), (b, 3), dev)?;
        let ls0 = Tensor::from_vec(flat_l(&batch.ls0), (b, NUM_LEVELS, 3), dev)?;
        let ls1 = Tensor::from_vec(flat_l(&batch.ls1), (b, NUM_LEVELS, 3), dev)?;
        let gt = Tensor::from_vec(flat3(&batch.gt), (b, 3), dev)?;
        let gt_oetf = Tensor::from_vec(
            flat3(&batch.gt).iter().map(|&x| srgb_oetf(x)).collect(),
            (b, 3),
            dev,
        )?;
        let poly = if batch.ld_poly.is_empty() {
            None
        } else {
            let part = |k: usize| {
                let v: Vec<f32> = batch.ld_poly.iter().flat_map(|p| p[k]).collect();
                Tensor::from_vec(v, (b, 3), dev)
            };
            Some((part(0)?, part(1)?))
        };
        let render = reflected(
            out,
            &ld,
            poly.as_ref().map(|(a, b)| (a, b)),
            &ls0,
            &ls1,
            levels,
        )?;
        // At a light's pixel the material's value enters but not its gradient, unless asked.
        let render = if emitter_material {
            render
        } else {
            let at: Vec<f32> = (0..b)
                .map(|j| {
                    let (ld, ls0, ls1) = (batch.ld[j], &batch.ls0[j], &batch.ls1[j]);
                    f32::from(u8::from(crate::ops::unreflectable(
                        ld,
                        ls0,
                        ls1,
                        batch.gt[j],
                    )))
                })
                .collect();
            let at = Tensor::from_vec(at, (b, 1), dev)?;
            let apart = at.affine(-1.0, 1.0)?;
            (render.broadcast_mul(&apart)? + render.detach().broadcast_mul(&at)?)?
        };
        let keep = out.alpha()?.affine(-1.0, 1.0)?;
        let pred = (render.broadcast_mul(&keep)? + gt.broadcast_mul(&out.alpha()?)?)?;
        let image = image_term(&pred, &gt, gt_oetf, batch, image_loss)?;
        let mask = out.alpha()?.mean_all()?;
        let prior = prior_term(out, batch, &weights)?;
        let segment = if batch.segment.is_empty() {
            Tensor::zeros((), candle_core::DType::F32, dev)?
        } else if let Some(sem) = &batch.semantic {
            semantic_segment_term(out, batch, sem)?
        } else {
            region_segment_term(out, batch, (&ls0, &ls1), levels)?
        };
        let total = (((image.clone() + mask.affine(mask_weight as f64, 0.0)?)? + &prior)?
            + segment.affine(segment_weight as f64, 0.0)?)?;
        Tensor::stack(&[total, image, mask, prior, segment], 0)
    })();
    r.ctx("candle-ops loss")
}

/// The image term: the mean squared sRGB error of `pred` against `gt`, or its slope-weighted
/// form ([`ImageLoss`]).
fn image_term(
    pred: &Tensor,
    gt: &Tensor,
    gt_oetf: Tensor,
    batch: &LossBatch,
    image_loss: ImageLoss,
) -> candle_core::Result<Tensor> {
    let (b, dev) = (batch.gt.len(), pred.device());
    Ok(match image_loss {
        ImageLoss::Srgb => (pred.apply_op1(SrgbOetf)? - gt_oetf)?.sqr()?.mean_all()?,
        ImageLoss::SrgbSlope => {
            // Where the slope-weighted error is within the clip: that error, the slope
            // held constant; elsewhere the sRGB difference.
            let pv = pred.flatten_all()?.to_vec1::<f32>()?;
            let gv: Vec<f32> = batch.gt.iter().flatten().copied().collect();
            let (w, near): (Vec<f32>, Vec<f32>) = pv
                .iter()
                .zip(&gv)
                .map(|(&p, &g)| {
                    let w = crate::ops::srgb_oetf_grad(p.max(0.0));
                    let near = (w * (p - g)).abs() <= crate::ops::SLOPE_LOSS_CLIP;
                    (w, f32::from(u8::from(near)))
                })
                .unzip();
            let t = |v: Vec<f32>| Tensor::from_vec(v, (b, 3), dev);
            let near = t(near)?;
            let lin = ((pred - gt)? * t(w)?)?;
            let srgb = (pred.apply_op1(SrgbOetf)? - gt_oetf)?;
            let e = ((lin * &near)? + (srgb * near.affine(-1.0, 1.0)?)?)?;
            e.sqr()?.mean_all()?
        }
    })
}

/// The prior: per pixel and part, the search's target pull where there is one, the default
/// σ/metallic prior elsewhere, weighted.
fn prior_term(
    out: &crate::field::FieldOutput,
    batch: &LossBatch,
    weights: &LossWeights,
) -> candle_core::Result<Tensor> {
    let (b, dev) = (batch.gt.len(), out.device());
    let (prior_weight, prior_norm) = (weights.prior, weights.prior_norm);
    let (roughness_prior, target_weight) = (weights.roughness_prior, weights.target);
    let dr = out.roughness()?.affine(1.0, -1.0)?;
    let k = roughness_prior as f64;
    // Per pixel and part: the search's target pull where there is one, the default prior
    // elsewhere.
    let part = |c: usize| -> candle_core::Result<(Tensor, Tensor)> {
        let t: Vec<f32> = (0..b)
            .map(|j| batch.target.get(j).map_or(f32::NAN, |t| t[c]))
            .collect();
        let has: Vec<f32> = t.iter().map(|v| u8::from(v.is_finite()) as f32).collect();
        let t: Vec<f32> = t
            .iter()
            .map(|v| if v.is_finite() { *v } else { 0.0 })
            .collect();
        Ok((
            Tensor::from_vec(has, (b, 1), dev)?,
            Tensor::from_vec(t, (b, 1), dev)?,
        ))
    };
    let ((hs, ts), (hm, tm)) = (part(0)?, part(1)?);
    let pull = (((&out.roughness()? - ts)?.sqr()? * &hs)?
        + ((&out.metallic()? - tm)?.sqr()? * &hm)?)?
        .mean_all()?;
    let (ns, nm) = (hs.affine(-1.0, 1.0)?, hm.affine(-1.0, 1.0)?);
    let ps = match prior_norm {
        PriorNorm::L1 => (dr.abs()? * &ns)?.mean_all()?,
        PriorNorm::L2 | PriorNorm::L2Roughness => (dr.sqr()? * &ns)?.mean_all()?,
    };
    let pm = match prior_norm {
        PriorNorm::L2 => (out.metallic()?.sqr()? * &nm)?.mean_all()?,
        PriorNorm::L1 | PriorNorm::L2Roughness => (&out.metallic()? * &nm)?.mean_all()?,
    };
    let prior = ((ps.affine(k, 0.0)? + pm)?.affine(prior_weight as f64, 0.0)?
        + pull.affine(target_weight as f64, 0.0)?)?;
    Ok(prior)
}

/// The semantic smoothness term: |σ − bilateral mean of σ over its partners| (and of m),
/// averaged per segment. The weights are constants of the step: the normalised bilateral
/// weights (albedo not differentiated) and 1/n_class; σ and m of the partners are gathered
/// with autograd.
fn semantic_segment_term(
    out: &crate::field::FieldOutput,
    batch: &LossBatch,
    sem: &SemanticPartners,
) -> candle_core::Result<Tensor> {
    let dev = out.device();
    let b = batch.gt.len();
    let k = sem.k;
    let albedo = out.albedo()?.to_vec2::<f32>()?;
    let mut count = vec![0f32; batch.segments];
    for &s in &batch.segment {
        if s != NO_SEGMENT {
            count[s as usize] += 1.0;
        }
    }
    let mut w = vec![0f32; b * k];
    let mut inv = vec![0f32; b];
    let mut own = vec![0f32; b];
    for i in 0..b {
        if batch.segment[i] == NO_SEGMENT {
            continue;
        }
        inv[i] = 1.0 / count[batch.segment[i] as usize];
        let mut total = SEGMENT_WEIGHT_FLOOR as f64;
        for q in 0..k {
            let j = sem.index[i * k + q] as usize;
            let d2: f32 = (0..3).map(|c| (albedo[i][c] - albedo[j][c]).powi(2)).sum();
            let v =
                sem.pos_w[i * k + q] * (-d2 / (2.0 * sem.sigma_albedo * sem.sigma_albedo)).exp();
            w[i * k + q] = v;
            total += v as f64;
        }
        for q in 0..k {
            w[i * k + q] = (w[i * k + q] as f64 / total) as f32;
        }
        own[i] = (SEGMENT_WEIGHT_FLOOR as f64 / total) as f32;
    }
    let idx = Tensor::from_vec(sem.index.clone(), b * k, dev)?;
    let w = Tensor::from_vec(w, (b, k), dev)?;
    let inv = Tensor::from_vec(inv, (b, 1), dev)?;
    let own = Tensor::from_vec(own, (b, 1), dev)?;
    let mean = |v: &Tensor| -> candle_core::Result<Tensor> {
        let partners = v.squeeze(1)?.index_select(&idx, 0)?.reshape((b, k))?;
        (partners * &w)?.sum_keepdim(1)? + (v * &own)?
    };
    let ds = (mean(&out.roughness()?)? - &out.roughness()?)?.abs()?;
    let dm = (mean(&out.metallic()?)? - &out.metallic()?)?.abs()?;
    ((ds + dm)? * inv)?.sum_all()
}

/// The region term: |σ − the segment's specular-weighted mean σ| (and of m). Pixels of no
/// segment gather from, and scatter to, one extra slot that is dropped.
fn region_segment_term(
    out: &crate::field::FieldOutput,
    batch: &LossBatch,
    (ls0, ls1): (&Tensor, &Tensor),
    levels: [f32; NUM_LEVELS],
) -> candle_core::Result<Tensor> {
    let dev = out.device();
    let b = batch.gt.len();
    let k = batch.segments;
    let ids: Vec<u32> = batch
        .segment
        .iter()
        .map(|&s| if s == NO_SEGMENT { k as u32 } else { s })
        .collect();
    let keep: Vec<f32> = ids
        .iter()
        .map(|&s| u8::from(s as usize != k) as f32)
        .collect();
    let ids = Tensor::from_vec(ids, b, dev)?;
    let keep = Tensor::from_vec(keep, (b, 1), dev)?;
    let spec = ((out.ks()? * reflected_specular(out, ls0, levels)?)?
        + reflected_specular(out, ls1, levels)?)?;
    let w = (spec.mean_keepdim(1)?.relu()? + SEGMENT_WEIGHT_FLOOR as f64)?.detach();
    let zeros = Tensor::zeros((k + 1, 1), candle_core::DType::F32, dev)?;
    let total_w = zeros.index_add(&ids, &w, 0)?;
    let seg_mean = |v: &Tensor| -> candle_core::Result<Tensor> {
        let sums = zeros.index_add(&ids, &(v * &w)?, 0)?;
        (sums / &total_w)?.index_select(&ids, 0)
    };
    let ds = (&out.roughness()? - seg_mean(&out.roughness()?)?)?.abs()?;
    let dm = (&out.metallic()? - seg_mean(&out.metallic()?)?)?.abs()?;
    ((ds + dm)? * keep)?.mean_all()
}
