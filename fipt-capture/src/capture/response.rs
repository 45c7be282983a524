//! The camera's response, estimated from the views where `capture.json` does not give it.
//!
//! A surface cell seen by several views at different exposures gives stored values s that
//! must all decode to one radiance times each view's gain: h(s_cv) = g_v · R_c. The inverse
//! response is fitted as h(s) = (sRGB⁻¹(s) · e^{d(s)})^γ, d piecewise linear on [`KNOTS`]
//! segments (d = 0, γ = 1 is sRGB), jointly with the gains: one linear least-squares solve
//! over d and the gains with each cell's radiance eliminated, residuals weighed into stored
//! units (the noise is in the stored values; the curve is judged on them exactly). Without known exposures the fit is ambiguous
//! up to h → h^γ (the gains and radiances follow): of that family the member nearest sRGB is
//! taken. With known exposures (`capture.json`, EXIF) the gains are those and γ is 1. The
//! curve is used only when it departs from sRGB by more than [`MIN_DEPARTURE`] and explains
//! the views clearly better: a plain sRGB capture comes back as sRGB, bit for bit.
use super::gains::{cell_sums, Cell};
use fipt_core::color::{srgb_oetf, Rgb};
use fipt_core::dataset::View;
use fipt_core::image::Image;
use fipt_geom::Geometry;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::HashMap;

mod curve;
use curve::{Curve, Inverse};

/// Segments of the log correction d on [0, 1].
const KNOTS: usize = 24;
/// Stored values used: above 16 8-bit steps (quantisation), at most 249 (every pixel a run
/// does not count as clipped: those at 250 or more are; a cell's mean near the top is biased
/// a little low by its noisy pixels over 249 being left out, less than the curve's
/// extrapolation from further down is off: `docs/phone-captures.md` section 12).
const LOW: f64 = 16.0 / 255.0;
const HIGH: f64 = 249.0 / 255.0;
/// The knot at the top of the data (249.2 / 255).
const TOP_KNOT: usize = KNOTS - 1;
/// A view sees a cell flat when its pixels' stored values there spread by at most this (std;
/// 2.5 8-bit steps).
const FLAT: f64 = 2.5 / 255.0;
/// Series ((cell, channel) seen by several views) the fit uses at most.
const MAX_SERIES: usize = 20_000;
/// Gauss–Newton rounds of the fit.
const ROUNDS: usize = 25;
/// Weight of d's second differences (smoothness) and of its pull to 0, against the data's
/// total weight.
const SMOOTH: f64 = 1e-5;
const PRIOR: f64 = 1e-10;
/// A curve is used when its linear values depart from sRGB's by this RMS over the stored
/// values…
pub const MIN_DEPARTURE: f32 = 0.03;
/// …and it lowers the views' disagreement by this share.
const MIN_GAIN: f32 = 0.1;
/// Without known exposures, views whose fitted exposures spread less than this do not tell
/// a curve from another.
const MIN_SPREAD: f32 = 1.5;

/// The values of a reported response table (linear values at stored 0, 1/32, …, 1).
pub const TABLE_VALUES: usize = 33;

/// `report.json`'s `capture.response`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ResponseFit {
    /// "srgb (assumed)", "fitted", or why no curve could be fitted.
    pub outcome: String,
    /// Whether the views were decoded again through the fitted curve.
    pub applied: bool,
    /// The linear value of stored 250 (where a view clips) through the curve the views
    /// were decoded with (exact, not from the 33-value table).
    pub clip_linear: f32,
    /// The fitted inverse response: linear values at stored values 0, 1/32, …, 1.
    pub linear: Vec<f32>,
    /// RMS over stored values of the fitted linear values against sRGB's.
    pub departure: f32,
    /// The views' disagreement on shared cells (RMS, in 8-bit steps of the stored values)
    /// under sRGB and under the fitted curve.
    pub residual_srgb: f32,
    pub residual_fitted: f32,
    /// What the gains were: fitted with the curve (up to the h^γ ambiguity, resolved towards
    /// sRGB), or known.
    pub gains: String,
    /// (cell, channel) series and observations the fit used.
    pub series: usize,
    pub observations: usize,
}

