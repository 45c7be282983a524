//! The training loss's per-pixel image error: which one ([`ImageLoss`]) and each one's value and
//! derivative in the prediction, on the sRGB curve of `fipt_core::color`. The fused loss
//! (`ops::FactorizedLoss`) and the candle reference (`train::candle_loss`) use these.
use fipt_core::color::{srgb_oetf_extended as srgb_oetf, srgb_oetf_grad};
use serde::{Deserialize, Serialize};

/// The per-pixel error of the training loss ([`crate::train::TrainConfig::image_loss`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ImageLoss {
    /// (oetf(p) − oetf(g))²: the reference.
    #[default]
    Srgb,
    /// (oetf′(p)·(p − g))², oetf′(p) held constant: unbiased under zero-mean noise in g.
    SrgbSlope,
}

/// Within this error (in sRGB units) [`ImageLoss::SrgbSlope`] linearises the sRGB curve at
/// the prediction; beyond it the error is the sRGB difference, as [`ImageLoss::Srgb`]. The
/// linearised error of a pixel far from its prediction (a light or a highlight the field does
/// not yet explain) is not bounded as the sRGB difference is: unbounded, it outweighed the
/// rest of the batch (`studio-mitsuba`: −2 dB of kd); bounded by a Huber loss, it no longer
/// pulled the emission mask over small lights (`room` at 80×60 lost its bulb).
pub const SLOPE_LOSS_CLIP: f32 = 0.1;

/// The pixel's [`ImageLoss::Srgb`] term, the squared sRGB difference, and its derivative in
/// the prediction `p`.
#[inline]
pub(crate) fn srgb_term(p: f32, g: f32) -> (f32, f32) {
    let e = srgb_oetf(p) - srgb_oetf(g);
    (e * e, 2.0 * e * srgb_oetf_grad(p))
}

/// The pixel's [`ImageLoss::SrgbSlope`] term and its derivative in the prediction `p`.
#[inline]
pub(crate) fn slope_term(p: f32, g: f32) -> (f32, f32) {
    let w = srgb_oetf_grad(p.max(0.0));
    let e = w * (p - g);
    if e.abs() <= SLOPE_LOSS_CLIP {
        (e * e, 2.0 * e * w)
    } else {
        srgb_term(p, g)
    }
}
