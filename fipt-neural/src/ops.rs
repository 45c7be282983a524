//! Small element-wise candle ops with hand-written CPU forward and backward.
//!
//! * [`SrgbOetf`]: the sRGB opto-electronic transfer function without clamping (the loss of
//!   method §4 compares sRGB-encoded HDR values): 12.92·x below 0.0031308, else
//!   1.055·x^(1/2.4) − 0.055; linear continuation for x < 0.
//! * [`LevelWeights`]: the hat-function weights of piecewise-linear interpolation over the
//!   roughness levels, so that `Σ_l w_l(σ)·Ls[l]` equals
//!   [`fipt_core::shading::lerp_levels`] and is differentiable in σ.
use candle_core::{CpuStorage, CustomOp1, Layout, Shape, Tensor};
use fipt_core::shading::{level_segment, NUM_LEVELS};

fn contiguous<'a>(s: &'a CpuStorage, l: &Layout, name: &str) -> candle_core::Result<&'a [f32]> {
    let data = match s {
        CpuStorage::F32(v) => v,
        _ => candle_core::bail!("{name}: expects f32"),
    };
    match l.contiguous_offsets() {
        Some((a, b)) => Ok(&data[a..b]),
        None => candle_core::bail!("{name}: expects a contiguous tensor"),
    }
}

const SRGB_KNEE: f32 = 0.003_130_8;

/// sRGB OETF of a linear value (no clamp).
#[inline]
pub fn srgb_oetf(x: f32) -> f32 {
    if x <= SRGB_KNEE {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// Derivative of [`srgb_oetf`].
#[inline]
pub fn srgb_oetf_grad(x: f32) -> f32 {
    if x <= SRGB_KNEE {
        12.92
    } else {
        1.055 / 2.4 * x.powf(1.0 / 2.4 - 1.0)
    }
}

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
    let d = 3 + 6 * frequencies;
    let mut out = Vec::with_capacity(points.len() * d);
    for p in points {
        out.extend_from_slice(p);
        for k in 0..frequencies {
            let f = (1u32 << k) as f32 * std::f32::consts::PI;
            for &x in p {
                out.push((f * x).sin());
            }
            for &x in p {
                out.push((f * x).cos());
            }
        }
    }
    out
}