impl ResponseFit {
    /// As a `capture.json` response table.
    pub fn as_response(&self) -> fipt_core::capture::Response {
        fipt_core::capture::Response::Table(self.linear.clone())
    }
}

/// One (cell, channel): its stored values per view.
type Series = Vec<(usize, f64)>;

/// Fits the response of 8-bit views decoded as sRGB (`images`, linear, clip level 1, each
/// divided by its known exposure in `known` if given), their `masked` pixels (per view; empty:
/// none) left out. Returns the fit; `images` are decoded
/// again through it when it is used.
pub fn fit_response(
    geometry: &Geometry,
    views: &[View],
    images: &mut [Image],
    known: Option<&[f32]>,
    masked: &[Vec<bool>],
) -> ResponseFit {
    let exposure = |v: usize| known.map_or(1.0, |e| e[v]);
    let series = stored_series(geometry, views, images, &exposure, masked);
    let observations = series.iter().map(Vec::len).sum();
    let mut fit = ResponseFit {
        series: series.len(),
        observations,
        gains: if known.is_some() { "known" } else { "fitted" }.into(),
        ..Default::default()
    };
    if series.len() < 50 {
        fit.outcome = format!(
            "srgb (assumed): only {} surface cells are seen unclipped by two views or more",
            series.len()
        );
        return fit;
    }
    let known_log: Option<Vec<f64>> = known.map(|e| centred(e.iter().map(|&x| (x as f64).ln())));
    let srgb = Curve::srgb();
    let (g0, _) = gains_for(&series, &srgb, views.len(), known_log.as_deref());
    let spread = (g0.iter().cloned().fold(f64::MIN, f64::max)
        - g0.iter().cloned().fold(f64::MAX, f64::min))
    .exp() as f32;
    if known.is_none() && spread < MIN_SPREAD {
        fit.outcome = format!(
            "srgb (assumed): the views' exposures spread ×{spread:.2} (under ×{MIN_SPREAD}): too alike to tell one response from another"
        );
        return fit;
    }
    // Leave out the series the views disagree on most (highlights that move with the view,
    // misregistered edges): above twice the median residual under a first fit on them all
    // (under sRGB the series a curve changes most would be the ones left out).
    let first = fit_curve(&series, views.len(), known_log.as_deref());
    let series = consistent(series, &first, views.len(), known_log.as_deref());
    fit.residual_srgb = gains_for(&series, &srgb, views.len(), known_log.as_deref()).1 as f32;
    let mut curve = fit_curve(&series, views.len(), known_log.as_deref());
    if known.is_none() {
        curve.gamma = curve.nearest_srgb_gamma().clamp(0.2, 5.0);
    }
    let (_, r1) = gains_for(&series, &curve, views.len(), known_log.as_deref());
    fit.residual_fitted = r1 as f32;
    fit.linear = (0..TABLE_VALUES)
        .map(|k| curve.linear(k as f64 / (TABLE_VALUES - 1) as f64) as f32)
        .collect();
    fit.departure = curve.departure();
    let better = fit.residual_fitted < (1.0 - MIN_GAIN) * fit.residual_srgb;
    if fit.departure < MIN_DEPARTURE || !better {
        fit.outcome = format!(
            "srgb (kept): the fitted curve departs from sRGB by {:.3} RMS and explains the views {} (RMS {:.2} 8-bit steps against sRGB's {:.2})",
            fit.departure,
            if better { "better" } else { "no better" },
            fit.residual_fitted,
            fit.residual_srgb
        );
        fit.linear.clear();
        return fit;
    }
    fit.outcome = "fitted".into();
    fit.applied = true;
    fit.clip_linear = curve.linear(250.0 / 255.0) as f32;
    // One decoded value per 8-bit level, then the 8-bit level of each pixel.
    let lut: Vec<f32> = (0..256)
        .map(|k| curve.linear(k as f64 / 255.0) as f32)
        .collect();
    for (v, img) in images.iter_mut().enumerate() {
        let e = exposure(v);
        for p in &mut img.data {
            *p = Rgb::from_array(p.to_array().map(|x| {
                let s = srgb_oetf((x * e).clamp(0.0, 1.0)) * 255.0;
                let (i, f) = ((s.floor() as usize).min(254), s - s.floor().min(254.0));
                (lut[i] * (1.0 - f) + lut[i + 1] * f) / e
            }));
        }
    }
    fit
}

