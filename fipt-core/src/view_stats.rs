//! A split's pixels summarised: range, luminance, bad values, black and saturated views, and
//! whether they are low dynamic range (`fipt info`).
use crate::dataset::{Dataset, Split};
use crate::error::Result;
use crate::image::BadPixelPolicy;
use serde::Serialize;

/// Summary of a split's HDR pixels.
#[derive(Clone, Debug, Default, Serialize)]
pub struct HdrStats {
    pub min: f32,
    pub max: f32,
    /// Mean luminance.
    pub mean_luminance: f64,
    /// Bad values found (before the policy was applied).
    pub bad: usize,
    /// Views with bad values: (view index, count).
    pub bad_views: Vec<(usize, usize)>,
    /// Median luminance (every 7th pixel of every view).
    pub median_luminance: f32,
    /// Views whose every pixel is black.
    pub black_views: Vec<usize>,
    /// Views with ≥ 99 % of their pixels at the view's maximum (clipped or blown out).
    pub saturated_views: Vec<usize>,
    /// Whether the views are low dynamic range, why, and which clip.
    pub ldr: crate::capture::LdrCheck,
}

/// Reads every image of `split` (in parallel) and summarises the HDR range.
pub fn hdr_stats(ds: &Dataset, split: &Split, policy: BadPixelPolicy) -> Result<HdrStats> {
    use rayon::prelude::*;
    type PerView = (
        usize,
        f32,
        f32,
        f64,
        usize,
        Vec<f32>,
        bool,
        crate::capture::ViewLdr,
    );
    let per: Vec<Result<PerView>> = split
        .views
        .par_iter()
        .map(|v| {
            let (img, bad) = ds.load_image(v, policy)?;
            let (lo, hi) = img.range();
            let lum: f64 = img
                .data
                .iter()
                .map(|&p| crate::color::luminance(p) as f64)
                .sum::<f64>()
                / img.data.len() as f64;
            let samples = img
                .data
                .iter()
                .step_by(7)
                .map(|&p| crate::color::luminance(p))
                .filter(|l| l.is_finite())
                .collect();
            let at_max = img.data.iter().filter(|p| p.max_element() >= hi).count();
            let saturated = hi > 0.0 && at_max * 100 >= img.data.len() * 99;
            let ldr = crate::capture::ViewLdr::of(&img);
            Ok((v.index, lo, hi, lum, bad.total(), samples, saturated, ldr))
        })
        .collect();
    let mut s = HdrStats {
        min: f32::INFINITY,
        max: f32::NEG_INFINITY,
        ..Default::default()
    };
    let n = per.len().max(1) as f64;
    let mut samples = Vec::new();
    let mut ldr = vec![];
    for r in per {
        let (k, lo, hi, lum, bad, l, saturated, view_ldr) = r?;
        ldr.push((k, view_ldr));
        samples.extend(l);
        // `hi` is the view's range's top: `Image::is_black`, the run's test, without a second pass.
        if hi <= 0.0 {
            s.black_views.push(k);
        } else if saturated {
            s.saturated_views.push(k);
        }
        s.min = s.min.min(lo);
        s.max = s.max.max(hi);
        s.mean_luminance += lum / n;
        if bad > 0 {
            s.bad += bad;
            s.bad_views.push((k, bad));
        }
    }
    if !samples.is_empty() {
        let m = samples.len() / 2;
        s.median_luminance = *samples.select_nth_unstable_by(m, f32::total_cmp).1;
    }
    let files_ldr = split
        .views
        .iter()
        .any(|v| crate::capture::is_ldr_file(&v.image));
    s.ldr = crate::capture::ldr_check(&ldr, files_ldr);
    Ok(s)
}