/// Per (cell, channel) seen by two views or more: each view's mean stored value there, over
/// the pixels whose every channel lies in [LOW, HIGH].
fn stored_series(
    geometry: &Geometry,
    views: &[View],
    images: &[Image],
    exposure: &(dyn Fn(usize) -> f32 + Sync),
    masked: &[Vec<bool>],
) -> Vec<Series> {
    let per_view = cell_sums(geometry, views, images, masked, |v, p| {
        let e = exposure(v);
        let s = p
            .to_array()
            .map(|x| srgb_oetf((x * e).clamp(0.0, 1.0)) as f64);
        s.iter()
            .all(|s| (LOW..=HIGH).contains(s))
            .then(|| [s[0], s[1], s[2], s[0] * s[0], s[1] * s[1], s[2] * s[2]])
    });
    // Only cells a view sees flat (no edge, no texture inside): their mean stored value is
    // that of one radiance, whichever of its pixels the view has.
    let mut cells: HashMap<(Cell, usize), Series> = HashMap::new();
    for (v, m) in per_view.iter().enumerate() {
        for (c, (s, n)) in m.iter().filter(|(_, (_, n))| *n >= 2) {
            let n = *n as f64;
            for ch in 0..3 {
                let mean = s[ch] / n;
                if (s[ch + 3] / n - mean * mean).max(0.0).sqrt() <= FLAT {
                    cells.entry((*c, ch)).or_default().push((v, mean));
                }
            }
        }
    }
    let mut out: Vec<((Cell, usize), Series)> =
        cells.into_iter().filter(|(_, o)| o.len() >= 2).collect();
    // A fixed order: the fit does not depend on the hash map's; at most MAX_SERIES of them,
    // evenly spread.
    out.sort_by_key(|(k, _)| *k);
    let step = out.len().div_ceil(MAX_SERIES).max(1);
    out.into_iter().step_by(step).map(|(_, o)| o).collect()
}

/// The series whose RMS residual under `curve` is at most twice the median one.
fn consistent(series: Vec<Series>, curve: &Curve, nv: usize, known: Option<&[f64]>) -> Vec<Series> {
    let (g, radiance) = fit_gains(&series, curve, nv, known);
    let inv = Inverse::of(curve);
    let rms: Vec<f64> = series
        .iter()
        .zip(&radiance)
        .map(|(o, r)| {
            let sq: f64 = o
                .iter()
                .map(|&(v, s)| residual(&inv, s, g[v] + r).powi(2))
                .sum();
            (sq / o.len() as f64).sqrt()
        })
        .collect();
    let mut sorted = rms.clone();
    let cut = 2.0
        * sorted
            .select_nth_unstable_by(rms.len() / 2, f64::total_cmp)
            .1
            .max(1e-4);
    series
        .into_iter()
        .zip(rms)
        .filter(|(_, r)| *r <= cut)
        .map(|(o, _)| o)
        .collect()
}

/// An observation's residual in stored units: s against the stored value the curve gives
/// g·R (exact: a flattened curve gains nothing).
fn residual(inv: &Inverse, s: f64, log_gr: f64) -> f64 {
    s - inv.stored(log_gr)
}

/// The gains (log, mean 0) and the series' radiances (log) under `curve`: each the weighted
/// mean of the other's residuals, alternated; or the known gains.
fn fit_gains(
    series: &[Series],
    curve: &Curve,
    nv: usize,
    known: Option<&[f64]>,
) -> (Vec<f64>, Vec<f64>) {
    let mut g = known.map_or_else(|| vec![0f64; nv], <[f64]>::to_vec);
    let mut radiance = vec![0f64; series.len()];
    let obs: Vec<Vec<(usize, f64, f64)>> = series
        .iter()
        .map(|o| {
            o.iter()
                .map(|&(v, s)| (v, curve.log(s), Curve::weight(s)))
                .collect()
        })
        .collect();
    for _ in 0..if known.is_some() { 1 } else { 600 } {
        for (c, o) in obs.iter().enumerate() {
            let q: f64 = o.iter().map(|x| x.2).sum();
            radiance[c] = o.iter().map(|&(v, y, w)| w * (y - g[v])).sum::<f64>() / q;
        }
        if known.is_some() {
            break;
        }
        let mut sum = vec![(0f64, 0f64); nv];
        for (c, o) in obs.iter().enumerate() {
            for &(v, y, w) in o {
                sum[v].0 += w * (y - radiance[c]);
                sum[v].1 += w;
            }
        }
        for (gv, (s, w)) in g.iter_mut().zip(&sum) {
            if *w > 0.0 {
                *gv = s / w;
            }
        }
        let mean = g.iter().sum::<f64>() / nv as f64;
        g.iter_mut().for_each(|x| *x -= mean);
    }
    (g, radiance)
}

/// The gains (log) and the RMS residual in 8-bit steps under `curve`.
fn gains_for(
    series: &[Series],
    curve: &Curve,
    nv: usize,
    known: Option<&[f64]>,
) -> (Vec<f64>, f64) {
    let (g, radiance) = fit_gains(series, curve, nv, known);
    let inv = Inverse::of(curve);
    let (mut sq, mut n) = (0.0, 0usize);
    for (o, r) in series.iter().zip(&radiance) {
        for &(v, s) in o {
            sq += residual(&inv, s, g[v] + r).powi(2);
            n += 1;
        }
    }
    (g, 255.0 * (sq / n.max(1) as f64).sqrt())
}

/// The correction d (γ = 1) jointly with the gains and the series' radiances, by damped
/// Gauss–Newton on the stored values: Σ (s − h⁻¹(g_v R_c))² plus d's smoothness. Each step
/// linearises at the predicted stored values and eliminates each series' radiance, so one
/// solve over the knots and the gains gives it; a step that does not lower the cost is
/// taken again with more damping. The residual is exact, so a curve flattened where the
/// data are dense pays for it (a least-squares fit of ln h(s) would not: a flat h makes
/// every view agree). d = 0 at the last knot the data reach (scale's gauge), and above it
/// (h(1) = 1); without known gains d(1/2) = 0 too (the h^γ ambiguity's
/// gauge) and the gains sum to 0.
fn fit_curve(series: &[Series], nv: usize, known: Option<&[f64]>) -> Curve {
    let nk = KNOTS + 1;
    let free_g = known.is_none();
    let n = nk + if free_g { nv } else { 0 };
    let mut curve = Curve::srgb();
    let (mut g, mut radiance) = fit_gains(series, &curve, nv, known);
    let mut cost = stored_cost(series, &Inverse::of(&curve), &g, &radiance);
    let mut damping = 1e-3;
    for _ in 0..ROUNDS {
        let mut a = vec![vec![0f64; n]; n];
        let mut b = vec![0f64; n];
        let mut scale = 0.0;
        // Per series, its rows (x, y, weight) in log units: y = r·v'(ŝ), weight 1/v'(ŝ)².
        let inv = Inverse::of(&curve);
        let rows_of = |c: usize, o: &Series| -> Vec<(Vec<(usize, f64)>, f64, f64)> {
            o.iter()
                .map(|&(v, s)| {
                    let pred = inv.stored(g[v] + radiance[c]);
                    let slope = curve.log_slope(pred);
                    let mut x: Vec<(usize, f64)> =
                        Curve::weights(pred).iter().map(|&(k, w)| (k, -w)).collect();
                    if free_g {
                        x.push((nk + v, 1.0));
                    }
                    (x, (s - pred) * slope, slope.powi(-2))
                })
                .collect()
        };
        for (c, o) in series.iter().enumerate() {
            scale += add_series(&mut a, &mut b, &rows_of(c, o));
        }
        regularise(&mut a, &mut b, scale, free_g, nv, &curve.d);
        for k in 0..n {
            a[k][k] *= 1.0 + damping;
        }
        let Some(step) = solve(a, b) else { break };
        let mut next = curve.clone();
        for k in 0..nk {
            next.d[k] += step[k];
        }
        next.monotone();
        let mut ng = g.clone();
        if free_g {
            for v in 0..nv {
                ng[v] += step[nk + v];
            }
        }
        // Each series' radiance: its best for the new curve and gains (a few Newton steps).
        let next_inv = Inverse::of(&next);
        let nr: Vec<f64> = series
            .par_iter()
            .zip(&radiance)
            .map(|(o, &r)| best_radiance(o, &next, &next_inv, &ng, r))
            .collect();
        let new_cost = stored_cost(series, &next_inv, &ng, &nr);
        if new_cost < cost {
            (curve, g, radiance, cost) = (next, ng, nr, new_cost);
            damping = (damping * 0.3).max(1e-6);
        } else {
            damping *= 10.0;
            if damping > 1e6 {
                break;
            }
        }
    }
    // Above the last knot the data reach, d goes on at its rate over the four segments
    // below; then h(1) = 1.
    let at = Curve::knot;
    let rate = (curve.d[TOP_KNOT] - curve.d[TOP_KNOT - 4]) / (at(TOP_KNOT) - at(TOP_KNOT - 4));
    for k in TOP_KNOT + 1..=KNOTS {
        curve.d[k] = curve.d[TOP_KNOT] + rate * (at(k) - at(TOP_KNOT));
    }
    let top = curve.d[KNOTS];
    curve.d.iter_mut().for_each(|d| *d -= top);
    curve.monotone();
    curve
}

/// Σ (s − h⁻¹(g R))² over every observation.
fn stored_cost(series: &[Series], inv: &Inverse, g: &[f64], radiance: &[f64]) -> f64 {
    // Per series in parallel, summed in order: the same cost, bit for bit, on any thread count.
    let per: Vec<f64> = series
        .par_iter()
        .zip(radiance)
        .map(|(o, r)| {
            o.iter()
                .map(|&(v, s)| residual(inv, s, g[v] + r).powi(2))
                .sum::<f64>()
        })
        .collect();
    per.iter().sum()
}

/// The log radiance of one series that fits its stored values best under `curve` and gains
/// `g`, from `start` (Gauss–Newton in one unknown).
fn best_radiance(o: &Series, curve: &Curve, inv: &Inverse, g: &[f64], start: f64) -> f64 {
    let mut r = start;
    for _ in 0..4 {
        let (mut num, mut den) = (0.0, 0.0);
        for &(v, s) in o {
            let pred = inv.stored(g[v] + r);
            let dpred = 1.0 / curve.log_slope(pred);
            num += (s - pred) * dpred;
            den += dpred * dpred;
        }
        if den <= 0.0 {
            break;
        }
        r += num / den;
    }
    r
}

/// Adds one series' rows (sparse x, y, weight), their weighted mean taken off, to the normal
/// equations; returns their total weight.
fn add_series(a: &mut [Vec<f64>], b: &mut [f64], rows: &[(Vec<(usize, f64)>, f64, f64)]) -> f64 {
    let qsum: f64 = rows.iter().map(|r| r.2).sum();
    let mut used: Vec<usize> = rows.iter().flat_map(|r| r.0.iter().map(|e| e.0)).collect();
    used.sort_unstable();
    used.dedup();
    let mut mean = vec![0f64; used.len()];
    let mut ymean = 0.0;
    for (x, y, q) in rows {
        for &(j, xj) in x {
            let at = used.binary_search(&j).unwrap_or(0);
            mean[at] += q * xj / qsum;
        }
        ymean += q * y / qsum;
    }
    for (x, y, q) in rows {
        let mut dense: Vec<f64> = mean.iter().map(|m| -m).collect();
        for &(j, xj) in x {
            dense[used.binary_search(&j).unwrap_or(0)] += xj;
        }
        let dy = y - ymean;
        for (pi, &p) in used.iter().enumerate() {
            b[p] += q * dense[pi] * dy;
            for (ri, &r) in used.iter().enumerate() {
                a[p][r] += q * dense[pi] * dense[ri];
            }
        }
    }
    qsum
}

/// d's smoothness (second differences) and a weak pull to 0 (only knots no observation
/// reaches rest on it), the held knots (d(1) = 0; d(1/2) = 0 when the gains are free) and
/// the free gains' sum 0, added to normal equations of data of total weight `scale`. The
/// top knot (above the data) rests on the smoothness alone.
fn regularise(a: &mut [Vec<f64>], b: &mut [f64], scale: f64, free_g: bool, nv: usize, d: &[f64]) {
    let nk = KNOTS + 1;
    // For a step δ from the current d: the penalty's gradient at d goes to the right side.
    for k in 0..nk {
        a[k][k] += PRIOR * scale;
        b[k] -= PRIOR * scale * d[k];
    }
    for k in 1..KNOTS {
        let w = [(k - 1, 1.0), (k, -2.0), (k + 1, 1.0)];
        let second: f64 = w.iter().map(|&(p, x)| x * d[p]).sum();
        for &(p, wp) in &w {
            b[p] -= SMOOTH * scale * wp * second;
            for &(q, wq) in &w {
                a[p][q] += SMOOTH * scale * wp * wq;
            }
        }
    }
    if free_g {
        for p in nk..nk + nv {
            for q in nk..nk + nv {
                a[p][q] += scale;
            }
        }
    }
    // The scale's gauge at the last knot the data reach (the knots above are set after),
    // and γ's at 1/2.
    let held: &[usize] = if free_g {
        &[TOP_KNOT, KNOTS / 2]
    } else {
        &[TOP_KNOT]
    };
    for &k in held {
        for row in 0..b.len() {
            a[row][k] = 0.0;
            a[k][row] = 0.0;
        }
        a[k][k] = 1.0;
        b[k] = 0.0;
    }
}

/// Gaussian elimination with partial pivoting; None when singular.
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for col in 0..n {
        let p = (col..n).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[p][col].abs() < 1e-14 {
            return None;
        }
        a.swap(col, p);
        b.swap(col, p);
        for row in col + 1..n {
            let f = a[row][col] / a[col][col];
            for k in col..n {
                a[row][k] -= f * a[col][k];
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = vec![0f64; n];
    for row in (0..n).rev() {
        let s: f64 = (row + 1..n).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    Some(x)
}

/// Values minus their mean.
fn centred(x: impl Iterator<Item = f64>) -> Vec<f64> {
    let v: Vec<f64> = x.collect();
    let m = v.iter().sum::<f64>() / v.len().max(1) as f64;
    v.iter().map(|x| x - m).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use fipt_core::color::srgb_eotf;

    #[test]
    fn solve_solves() {
        let x = solve(vec![vec![2.0, 1.0], vec![1.0, 3.0]], vec![3.0, 5.0]).unwrap();
        assert!((x[0] - 0.8).abs() < 1e-12 && (x[1] - 1.4).abs() < 1e-12);
    }

    /// Synthetic series: 3,000 cells of random radiance, each seen by some of 12 views of
    /// exposures ×1 … ×4 through `tone`, stored on 8-bit steps; and the views' log exposures.
    fn synthetic(tone: &dyn Fn(f64) -> f64) -> (Vec<Series>, Vec<f64>) {
        let nv = 12;
        let mut rng = fipt_core::rng::Pcg32::from_keys(&[5]);
        let gains: Vec<f64> = (0..nv)
            .map(|v| 4f64.powf(v as f64 / (nv - 1) as f64))
            .collect();
        let series = (0..3000)
            .map(|_| {
                let r = 0.005 * 150f64.powf(rng.next_f32() as f64);
                (0..nv)
                    .filter(|_| rng.next_f32() < 0.4)
                    .map(|v| (v, (tone(r * gains[v]) * 255.0).round() / 255.0))
                    .filter(|(_, s)| (LOW..=HIGH).contains(s))
                    .collect::<Series>()
            })
            .filter(|o| o.len() >= 2)
            .collect();
        (series, centred(gains.iter().map(|g| g.ln())))
    }

    fn srgb_tone(x: f64) -> f64 {
        srgb_oetf(x.min(1.0) as f32) as f64
    }

    /// A phone's contrast S-curve over sRGB.
    fn s_curve(t: f64) -> f64 {
        t.powf(1.5) / (t.powf(1.5) + (1.0 - t).powf(1.5))
    }

    /// RMS over stored values 0 … 250 of two inverse responses, each scaled to 1 at 250 (the
    /// scale is the gains'; above 250 a camera clips).
    fn rms_to_250(a: &dyn Fn(f64) -> f64, b: &dyn Fn(f64) -> f64) -> f64 {
        let top = 250.0 / 255.0;
        let sq: f64 = (0..=250)
            .map(|k| (a(k as f64 / 255.0) / a(top) - b(k as f64 / 255.0) / b(top)).powi(2))
            .sum();
        (sq / 251.0).sqrt()
    }

    #[test]
    fn an_srgb_camera_fits_srgb() {
        let (series, g) = synthetic(&srgb_tone);
        for known in [None, Some(g.as_slice())] {
            let mut c = fit_curve(&series, g.len(), known);
            if known.is_none() {
                c.gamma = c.nearest_srgb_gamma();
            }
            assert!(c.departure() < 0.005, "{known:?}: {}", c.departure());
        }
    }

    #[test]
    fn an_s_curve_is_recovered_from_known_exposures() {
        let (series, g) = synthetic(&|x| s_curve(srgb_tone(x)));
        let c = fit_curve(&series, g.len(), Some(&g));
        // The true curve as `fipt degrade --tone scurve:1.5` tabulates it (the same S-curve).
        let table = crate::degrade::tone_curve("scurve:1.5").expect("a tone curve");
        let truth = |s: f64| table.to_linear(s as f32) as f64;
        let fitted = rms_to_250(&|s| c.linear(s), &truth);
        let srgb = rms_to_250(&|s| srgb_eotf(s as f32) as f64, &truth);
        // The data reach stored 249 (0.0034 here); when they stopped at 242 the curve
        // extrapolated over this S-curve's shoulder (a zero slope at 255, the steepest a
        // camera's can be) was 0.02 off.
        assert!(
            fitted < 0.008 && srgb > 5.0 * fitted,
            "fitted {fitted}, sRGB {srgb}"
        );
    }

    #[test]
    fn without_exposures_a_power_of_srgb_is_srgb() {
        // The h^γ ambiguity: sRGB⁻¹ raised to 1.4 with gains ×4 is sRGB⁻¹ with gains ×4^(1/1.4);
        // the member nearest sRGB is taken.
        let (series, g) = synthetic(&|x| srgb_tone(x.powf(1.0 / 1.4)));
        let mut c = fit_curve(&series, g.len(), None);
        c.gamma = c.nearest_srgb_gamma();
        assert!(c.departure() < 0.01, "{}", c.departure());
    }
}
